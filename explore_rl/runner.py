"""The exploration loop every policy runs in: observe -> decide -> drive, until done.

One :class:`Explorer` owns a scene, a robot, a LiDAR and a SLAM session. ``observe()``
builds the :class:`ExplorationState` (frontiers of the estimated map, one Dijkstra from
the robot's belief pose, a path per reachable frontier); a policy picks a candidate;
``drive()`` follows its path with SLAM at every keyframe. ``run()`` repeats until 85 %
explored, no reachable frontier, the travel budget or the decision cap, and logs one
:class:`DecisionRecord` per decision. The same object backs the TorchRL env later.

A path can end ``blocked`` with the robot's footprint touching an obstacle. Every decision
therefore starts by backing the robot off (``Robot.escape``: ordinary motion steps, seen by
SLAM) when it is within ``explore.escape.clearance`` of an obstacle; otherwise every turn
from there risks a collision and each frontier tried would be skipped as blocked at once.
"""

from __future__ import annotations

import logging
import time
from dataclasses import asdict, dataclass, field
from enum import Enum

import numpy as np

from explore_rl.local_planner import make_local_planner
from explore_rl.mapping.frontiers import Frontier, find_frontiers
from explore_rl.mapping.paths import PathPlanner, path_length, simplify_path, traversability, traversability_reference
from explore_rl.planning.policies import Policy, make_policy
from explore_rl.robot import PathStatus, Robot
from explore_rl.run_config import ExploreConfig as ExploreConfig  # the config lives there
from explore_rl.scene.build import Scene, make_scene
from explore_rl.sensors.lidar import Lidar
from explore_rl.slam.session import SlamSession
from explore_rl.state import Candidate, ExplorationState

log = logging.getLogger(__name__)


class Status(str, Enum):
    RUNNING = "running"
    EXPLORED = "explored"
    NO_FRONTIER = "no_reachable_frontier"
    BUDGET = "travel_budget"
    MAX_DECISIONS = "max_decisions"


@dataclass
class DecisionRecord:
    decision: int
    travel_m: float
    explored: float
    volume_m3: float
    map_error_m: float
    ate_m: float
    loop_closures: int
    keyframes: int
    candidates: int
    chosen: int
    chosen_x: float
    chosen_y: float
    path_length_m: float
    path_status: str
    ms_decide: float
    ms_drive: float
    # safety (run totals so far, like travel_m): motion steps whose true footprint touched an
    # obstacle (not taken), the least true footprint clearance (m) of every step taken,
    # decisions whose path ended blocked, steps the local safety layer changed
    contacts: int = 0
    min_clearance_m: float = float("inf")
    blocked_decisions: int = 0
    safety_interventions: int = 0
    # paths Robot.follow ended at its step cap (robot.path_step_factor): each is also blocked
    capped_paths: int = 0
    # time in the local safety layer during this decision's drive (ring casts included)
    ms_safety: float = 0.0


@dataclass
class ExplorationResult:
    status: Status
    records: list[DecisionRecord] = field(default_factory=list)

    def table(self) -> list[dict]:
        return [asdict(r) for r in self.records]


