"""Decision time of the EM planner, the learned policy and nearest frontier, as the graph and the candidates grow.

Synthetic but realistic states: a real iSAM2 ``PoseGraph`` of N keyframes every 0.5 m
along a lawnmower trajectory (rows 3 m apart, then back along the edges) in a 20 m x 20 m
area, with noisy odometry and scan-matching factors and a loop closure wherever it comes
back near an older keyframe; a real ``OccupancyGrid`` (known free within the LiDAR's
floor ring of the trajectory, unknown stripes between rows); candidates = frontier cells
spread by farthest-point sampling, each with its Dijkstra path from the robot over the
known-free space. Paths running along older rows predict loop closures (graph-copy
path), short ones into new space do not (the covariance-propagation shortcut). All
policies see the same state; nearest frontier's time is its ``choose`` alone (the
state's Dijkstra is shared by every policy). The learned policy's time is its ``choose``:
action set (the same as EM's), exploration graph, encoding and forward pass, with the
shipped actor if ``policies/buildings_office_distill/actor.pt`` exists, else a randomly initialised
actor of the default model size (the output says which); the forward pass of a
hidden-1000 actor is timed as well. ``ms_learned_reference`` is the same decision by the
first implementation (``LearnedPolicy(reference=True)``: candidates' revisits one path at a
time, two landmark fusions from full distance matrices, padding to ``graph.max_nodes``),
``em_over_learned`` EM's time over the fast path's. Real states (street, garage):
``benchmarks/bench_decision_real.py``. One torch thread.

    python benchmarks/bench_decision.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, new_observation, parse_args, time_call  # noqa: E402

import torch  # noqa: E402

from explore_rl.geometry import se2_between, se2_compose, se2_to_matrix  # noqa: E402
from explore_rl.graph.config import GraphConfig  # noqa: E402
from explore_rl.graph.encode import encode  # noqa: E402
from explore_rl.graph.features import feature_names  # noqa: E402
from explore_rl.grid import GridSpec  # noqa: E402
from explore_rl.mapping.config import MappingConfig  # noqa: E402
from explore_rl.mapping.frontiers import Frontier, frontier_mask  # noqa: E402
from explore_rl.mapping.occupancy import OccupancyGrid  # noqa: E402
from explore_rl.mapping.paths import DistanceField, PathPlanner, path_length, traversability  # noqa: E402
from explore_rl.planning.config import ActionSetConfig, PlanningConfig  # noqa: E402
from explore_rl.models.actor_critic import GraphActor  # noqa: E402
from explore_rl.models.actor_file import DEFAULT_ACTOR, load_actor, resolve  # noqa: E402
from explore_rl.models.config import ModelConfig  # noqa: E402
from explore_rl.planning.em import EMPlanner  # noqa: E402
from explore_rl.planning.learned import LearnedPolicy, choose_row  # noqa: E402
from explore_rl.planning.policies import NearestFrontier, PolicyConfig  # noqa: E402
from explore_rl.planning.revisits import sample_path  # noqa: E402
from explore_rl.robot import RobotConfig  # noqa: E402
from explore_rl.state import Candidate, ExplorationState  # noqa: E402
from explore_rl.slam.config import SlamConfig  # noqa: E402
from explore_rl.slam.frontend import ScanMatch  # noqa: E402
from explore_rl.slam.pose_graph import PoseGraph  # noqa: E402


MAX_TOURS = 3
# the learned policy's graph keeps every pose (a garage evaluation reaches ~800 keyframes)
LEARNED_GRAPH = GraphConfig(max_nodes=1024)
PAPER_MODEL = ModelConfig(hidden=1000, mlp_hidden=0)  # model=gunet_paper


def learned_actor() -> tuple[GraphActor, str, str]:
    """The shipped policy if it exists, else a randomly initialised actor of the default
    model size (``model=gunet``): the decision time does not depend on the weights. Also
    the node-feature set it reads (``graph.features``)."""
    if resolve(None).is_file():
        actor, actor_file = load_actor(None)
        return actor, f"trained: {DEFAULT_ACTOR}", actor_file.feature_set
    torch.manual_seed(0)
    config = ModelConfig()
    return (GraphActor(config, 4).eval(), f"random init, default model size (hidden {config.hidden}): no {DEFAULT_ACTOR}",
            "paper")


@dataclass
class BenchSetup:
    """The synthetic world: area, trajectory shape and measurement noise."""

    area: float = 20.0  # m, square side
    resolution: float = 0.1  # m, occupancy grid
    margin: float = 1.0  # m, first row / column offset from the area's edge
    row_spacing: float = 3.0  # m between lawnmower rows
    floor_reach: float = 1.2  # m around each keyframe known free (the LiDAR's floor ring)
    loop_every: int = 5  # keyframes between loop-closure attempts
    loop_radius: float = 1.0  # m, farthest older keyframe a loop closure joins
    loop_min_gap: int = 20  # keyframes; closer ones are sequential, not loops
    odom_noise_xy: float = 0.01  # m per keyframe step, applied to the odometry measurement
    odom_noise_yaw_deg: float = 0.1
    ssm_sigma_translation: float = 0.01
    ssm_sigma_rotation_deg: float = 0.15
    loop_sigma_translation: float = 0.05
    loop_sigma_rotation_deg: float = 0.5
    max_path: float = 15.0  # m; candidates farther away are not offered (keeps paths comparable)
    repeats: int = 2
    seed: int = 0


def lawnmower(n_poses: int, setup: BenchSetup, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """``n_poses`` poses every ``spacing`` along boustrophedon rows, then back along the
    area's edges (crossing the rows' ends, re-driving the first row), and their travel;
    the same tour again if that is not enough (a tour holds ~790 poses)."""
    lo, hi = setup.margin, setup.area - setup.margin
    corners, y, east = [], lo, True
    while y <= hi + 1e-9:
        corners += [[lo, y], [hi, y]] if east else [[hi, y], [lo, y]]
        y, east = y + setup.row_spacing, not east
    x_end = corners[-1][0]
    corners += [[x_end, lo], [lo + hi - x_end, lo], [lo + hi - x_end, hi]]
    tour = corners + corners[::-1]  # then the whole tour backwards, back to the start
    corners = list(tour)
    poses, travel = sample_path(np.array(corners), spacing, include_start=True)
    for _ in range(MAX_TOURS - 1):  # long runs (800 poses) drive the tour again
        if len(poses) >= n_poses:
            break
        corners += tour[1:]
        poses, travel = sample_path(np.array(corners), spacing, include_start=True)
    if len(poses) < n_poses:
        raise ValueError(f"the trajectory holds only {len(poses)} poses, asked for {n_poses}")
    poses[0, 2] = poses[1, 2]
    return poses[:n_poses], travel[:n_poses]


def build_graph(true_poses: np.ndarray, setup: BenchSetup, slam: SlamConfig,
                rng: np.random.Generator) -> PoseGraph:
    """A real iSAM2 graph: noisy odometry + SSM per keyframe, loops where it revisits."""
    graph = PoseGraph(slam.pose_graph, true_poses[0])
    ssm_cov = np.diag([np.deg2rad(setup.ssm_sigma_rotation_deg) ** 2] * 3
                      + [setup.ssm_sigma_translation**2] * 3)
    loop_cov = np.diag([np.deg2rad(setup.loop_sigma_rotation_deg) ** 2] * 3
                       + [setup.loop_sigma_translation**2] * 3)
    noise = np.array([setup.odom_noise_xy, setup.odom_noise_xy, np.deg2rad(setup.odom_noise_yaw_deg)])
    steps = int(np.ceil(slam.keyframe_distance / RobotConfig().step_distance))
    for k in range(1, len(true_poses)):
        delta = se2_between(true_poses[k - 1], true_poses[k])
        odom = se2_compose(delta, rng.normal(0.0, noise))
        measured = se2_compose(delta, rng.normal(0.0, noise / 2))
        match = ScanMatch(relative=se2_to_matrix(measured), covariance=ssm_cov, degenerate=False,
                          weak_directions=0, n_points=0, ms=0.0)
        graph.add_keyframe(odom, steps, match)
        if k % setup.loop_every == 0:
            _maybe_close_loop(graph, true_poses, k, setup, loop_cov)
    return graph


def _maybe_close_loop(graph: PoseGraph, true_poses: np.ndarray, k: int, setup: BenchSetup,
                      loop_cov: np.ndarray) -> None:
    """Join keyframe ``k`` to its nearest keyframe at least ``loop_min_gap`` older, if close."""
    older = true_poses[: max(k - setup.loop_min_gap, 0)]
    if len(older) == 0:
        return
    gaps = np.linalg.norm(older[:, :2] - true_poses[k, :2], axis=1)
    j = int(np.argmin(gaps))
    if gaps[j] <= setup.loop_radius:
        graph.add_loop_closure(j, k, se2_to_matrix(se2_between(true_poses[j], true_poses[k])), loop_cov,
                               "pose_matching")


def known_space(grid: GridSpec, poses: np.ndarray, setup: BenchSetup) -> OccupancyGrid:
    """Known free within ``floor_reach`` of any keyframe; the rest unknown."""
    occupancy = OccupancyGrid(grid)
    centres = grid.cell_centers().reshape(-1, 2)
    near, _ = cKDTree(poses[:, :2]).query(centres, distance_upper_bound=setup.floor_reach)
    free = np.isfinite(near).reshape(grid.shape)
    occupancy.log_odds[free] = occupancy.config.free_threshold - 1.0
    return occupancy


def candidates(occupancy: OccupancyGrid, start: np.ndarray, count: int, setup: BenchSetup,
               mapping: MappingConfig, robot: RobotConfig) -> tuple[list[Candidate], DistanceField]:
    """``count`` frontier cells within ``max_path`` path cost, spread out by farthest-point
    sampling (nearest first), each with its Dijkstra path from ``start``."""
    grid = occupancy.grid
    traversable, cost = traversability(occupancy.known_free, occupancy.known_occupied, grid,
                                       robot.radius, mapping.paths)
    field = PathPlanner(grid, traversable, cost, mapping.paths).from_start(start[:2])
    cells = np.argwhere(frontier_mask(occupancy.known_free, occupancy.unknown) & traversable
                        & (field.distances <= setup.max_path))
    xy = grid.cell_to_world(cells)
    chosen = [int(np.argmin(field.cost_to(cells)))]
    gap = np.linalg.norm(xy - xy[chosen[0]], axis=1)
    while len(chosen) < min(count, len(cells)):
        chosen.append(int(np.argmax(gap)))
        gap = np.minimum(gap, np.linalg.norm(xy - xy[chosen[-1]], axis=1))
    out = []
    for i in chosen:
        path = np.vstack([start[:2], field.path_to(cells[i])[1:]])
        out.append(Candidate(Frontier(cells[i][None], cells[i], xy[i], 1), path, path_length(path)))
    return out, field


def make_state(n_poses: int, n_candidates: int, setup: BenchSetup) -> ExplorationState:
    """A decision state after ``n_poses`` keyframes of lawnmower exploration."""
    slam, mapping, robot = SlamConfig(), MappingConfig(), RobotConfig()
    grid = GridSpec((0.0, 0.0), setup.resolution, (int(setup.area / setup.resolution),) * 2)
    rng = np.random.default_rng([setup.seed, n_poses])
    true_poses, travel = lawnmower(n_poses, setup, slam.keyframe_distance)
    graph = build_graph(true_poses, setup, slam, rng)
    estimates = graph.poses_se2()
    occupancy = known_space(grid, estimates, setup)
    cands, field = candidates(occupancy, estimates[-1], n_candidates, setup, mapping, robot)
    session = SimpleNamespace(graph=graph, occupancy=occupancy, config=slam,
                              keyframes=[SimpleNamespace(travel=t) for t in travel])
    nearest = int(np.argmin([c.length for c in cands]))
    return ExplorationState(session, estimates[-1], float(travel[-1]), cands, nearest, field, None)


def measure(n_poses: int, n_candidates: int, setup: BenchSetup, actor: GraphActor,
            paper_actor: GraphActor, graph: GraphConfig = LEARNED_GRAPH) -> dict:
    """Milliseconds per decision of EM, the learned policy and nearest frontier on one state.

    The learned policy's time is its whole ``choose``: the action set (the same as EM's),
    the exploration graph (all pose marginals + the frontiers' landmarks), the encoding and
    the actor's forward pass; ``ms_learned_forward_paper`` is the forward pass alone of a
    hidden-1000 actor (the paper's size) on the same encoded graph."""
    state = make_state(n_poses, n_candidates, setup)
    # the n_candidates nearest frontiers: EM's cost per candidate, whatever the action set
    planning = PlanningConfig(actions=ActionSetConfig(kind="nearest", max_frontiers=n_candidates))
    em = EMPlanner(PolicyConfig(name="em"), planning)
    nearest = NearestFrontier()
    learned = LearnedPolicy(PolicyConfig(name="learned"), planning, graph=graph, actor=actor)
    reference = LearnedPolicy(PolicyConfig(name="learned"), planning, graph=graph, actor=actor, reference=True)

    ms_em = 1e3 * time_call(lambda: em.choose(state), setup.repeats)
    ms_nearest = 1e3 * time_call(lambda: nearest.choose(state), 1000)
    ms_learned_reference = 1e3 * time_call(new_observation(lambda: reference.choose(state)), max(setup.repeats, 3))
    ms_learned = 1e3 * time_call(new_observation(lambda: learned.choose(state)), max(setup.repeats, 3))
    parts = dict(learned.last_ms)
    same_choice = learned.choose(state) == reference.choose(state)
    encoded = encode(learned.last_graph, graph.max_nodes)
    ms_paper = 1e3 * time_call(new_observation(lambda: choose_row(paper_actor, encoded)), max(setup.repeats, 3))
    evaluation = em.last_evaluation
    return {"poses": n_poses, "candidates": len(state.candidates), "ms_em": ms_em,
            "path_m": float(np.mean(evaluation.lengths)),
            "ms_nearest": ms_nearest, "loops": int(np.count_nonzero(evaluation.loops)),
            "em_choice_is_nearest": bool(evaluation.chosen == state.nearest),
            "ms_learned": ms_learned, "ms_learned_reference": ms_learned_reference,
            "em_over_learned": ms_em / ms_learned, "same_choice": same_choice,
            "ms_learned_actions": parts["actions"], "ms_learned_graph": parts["graph"],
            "ms_learned_forward": parts["forward"], "ms_learned_forward_paper": ms_paper,
            "graph_nodes": learned.last_graph.num_nodes}


def growth(rows: list[dict]) -> dict:
    """Least-squares fit ``ms_em ~ a + b * poses + c * poses * candidates`` and ratios."""
    poses = np.array([r["poses"] for r in rows], float)
    cands = np.array([r["candidates"] for r in rows], float)
    ms = np.array([r["ms_em"] for r in rows])
    design = np.column_stack([np.ones_like(ms), poses, poses * cands])
    (a, b, c), *_ = np.linalg.lstsq(design, ms, rcond=None)
    largest = max(rows, key=lambda r: (r["poses"], r["candidates"]))
    smallest = min(rows, key=lambda r: (r["poses"], r["candidates"]))
    return {"fit": "ms_em = a + b*poses + c*poses*candidates",
            "a_ms": round(float(a), 2), "b_ms_per_pose": round(float(b), 4),
            "c_ms_per_pose_candidate": round(float(c), 4),
            "em_over_nearest_at_largest": round(largest["ms_em"] / largest["ms_nearest"]),
            "em_largest_over_smallest": round(largest["ms_em"] / smallest["ms_em"], 1),
            "em_ms_per_candidate_at_largest": round(largest["ms_em"] / largest["candidates"], 1),
            "learned_largest_over_smallest": round(largest["ms_learned"] / smallest["ms_learned"], 1),
            "em_over_learned_at_largest": round(largest["ms_em"] / largest["ms_learned"], 1),
            "em_over_learned_min": round(min(r["em_over_learned"] for r in rows), 2),
            "em_over_learned_median": round(float(np.median([r["em_over_learned"] for r in rows])), 2)}


def print_table(rows: list[dict]) -> None:
    print(f"{'poses':>6} {'cands':>6} {'path m':>7} {'loops':>6} {'ms EM':>9} {'ms/cand':>8} "
          f"{'ms nearest':>11} {'EM=nearest':>11} {'ms learned':>11} {'(actions':>9} {'graph':>7} "
          f"{'forward)':>9} {'fwd h1000':>10} {'ms ref':>7} {'EM/learned':>10}")
    for r in rows:
        print(f"{r['poses']:>6} {r['candidates']:>6} {r['path_m']:>7.1f} {r['loops']:>6} {r['ms_em']:>9.1f} "
              f"{r['ms_em'] / r['candidates']:>8.1f} {r['ms_nearest']:>11.4f} "
              f"{str(r['em_choice_is_nearest']):>11} {r['ms_learned']:>11.1f} {r['ms_learned_actions']:>9.1f} "
              f"{r['ms_learned_graph']:>7.1f} {r['ms_learned_forward']:>9.1f} {r['ms_learned_forward_paper']:>10.1f} "
              f"{r['ms_learned_reference']:>7.1f} {r['em_over_learned']:>10.1f}")


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    torch.set_num_threads(1)  # one core, as EM (numpy) and bench_policy's decision latency
    setup = BenchSetup()
    pose_counts = [50, 100] if args.quick else [50, 100, 200, 400, 800]
    candidate_counts = [2, 5, 10]
    if args.smoke:  # four small states: enough for the growth fit, no figure to quote
        setup, pose_counts, candidate_counts = BenchSetup(repeats=1), [30, 50], [2, 5]
    actor, actor_source, features = learned_actor()
    graph = dataclasses.replace(LEARNED_GRAPH, features=features)
    torch.manual_seed(1)
    paper_actor = GraphActor(PAPER_MODEL, len(feature_names(features))).eval()
    print(f"learned policy: {actor_source}; forward pass also timed at hidden 1000 (random init)")
    rows = [measure(n, c, setup, actor, paper_actor, graph) for n in pose_counts for c in candidate_counts]
    print_table(rows)
    summary = growth(rows)
    print("growth:", summary)
    rounded = {key: [round(r[key], 2) for r in rows] for key in
               ("ms_learned", "ms_learned_reference", "em_over_learned", "ms_learned_actions", "ms_learned_graph",
                "ms_learned_forward", "ms_learned_forward_paper")}
    emit({"benchmark": "decision", "quick": args.quick, "smoke": args.smoke,
          "poses": [r["poses"] for r in rows], "candidates": [r["candidates"] for r in rows],
          "ms_em": [round(r["ms_em"], 2) for r in rows],
          "ms_nearest": [round(r["ms_nearest"], 5) for r in rows],
          **rounded, "same_choice": all(r["same_choice"] for r in rows),
          "graph_nodes": [r["graph_nodes"] for r in rows], "learned_actor": actor_source,
          "features": features,
          "loop_candidates": [r["loops"] for r in rows],
          "growth": summary, "machine": machine()})


if __name__ == "__main__":
    main()
