"""Decision time on real states: EM, the learned policy (fast path and reference) and nearest frontier.

The states are those of an exploration driven by the learned policy (the shipped actor,
``graph.max_nodes=1024``, the real front end ``slam=icp``) in the zero-shot scenes street
and garage: every ``EVERY``-th decision, the same state is handed to EM (default fast
backend), to the learned policy's fast path (the pose marginals by depth levels with
loop-free chains halved, one landmark fusion by EM's fast rounds, KD-tree pairs, line of
sight by length, the encoding padded only to the graph's nodes, the g-U-Net's input
level from the encoded edges) and to its
reference (the first implementation, EM's marginals, padded to ``graph.max_nodes``),
and to nearest frontier. Times are each policy's ``choose`` (after a warm-up call, the
mean of the same number of repeats for EM and the learned policy: 3, ``--quick`` 2);
``ms_state`` is the state itself (the runner's ``observe``: frontiers, Dijkstra, paths; what every policy pays
before choosing, timed once per decision), so ``em_over_learned_decide``
compares what the runner's ``ms_decide`` column holds. ``ms_observe`` times that observation again
like the choices (warm-up, repeats) and ``ms_observe_reference`` the same moment observed by every
stage as first written (``Explorer.observe(reference=True)``: whole-grid traversability, frontiers
and graph, one path at a time); ``same_observation``: both give the state bit for bit,
``observe_speedup`` their ratio. On every state the fast path must
be the reference's decision under :class:`~explore_rl.planning.learned.Equivalence`
(round-off only: the same frontier, node features within 1e-9 relative, logits within
1e-6 of the largest, probabilities within 1e-6). ``em_over_shared`` is the structural
bound: EM over the parts EM pays too (the action set and the pose marginals), i.e. the
ratio if every part of the learned decision only it has (landmark fusion, extras, graph,
encoding, forward) cost nothing; an actor of ``graph.features=no_covariance`` (``reads_covariances`` false)
pays neither the marginals nor the landmarks in its ``choose``, though both are still timed as parts (what a
covariance-reading actor pays). ``ms_top{k}`` times the hybrid ``policy.em_top_k=k`` (the
actor shortlists k frontiers, EM picks among them; k in ``SHORTLISTS``) on the same states,
``em_over_top{k}`` EM over it. One torch thread, as ``explore-rl-eval``'s workers.

    python benchmarks/bench_decision_real.py [--quick | --smoke] [--actor FILE]
"""

from __future__ import annotations

import sys
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, new_observation, parse_args, time_call  # noqa: E402

import torch  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.graph.encode import encode  # noqa: E402
from explore_rl.graph.exploration_graph import (  # noqa: E402
    action_frontiers,
    factor_edges,
    graph_from_estimates,
    select_features,
)
from explore_rl.graph.features import frontier_extras, has_loop_length, reads_covariances  # noqa: E402
from explore_rl.planning.actions import select_actions  # noqa: E402
from explore_rl.planning.em import EMPlanner, pose_covariances  # noqa: E402
from explore_rl.planning.learned import (  # noqa: E402
    Equivalence,
    LearnedPolicy,
    actor_logits,
    decision_difference,
    frontier_covariances,
    landmark_covariances,
    landmarks_near,
    pose_marginals,
)
from explore_rl.planning.policies import NearestFrontier, PolicyConfig  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402
from explore_rl.state import ExplorationState  # noqa: E402

EQUIVALENCE = Equivalence()
SHORTLISTS = (2, 3)  # policy.em_top_k values timed beside EM and the actor alone
ZERO_SHOT = ["slam=icp", "graph.max_nodes=1024", "policy=learned", "explore.progress_bar=false", "seed=0"]


