"""Deployment: the trained policy on a robot with its own SLAM (no simulator, no gtsam).

Load an actor file (or a ``torch.export`` program of it), describe the robot's current
exploration state with plain arrays, get back the frontier to visit next::

    from explore_rl.deploy import load_policy

    policy = load_policy("policies/buildings_office_distill/actor.pt")   # or an exported "actor.pt2"
    k = policy.choose(
        pose_xy=poses[:, :2],              # (K, 2) keyframe estimates, oldest first, world frame (m)
        pose_cov=covs,                     # (K, 2, 2) world-frame xy marginals (or (K, 3, 3) x, y, yaw)
        pose_edges=factors,                # (M, 2) keyframe pairs joined by a SLAM factor
        frontier_xy=frontiers,             # (F, 2) reachable frontiers (path waypoints)
        frontier_cov=landmark_covs,        # (F, 2, 2) their virtual landmarks' covariance
        frontier_revisits=[[], [3, 17]],   # keyframes the path to each frontier would revisit
        nearest=0,                         # which frontier has the shortest path
    )                                      # -> index into frontiers

``loop_bias=0.04`` (keyword) adds the decision-time loop prior of ``policy.loop_bias`` (per metre of
each frontier's ``loop_length``, computed from ``pose_edges`` and the revisits); the caller keeps it
to its travel window, e.g. from 150 m of odometry on (``policy.loop_bias_from_m=150``: an option,
not the shipped default; benchmarks/RESULTS.md "Session 69").
Traces may be passed instead of covariances (``pose_uncertainty``, ``frontier_uncertainty``). A policy of
``graph.features=no_covariance`` reads none of them (pass neither): it needs no marginals at all.
The current pose is the newest keyframe unless ``current`` says otherwise. The graph is
the paper's (explore_rl/graph/exploration_graph.py, :func:`build_graph`): offer the nearest
frontier and every frontier whose path closes a loop, as the policy was trained with.

This module and everything it imports need only numpy, scipy and torch: no MuJoCo, gtsam,
kiss-icp or TorchRL (tests/test_deploy.py checks ``sys.modules`` in a fresh process).

Command line: ``explore-rl-export CHECKPOINT OUT.pt [--program OUT.pt2]`` writes the actor
file of a training checkpoint (and optionally its ``torch.export`` program).
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import torch

from explore_rl.graph.encode import EncodedGraph, encode, loop_length_rows
from explore_rl.graph.exploration_graph import ExplorationGraph, build_graph, select_features
from explore_rl.graph.features import (
    COVARIANCE_FEATURES,
    FRONTIER_EXTRAS,
    has_frontier_extras,
    has_loop_length,
    reads_covariances,
)
from explore_rl.models.actor_critic import greedy_row
from explore_rl.models.actor_file import ActorFile, check_output_file, export_actor_file, load_actor
from explore_rl.models.export import ExportedActor, export_actor
from explore_rl.models.checkpoint import CheckpointError

Logits = Callable[[torch.Tensor, torch.Tensor, torch.Tensor], torch.Tensor]  # x[N,F], adj[N,N], mask[N] -> [N]


def uncertainty(cov: np.ndarray | None, trace: np.ndarray | None, count: int, name: str) -> np.ndarray:
    """Traces of the xy block of ``cov`` (``(n, 2, 2)`` or ``(n, 3, 3)``), or ``trace`` itself."""
    if (cov is None) == (trace is None):
        raise ValueError(f"give exactly one of {name}_cov and {name}_uncertainty")
    if trace is not None:
        values = np.asarray(trace, float).reshape(-1)
    else:
        cov = np.asarray(cov, float)
        if cov.ndim != 3 or cov.shape[1] != cov.shape[2] or cov.shape[1] < 2:
            raise ValueError(f"{name}_cov must be (n, 2, 2) or (n, 3, 3), got {cov.shape}")
        values = cov[:, 0, 0] + cov[:, 1, 1]
    if len(values) != count:
        raise ValueError(f"{name} uncertainty has {len(values)} entries for {count} {name}s")
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise ValueError(f"{name} uncertainty must be finite and >= 0")
    return values


@dataclass
class FrontierChoice:
    """A choice and what it was made from."""

    frontier: int  # index into the caller's frontier arrays
    probabilities: np.ndarray  # (F,) the policy's distribution over the caller's frontiers
    graph: ExplorationGraph  # nodes: poses, then frontiers (nearest first)
    encoded: EncodedGraph


class DeployedPolicy:
    """A trained actor choosing frontiers from plain arrays (see the module docstring)."""

    def __init__(self, logits: Logits, max_nodes: int, source: str = "", actor_file: ActorFile | None = None):
        self.logits = logits
        self.max_nodes = int(max_nodes)
        self.source = source
        self.actor_file = actor_file

    def graph(self, pose_xy, pose_edges, frontier_xy, frontier_revisits: Sequence[Sequence[int]], *,
              pose_cov=None, pose_uncertainty=None, frontier_cov=None, frontier_uncertainty=None,
              nearest: int = 0, current: int | None = None, frontier_extra=None) -> ExplorationGraph:
        """The exploration graph of the arrays (frontier node ``j`` refers to the caller's
        frontier ``graph.candidate[node]``; the nearest comes first). ``frontier_extra (F, 6)``:
        the extended columns (explore_rl/graph/features.py ``FRONTIER_EXTRAS``), needed by a
        policy trained with ``graph.features=extended`` or ``loops`` and refused by one trained
        without (``loops``' own column is computed from ``pose_edges`` and the revisits); ``(F, 4)``,
        those without covariance (:attr:`extra_columns`), for ``no_covariance``, which takes no
        uncertainty either."""
        pose_xy = np.asarray(pose_xy, float).reshape(-1, 2)
        frontier_xy = np.asarray(frontier_xy, float).reshape(-1, 2)
        n_poses, n_frontiers = len(pose_xy), len(frontier_xy)
        if not 0 <= nearest < max(n_frontiers, 1):
            raise ValueError(f"nearest={nearest} is not a frontier index (0..{n_frontiers - 1})")
        if self.reads_covariances:
            pose_u = uncertainty(pose_cov, pose_uncertainty, n_poses, "pose")
            frontier_u = uncertainty(frontier_cov, frontier_uncertainty, n_frontiers, "frontier")
        elif any(value is not None for value in (pose_cov, pose_uncertainty, frontier_cov, frontier_uncertainty)):
            raise ValueError(f"this policy reads graph.features={self.actor_file.feature_set}, no covariance: do not "
                             "pass pose_cov, pose_uncertainty, frontier_cov or frontier_uncertainty")
        else:  # columns the policy does not read (select_features leaves them out)
            pose_u, frontier_u = np.zeros(n_poses), np.zeros(n_frontiers)
        if len(frontier_revisits) != n_frontiers:
            raise ValueError(f"frontier_revisits has {len(frontier_revisits)} entries for {n_frontiers} frontiers")
        for f, keyframes in enumerate(frontier_revisits):
            bad = [k for k in keyframes if not 0 <= int(k) < n_poses]
            if bad:
                raise ValueError(f"frontier_revisits[{f}] names keyframes {bad} outside 0..{n_poses - 1}")
        edges = np.asarray(pose_edges, dtype=np.int64).reshape(-1, 2)
        if len(edges) and (edges.min() < 0 or edges.max() >= n_poses):
            raise ValueError(f"pose_edges must index keyframes 0..{n_poses - 1}")
        order = [nearest] + [f for f in range(n_frontiers) if f != nearest]
        extra = self.frontier_extra(frontier_extra, n_frontiers)
        graph = build_graph(pose_xy, pose_u, edges, frontier_xy[order], frontier_u[order],
                            [list(frontier_revisits[f]) for f in order], current=current,
                            frontier_candidates=order, frontier_extra=None if extra is None else extra[order],
                            loop_length=self.reads_loop_length)
        return graph if self.actor_file is None else select_features(graph, self.actor_file.feature_set)

    @property
    def reads_covariances(self) -> bool:
        """Whether the policy reads the pose and frontier uncertainty (every feature set but ``no_covariance``)."""
        return self.actor_file is None or reads_covariances(self.actor_file.feature_set)

    @property
    def extra_columns(self) -> tuple[str, ...]:
        """The ``frontier_extra`` columns the caller passes: ``FRONTIER_EXTRAS``, those without covariance for a
        policy that reads none."""
        if self.reads_covariances:
            return FRONTIER_EXTRAS
        return tuple(name for name in FRONTIER_EXTRAS if name not in COVARIANCE_FEATURES)

    @property
    def reads_loop_length(self) -> bool:
        """Whether the policy reads ``loop_length`` (``graph.features=loops``): the graph
        computes it from the pose edges and revisits given, so the caller passes nothing more."""
        return self.actor_file is not None and has_loop_length(self.actor_file.feature_set)

    def frontier_extra(self, extra, n_frontiers: int) -> np.ndarray | None:
        """``frontier_extra`` checked against what the policy reads."""
        wants = self.actor_file is not None and has_frontier_extras(self.actor_file.feature_set)
        columns = self.extra_columns
        if extra is None:
            if wants:
                raise ValueError(f"this policy reads graph.features={self.actor_file.feature_set}: pass frontier_extra=(F, "
                                 f"{len(columns)}) with columns {', '.join(columns)}")
            return None
        if self.actor_file is not None and not wants:
            raise ValueError("this policy reads the paper's 4 node features: do not pass frontier_extra")
        extra = np.asarray(extra, float)
        if extra.shape != (n_frontiers, len(columns)) or not np.isfinite(extra).all():
            raise ValueError(f"frontier_extra must be finite, shape ({n_frontiers}, {len(columns)}) with columns "
                             f"{', '.join(columns)}, got {extra.shape}")
        full = np.zeros((n_frontiers, len(FRONTIER_EXTRAS)))  # the columns not read stay 0 (select_features drops them)
        full[:, [FRONTIER_EXTRAS.index(name) for name in columns]] = extra
        return full

    def decide(self, pose_xy, pose_edges, frontier_xy, frontier_revisits, *, loop_bias: float = 0.0,
               **kwargs) -> FrontierChoice:
        """The most probable frontier (greedy) and the policy's distribution. ``loop_bias``: the
        decision-time loop prior of ``policy.loop_bias``, added to each frontier's logit per metre
        of its ``loop_length`` (computed from ``pose_edges`` and the revisits); the caller keeps
        it to its travel window (``policy.loop_bias_from_m``, ``loop_bias_until_m``), e.g. 0.04
        once the robot has driven 150 m (benchmarks/RESULTS.md "Session 69"); 0: the actor alone."""
        if not (math.isfinite(loop_bias) and loop_bias >= 0):
            raise ValueError(f"loop_bias={loop_bias} must be finite and >= 0 (0: the actor alone)")
        graph = self.graph(pose_xy, pose_edges, frontier_xy, frontier_revisits, **kwargs)
        encoded = encode(graph, max(self.max_nodes, graph.frontier_nodes.size + 1))
        n = int(encoded.node_mask.sum())  # real rows come first; padding changes nothing
        logits = self.logits(torch.from_numpy(encoded.x[:n]), torch.from_numpy(encoded.adj[:n, :n]),
                             torch.from_numpy(encoded.node_mask[:n]))
        if loop_bias:
            logits = logits + loop_bias * torch.from_numpy(loop_length_rows(graph, encoded)[:n])
        rows = np.flatnonzero(encoded.action_mask[:n])
        action_logits = logits[torch.from_numpy(rows)].double()
        probabilities_rows = torch.softmax(action_logits, 0).numpy()
        frontier_of_row = graph.candidate[encoded.nodes[rows]]
        probabilities = np.zeros(len(graph.frontier_nodes))
        probabilities[frontier_of_row] = probabilities_rows
        best = greedy_row(logits, torch.from_numpy(encoded.action_mask[:n]))
        return FrontierChoice(int(graph.candidate[encoded.nodes[best]]), probabilities, graph, encoded)

    def choose(self, pose_xy, pose_edges, frontier_xy, frontier_revisits, **kwargs) -> int:
        """Index into ``frontier_xy`` of the frontier to visit next (keyword arguments as
        :meth:`graph`: ``pose_cov``/``pose_uncertainty``, ``frontier_cov``/
        ``frontier_uncertainty``, ``nearest``, ``current``; and :meth:`decide`'s ``loop_bias``)."""
        return self.decide(pose_xy, pose_edges, frontier_xy, frontier_revisits, **kwargs).frontier


def load_policy(path: str | Path | None = None, max_nodes: int | None = None) -> DeployedPolicy:
    """The policy of an actor file (default: the shipped one), a training checkpoint, or a
    ``torch.export`` program (``*.pt2``, :func:`export_program`). ``max_nodes``: graphs
    larger than this lose far poses, as in training (default: the training run's)."""
    if path is not None and Path(path).suffix == ".pt2":
        if not Path(path).is_file():
            raise CheckpointError(f"{path}: no exported actor there (write one with "
                                  "`explore-rl-export CHECKPOINT actor.pt --program actor.pt2`)")
        program = ExportedActor.load(path)
        return DeployedPolicy(program, max_nodes or program.graph_max_nodes, str(path))
    actor, actor_file = load_actor(path)

    def logits(x, adj, mask):
        with torch.no_grad():
            return actor(x[None], adj[None], mask[None])[0]

    return DeployedPolicy(logits, max_nodes or actor_file.graph_max_nodes, str(path or "shipped policy"), actor_file)


def export_program(actor_path: str | Path | None, out: str | Path) -> Path:
    """The actor of ``actor_path`` as a ``torch.export`` program at ``out`` (``*.pt2``)."""
    actor, actor_file = load_actor(actor_path)
    export_actor(actor, out, graph_max_nodes=actor_file.graph_max_nodes)
    return Path(out)


def main(argv: Sequence[str] | None = None) -> None:
    """``explore-rl-export CHECKPOINT OUT.pt [--program OUT.pt2] [--features SET]``."""
    parser = argparse.ArgumentParser(
        prog="explore-rl-export",
        description="Write the actor file of a training checkpoint (weights + model config, for "
                    "policy=learned, explore-rl-eval and explore_rl.deploy), optionally also its "
                    "torch.export program.")
    parser.add_argument("checkpoint", help="a training checkpoint (RUN/checkpoints/best.pt) or an actor file")
    parser.add_argument("out", help="the actor file to write, e.g. policies/buildings_office_distill/actor.pt")
    parser.add_argument("--program", help="also write the torch.export program here (e.g. actor.pt2)")
    parser.add_argument("--features", default=None,
                        help="write it reading this graph.features (exact only: e.g. no_covariance from an actor "
                             "whose weights on the covariance columns are 0)")
    args = parser.parse_args(argv)
    try:
        if args.program:
            check_output_file(args.program, "actor.pt2")  # before anything is written
        path = export_actor_file(args.checkpoint, args.out, args.features)
        size = path.stat().st_size / 2**20
        print(f"wrote {path} ({size:.1f} MB)")
        if args.program:
            print(f"wrote {export_program(path, args.program)}")
    except ValueError as error:  # CheckpointError, or an output path that is a folder
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
