"""Does the trained policy learn? Greedy office evaluation of training runs vs nearest/EM/random.

For each run folder (``explore-rl-train ... out=DIR``) the actor of its last checkpoint
(and of its numbered snapshots with ``--snapshots``) plays the evaluation episodes of
``explore_rl.trainer.evaluate`` (the office's 9 starts, seeds training never uses, at most
``--max-decisions`` decisions); nearest frontier, EM and random play the same episodes.
Reported: mean Algorithm 1 reward per decision and agreement with EM's choice, and
whether issue 13's bar (nearest + half of EM - nearest) is met. Training curves (episode
reward and EM agreement against wall-clock) of all runs go into one figure and a CSV.

    python benchmarks/study_learning.py --runs runs/office_imitation_s0 runs/office_plain_s0 \\
        [--snapshots] [--checkpoint last|best|update_<k>] [--max-decisions 15] [--out benchmarks/results/learning] [--smoke]
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

from explore_rl.config import load_config, load_saved_config  # noqa: E402
from explore_rl.trainer.evaluate import (  # noqa: E402
    baseline,
    evaluate,
    greedy_actor,
    learning_target,
    summarize,
)

RESULTS = Path(__file__).resolve().parent / "results" / "learning"
BASELINES = ("nearest", "em", "random")
SCALARS = Path("logs") / "a2c" / "scalars"


def evaluate_baselines(config, starts: list[int], max_decisions: int, cache: Path) -> dict:
    """nearest, EM and random on the evaluation episodes (cached: they never change)."""
    key = f"starts={starts},max_decisions={max_decisions}"
    stored = json.loads(cache.read_text()) if cache.is_file() else {}
    if key not in stored:
        stored[key] = {name: summarize(evaluate(config, name, baseline(name), starts, max_decisions))
                       for name in BASELINES}
        cache.parent.mkdir(parents=True, exist_ok=True)
        cache.write_text(json.dumps(stored, indent=1))
    return stored[key]


def read_scalar(run_dir: Path, name: str) -> np.ndarray:
    """``(K, 2)`` rows (decisions collected, value) of one logged scalar."""
    path = run_dir / SCALARS / f"{name}.csv"
    if not path.is_file():
        return np.zeros((0, 2))
    return np.loadtxt(path, delimiter=",", ndmin=2)


def curves(run_dir: Path) -> dict[str, np.ndarray]:
    """Episode reward and EM agreement against wall-clock minutes."""
    wall = read_scalar(run_dir, "wall_s")
    out = {}
    for name in ("episode/reward", "em_agreement", "episode/explored"):
        values = read_scalar(run_dir, name)
        if len(values) and len(wall):
            minutes = np.interp(values[:, 0], wall[:, 0], wall[:, 1]) / 60.0
            out[name] = np.column_stack([values[:, 0], minutes, values[:, 1]])
    return out


def rolling(values: np.ndarray, window: int) -> np.ndarray:
    kernel = np.ones(min(window, len(values))) / min(window, len(values))
    return np.convolve(values, kernel, mode="valid")


def plot_curves(runs: dict[str, dict], baselines: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for name, data in runs.items():
        for ax, key, window in ((axes[0], "episode/reward", 10), (axes[1], "em_agreement", 20)):
            if key in data and len(data[key]) >= 2:
                smooth = rolling(data[key][:, 2], window)
                ax.plot(data[key][len(data[key]) - len(smooth):, 1], smooth, label=name)
    for policy, style in (("nearest", ":"), ("em", "--"), ("random", "-.")):
        if policy in baselines:
            axes[0].axhline(baselines[policy]["mean_reward"], ls=style, c="gray", label=f"{policy} (greedy eval)")
            axes[1].axhline(baselines[policy]["em_agreement"], ls=style, c="gray", label=policy)
    axes[0].set(xlabel="wall-clock [min]", ylabel="Alg. 1 reward per decision", title="training episodes (rolling 10)")
    axes[1].set(xlabel="wall-clock [min]", ylabel="agreement with EM", title="per update (rolling 20)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def write_curves_csv(runs: dict[str, dict], path: Path) -> None:
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["run", "scalar", "decisions", "wall_min", "value"])
        for name, data in runs.items():
            for key, rows in data.items():
                for decisions, minutes, value in rows:
                    writer.writerow([name, key, int(decisions), round(minutes, 3), value])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", nargs="*", default=[])
    parser.add_argument("--snapshots", action="store_true", help="evaluate every numbered snapshot too")
    parser.add_argument("--checkpoint", default="last",
                        help="which checkpoint of each run: last, best or update_<k> (e.g. a 2-hour snapshot)")
    parser.add_argument("--max-decisions", type=int, default=15)
    parser.add_argument("--starts", type=int, nargs="*", default=list(range(9)))
    parser.add_argument("--out", default=None)
    parser.add_argument("--smoke", action="store_true", help="train a 5-decision run and evaluate it on 1 start")
    args = parser.parse_args()
    extra = ["planning.actions.max_frontiers=3", "model.hidden=16", "model.mlp_hidden=16"] if args.smoke else []
    out = Path(args.out) if args.out else (Path(tempfile.mkdtemp()) if args.smoke else RESULTS)
    out.mkdir(parents=True, exist_ok=True)
    runs = [Path(r) for r in args.runs]
    if args.smoke:
        args.starts, args.max_decisions = [0], 2
        runs = [smoke_run(out / "smoke_run", extra)]

    config = load_config(["scene=office", "slam=model", *extra])
    baselines = evaluate_baselines(config, args.starts, args.max_decisions, out / "eval_baselines.json")
    target = learning_target(baselines["nearest"]["mean_reward"], baselines["em"]["mean_reward"])
    results, all_curves = {}, {}
    for run_dir in runs:
        config = load_saved_config(run_dir / "config.yaml")
        checkpoints = sorted((run_dir / "checkpoints").glob("update_*.pt")) if args.snapshots else []
        checkpoints.append(run_dir / "checkpoints" / f"{args.checkpoint}.pt")
        evaluations = {}
        for path in checkpoints:
            summary = summarize(evaluate(config, "learned", greedy_actor(config, path), args.starts,
                                         args.max_decisions))
            summary["meets_target"] = summary["mean_reward"] >= target
            evaluations[path.stem] = summary
            print(f"{run_dir.name:28s} {path.stem:14s} reward {summary['mean_reward']:+.3f}  "
                  f"EM agreement {summary['em_agreement']:.2f}", flush=True)
        results[run_dir.name] = evaluations
        all_curves[run_dir.name] = curves(run_dir)
    for name in BASELINES:
        print(f"{name:28s} {'':14s} reward {baselines[name]['mean_reward']:+.3f}  "
              f"EM agreement {baselines[name]['em_agreement']:.2f}")
    print(f"target (nearest + half the gap to EM): {target:+.3f}")
    plot_curves(all_curves, baselines, out / "learning_curves.png")
    write_curves_csv(all_curves, out / "learning_curves.csv")
    (out / "learning_eval.json").write_text(json.dumps({"baselines": baselines, "runs": results}, indent=1))
    emit({"study": "learning", "smoke": args.smoke, "machine": machine(), "max_decisions": args.max_decisions,
          "starts": args.starts, "baselines": baselines, "target_reward": target, "runs": results,
          "figure": str(out / "learning_curves.png")})


def smoke_run(run_dir: Path, extra: list[str]) -> Path:
    """A 5-decision training run through the CLI's trainer (for the smoke test)."""
    from omegaconf import OmegaConf

    from explore_rl.trainer.a2c import train

    config = load_config(["scene=office", "slam=model", "train.frames=5", "algo.steps_per_update=5",
                          "train.progress_bar=false", *extra])
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.yaml").write_text(OmegaConf.to_yaml(OmegaConf.structured(config)))
    train(config, run_dir)
    return run_dir


if __name__ == "__main__":
    main()