def part_times(state: ExplorationState, policy: LearnedPolicy, repeats: int) -> dict:
    """Milliseconds of each part of the learned decision on ``state`` (the fast path's
    parts, and the reference's version of each part the fast path replaced)."""
    planning, session = policy.planning, state.session
    vmap = policy.virtual_map(session.occupancy.grid)
    actions = select_actions(state, planning.actions, planning.revisits)
    poses = session.graph.poses_se2()
    pose_covs = pose_marginals(session.graph, poses, planning.em.backend)
    blocked, frontier_xy, radius = session.occupancy.known_occupied, action_frontiers(state, actions), \
        vmap.config.sensor_range
    index = vmap.landmark_index(frontier_xy)
    near = landmarks_near(vmap, frontier_xy, radius)
    landmarks = np.union1d(index[index >= 0], near)
    covs = landmark_covariances(vmap, poses, pose_covs, blocked, near)
    extras = frontier_extras(state, actions, pose_covs, vmap.landmark_xy[near], covs, radius)
    frontier_covs = frontier_covariances(vmap, poses, pose_covs, blocked, frontier_xy)
    edges = factor_edges(session.graph.edges)
    loops = has_loop_length(policy.features)  # graph.features=loops: loop_length from the graph's own edges
    graph = select_features(graph_from_estimates(state, actions, poses, pose_covs, frontier_covs, edges, extras, loops),
                            policy.features)
    compact, padded = encode(graph, policy.max_nodes, compact=True), encode(graph, policy.max_nodes)

    def reference_landmarks() -> None:  # the frontiers' landmarks, then those near them, full distance matrices
        frontier_covariances(vmap, poses, pose_covs, blocked, frontier_xy, reference=True)
        landmark_covariances(vmap, poses, pose_covs, blocked, near, reference=True)

    parts = {
        "actions": lambda: select_actions(state, planning.actions, planning.revisits),
        "actions_reference": lambda: select_actions(state, planning.actions, planning.revisits, reference=True),
        "marginals": lambda: pose_marginals(session.graph, poses, planning.em.backend),
        "marginals_reference": lambda: pose_covariances(session.graph, poses, planning.em.backend),
        "landmarks": lambda: landmark_covariances(vmap, poses, pose_covs, blocked, landmarks),
        "landmarks_reference": reference_landmarks,
        "extras": lambda: frontier_extras(state, actions, pose_covs, vmap.landmark_xy[near], covs, radius),
        "graph_build": lambda: graph_from_estimates(state, actions, poses, pose_covs, frontier_covs, edges, extras,
                                                    loops),
        "encode": lambda: encode(graph, policy.max_nodes, compact=True),
        "encode_reference": lambda: encode(graph, policy.max_nodes),
        "forward": lambda: actor_logits(policy.actor, compact),
        "forward_reference": lambda: actor_logits(policy.actor, padded),
    }
    return {f"ms_part_{name}": 1e3 * time_call(new_observation(part), repeats) for name, part in parts.items()}



def measure_state(state: ExplorationState, ms_state: float, learned: LearnedPolicy, reference: LearnedPolicy,
                  em: EMPlanner, repeats: int, hybrids: dict[int, LearnedPolicy]) -> dict:
    """Milliseconds of each policy's ``choose`` on ``state`` and the fast/reference agreement."""
    ms_em = 1e3 * time_call(lambda: em.choose(state), repeats)  # as the learned policy: less noise
    ms_hybrid = {f"ms_top{k}": 1e3 * time_call(new_observation(lambda h=hybrid: h.choose(state)), repeats)
                 for k, hybrid in hybrids.items()}
    ms_reference = 1e3 * time_call(new_observation(lambda: reference.choose(state)), repeats)
    ms_learned = 1e3 * time_call(new_observation(lambda: learned.choose(state)), repeats)
    parts = dict(learned.last_ms)
    learned.choose(state), reference.choose(state)
    difference = decision_difference(learned, reference)
    n = len(learned.last_encoded.nodes)
    nearest = NearestFrontier()
    return {"poses": int(state.session.graph.num_poses), "candidates": len(state.candidates),
            "graph_nodes": int(learned.last_graph.num_nodes), "ms_state": ms_state, "ms_em": ms_em,
            "ms_learned": ms_learned, "ms_learned_reference": ms_reference,
            "ms_nearest": 1e3 * time_call(lambda: nearest.choose(state), 100),
            "ms_learned_actions": parts["actions"], "ms_learned_graph": parts["graph"],
            "ms_learned_forward": parts["forward"], "same_choice": difference.same_choice,
            "equivalent": difference.within(EQUIVALENCE), "feature_rel_diff": difference.feature_rel,
            "logit_rel_diff": difference.logit_rel, "probability_diff": difference.probability,
            "max_logit_diff": float((learned.last_logits - reference.last_logits[:n]).abs().max()),
            **ms_hybrid, **part_times(state, learned, repeats)}


