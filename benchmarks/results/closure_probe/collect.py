"""Collect decisions with each frontier's *relative* loop uncertainty (session 45, closure_probe/plan.md).

Per decision of a ``graph.features=loops`` exploration (the env of the trainer, ``slam=model``, building family),
for every frontier of the action set: its ``loops`` node features, EM's Algorithm 1 reward, and
``loop_uncertainty``: the largest trace of the world-frame xy covariance of the robot's keyframe *relative to* a
keyframe the frontier's path revisits (``Cov(p_c - p_k)``, from one sparse factorisation of the pose graph's
information matrix and the current keyframe's covariance columns; 0 if the path revisits none). That is what a
loop closure corrects, and what ``loop_length`` stands in for. And three quantities of the virtual map along the
path (``path_map``; plan addendum of 21:35): of the virtual landmarks within sensor range of the path's predicted
keyframes (line of sight ignored), how many (``landmarks``), the sum of the traces of their covariances
(``uncertainty``, m^2), and the sum of what one observation from a pose as uncertain as the robot's would take off
those traces (``gain``, m^2): EM's first-order term, without its forward simulation. Research code: not a feature
of the product.

Spawned workers play whole episodes (an actor file in the loop, greedy, a random valid frontier with probability
``--explore``); the main process appends one JSON line per decision to ``OUT/decisions.jsonl`` and one per
episode to ``OUT/episodes.jsonl``; running it again resumes (finished episodes are skipped).

    python benchmarks/results/closure_probe/collect.py --out /work/runs/closure_probe --episodes 200 \
        [--layouts 0 1000] [--max-decisions 20] [--workers 2] [--minutes 30] [--actor FILE] [--explore 0.25]

The last line of stdout is one JSON object: ``decisions``, ``episodes``, ``layouts``, ``decisions_per_s``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from common import spawned_results  # noqa: E402

ACTOR = "benchmarks/results/loop_feature/candidate_widened_loops_actor.pt"
EPISODE_STREAM = 45  # the episodes' seeds, apart from every other stream of the project


def relative_uncertainty(information, poses: np.ndarray, current: int) -> np.ndarray:
    """``(K,)`` trace of the world-frame xy covariance of ``p_current - p_k`` for every keyframe ``k``, from the
    pose graph's information matrix ``(6K, 6K)`` (Pose3 tangents in pose order) at planar ``poses (K, 3)``
    (``explore_rl.planning.learned.relative_position_covariances``, which ``policy.closure_bias`` reads)."""
    from explore_rl.planning.learned import relative_position_covariances

    relative = relative_position_covariances(information, poses, current, np.arange(len(poses)))
    return np.trace(relative, axis1=1, axis2=2)


def path_map(prediction, landmark_xy: np.ndarray, landmark_covs: np.ndarray, robot_xy_cov: np.ndarray,
             sensor_range: float) -> tuple[int, float, float]:
    """``(landmarks, uncertainty, gain)`` of the virtual landmarks within ``sensor_range`` of a path's predicted
    keyframes (see the module docstring); an observation is taken as the robot's xy covariance."""
    from scipy.spatial import cKDTree

    if len(prediction.poses) == 0:
        return 0, 0.0, 0.0
    near = cKDTree(prediction.poses[:, :2]).query_ball_point(landmark_xy, sensor_range, return_length=True) > 0
    covs = landmark_covs[near]
    if not len(covs):
        return 0, 0.0, 0.0
    after = np.linalg.inv(np.linalg.inv(covs) + np.linalg.inv(robot_xy_cov))
    before = np.trace(covs, axis1=1, axis2=2)
    return int(near.sum()), float(before.sum()), float((before - np.trace(after, axis1=1, axis2=2)).sum())


def decision_row(decision, em=None) -> dict | None:
    """One decision's record (None if EM failed on it); ``em``: the env's EM planner, for the virtual map."""
    from explore_rl.graph.features import feature_names
    from explore_rl.planning.learned import linearised_information

    if decision.rewards is None:
        return None
    state, graph = decision.state, decision.graph
    poses = state.session.graph.poses_se2()
    current = int(graph.keyframe[graph.current])
    relative = relative_uncertainty(linearised_information(state.session.graph), poses, current)
    loop_uncertainty = [max((float(relative[r.keyframe_index]) for r in action.prediction.revisits), default=0.0)
                        for action in decision.actions]
    row = {"features": list(feature_names("loops")),
            "x": np.round(graph.features[graph.frontier_nodes], 6).tolist(),
            "loop_uncertainty": np.round(loop_uncertainty, 8).tolist(),
            "rewards": np.round(decision.rewards, 8).tolist(), "em_choice": int(decision.em_choice),
            "poses": len(poses)}
    if em is not None:
        context = em.decision_context(state)
        robot = context.pose_covs[current, :2, :2] + 1e-9 * np.eye(2)
        values = [path_map(action.prediction, context.vmap.landmark_xy, context.landmark_covs, robot,
                           context.vmap.config.sensor_range) for action in decision.actions]
        row["path_map"] = {key: [v[k] for v in values] for k, key in enumerate(("landmarks", "uncertainty", "gain"))}
    return row


