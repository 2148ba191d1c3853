"""Cost of the policy networks: our padded-batch g-U-Net actor-critic
(``explore_rl.models.graph_unet``: padded tensors in and out, packed sparse maths inside)
against the same networks built on PyG's ``GraphUNet`` (sparse edge lists), same inputs.

* **Train step**: forward + backward + Adam step of actor and critic together (an
  A2C-shaped loss: policy gradient, value regression, entropy) on one batch of
  ``batch_size`` synthetic exploration graphs, per hidden size. Dropout is on. Each step
  packs the batch afresh, as training does with each new batch (the critic reuses the
  actor's packing of the same observation, as in training).
* **Decision latency**: the actor alone, eval mode, no gradients, one graph of 300 and of
  800 nodes (the robot's per-decision cost), packed afresh each call.

Both sides use the same weights (PyG's are copied into ours; the heads and the input
feature scaling are shared copies), and the run checks that their logits agree. PyG gets
its edge lists prepared outside the timed region; our side reads the padded tensors
``explore_rl.graph.encode`` produces. One torch thread (``torch.set_num_threads(1)``) so
figures compare across runs and machine load, and because the learner shares the CPU
with the env workers; each figure is the fastest of a few repeats (the least disturbed by
other processes on a shared machine), ours and PyG's taking turns. ``*_cpu`` keys give the fastest CPU time of the
thread as well: on a loaded machine wall-clock minima favour the shorter call (a longer
one is more likely to be interrupted in every repeat), CPU time does not.

Graphs come from :func:`synthetic_exploration_graph` (a random-walk pose chain with loop
closures and frontiers, features as the encoder's contract).

    python benchmarks/bench_policy.py [--quick | --smoke]
"""

from __future__ import annotations

import copy
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

from explore_rl.models.actor_critic import GraphActor, GraphCritic  # noqa: E402
from explore_rl.models.config import ModelConfig  # noqa: E402
from explore_rl.models.graph_unet import INPUT_LEVELS, state_dict_from_pyg  # noqa: E402


@dataclass
class GraphShape:
    """How the synthetic exploration graphs look (numbers from DESIGN.md)."""

    area: float = 20.0  # m, square the robot walks in
    step: float = 0.5  # m between keyframes
    turn_std: float = 0.4  # rad, heading change per keyframe
    loop_radius: float = 1.0  # m; a revisit this close to an older pose may close a loop
    loop_min_gap: int = 20  # keyframes; closer ones are sequential, not loops
    loops_per_pose: float = 0.04  # at most this many loop edges per pose
    min_frontiers: int = 5
    max_frontiers: int = 20
    max_poses_per_frontier: int = 3
    frontier_reach: tuple[float, float] = (1.0, 3.0)  # m from a pose it attaches to
    trace_per_metre: float = 2e-4  # m^2 of xy covariance trace per metre travelled
    landmark_prior_trace: float = 0.08  # 2 x (0.2 m)^2, a virtual landmark's prior


@dataclass
class BenchSetup:
    hidden_sizes: list[int] = field(default_factory=lambda: [1000, 256, 128])
    batch_size: int = 16
    batch_nodes: tuple[int, int] = (50, 300)  # graph sizes drawn uniformly in this range
    decision_nodes: list[int] = field(default_factory=lambda: [300, 800])
    train_repeats: int = 5
    decision_repeats: int = 20
    learning_rate: float = 1e-4  # paper's A2C learning rate
    value_coef: float = 0.5
    entropy_coef: float = 0.01
    seed: int = 0


QUICK = dict(hidden_sizes=[128], train_repeats=3, decision_repeats=10)
SMOKE = dict(hidden_sizes=[16], batch_size=4, batch_nodes=(20, 60), decision_nodes=[300, 800],
             train_repeats=1, decision_repeats=1)


@dataclass
class EncodedGraph:
    """One graph as the encoder's contract: features, metre-weighted adjacency, frontiers."""

    x: np.ndarray  # [n, 4]: trace of xy covariance, distance, bearing, identity
    adj: np.ndarray  # [n, n] symmetric, metres, zero diagonal
    action_mask: np.ndarray  # [n] bool, frontier nodes


