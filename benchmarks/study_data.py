"""Find the bottleneck: validation gap_closed against dataset size, paper vs extended features.

For each dataset size (the first K decisions of a dataset from
benchmarks/collect_decisions.py, collected with ``graph.features=extended``, which holds
the paper's four columns too) and each feature set, an actor is trained offline with the
*same* budget (``--steps`` minibatches; explore_rl/trainer/offline.py: distillation of EM's
per-frontier evaluation, ``expected_reward``) and evaluated under the protocol
(explore_rl/trainer/evaluate.py: the same validation episodes for every policy, paired
bootstrap interval of gap_closed). Also reported, cheaply and with less noise: the
*offline* gap closed on held-out decisions (those of the dataset's layouts in
``--holdout-layouts``, never trained on; training sizes count the other decisions in the
order they were collected, so a grown dataset keeps its first K): (E_policy - E_random) / (E_EM - E_random) of the Algorithm 1 reward, with E
the expectation under the policy's probabilities (random: uniform over frontiers; EM: the
best frontier), and the same figure in-sample. A curve that keeps rising with K says
data-bound; one that is flat, with in-sample far above held-out or both low, says the
features (information) bound it.

    python benchmarks/study_data.py --dataset /work/data/office_ext --sizes 250 500 1000 2000 \
        --features paper extended --steps 400 --holdout-layouts 900 1000 --layouts 1000 1001 --starts 3 --max-decisions 8 \
        --workers 2 --out benchmarks/results/data

Writes ``OUT/data_curve.csv``, ``OUT/data_curve.png``, ``OUT/summary.json``, actor files under
``OUT/actors/`` and the protocol's episode cache ``OUT/episodes.jsonl``; the last line of
stdout is one JSON object (``rows``: per feature set and size, ``gap_closed``, its ``ci95``,
``offline_gap_holdout``, ``offline_gap_train``, ``train_s``; ``decisions``; ``layouts``).
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results" / "data"
FEATURE_SETS = ("paper", "extended")
log = logging.getLogger("study_data")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", type=Path, default=None, help="dataset folder (collect_decisions.py)")
    parser.add_argument("--sizes", type=int, nargs="+", default=[250, 500, 1000, 2000, 4000, 16000, 64000],
                        help="training set sizes (those above what the dataset holds are left out)")
    parser.add_argument("--features", nargs="+", default=list(FEATURE_SETS), choices=FEATURE_SETS)
    parser.add_argument("--no-full", action="store_true", help="only --sizes, not also the whole training set")
    parser.add_argument("--steps", type=int, default=400, help="minibatches per actor (the same for every size)")
    parser.add_argument("--holdout-layouts", type=int, nargs=2, default=[900, 1000], metavar=("FIRST", "STOP"),
                        help="dataset layouts [FIRST, STOP) held out of training (offline held-out figure)")
    parser.add_argument("--layouts", type=int, nargs="+", default=[1000, 1001], help="validation layouts")
    parser.add_argument("--starts", type=int, default=3)
    parser.add_argument("--max-decisions", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--scene", default="office")
    parser.add_argument("--seed", type=int, default=0, help="weights and minibatch order")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE", help="config overrides (model.*, algo.lr)")
    parser.add_argument("--offline-only", action="store_true",
                        help="the offline figures only, no protocol episodes (gap_closed left empty)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--smoke", action="store_true", help="a tiny dataset, 2 steps, 1 episode: that it runs")
    args = parser.parse_args(argv)
    if args.smoke:
        args.sizes, args.steps, args.layouts, args.starts, args.max_decisions, args.workers = [2, 4], 2, [1000], 1, 1, 1
        args.holdout_layouts = [5, 10]
    elif args.dataset is None:
        parser.error("--dataset DIR is required (collect one with benchmarks/collect_decisions.py)")
    if args.holdout_layouts[1] <= args.holdout_layouts[0]:
        parser.error(f"--holdout-layouts {args.holdout_layouts}: STOP must be > FIRST")
    for key in ("steps", "starts", "max_decisions", "workers"):
        if getattr(args, key) < 1:
            parser.error(f"--{key.replace('_', '-')} must be >= 1, got {getattr(args, key)}")
    return args


def smoke_dataset(out: Path) -> Path:
    """A tiny real dataset for --smoke: two office episodes of 3 random decisions."""
    import collect_decisions

    path = out / "smoke_dataset"
    collect_decisions.collect(collect_decisions.parse_args(
        ["--out", str(path), "--tasks", "2", "--max-decisions", "3", "--workers", "1", "--layouts", "0", "10",
         "--set", "train.dataset_capacity=64"]))
    return path


def study_config(args: argparse.Namespace, features: str, train_layouts: list[int]):
    from explore_rl.config import load_config

    return load_config([f"scene={args.scene}", "slam=model", f"graph.features={features}",
                        f"env.train_layouts=[{train_layouts[0]},{train_layouts[1]}]", *args.set])


def offline_gaps(learner, dataset, index, columns) -> float:
    """(E_policy - E_random) / (E_EM - E_random) of the Algorithm 1 reward over ``index``."""
    import torch

    from explore_rl.envs.keys import ACTION_REWARDS
    from explore_rl.trainer.dataset import padded_batch

    learner.set_training(False)
    policy, uniform, best = [], [], []
    with torch.no_grad():
        for chunk in index.split(64):
            batch = padded_batch(dataset.rows(chunk), columns)
            rewards, mask = batch[ACTION_REWARDS], batch["action_mask"]
            probs = learner.actor.get_dist(batch).probs
            policy.append((probs * rewards).sum(-1))
            uniform.append((rewards * mask).sum(-1) / mask.sum(-1))
            best.append(rewards.masked_fill(~mask, -torch.inf).max(-1).values)
    if len(index) == 0:
        return float("nan")
    e_policy, e_random, e_em = (float(torch.cat(v).mean()) for v in (policy, uniform, best))
    return (e_policy - e_random) / (e_em - e_random) if e_em > e_random else float("nan")


def train_and_evaluate(args, dataset, features: str, size: int, trainable, holdout, train_layouts,
                       out: Path) -> dict:
    import torch

    from explore_rl.graph.features import feature_names
    from explore_rl.trainer.evaluate import episode_specs, run_protocol, summarize
    from explore_rl.trainer.offline import save_offline_actor, train_offline

    config = study_config(args, features, train_layouts)
    torch.manual_seed(args.seed)
    learner, result = train_offline(config, dataset, args.steps, index=trainable[:size])
    columns = dataset.columns_for(feature_names(features))
    actor = save_offline_actor(learner, out / "actors" / f"{features}_{size}.pt",
                               meta={"dataset": str(dataset.path), "rows": size, "steps": args.steps})
    offline_train = offline_gaps(learner, dataset, trainable[:size], columns)
    offline_holdout = offline_gaps(learner, dataset, holdout, columns)
    start = time.perf_counter()
    summary = {"policies": {name: {"mean_reward": None, "em_agreement": None} for name in ("learned", "em", "random")}}
    if not args.offline_only:
        results = run_protocol(config, episode_specs(args.layouts, args.starts), ("learned", "em", "random", "nearest"),
                               args.max_decisions, actor_path=actor, workers=args.workers, cache=out / "episodes.jsonl")
        summary = summarize(results)
    row = {
        "features": features, "decisions": size, "steps": args.steps, "train_s": round(result.seconds, 1),
        "loss_first": round(float(np.mean(result.losses[:20])), 4) if result.losses else None,
        "loss_last": round(float(np.mean(result.losses[-20:])), 4) if result.losses else None,
        "offline_gap_train": round(offline_train, 3), "offline_gap_holdout": round(offline_holdout, 3),
        "gap_closed": summary.get("gap_closed"), "gap_closed_ci95": summary.get("gap_closed_ci95"),
        "learned_reward": summary["policies"]["learned"]["mean_reward"],
        "learned_em_agreement": summary["policies"]["learned"]["em_agreement"],
        "em_reward": summary["policies"]["em"]["mean_reward"],
        "random_reward": summary["policies"]["random"]["mean_reward"],
        "eval_s": round(time.perf_counter() - start, 1), "actor": str(actor),
    }
    log.info("%s %d: offline gap train %.3f holdout %.3f; protocol gap_closed %s", features, size,
             offline_train, offline_holdout, row["gap_closed"])
    return row


def write_csv(rows: list[dict], path: Path) -> None:
    keys = [k for k in rows[0] if k != "gap_closed_ci95"] + ["ci_low", "ci_high"]
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=keys)
        writer.writeheader()
        for row in rows:
            low, high = row.get("gap_closed_ci95") or (None, None)
            writer.writerow({**{k: row[k] for k in keys[:-2]}, "ci_low": low, "ci_high": high})


def plot(rows: list[dict], path: Path, decisions: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for features, colour in zip(FEATURE_SETS, ("tab:blue", "tab:orange")):
        mine = [r for r in rows if r["features"] == features]
        if not mine:
            continue
        sizes = np.array([r["decisions"] for r in mine])
        gap = np.array([np.nan if r["gap_closed"] is None else r["gap_closed"] for r in mine])
        ci = np.array([r["gap_closed_ci95"] or [np.nan, np.nan] for r in mine], dtype=float)
        axes[0].errorbar(sizes, gap, yerr=[gap - ci[:, 0], ci[:, 1] - gap], marker="o", capsize=3, c=colour,
                         label=f"{features} (95 % paired bootstrap CI)")
        axes[1].plot(sizes, [r["offline_gap_holdout"] for r in mine], marker="o", c=colour, label=f"{features}: held out")
        axes[1].plot(sizes, [r["offline_gap_train"] for r in mine], marker="x", ls="--", c=colour,
                     label=f"{features}: in sample")
    for ax in axes:
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.axhline(0, c="gray", lw=0.8)
        ax.axhline(1, c="gray", lw=0.8, ls="--")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        ax.set_xlabel("training decisions")
    axes[0].set(ylabel="gap_closed (validation layouts, protocol)", title="protocol: (learned - random) / (EM - random)")
    axes[1].set(ylabel="offline gap closed (expected Alg. 1 reward)",
                title=f"offline, on held-out decisions of the dataset ({decisions} in all)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    args = parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    import torch

    from explore_rl.trainer.dataset import DecisionDataset

    torch.set_num_threads(1)
    started = time.perf_counter()
    try:
        dataset = DecisionDataset(smoke_dataset(args.out) if args.smoke else args.dataset)
        total = len(dataset)
        layouts = dataset.rows()["layout"]
        seen = sorted(set(layouts.tolist()) & set(args.layouts))
        if seen:
            raise ValueError(f"--layouts {seen} are in the dataset (training layouts): evaluate on held-out ones")
        train_layouts = [int(layouts.min()), int(layouts.max()) + 1]
        first, stop = args.holdout_layouts
        held = (layouts >= first) & (layouts < stop)
        trainable, holdout = torch.nonzero(~held).flatten(), torch.nonzero(held).flatten()
        if len(trainable) == 0:
            raise ValueError(f"every decision of the dataset is in --holdout-layouts {first} {stop}: none to train on")
        if len(holdout) == 0:
            log.warning("no decision of the dataset is in --holdout-layouts %d %d: no offline held-out figure",
                        first, stop)
        sizes = [s for s in args.sizes if s <= len(trainable)] or [len(trainable)]
        if max(sizes) < len(trainable) and not (args.smoke or args.no_full):
            sizes.append(len(trainable))
        rows = [train_and_evaluate(args, dataset, features, size, trainable, holdout, train_layouts, args.out)
                for features in args.features for size in sizes]
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(2) from None
    write_csv(rows, args.out / "data_curve.csv")
    plot(rows, args.out / "data_curve.png", total)
    result = {"dataset": str(dataset.path), "decisions": total, "trainable": len(trainable), "held_out": len(holdout),
              "holdout_layouts": args.holdout_layouts,
              "dataset_layouts": len(set(layouts.tolist())), "sizes": sizes, "layouts": args.layouts,
              "starts": args.starts, "max_decisions": args.max_decisions, "steps": args.steps, "rows": rows,
              "wall_s": round(time.perf_counter() - started, 1), "machine": machine(), "smoke": args.smoke}
    (args.out / "summary.json").write_text(json.dumps(result, indent=1))
    emit(result)


if __name__ == "__main__":
    main()