def play(task: tuple) -> tuple[int, list[dict], dict]:
    """Episode ``k``: its decision records and a summary."""
    config, k, max_decisions, actor_path, explore = task
    import torch

    from explore_rl.envs.factory import make_env
    from explore_rl.models.actor_file import load_actor
    from explore_rl.models.actor_critic import greedy_row

    torch.set_num_threads(1)
    start = time.perf_counter()
    seed = int(np.random.SeedSequence([config.seed, EPISODE_STREAM, k]).generate_state(1)[0])
    rng = np.random.default_rng(seed)
    actor, _ = load_actor(actor_path)
    env = make_env(config)
    env.set_seed(seed)
    td, rows = env.reset(), []
    layout = int(td["layout"])
    for step in range(max_decisions):
        row = decision_row(env.decision, env.em)
        if row is not None:
            rows.append({"episode": k, "layout": layout, "step": step, **row})
        mask = td["action_mask"]
        if rng.random() < explore:
            action = int(rng.choice(np.flatnonzero(mask.numpy())))
        else:
            with torch.no_grad():
                action = greedy_row(actor(td["x"], td["adj"], td["node_mask"]), mask)
        td = env.step(td.set("action", torch.tensor(action)))["next"]
        if bool(td["done"]):
            break
    return k, rows, {"episode": k, "layout": layout, "decisions": len(rows),
                     "seconds": round(time.perf_counter() - start, 2)}


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder of decisions.jsonl (created or grown)")
    parser.add_argument("--episodes", type=int, default=200, help="episodes in all (finished ones are skipped)")
    parser.add_argument("--layouts", type=int, nargs=2, default=[0, 1000], metavar=("FIRST", "STOP"))
    parser.add_argument("--max-decisions", type=int, default=20)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--minutes", type=float, default=0.0, help="start no episode after this (0: no limit)")
    parser.add_argument("--actor", default=ACTOR, help="a graph.features=loops actor file in the loop")
    parser.add_argument("--explore", type=float, default=0.25, help="probability of a random valid frontier")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE")
    args = parser.parse_args(argv)
    for key in ("episodes", "max_decisions", "workers"):
        if getattr(args, key) < 1:
            parser.error(f"--{key.replace('_', '-')} must be >= 1, got {getattr(args, key)}")
    if args.layouts[1] <= args.layouts[0]:
        parser.error(f"--layouts {args.layouts[0]} {args.layouts[1]}: STOP must be > FIRST")
    if not 0.0 <= args.explore <= 1.0:
        parser.error(f"--explore {args.explore}: give a probability in [0, 1]")
    if not Path(args.actor).is_file():
        parser.error(f"--actor {args.actor}: no such file")
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    from explore_rl.config import load_config
    from explore_rl.models.actor_file import read_actor_file

    try:
        config = load_config(["scene=building", "slam=model", "graph.features=loops",
                              f"env.train_layouts=[{args.layouts[0]},{args.layouts[1]}]", *args.set])
        if read_actor_file(args.actor).feature_set != "loops":
            raise ValueError(f"--actor {args.actor}: give an actor reading graph.features=loops")
    except ValueError as error:
        sys.exit(str(error))
    args.out.mkdir(parents=True, exist_ok=True)
    episodes_file, decisions_file = args.out / "episodes.jsonl", args.out / "decisions.jsonl"
    done = {json.loads(line)["episode"] for line in episodes_file.read_text().splitlines()} \
        if episodes_file.is_file() else set()
    tasks = [(config, k, args.max_decisions, args.actor, args.explore) for k in range(args.episodes) if k not in done]
    started, stored = time.perf_counter(), 0
    deadline = started + 60 * args.minutes if args.minutes > 0 else float("inf")
    for _, rows, info in spawned_results(play, tasks, args.workers, deadline):
        with open(decisions_file, "a") as handle:
            handle.writelines(json.dumps(row) + "\n" for row in rows)
        with open(episodes_file, "a") as handle:
            handle.write(json.dumps(info) + "\n")
        stored += len(rows)
        print(json.dumps(info), file=sys.stderr, flush=True)
    rows = [json.loads(line) for line in decisions_file.read_text().splitlines()] if decisions_file.is_file() else []
    print(json.dumps({"decisions": len(rows), "episodes": len({row["episode"] for row in rows}),
                      "layouts": len({row["layout"] for row in rows}),
                      "decisions_per_s": round(stored / max(time.perf_counter() - started, 1e-9), 3)}))


if __name__ == "__main__":
    main()