def synthetic_exploration_graph(n_nodes: int, rng: np.random.Generator,
                                shape: GraphShape | None = None) -> EncodedGraph:
    """An exploration-graph look-alike: a random walk of keyframes ``step`` apart (pose
    chain), a few loop edges where the walk revisits, and 5-20 frontiers each attached to
    1-3 poses (the first to the current pose). Nodes: poses in order (the current pose
    last), then frontiers."""
    shape = shape or GraphShape()
    n_frontiers = int(min(rng.integers(shape.min_frontiers, shape.max_frontiers + 1), n_nodes - 1))
    n_poses = n_nodes - n_frontiers
    poses = random_walk(n_poses, shape, rng)
    current = n_poses - 1
    adj = np.zeros((n_nodes, n_nodes))
    chain = np.arange(n_poses - 1)
    add_edges(adj, poses, chain, chain + 1)
    add_loop_edges(adj, poses, shape, rng)

    frontiers = frontier_points(poses, n_frontiers, shape, rng)
    points = np.concatenate([poses, frontiers])
    for f in range(n_frontiers):
        add_edges(adj, points, frontier_anchors(poses, frontiers[f], f == 0, shape, rng), n_poses + f)

    travelled = shape.step * np.arange(n_poses)
    trace = np.concatenate([shape.trace_per_metre * travelled,
                            shape.landmark_prior_trace + rng.uniform(0, shape.trace_per_metre * travelled[-1] + 1e-6,
                                                                     n_frontiers)])
    offset = points - points[current]
    identity = np.full(n_nodes, -1.0)
    identity[current], identity[n_poses:] = 0.0, 1.0
    x = np.stack([trace, np.linalg.norm(offset, axis=1), np.arctan2(offset[:, 1], offset[:, 0]), identity], axis=1)
    action_mask = identity == 1.0
    return EncodedGraph(x.astype(np.float32), adj.astype(np.float32), action_mask)


def random_walk(n: int, shape: GraphShape, rng: np.random.Generator) -> np.ndarray:
    """``n`` points ``step`` apart, heading jittering, bouncing off the area's walls."""
    points = np.empty((n, 2))
    points[0] = shape.area / 2
    heading = rng.uniform(-np.pi, np.pi)
    for k in range(1, n):
        heading += rng.normal(0.0, shape.turn_std)
        step = shape.step * np.array([np.cos(heading), np.sin(heading)])
        if not np.all((points[k - 1] + step > 0) & (points[k - 1] + step < shape.area)):
            heading += np.pi
            step = -step
        points[k] = points[k - 1] + step
    return points


def frontier_points(poses: np.ndarray, n: int, shape: GraphShape, rng: np.random.Generator) -> np.ndarray:
    """``n`` frontiers 1-3 m from a pose: the current (last) pose for the first, random
    poses for the others."""
    bases = np.concatenate([[len(poses) - 1], rng.integers(0, len(poses), n - 1)])
    angle = rng.uniform(-np.pi, np.pi, n)
    reach = rng.uniform(*shape.frontier_reach, n)
    return poses[bases] + reach[:, None] * np.stack([np.cos(angle), np.sin(angle)], axis=1)


def frontier_anchors(poses: np.ndarray, frontier: np.ndarray, nearest: bool, shape: GraphShape,
                     rng: np.random.Generator) -> np.ndarray:
    """The poses a frontier is joined to: the current pose for the nearest frontier, else
    the 1-3 poses closest to it (the poses its path would revisit)."""
    if nearest:
        return np.array([len(poses) - 1])
    k = int(rng.integers(1, shape.max_poses_per_frontier + 1))
    return np.argsort(np.linalg.norm(poses - frontier, axis=1))[:k]


def add_edges(adj: np.ndarray, points: np.ndarray, i: np.ndarray, j: np.ndarray | int) -> None:
    """Symmetric edges ``i``-``j`` weighted by Euclidean length."""
    length = np.linalg.norm(points[i] - points[j], axis=1)
    adj[i, j] = length
    adj[j, i] = length


def add_loop_edges(adj: np.ndarray, poses: np.ndarray, shape: GraphShape, rng: np.random.Generator) -> None:
    """Up to ``loops_per_pose * n`` edges between poses that are close in space but far
    apart along the walk."""
    gaps = np.linalg.norm(poses[:, None] - poses[None], axis=-1)
    index = np.arange(len(poses))
    close = (gaps < shape.loop_radius) & (index[:, None] - index[None] > shape.loop_min_gap)
    later, earlier = np.nonzero(close)
    n_loops = min(len(later), int(shape.loops_per_pose * len(poses)))
    chosen = rng.choice(len(later), n_loops, replace=False)
    add_edges(adj, poses, later[chosen], earlier[chosen])