def observation_times(explorer: Explorer, state: ExplorationState, repeats: int) -> dict:
    """Milliseconds of the runner's observation of ``state``'s moment and of its reference
    (every stage as first written), timed alike, and whether both observed ``state``."""
    same = state.same_observation(explorer.observe()) and state.same_observation(explorer.observe(reference=True))
    return {"ms_observe": 1e3 * time_call(explorer.observe, repeats),
            "ms_observe_reference": 1e3 * time_call(lambda: explorer.observe(reference=True), repeats),
            "same_observation": same}


def explore(scene: str, max_decisions: int, every: int, repeats: int, extra: list[str]) -> list[dict]:
    """Drive ``scene`` with the learned policy (fast path); measure every ``every``-th state."""
    config = load_config([f"scene={scene}", *ZERO_SHOT, *extra])
    explorer = Explorer(config)
    learned = explorer.policy
    assert isinstance(learned, LearnedPolicy)
    reference = LearnedPolicy(learned.config, config.planning, graph=config.graph, actor=learned.actor,
                              reference=True)
    reference.features = learned.features
    em = EMPlanner(PolicyConfig(name="em"), config.planning)
    hybrids = {k: LearnedPolicy(replace(learned.config, em_top_k=k), config.planning, graph=config.graph,
                                actor=learned.actor, robot=config.robot) for k in SHORTLISTS}
    for hybrid in hybrids.values():
        hybrid.features = learned.features
    rows = []
    for decision in range(max_decisions):
        state = explorer.next_state()
        ms_state = explorer.ms_observe  # the runner's share of ms_decide before the choice
        if state is None:
            break
        if decision % every == every - 1:
            rows.append({"scene": scene, "decision": decision, "features": learned.features,
                         **measure_state(state, ms_state, learned, reference, em, repeats, hybrids),
                         **observation_times(explorer, state, repeats)})
            r = rows[-1]
            print(f"{scene:7s} {decision:3d} {r['poses']:5d} {r['graph_nodes']:6d} {r['ms_state']:8.1f} "
                  f"{r['ms_em']:8.1f} {r['ms_learned']:8.1f} {r['ms_learned_reference']:8.1f} "
                  f"({r['ms_learned_actions']:.1f} / {r['ms_learned_graph']:.1f} / {r['ms_learned_forward']:.1f}) "
                  f"{r['ms_em'] / r['ms_learned']:6.1f} {r['equivalent']!s:>6} {r['feature_rel_diff']:.1e} "
                  f"{r['logit_rel_diff']:.1e} {r['probability_diff']:.1e}", flush=True)
        explorer.act(state, learned.choose(state))
    return rows


def summary(rows: list[dict]) -> dict:
    """Means and medians over the measured states, the ratios of the means and the median
    of the per-state ratios (single states are noisy on a shared machine: the median)."""
    keys = ("ms_state", "ms_observe", "ms_observe_reference", "ms_em", "ms_learned", "ms_learned_reference",
            "ms_nearest", "ms_learned_actions",
            "ms_learned_graph", "ms_learned_forward", "poses",
            *[key for key in rows[0] if key.startswith(("ms_part_", "ms_top"))])
    mean = {key: float(np.mean([r[key] for r in rows])) for key in keys}
    median = {f"{key}_median": round(float(np.median([r[key] for r in rows])), 2) for key in keys}
    ratios = np.array([r["ms_em"] / r["ms_learned"] for r in rows])
    decide = np.array([(r["ms_state"] + r["ms_em"]) / (r["ms_state"] + r["ms_learned"]) for r in rows])
    return {**{key: round(value, 2) for key, value in mean.items()}, **median, "states": len(rows),
            "em_over_learned": round(mean["ms_em"] / mean["ms_learned"], 2),
            "em_over_learned_reference": round(mean["ms_em"] / mean["ms_learned_reference"], 2),
            "em_over_learned_decide": round((mean["ms_state"] + mean["ms_em"])
                                            / (mean["ms_state"] + mean["ms_learned"]), 2),
            "em_over_learned_median": round(float(np.median(ratios)), 2),
            "em_over_shared": round(mean["ms_em"] / (mean["ms_part_actions"] + mean["ms_part_marginals"]), 2),
            "em_over_learned_decide_median": round(float(np.median(decide)), 2),
            "em_over_learned_min": round(float(ratios.min()), 2),
            "observe_speedup": round(mean["ms_observe_reference"] / mean["ms_observe"], 2),
            **{f"em_over_top{k}": round(mean["ms_em"] / mean[f"ms_top{k}"], 2) for k in SHORTLISTS},
            "states_at_5x": int(np.sum(ratios >= 5)),
            "reference_over_learned": round(mean["ms_learned_reference"] / mean["ms_learned"], 2),
            "reference_over_learned_median": round(float(np.median(
                [r["ms_learned_reference"] / r["ms_learned"] for r in rows])), 2)}


