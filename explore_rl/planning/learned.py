"""The learned policy in the plain runner: the trained actor picks the frontier.

At a decision: the action set (:func:`~explore_rl.planning.actions.select_actions`, the
one EM and the environment use), the exploration graph, its padded encoding, the actor's
logits, the most probable frontier (greedy), and back from the encoded row to the graph
node, the action and the candidate -- what the environment does with the actor, minus
the reward.

**Cheaper features, same graph.** The environment builds its graph from EM's decision
context, which fuses *every* keyframe's observations into the whole virtual map (the
EM utility needs all of it; its cost grows with poses x landmarks in range, plus a
line-of-sight test per pair). The graph needs less: every keyframe's xy covariance
(all pose marginals, read at once by :func:`~explore_rl.planning.em.pose_covariances`)
and the virtual landmark of each action frontier -- a handful of cells. :func:`graph_features`
fuses only the observations of those landmarks, from the keyframes within sensor range,
in keyframe order and with the same observation model and covariance-intersection kernel
as the full map (:class:`~explore_rl.planning.em.Observations`), so the graph is the same
(tests/planning/test_learned.py compares it with the environment's on real states).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
import torch

from explore_rl.graph.config import GraphConfig
from explore_rl.graph.encode import EncodedGraph, encode
from explore_rl.graph.exploration_graph import (
    ExplorationGraph,
    action_frontiers,
    factor_edges,
    graph_from_estimates,
)
from explore_rl.graph.features import frontier_extras
from explore_rl.grid import GridSpec
from explore_rl.mapping.visibility import line_of_sight
from explore_rl.models.actor_critic import GraphActor, greedy_row
from explore_rl.models.actor_file import ActorFile, load_actor
from explore_rl.planning.actions import Action, select_actions
from explore_rl.planning.config import PlanningConfig
from explore_rl.planning.em import Observations, pose_covariances
from explore_rl.planning.policies import PolicyConfig
from explore_rl.planning.virtual_map import VirtualMap

if TYPE_CHECKING:
    from explore_rl.state import ExplorationState


def landmark_observations(vmap: VirtualMap, poses: np.ndarray, blocked: np.ndarray,
                          landmarks: np.ndarray) -> Observations:
    """The observations of ``landmarks`` only, exactly as ``vmap.visible_pairs`` would
    list them among all pairs: within ``sensor_range`` (same distance expression) and in
    line of sight (same test and parameters), in pose order."""
    config = vmap.config
    dist = np.linalg.norm(vmap.landmark_xy[landmarks][None, :, :] - poses[:, None, :2], axis=-1)
    pose_idx, slot = np.nonzero(dist <= config.sensor_range)
    landmark_idx = landmarks[slot]
    visible = line_of_sight(poses[pose_idx, :2], vmap.landmark_xy[landmark_idx], blocked, vmap.grid,
                            config.los_step_fraction, end_box=config.cell_size,
                            max_batch_samples=config.max_batch_samples)
    return Observations.of_pairs(vmap, poses, pose_idx[visible], landmark_idx[visible])


def landmark_covariances(vmap: VirtualMap, poses: np.ndarray, pose_covs: np.ndarray, blocked: np.ndarray,
                         landmarks: np.ndarray) -> np.ndarray:
    """``(L, 2, 2)``: the fused covariances of the virtual landmarks ``landmarks`` (unique
    indices, ascending) after every keyframe's observations -- as in the fully fused map
    (each landmark is fused on its own), from their observations alone."""
    prior = vmap.config.prior_std**2 * np.eye(2)  # as VirtualMap.prior_covariances
    fused = np.repeat(prior[None], len(landmarks), axis=0)
    if len(landmarks):
        observations = landmark_observations(vmap, poses, blocked, landmarks)
        compact = Observations(observations.pose_idx, np.searchsorted(landmarks, observations.landmark_idx),
                               observations.gain, observations.noise)
        fused = compact.fuse(fused, pose_covs)
    return fused


def frontier_covariances(vmap: VirtualMap, poses: np.ndarray, pose_covs: np.ndarray, blocked: np.ndarray,
                         frontier_xy: np.ndarray) -> np.ndarray:
    """``(F, 2, 2)``: the virtual-landmark covariance of each frontier's cell after every
    keyframe's observations -- ``vmap.frontier_landmark_covariance`` of the fully fused
    map, computed from the frontiers' landmarks alone (the prior outside the map)."""
    index = vmap.landmark_index(np.asarray(frontier_xy, float).reshape(-1, 2))
    landmarks = np.unique(index[index >= 0])
    fused = landmark_covariances(vmap, poses, pose_covs, blocked, landmarks)
    covs = np.repeat((vmap.config.prior_std**2 * np.eye(2))[None], len(index), axis=0)
    inside = index >= 0
    covs[inside] = fused[np.searchsorted(landmarks, index[inside])]
    return covs


