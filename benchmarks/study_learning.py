"""The evaluation protocol on the command line: does a policy decide like EM on layouts it never saw?

Every policy (the learned one, EM, nearest frontier, random) plays exactly the same
episodes -- ``--layouts`` (scene seeds) x the first ``--starts`` starts, each with a noise
seed of its own, at most ``--max-decisions`` decisions -- with one config, and every
decision is scored by the Algorithm 1 reward (explore_rl/trainer/evaluate.py). Reported:
mean reward per decision with a 95 % bootstrap interval over episodes, agreement with
EM, and gap_closed = (learned - random) / (EM - random) with its paired bootstrap
interval, pooled and per layout. The policy's training layouts are refused.

    # a policy file (actor file or training checkpoint) on held-out layouts
    python benchmarks/study_learning.py --policy policies/office_paper/actor.pt --layouts 2000 2001 \
        [--scene office|building|street|garage|file] [--set scene.path=lab.yaml ...] --starts 9 \
        --max-decisions 10 [--workers 2] [--out DIR] [--compare OTHER_ACTOR]
    # training runs: each run's checkpoint (and numbered snapshots, for model selection) on
    # its validation layouts (default) or --layouts; training curves against wall-clock
    python benchmarks/study_learning.py --runs runs/a runs/b [--snapshots] [--checkpoint last|best|update_<k>]

The last line of stdout is one JSON object: ``policies`` (each ``mean_reward``, ``ci95``,
``em_agreement``, ...), ``gap_closed``, ``gap_closed_ci95``, ``layouts``, ``per_layout``,
with ``--compare`` also ``compare`` (the other actor's ``gap_closed`` on the same episodes and
``difference`` = this one's minus it, with a paired ``difference_ci95``)
(for ``--runs``: one such object per run and checkpoint under ``runs``).
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, output_dir  # noqa: E402

from explore_rl.config import Config, load_config, load_saved_config  # noqa: E402
from explore_rl.trainer.evaluate import (  # noqa: E402
    POLICIES,
    actor_training_config,
    EpisodeResult,
    check_actor_features,
    check_held_out,
    episode_specs,
    gap_closed,
    layout_range,
    paired_bootstrap,
    run_protocol,
    summarize,
    training_layouts,
)

RESULTS = Path(__file__).resolve().parent / "results" / "learning"
SCALARS = Path("logs") / "a2c" / "scalars"


def play_policy(config: Config, actor_path: Path | None, layouts: list[int], starts: int, max_decisions: int,
                workers: int, out: Path, policies: tuple[str, ...] = POLICIES) -> dict[str, list[EpisodeResult]]:
    """The protocol for one policy file: every policy on the same episodes (cached in ``out``)."""
    return run_protocol(config, episode_specs(layouts, starts), policies, max_decisions, actor_path=actor_path,
                        workers=workers, cache=out / "episodes.jsonl")


def evaluate_policy(config: Config, actor_path: Path | None, layouts: list[int], starts: int, max_decisions: int,
                    workers: int, out: Path, policies: tuple[str, ...] = POLICIES) -> dict:
    """:func:`play_policy`'s summary."""
    return summarize(play_policy(config, actor_path, layouts, starts, max_decisions, workers, out, policies))


def policy_difference(results: dict[str, list[EpisodeResult]], other: list[EpisodeResult]) -> dict:
    """``other``'s gap_closed on the same episodes as ``results``' learned policy, and the
    difference learned - other with a paired 95 % interval (the same resampled episodes for
    both learned policies, EM and random)."""
    if [(e.layout, e.start) for e in other] != [(e.layout, e.start) for e in results["learned"]]:
        raise ValueError("the two policies' results are not of the same episodes")
    values = {name: np.array([e.mean_reward for e in results[name]]) for name in ("learned", "em", "random")}
    values["other"] = np.array([e.mean_reward for e in other])

    def gap_of(column: str, v: dict[str, np.ndarray]) -> float:
        return gap_closed({"learned": float(np.mean(v[column])), "em": float(np.mean(v["em"])),
                           "random": float(np.mean(v["random"]))})

    def difference(v: dict[str, np.ndarray]) -> float:
        return gap_of("learned", v) - gap_of("other", v)

    return {"gap_closed": gap_of("other", values), "gap_closed_ci95": list(paired_bootstrap(values, lambda v: gap_of(
        "other", v))), "difference": difference(values), "difference_ci95": list(paired_bootstrap(values, difference))}