class Explorer:
    """Scene + robot + LiDAR + SLAM + policy for one seeded run (see the module docstring)."""

    def __init__(self, config, policy: Policy | None = None, scene: Scene | None = None):
        self.config = config
        self.rng = np.random.default_rng(config.seed)
        self.scene = scene or make_scene(config.scene, config.robot, config.lidar)
        start = self.scene.start_pose
        self.lidar = Lidar(self.scene, config.lidar, np.random.default_rng([config.seed, 1]))
        # the local safety layer on its own LiDAR ring (None with robot.safety.enabled=false)
        self.local_planner = make_local_planner(config.robot.safety, config.robot, self.scene, config.lidar,
                                                np.random.default_rng([config.seed, 5]))
        self.robot = Robot(config.robot, start, None, np.random.default_rng([config.seed, 2]),
                           clearance=self.scene.footprint_clearance, guard=self.local_planner)
        self.session = SlamSession(config.slam, config.mapping, self.scene, self.lidar, start,
                                   np.random.default_rng([config.seed, 3]))
        self.policy = policy or make_policy(config.policy, np.random.default_rng([config.seed, 4]),
                                            planning=config.planning, robot=config.robot, graph=config.graph)
        self.skipped_cells: set[tuple[int, int]] = set()
        self.visited_waypoints = np.zeros((0, 2))
        self.result = ExplorationResult(Status.RUNNING)
        self.last_state: ExplorationState | None = None
        self.last_choice: int = -1
        self._safety_seconds = 0.0  # the layer's time already booked to a decision
        self.ms_observe = 0.0  # the last state's observation (frontiers, Dijkstra, paths): part of ms_decide
        self._ms_escape = 0.0  # backing off an obstacle before that state: motion, booked to ms_drive

    # ------------------------------------------------------------------ observe

    def observe(self, reference: bool = False) -> ExplorationState | None:
        """The exploration state at the robot's belief pose; None if no frontier is reachable.
        ``reference``: every stage as first written (whole-grid traversability, frontiers and
        graph, one path at a time): the same state, for the equivalence test and benchmarks."""
        occupancy = self.session.occupancy
        grid = self.scene.grid
        traversable, cost = (traversability_reference if reference else traversability)(
            occupancy.known_free, occupancy.known_occupied, grid, self.config.robot.radius, self.config.mapping.paths)
        frontiers = find_frontiers(occupancy.known_free, occupancy.unknown, grid,
                                   self.config.mapping.frontiers, traversable, reference=reference)
        pose = self.robot.belief_pose.copy()
        field_ = PathPlanner(grid, traversable, cost, self.config.mapping.paths,
                             reference=reference).from_start(pose[:2])
        # The path's first cell is the robot's own cell, replaced by its exact position; if
        # that cell is not traversable (inside the inflated obstacles) the planner started
        # from the nearest traversable cell instead, which stays the first waypoint: the way out.
        snapped = field_.start_cell is not None and not np.array_equal(field_.start_cell, grid.world_to_cell(pose[:2]))
        frontiers = [frontier for frontier in frontiers if not self.is_skipped(frontier)]
        waypoints = np.array([frontier.waypoint_cell for frontier in frontiers]).reshape(-1, 2)
        paths = [field_.path_to(cell) for cell in waypoints] if reference else field_.paths_to(waypoints)
        candidates = []
        for frontier, path in zip(frontiers, paths):
            if path is None:
                continue
            if snapped:
                path = np.vstack([pose[:2], path])
            elif len(path) > 1:
                path = np.vstack([pose[:2], path[1:]])
            candidates.append(Candidate(frontier, path, path_length(path)))
        if not candidates:
            return None
        nearest = int(np.argmin([c.length for c in candidates]))
        return ExplorationState(self.session, pose, self.robot.travelled, candidates, nearest,
                                field_, traversable)

    def is_skipped(self, frontier: Frontier) -> bool:
        """Frontiers blocked at once, or next to a waypoint already visited, are not offered."""
        if tuple(int(c) for c in frontier.waypoint_cell) in self.skipped_cells:
            return True
        if len(self.visited_waypoints) == 0:
            return False
        gaps = np.linalg.norm(self.visited_waypoints - frontier.waypoint_xy, axis=1)
        return bool(gaps.min() < self.config.explore.visited_radius)

    # ------------------------------------------------------------------ act

    def drive(self, candidate: Candidate) -> PathStatus:
        """Follow a candidate's path with SLAM at every keyframe (each step checked by the
        local safety layer, if on: ``Robot.follow``)."""
        self.move(self.robot.follow(simplify_path(candidate.path)[1:]))
        return self.robot.status

    def move(self, steps) -> None:
        """Run motion steps through SLAM, correcting the belief at every keyframe."""
        for step in steps:
            if self.session.observe(step):
                self.robot.correct_belief(self.session.belief(self.robot.odom_pose))

    def escape(self) -> None:
        """Back the robot off an obstacle its footprint is touching (no-op when clear)."""
        robot, config = self.robot, self.config.explore.escape
        if not robot.needs_escape(config):
            return
        true_before, belief_before = robot.true_pose[:2].round(2), robot.belief_pose[:2].round(2)
        clearance_before, travel_before = robot.footprint_clearance(), robot.travelled
        self.move(robot.escape(config))
        escaped = robot.status is PathStatus.REACHED
        # routine next to walls (paths have no inflation margin): debug; a failed escape: warning
        log.log(
            logging.DEBUG if escaped else logging.WARNING,
            "robot %.3f m from an obstacle at %s (belief %s): escape %s after %.2f m at %s "
            "(belief %s), clearance %.3f m", clearance_before, true_before, belief_before,
            "done" if escaped else "failed", robot.travelled - travel_before,
            robot.true_pose[:2].round(2), robot.belief_pose[:2].round(2), robot.footprint_clearance())

    def done(self) -> Status:
        cfg = self.config.explore
        explored = self.session.explored()
        if explored >= cfg.target_explored:
            return Status.EXPLORED
        if self.robot.travelled >= cfg.travel_budget:
            return Status.BUDGET
        if len(self.result.records) >= cfg.max_decisions:
            return Status.MAX_DECISIONS
        return Status.RUNNING

    def step(self) -> DecisionRecord | None:
        """One decision: observe, choose, drive, log. None (and a final status) when done.
        ``ms_decide`` is what deciding costs a robot: observing the state and choosing
        (not the stop check's ground-truth metrics, nor an escape's motion, which drives)."""
        state = self.next_state()
        if state is None:
            return None
        start = time.perf_counter()
        chosen = int(self.policy.choose(state))
        return self.act(state, chosen, ms_decide=self.ms_observe + 1e3 * (time.perf_counter() - start))

    def next_state(self) -> ExplorationState | None:
        """The state of the next decision (after backing off an obstacle if needed), or
        None with ``result.status`` set when the exploration is over.

        The first half of :meth:`step`; the TorchRL environment calls it and :meth:`act`
        around its own choice, so both loops share one exploration step.
        """
        status = self.done()
        if status is not Status.RUNNING:
            self.result.status = status
            return None
        start = time.perf_counter()
        self.escape()
        observed = time.perf_counter()
        state = self.observe()
        self._ms_escape += 1e3 * (observed - start)
        self.ms_observe = 1e3 * (time.perf_counter() - observed)
        if state is None:
            self.result.status = Status.NO_FRONTIER
            log.info("no reachable frontier: exploration ends")
        return state

    def act(self, state: ExplorationState, chosen: int, ms_decide: float = 0.0) -> DecisionRecord:
        """Drive to ``state.candidates[chosen]``, update the skip lists, log the decision."""
        if not 0 <= chosen < len(state.candidates):
            raise ValueError(f"policy {self.policy.name} chose {chosen} of {len(state.candidates)} candidates")
        self.last_state, self.last_choice = state, chosen
        candidate = state.candidates[chosen]
        start, travel_before = time.perf_counter(), self.robot.travelled
        path_status = self.drive(candidate)
        if path_status is PathStatus.REACHED:
            self.visited_waypoints = np.vstack([self.visited_waypoints, candidate.frontier.waypoint_xy])
        if path_status is PathStatus.BLOCKED and self.robot.travelled - travel_before < self.config.explore.blocked_progress:
            self.skipped_cells.add(tuple(int(c) for c in candidate.frontier.waypoint_cell))
            log.warning("path to frontier %s blocked at once at %s (belief %s, clearance %.3f m); skipping it",
                        candidate.frontier.waypoint_xy.round(2), self.robot.true_pose[:2].round(2),
                        self.robot.belief_pose[:2].round(2), self.robot.footprint_clearance())
        ms_drive, self._ms_escape = 1e3 * (time.perf_counter() - start) + self._ms_escape, 0.0
        record = self.record(state, chosen, path_status, ms_decide, ms_drive)
        self.result.records.append(record)
        return record

    def record(self, state: ExplorationState, chosen: int, path_status: PathStatus,
               ms_decide: float, ms_drive: float) -> DecisionRecord:
        metrics = self.session.metrics()
        candidate = state.candidates[chosen]
        local = self.local_planner
        seconds_safety = 0.0 if local is None else local.seconds
        ms_safety, self._safety_seconds = 1e3 * (seconds_safety - self._safety_seconds), seconds_safety
        blocked = sum(r.path_status == PathStatus.BLOCKED.value for r in self.result.records)
        return DecisionRecord(
            decision=len(self.result.records), travel_m=self.robot.travelled,
            explored=metrics.explored, volume_m3=metrics.volume_m3, map_error_m=metrics.map_error_m,
            ate_m=metrics.ate_m, loop_closures=metrics.loop_closures, keyframes=metrics.keyframes,
            candidates=len(state.candidates), chosen=chosen,
            chosen_x=float(candidate.frontier.waypoint_xy[0]), chosen_y=float(candidate.frontier.waypoint_xy[1]),
            path_length_m=candidate.length, path_status=path_status.value,
            ms_decide=ms_decide, ms_drive=ms_drive,
            contacts=self.robot.contacts, min_clearance_m=self.robot.min_clearance,
            blocked_decisions=blocked + (path_status is PathStatus.BLOCKED),
            safety_interventions=0 if local is None else local.interventions, ms_safety=ms_safety,
            capped_paths=self.robot.capped_paths,
        )

    def run(self, on_decision=None) -> ExplorationResult:
        """Explore until done; ``on_decision(explorer, state_record)`` is called after each decision."""
        while (record := self.step()) is not None:
            if on_decision is not None:
                on_decision(self, record)
        return self.result
