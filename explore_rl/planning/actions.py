"""The action set of a decision: which frontiers a policy may choose, and the loops each closes.

One definition serves the exploration graph (its frontier nodes), the EM planner (the
candidates it evaluates) and the Algorithm 1 reward (normalised over the same set), so
the learner, the expert and the reward never disagree about what the choices were.

The paper's set (``kind="graph"``): the frontier nearest the robot (shortest path) plus
every frontier whose path :func:`~explore_rl.planning.revisits.predict_revisits` says
closes a loop. ``extra_nearest`` adds the K nearest frontiers for studies; ``kind="nearest"``
is the ``max_frontiers`` nearest alone (the EM planner's set before the exploration graph).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from explore_rl.grid import GridSpec
from explore_rl.planning.config import ActionSetConfig, RevisitConfig
from explore_rl.planning.revisits import (
    Revisit,
    predict_revisits,
    predict_revisits_of_paths,
    predict_revisits_reference,
    sample_path,
    sample_paths,
)

if TYPE_CHECKING:
    from explore_rl.state import ExplorationState


@dataclass
class PathPrediction:
    """Keyframes a path would add and the loops they would close."""

    poses: np.ndarray  # (P, 3) predicted keyframe poses [x, y, yaw] along the path
    travel: np.ndarray  # (P,) travel from the robot's pose to each
    revisits: list[Revisit]  # keyframe_index: the old keyframe; path_index: into poses


@dataclass
class Action:
    """One frontier of the action set."""

    candidate: int  # index into state.candidates
    prediction: PathPrediction

    @property
    def closes_loop(self) -> bool:
        return bool(self.prediction.revisits)


def predict_path(path_xy: np.ndarray, keyframe_xy: np.ndarray, keyframe_travel: np.ndarray,
                 travel: float, blocked: np.ndarray, grid: GridSpec, revisits: RevisitConfig,
                 keyframe_spacing: float) -> PathPrediction:
    """Predicted keyframes every ``keyframe_spacing`` along ``path_xy`` and their revisits
    of the keyframes at ``keyframe_xy`` (current estimates)."""
    poses, path_travel = sample_path(path_xy, keyframe_spacing)
    found = predict_revisits(poses[:, :2], keyframe_xy, keyframe_travel, travel, blocked, grid,
                             revisits, path_travel=path_travel)
    return PathPrediction(poses, path_travel, found)


def predict_candidate_paths(state: ExplorationState, revisits: RevisitConfig) -> list[PathPrediction]:
    """:func:`predict_path` for every candidate of ``state``, all at once (their paths
    sampled by :func:`~explore_rl.planning.revisits.sample_paths`, their revisits by
    :func:`~explore_rl.planning.revisits.predict_revisits_of_paths`: one KD-tree query,
    the paths' shared segments tested once; the same answers as one path at a time,
    :func:`predict_candidate_paths_reference`)."""
    session = state.session
    keyframe_xy, keyframe_travel, blocked, spacing = _keyframe_inputs(state)
    samples = sample_paths([c.path for c in state.candidates], spacing)
    found = predict_revisits_of_paths([poses[:, :2] for poses, _ in samples], keyframe_xy, keyframe_travel,
                                      float(state.travel), blocked, session.occupancy.grid, revisits,
                                      [travel for _, travel in samples])
    return [PathPrediction(poses, travel, revisits_of) for (poses, travel), revisits_of in zip(samples, found)]


def predict_candidate_paths_reference(state: ExplorationState, revisits: RevisitConfig) -> list[PathPrediction]:
    """:func:`predict_path` for every candidate of ``state``, one at a time, as first
    written (:func:`~explore_rl.planning.revisits.predict_revisits_reference`)."""
    keyframe_xy, keyframe_travel, blocked, spacing = _keyframe_inputs(state)
    predictions = []
    for candidate in state.candidates:
        poses, travel = sample_path(candidate.path, spacing)
        found = predict_revisits_reference(poses[:, :2], keyframe_xy, keyframe_travel, float(state.travel), blocked,
                                           state.session.occupancy.grid, revisits, path_travel=travel)
        predictions.append(PathPrediction(poses, travel, found))
    return predictions


def _keyframe_inputs(state: ExplorationState) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Keyframe estimates (xy) and travel, the known-occupied cells and the keyframe spacing."""
    session = state.session
    keyframe_xy = session.graph.poses_se2()[:, :2]
    keyframe_travel = np.array([k.travel for k in session.keyframes], dtype=float)
    return keyframe_xy, keyframe_travel, session.occupancy.known_occupied, float(session.config.keyframe_distance)


def select_actions(state: ExplorationState, config: ActionSetConfig,
                   revisits: RevisitConfig, reference: bool = False) -> list[Action]:
    """The action set of ``state``: nearest first, then by path length, at most
    ``config.max_frontiers`` (the nearest is always in it). ``reference``: predict the
    candidates' paths one at a time (the same set, slower; kept to check and time against)."""
    predict = predict_candidate_paths_reference if reference else predict_candidate_paths
    predictions = predict(state, revisits)
    by_length = np.argsort([c.length for c in state.candidates], kind="stable")
    if config.kind == "nearest":
        chosen = list(by_length)
    elif config.kind == "graph":
        extra = set(int(i) for i in by_length[: config.extra_nearest])
        chosen = [i for i in by_length if i == state.nearest or i in extra or predictions[i].revisits]
    else:
        raise ValueError(f"planning.actions.kind={config.kind!r}: choose graph or nearest")
    chosen = [state.nearest] + [int(i) for i in chosen if i != state.nearest]
    return [Action(i, predictions[i]) for i in chosen[: max(config.max_frontiers, 1)]]