def print_parts(scenes: dict[str, dict]) -> None:
    """The mean ms of each part per scene, fast path and reference side by side."""
    names = [key[len("ms_part_"):] for key in next(iter(scenes.values())) if key.startswith("ms_part_")
             and not key.endswith(("_reference", "_median"))]
    print(f"{'part':12s}" + "".join(f"{scene + ' fast':>14s}{scene + ' ref':>14s}" for scene in scenes))
    for name in names:
        cells = []
        for s in scenes.values():
            fast = s[f"ms_part_{name}"]
            cells.append(f"{fast:14.1f}{s.get(f'ms_part_{name}_reference', fast):14.1f}")
        print(f"{name:12s}" + "".join(cells))


def add_actor(parser) -> None:
    parser.add_argument("--actor", default=None, help="the actor file that drives and decides (default: the shipped one)")


def main() -> None:
    args = parse_args(__doc__.splitlines()[0], add_arguments=add_actor)
    if args.actor is not None and not Path(args.actor).is_file():
        sys.exit(f"--actor {args.actor}: no such file")
    torch.set_num_threads(1)
    if args.smoke:  # the office with the model front end: seconds, figures meaningless
        plan, repeats, extra = [("office", 2, 1)], 1, ["slam=model"]
    elif args.quick:
        plan, repeats, extra = [("street", 12, 4)], 2, []
    else:
        plan, repeats, extra = [("street", 60, 3), ("garage", 60, 3)], 3, []
    if args.actor is not None:
        extra = [*extra, f"policy.checkpoint={args.actor}"]
    print(f"{'scene':7s} {'dec':>3s} {'poses':>5s} {'nodes':>6s} {'ms state':>8s} {'ms EM':>8s} {'learned':>8s} "
          f"{'ref':>8s} (actions / graph / forward) EM/learned equivalent (features / logits / probabilities)")
    rows = [row for scene, decisions, every in plan for row in explore(scene, decisions, every, repeats, extra)]
    scenes = {scene: summary([r for r in rows if r["scene"] == scene]) for scene, _, _ in plan}
    for scene, s in scenes.items():
        print(scene, s)
    print_parts(scenes)
    features = rows[0]["features"] if rows else None
    emit({"benchmark": "decision_real", "quick": args.quick, "smoke": args.smoke, "actor": args.actor,
          "features": features, "reads_covariances": reads_covariances(features) if features else None,
          **summary(rows), "scenes": scenes,
          "same_choice": all(r["same_choice"] for r in rows),
          "same_observation": all(r["same_observation"] for r in rows),
          "equivalent": all(r["equivalent"] for r in rows),
          "equivalence": asdict(EQUIVALENCE),
          **{key: max(r[key] for r in rows) for key in ("feature_rel_diff", "logit_rel_diff", "probability_diff",
                                                        "max_logit_diff")},
          "rows": [{key: (round(value, 2) if isinstance(value, float) and not key.endswith("_diff") else value)
                    for key, value in r.items()}
                   for r in rows],
          "machine": machine()})


if __name__ == "__main__":
    main()