@dataclass
class PolicyBatch:
    """One training batch in both layouts, plus the A2C targets."""

    x: Tensor  # [B, N, 4]
    adj: Tensor  # [B, N, N]
    node_mask: Tensor  # [B, N]
    action_mask: Tensor  # [B, N]
    pyg: tuple[Tensor, Tensor, Tensor, Tensor]  # x, edge_index, batch, edge_weight
    action: Tensor  # [B] a frontier node per graph
    returns: Tensor  # [B]


def make_batch(graphs: list[EncodedGraph], rng: np.random.Generator) -> PolicyBatch:
    """Pad ``graphs`` to the largest one; the same graphs as PyG edge lists."""
    n_slots = max(len(g.x) for g in graphs)
    x = torch.zeros(len(graphs), n_slots, 4)
    adj = torch.zeros(len(graphs), n_slots, n_slots)
    node_mask = torch.zeros(len(graphs), n_slots, dtype=torch.bool)
    action_mask = torch.zeros_like(node_mask)
    for b, g in enumerate(graphs):
        n = len(g.x)
        x[b, :n], adj[b, :n, :n] = torch.from_numpy(g.x), torch.from_numpy(g.adj)
        node_mask[b, :n], action_mask[b, :n] = True, torch.from_numpy(g.action_mask)
    action = torch.tensor([rng.choice(np.flatnonzero(g.action_mask)) for g in graphs])
    returns = torch.from_numpy(rng.uniform(-1.0, 1.0, len(graphs)).astype(np.float32))
    return PolicyBatch(x, adj, node_mask, action_mask, pyg_inputs(graphs), action, returns)


def pyg_inputs(graphs: list[EncodedGraph]) -> tuple[Tensor, Tensor, Tensor, Tensor]:
    xs, edges, weights, batch, offset = [], [], [], [], 0
    for b, g in enumerate(graphs):
        adj = torch.from_numpy(g.adj)
        edge_index = adj.nonzero().T
        xs.append(torch.from_numpy(g.x))
        edges.append(edge_index + offset)
        weights.append(adj[edge_index[0], edge_index[1]])
        batch.append(torch.full((len(g.x),), b, dtype=torch.long))
        offset += len(g.x)
    return torch.cat(xs), torch.cat(edges, dim=1), torch.cat(batch), torch.cat(weights)


class PygActorCritic(nn.Module):
    """The same actor and critic on ``torch_geometric.nn.GraphUNet``; outputs padded like ours."""

    def __init__(self, actor: GraphActor, critic: GraphCritic, config: ModelConfig, n_features: int):
        super().__init__()
        from torch_geometric.nn import GraphUNet

        def unet() -> nn.Module:
            return GraphUNet(n_features, config.hidden, config.hidden, config.depth,
                             pool_ratios=config.pool_ratio, sum_res=config.sum_res)

        self.actor_unet, self.critic_unet = unet(), unet()
        actor.unet.load_state_dict(state_dict_from_pyg(self.actor_unet.state_dict()))
        critic.unet.load_state_dict(state_dict_from_pyg(self.critic_unet.state_dict()))
        self.actor_head, self.critic_head = copy.deepcopy(actor.head), copy.deepcopy(critic.head)
        self.scale = copy.deepcopy(actor.scale)  # model.feature_scale, as both of ours apply

    def actor_logits(self, x: Tensor, edge_index: Tensor, batch: Tensor, edge_weight: Tensor,
                     n_slots: int) -> Tensor:
        from torch_geometric.utils import to_dense_batch

        features = self.actor_unet(self.scale(x), edge_index, batch=batch, edge_weight=edge_weight)
        return to_dense_batch(self.actor_head(features), batch, max_num_nodes=n_slots)[0].squeeze(-1)

    def forward(self, batch: PolicyBatch) -> tuple[Tensor, Tensor]:
        from torch_geometric.utils import scatter

        x, edge_index, node_batch, edge_weight = batch.pyg
        logits = self.actor_logits(x, edge_index, node_batch, edge_weight, batch.x.shape[1])
        features = self.critic_unet(self.scale(x), edge_index, batch=node_batch, edge_weight=edge_weight)
        scores = self.critic_head(features).squeeze(-1)
        return logits, scatter(scores, node_batch, reduce="mean")


class DenseActorCritic(nn.Module):
    def __init__(self, actor: GraphActor, critic: GraphCritic):
        super().__init__()
        self.actor, self.critic = actor, critic

    def forward(self, batch: PolicyBatch) -> tuple[Tensor, Tensor]:
        # Every training step sees a new batch: no packing left over from the last step
        # (the critic reuses the actor's, as in training).
        INPUT_LEVELS.clear()
        inputs = (batch.x, batch.adj, batch.node_mask)
        return self.actor(*inputs), self.critic(*inputs).squeeze(-1)