def landmarks_near(vmap: VirtualMap, points: np.ndarray, radius: float) -> np.ndarray:
    """Indices (ascending) of the virtual landmarks within ``radius`` of any of ``points``."""
    points = np.asarray(points, float).reshape(-1, 2)
    near = np.zeros(vmap.num_landmarks, dtype=bool)
    for point in points:
        near |= np.linalg.norm(vmap.landmark_xy - point, axis=1) <= radius
    return np.flatnonzero(near)


def graph_features(state: ExplorationState, actions: list[Action], vmap: VirtualMap,
                   backend: str = "fast", features: str = "paper") -> ExplorationGraph:
    """The exploration graph of ``state`` (equal to ``graph_from_state`` with EM's decision
    context; see the module docstring for what is skipped). ``backend`` reads the pose
    marginals as EM's (``planning.em.backend``): one factorisation or one query per pose.
    ``features=extended`` also fuses the landmarks within sensor range of each frontier
    (their mean uncertainty is a column), still a small part of the map."""
    session = state.session
    poses = session.graph.poses_se2()
    pose_covs, _ = pose_covariances(session.graph, poses, backend)
    blocked = session.occupancy.known_occupied
    frontier_xy = action_frontiers(state, actions)
    frontier_covs = frontier_covariances(vmap, poses, pose_covs, blocked, frontier_xy)
    extra = None
    if features == "extended":
        landmarks = landmarks_near(vmap, frontier_xy, vmap.config.sensor_range)
        covs = landmark_covariances(vmap, poses, pose_covs, blocked, landmarks)
        extra = frontier_extras(state, actions, pose_covs, vmap.landmark_xy[landmarks], covs,
                                vmap.config.sensor_range)
    return graph_from_estimates(state, actions, poses, pose_covs, frontier_covs,
                                factor_edges(session.graph.edges), extra)


def choose_row(actor: GraphActor, encoded: EncodedGraph) -> int:
    """Row of the most probable action of ``encoded`` (:func:`greedy_row`)."""
    with torch.no_grad():
        logits = actor(torch.from_numpy(encoded.x)[None], torch.from_numpy(encoded.adj)[None],
                       torch.from_numpy(encoded.node_mask)[None])[0]
    return greedy_row(logits, torch.from_numpy(encoded.action_mask))


class LearnedPolicy:
    """The trained actor, greedy, behind the :class:`~explore_rl.planning.policies.Policy` protocol.

    ``config.checkpoint``: an actor file (explore_rl/models/actor_file.py) or a training
    checkpoint; by default the shipped policy. A missing or unusable file raises
    ``CheckpointError`` (a ValueError) with one line naming it.
    """

    name = "learned"

    def __init__(self, config: PolicyConfig, planning: PlanningConfig, graph: GraphConfig | None = None,
                 actor: GraphActor | None = None):
        self.config = config
        self.planning = planning
        self.actor_file: ActorFile | None = None
        if actor is None:
            actor, self.actor_file = load_actor(config.checkpoint)
        self.actor = actor.eval()
        self.max_nodes = int((graph or GraphConfig()).max_nodes)
        # what the actor reads: its file says so; an actor handed in reads graph.features
        self.features = (self.actor_file.feature_set if self.actor_file is not None
                         else (graph or GraphConfig()).features)
        self._vmap: VirtualMap | None = None
        self.last_graph: ExplorationGraph | None = None
        self.last_encoded: EncodedGraph | None = None
        self.last_ms: dict[str, float] = {}

    def virtual_map(self, grid: GridSpec) -> VirtualMap:
        """The virtual map geometry on ``grid`` (built once; its state is never used)."""
        if self._vmap is None or self._vmap.grid != grid:
            self._vmap = VirtualMap(grid, self.planning.virtual_map)
        return self._vmap

    def choose(self, state: ExplorationState) -> int:
        start = time.perf_counter()
        actions = select_actions(state, self.planning.actions, self.planning.revisits)
        after_actions = time.perf_counter()
        graph = graph_features(state, actions, self.virtual_map(state.session.occupancy.grid),
                               self.planning.em.backend, self.features)
        encoded = encode(graph, self.max_nodes)
        after_graph = time.perf_counter()
        row = choose_row(self.actor, encoded)
        end = time.perf_counter()
        self.last_graph, self.last_encoded = graph, encoded
        self.last_ms = {"actions": 1e3 * (after_actions - start), "graph": 1e3 * (after_graph - after_actions),
                        "forward": 1e3 * (end - after_graph)}
        return int(graph.candidate[encoded.nodes[row]])