def compare_policy(config: Config, other: Path, layouts: list[int], starts: int, max_decisions: int, workers: int,
                   out: Path, mine: dict[str, list[EpisodeResult]]) -> dict:
    """``--compare``: the other actor on the episodes of ``mine`` (the policy's protocol results)."""
    theirs = play_policy(config, other, layouts, starts, max_decisions, workers, out, ("learned",))
    return {"policy": str(other), **policy_difference(mine, theirs["learned"])}


def print_summary(title: str, summary: dict) -> None:
    print(f"== {title}: layouts {summary['layouts']}")
    for name, figures in summary["policies"].items():
        low, high = figures["ci95"]
        print(f"  {name:8s} reward {figures['mean_reward']:+.3f} [{low:+.3f}, {high:+.3f}]  EM agreement "
              f"{figures['em_agreement']:.2f}  ({figures['episodes']} episodes, {figures['decisions']} decisions)")
    if "gap_closed" in summary:
        low, high = summary["gap_closed_ci95"]
        print(f"  gap_closed {summary['gap_closed']:+.3f} [{low:+.3f}, {high:+.3f}]")
        for layout, per in summary["per_layout"].items():
            low, high = per.get("gap_closed_ci95", [float("nan")] * 2)
            print(f"    layout {layout}: gap_closed {per.get('gap_closed', float('nan')):+.3f} [{low:+.3f}, {high:+.3f}]")


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


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--policy", default=None, help="an actor file or training checkpoint to evaluate")
    parser.add_argument("--compare", default=None, metavar="FILE",
                        help="--policy: another actor on the same episodes, and the gap_closed difference")
    parser.add_argument("--runs", nargs="*", default=[], help="training run folders to evaluate")
    parser.add_argument("--layouts", type=int, nargs="*", default=None,
                        help="scene seeds to evaluate on (--runs: default the run's env.validation_layouts)")
    parser.add_argument("--scene", default="office", help="office, building, street, garage or file (--policy)")
    parser.add_argument("--slam", default="model", help="the front end of the episodes (--policy): model or icp")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="further config overrides of the episodes, e.g. scene.path=lab.yaml")
    parser.add_argument("--starts", type=int, default=9, help="the first N starts of each layout")
    parser.add_argument("--max-decisions", type=int, default=10)
    parser.add_argument("--workers", type=int, default=1, help="episode processes")
    parser.add_argument("--snapshots", action="store_true", help="--runs: every numbered snapshot too (selection)")
    parser.add_argument("--checkpoint", default="last", help="--runs: last, best or update_<k>")
    parser.add_argument("--allow-training-layouts", action="store_true",
                        help="score on the policy's own training layouts (an in-sample figure, labelled so)")
    parser.add_argument("--out", default=None)
    parser.add_argument("--smoke", action="store_true", help="train a 5-decision run and evaluate it on 1 start")
    args = parser.parse_args(argv)
    if not args.policy and not args.runs and not args.smoke:
        parser.error("give --policy FILE or --runs DIR ... (or --smoke)")
    if args.compare and not args.policy:
        parser.error("--compare FILE needs --policy FILE (the two are scored on the same episodes)")
    if args.starts < 1 or args.max_decisions < 1 or args.workers < 1:
        parser.error("--starts, --max-decisions and --workers must be >= 1")
    return args