def a2c_loss(logits: Tensor, values: Tensor, batch: PolicyBatch, setup: BenchSetup) -> Tensor:
    """Policy gradient + value regression - entropy bonus, over frontier nodes only."""
    log_probs = F.log_softmax(logits.masked_fill(~batch.action_mask, -torch.inf), dim=-1)
    chosen = log_probs.gather(-1, batch.action.unsqueeze(-1)).squeeze(-1)
    # 0 * log(0) of a masked node is NaN, and so is its gradient even when masked out after
    # the product: take the product with finite log-probabilities only.
    entropy = -(log_probs.exp() * log_probs.masked_fill(~batch.action_mask, 0.0)).sum(-1)
    advantage = batch.returns - values.detach()
    return (-(advantage * chosen).mean() + setup.value_coef * (batch.returns - values).square().mean()
            - setup.entropy_coef * entropy.mean())


@dataclass
class Timing:
    wall_ms: float  # fastest wall-clock time of the repeats
    cpu_ms: float  # fastest CPU time of this thread: leaves out the time other processes ran


def best_ms(calls: dict[str, Callable[[], object]], repeats: int) -> dict[str, Timing]:
    """Fastest of ``repeats`` calls of each function after one warm-up each; the functions
    take turns, so that all see the same spells of machine load. The minimum is the figure
    least disturbed by other processes. CPU time too: under load it compares more fairly
    than wall-clock (a longer call is more likely to be interrupted in every repeat)."""
    for fn in calls.values():
        fn()
    wall: dict[str, list[float]] = {name: [] for name in calls}
    cpu: dict[str, list[float]] = {name: [] for name in calls}
    for _ in range(repeats):
        for name, fn in calls.items():
            start, start_cpu = time.perf_counter(), time.thread_time()
            fn()
            wall[name].append(time.perf_counter() - start)
            cpu[name].append(time.thread_time() - start_cpu)
    return {name: Timing(1000 * min(wall[name]), 1000 * min(cpu[name])) for name in calls}


def train_steps_ms(models: dict[str, nn.Module], batch: PolicyBatch, setup: BenchSetup) -> dict[str, Timing]:
    """One A2C-shaped training step of each model (its own Adam), timed in turns."""
    def make_step(model: nn.Module) -> Callable[[], None]:
        optimizer = torch.optim.Adam(model.parameters(), lr=setup.learning_rate)
        model.train()

        def step() -> None:
            optimizer.zero_grad()
            a2c_loss(*model(batch), batch, setup).backward()
            optimizer.step()
        return step

    timings = best_ms({name: make_step(model) for name, model in models.items()}, setup.train_repeats)
    for name, model in models.items():  # NaN weights would time something else than training
        if not all(bool(torch.isfinite(p).all()) for p in model.parameters()):
            raise RuntimeError(f"{name}: the training steps made a parameter non-finite")
    return timings


def decision_ms(actor: GraphActor, pyg: PygActorCritic, graph: EncodedGraph,
                setup: BenchSetup) -> dict[str, Timing]:
    """Actor forward on one graph, eval, no gradients (each call a new observation)."""
    batch = make_batch([graph], np.random.default_rng(0))
    x, adj, node_mask = batch.x[0], batch.adj[0], batch.node_mask[0]  # no batch dim, as an env step
    actor.eval()
    pyg.eval()

    def dense_decision() -> Tensor:
        INPUT_LEVELS.clear()
        return actor(x, adj, node_mask)

    with torch.no_grad():
        return best_ms({"dense": dense_decision, "pyg": lambda: pyg.actor_logits(*batch.pyg, len(graph.x))},
                       setup.decision_repeats)


def max_logit_gap(dense: DenseActorCritic, pyg: PygActorCritic, batch: PolicyBatch) -> float:
    """Largest |dense - PyG| over real nodes' logits and the values, eval mode."""
    dense.eval()
    pyg.eval()
    with torch.no_grad():
        (logits_d, values_d), (logits_p, values_p) = dense(batch), pyg(batch)
    gap_logits = (logits_d - logits_p)[batch.node_mask].abs().max()
    return float(torch.maximum(gap_logits, (values_d - values_p).abs().max()))