def held_out(args, scene: str, layouts: list[int], trained_scene: str | None, trained: range, what: str) -> bool:
    """Refuse training layouts unless allowed; True when the figure is held out."""
    if args.allow_training_layouts:
        return trained_scene != scene or not set(layouts) & set(trained)
    check_held_out(scene, layouts, trained_scene, trained, what)
    return True


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    extra = ["planning.actions.max_frontiers=3", "model.hidden=16", "model.mlp_hidden=16"] if args.smoke else []
    out = output_dir(args.out or None, RESULTS, args.smoke, "learning")
    out.mkdir(parents=True, exist_ok=True)
    runs = [Path(r) for r in args.runs]
    if args.smoke:
        args.starts, args.max_decisions = 1, 2
        runs = [smoke_run(out / "smoke_run", extra)]
        args.policy = str(runs[0] / "checkpoints" / "last.pt")
        args.layouts = [1000]
    result = {"study": "learning", "smoke": args.smoke, "machine": machine(), "starts": args.starts,
              "max_decisions": args.max_decisions}
    if args.policy:
        layouts = args.layouts or []
        if not layouts:
            raise SystemExit("error: --policy needs --layouts S1 S2 ... (held-out scene seeds)")
        config = load_config([f"scene={args.scene}", f"slam={args.slam}", *extra, *args.set])
        try:
            trained_scene, trained = training_layouts(actor_training_config(args.policy))
            is_held_out = held_out(args, config.scene.name, layouts, trained_scene, trained, args.policy)
            if args.compare:  # the other actor's layouts are held out too (checked before any episode)
                other_scene, other_trained = training_layouts(actor_training_config(args.compare))
                held_out(args, config.scene.name, layouts, other_scene, other_trained, args.compare)
            for actor in filter(None, (args.policy, args.compare)):
                check_actor_features(config, actor)
        except ValueError as error:
            raise SystemExit(f"error: {error}") from None
        results = play_policy(config, Path(args.policy), layouts, args.starts, args.max_decisions, args.workers, out)
        summary = summarize(results)
        print_summary(f"{args.policy} on {config.scene.name} ({'held out' if is_held_out else 'IN-SAMPLE'})", summary)
        if args.compare:
            summary["compare"] = compare_policy(config, Path(args.compare), layouts, args.starts, args.max_decisions,
                                                args.workers, out, results)
            figures = summary["compare"]
            print(f"  {args.compare}: gap_closed {figures['gap_closed']:+.3f}; difference {figures['difference']:+.3f} "
                  f"[{figures['difference_ci95'][0]:+.3f}, {figures['difference_ci95'][1]:+.3f}] (paired)")
        (out / "protocol.json").write_text(json.dumps(summary, indent=1))
        result.update(summary, policy=args.policy, scene=config.scene.name, slam=config.slam.frontend,
                      held_out=is_held_out)
    if runs:
        result["runs"] = evaluate_runs(args, runs, out)
    emit(result)


def evaluate_runs(args, runs: list[Path], out: Path) -> dict:
    """Each run's checkpoints under the protocol (its own config, its validation layouts
    unless --layouts), the training curves of all runs in one figure and CSV."""
    results, all_curves, baselines = {}, {}, {}
    for run_dir in runs:
        config = load_saved_config(run_dir / "config.yaml")
        layouts = args.layouts or list(layout_range(config.env.validation_layouts))
        trained = layout_range(config.env.train_layouts) or range(config.scene.seed, config.scene.seed + 1)
        try:
            is_held_out = held_out(args, config.scene.name, layouts, config.scene.name, trained, str(run_dir))
        except ValueError as error:
            raise SystemExit(f"error: {error}") from None
        checkpoints = sorted((run_dir / "checkpoints").glob("update_*.pt")) if args.snapshots else []
        checkpoints.append(run_dir / "checkpoints" / f"{args.checkpoint}.pt")
        evaluations = {}
        for path in checkpoints:
            summary = evaluate_policy(config, path, layouts, args.starts, args.max_decisions, args.workers, out)
            summary["held_out"] = is_held_out
            print_summary(f"{run_dir.name}/{path.stem}", summary)
            evaluations[path.stem] = summary
            baselines = {name: summary["policies"][name] for name in ("em", "nearest", "random")}
        if args.snapshots:
            best = max(evaluations, key=lambda name: evaluations[name].get("gap_closed", -np.inf))
            print(f"{run_dir.name}: selected on layouts {layouts}: {best}")
            evaluations["selected"] = best
        results[run_dir.name] = evaluations
        all_curves[run_dir.name] = curves(run_dir)
    plot_curves(all_curves, baselines, out / "learning_curves.png")
    write_curves_csv(all_curves, out / "learning_curves.csv")
    (out / "learning_eval.json").write_text(json.dumps(results, indent=1))
    return results


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