def measure_hidden(hidden: int, batch: PolicyBatch, decision_graphs: dict[int, EncodedGraph],
                   setup: BenchSetup) -> dict:
    torch.manual_seed(setup.seed)
    config = ModelConfig(hidden=hidden)  # the default head (mlp_hidden) on both sides
    actor, critic = GraphActor(config, 4), GraphCritic(config, 4)
    pyg = PygActorCritic(actor, critic, config, 4)
    dense = DenseActorCritic(actor, critic)
    result = {"max_abs_diff_vs_pyg": max_logit_gap(dense, pyg, batch)}
    for name, timing in train_steps_ms({"dense": dense, "pyg": pyg}, batch, setup).items():
        result[f"ms_train_step_{name}"], result[f"ms_train_step_{name}_cpu"] = timing.wall_ms, timing.cpu_ms
    for n, graph in decision_graphs.items():
        for name, timing in decision_ms(actor, pyg, graph, setup).items():
            result[f"ms_decision_{n}_{name}"], result[f"ms_decision_{n}_{name}_cpu"] = timing.wall_ms, timing.cpu_ms
    print(f"hidden {hidden}: " + ", ".join(f"{k} {v:.3g}" for k, v in result.items()), flush=True)
    return result


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    setup = BenchSetup(**(SMOKE if args.smoke else QUICK if args.quick else {}))
    torch.set_num_threads(1)
    for noise in ("Sparse invariant checks", "Sparse CSR tensor support"):  # PyG's augment_adj
        warnings.filterwarnings("ignore", message=noise)
    rng = np.random.default_rng(setup.seed)
    sizes = rng.integers(setup.batch_nodes[0], setup.batch_nodes[1] + 1, setup.batch_size)
    batch = make_batch([synthetic_exploration_graph(int(n), rng) for n in sizes], rng)
    decision_graphs = {n: synthetic_exploration_graph(n, rng) for n in setup.decision_nodes}

    per_hidden = {h: measure_hidden(h, batch, decision_graphs, setup) for h in setup.hidden_sizes}
    emit(summarise(per_hidden, setup, sizes, args))


def summarise(per_hidden: dict[int, dict], setup: BenchSetup, sizes: np.ndarray, args) -> dict:
    """The JSON last line: per-hidden dicts, flat figures at hidden 1000 (None unless
    measured) and decision latency at the largest hidden measured."""
    def per(key: str) -> dict[str, float]:
        return {str(h): round(r[key], 2) for h, r in per_hidden.items()}

    paper = per_hidden.get(1000)
    largest = max(per_hidden)
    result = {
        "benchmark": "policy", "quick": args.quick, "smoke": args.smoke, "torch_threads": 1,
        "batch_graphs": setup.batch_size, "batch_nodes_mean": float(np.mean(sizes)),
        "batch_nodes_max": int(np.max(sizes)),
        "ms_train_step_dense": per("ms_train_step_dense"),
        "ms_train_step_pyg": per("ms_train_step_pyg"),
        "speedup_train": {str(h): round(r["ms_train_step_pyg"] / r["ms_train_step_dense"], 2)
                          for h, r in per_hidden.items()},
        "ms_train_step_dense_cpu": per("ms_train_step_dense_cpu"),
        "ms_train_step_pyg_cpu": per("ms_train_step_pyg_cpu"),
        "speedup_train_cpu": {str(h): round(r["ms_train_step_pyg_cpu"] / r["ms_train_step_dense_cpu"], 2)
                              for h, r in per_hidden.items()},
        "ms_train_step_dense_1000": round(paper["ms_train_step_dense"], 2) if paper else None,
        "ms_train_step_pyg_1000": round(paper["ms_train_step_pyg"], 2) if paper else None,
        "speedup_train_1000": round(paper["ms_train_step_pyg"] / paper["ms_train_step_dense"], 2) if paper else None,
        "decision_hidden": largest,
        "max_abs_diff_vs_pyg": max(r["max_abs_diff_vs_pyg"] for r in per_hidden.values()),
    }
    for n in setup.decision_nodes:
        result[f"ms_decision_{n}"] = round(per_hidden[largest][f"ms_decision_{n}_dense"], 2)
        result[f"ms_decision_{n}_pyg"] = round(per_hidden[largest][f"ms_decision_{n}_pyg"], 2)
        result[f"ms_decision_{n}_cpu"] = round(per_hidden[largest][f"ms_decision_{n}_dense_cpu"], 2)
        result[f"ms_decision_{n}_by_hidden"] = per(f"ms_decision_{n}_dense")
    return {**result, "machine": machine()}


if __name__ == "__main__":
    main()
