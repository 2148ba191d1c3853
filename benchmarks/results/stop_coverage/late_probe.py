"""Is the late band data-bound? Fine-tune an actor offline on all, or only the late, decisions of a dataset.

From an actor file (by default the one sessions 55-58 fine-tuned from, the default until session 58), ``--steps``
offline steps of EM-choice distillation (not A2C;
``explore_rl.trainer.offline.train_offline``) on the decisions of a ``benchmarks/collect_decisions.py`` dataset whose
layouts are not held out (``one_step.held_out``: ``layout % 4 == 3`` never trains), either all of them (``--arm all``)
or only those from decision ``--late-from`` of their episode on (``--arm late``). Session 56 added ``--late-repeat N``
(the late ones drawn N times as often) and ``--fraction F`` (a seeded fraction of the episodes, for a learning curve);
session 57 ``--blind NAME ...`` (those node-feature columns read as 0 in training, and the written file's input weights
on them are 0: an actor that does not read them, scored or run as it is by ``one_step.py`` and the runner); session 72
``--revisit-repeat N`` (the decisions whose EM choice revisits keyframes, ``revisits`` > 0, drawn N times as often;
with ``--revisit-kind lot`` only those on parking-lot plans, drawn with the collection's ``--set`` overrides).
Writes the fine-tuned actor file; ``one_step.py --held-out --actor FILE`` then scores it by band on the held-out
layouts (plan.md, sessions 55-56). One JSON line: arm, fraction, training decisions and episodes, late repeat, rows
drawn from, steps, seconds, the mean loss of the first and last tenth of the steps, the file.

    python benchmarks/results/stop_coverage/late_probe.py /work/data/s55_phases --arm late --out /work/runs/s55_late.pt
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "selection_v6"))
from one_step import decision_index, held_out  # noqa: E402
from revisit_choice import em_revisits  # noqa: E402
from revisit_probe import greedy_learner  # noqa: E402

START = "policies/buildings_sparse_em_choice/actor.pt"  # the default of sessions 35-57, every fine-tune's start


def training_rows(layouts: np.ndarray, episodes: np.ndarray, arm: str, late_from: int,
                  late_repeat: int = 1) -> np.ndarray:
    """Rows a fine-tuning arm draws from: not held out, and (arm ``late``) from decision ``late_from`` on. With
    ``late_repeat`` N the late rows appear N times, so uniform draws take them N times as often."""
    kept = ~held_out(layouts)
    late = decision_index(episodes) >= late_from
    if arm == "late":
        kept &= late
    return repeated(np.flatnonzero(kept), late, late_repeat)


def repeated(rows: np.ndarray, chosen: np.ndarray, repeat: int) -> np.ndarray:
    """``rows`` with those where the boolean ``chosen`` (over all rows) holds appearing ``repeat`` times in all, so
    that uniform draws take them ``repeat`` times as often."""
    return np.concatenate([rows] + [rows[chosen[rows]]] * (repeat - 1))


class BlindColumns:
    """A dataset whose node-feature columns ``names`` read as 0: what an actor that does not read them sees (its
    input layer's weights on them meet only zeros, so training leaves them). Rows are copies; the stored dataset is
    not touched."""

    def __init__(self, dataset, names: list[str]) -> None:
        self.dataset, self.names = dataset, list(names)
        self.blind = dataset.columns_for(self.names)  # ValueError naming a column the dataset lacks

    def __len__(self) -> int:
        return len(self.dataset)

    def __getattr__(self, name: str):
        return getattr(self.dataset, name)

    def rows(self, index=None):
        rows = self.dataset.rows(index)
        x = rows["x"].clone()
        x[..., self.blind] = 0
        rows.set("x", x)
        return rows


def blinded(dataset, names: list[str]):
    """``dataset`` with the columns ``names`` read as 0 (:class:`BlindColumns`), or itself if none."""
    return BlindColumns(dataset, names) if names else dataset


def blind_actor_file(path: Path, names: list[str]) -> None:
    """Set the input layer's weights on the node features ``names`` of the actor file at ``path`` to 0, so that it
    computes without them whatever the runner feeds there (a blind-trained actor, as it trained)."""
    from explore_rl.models.actor_critic import INPUT_WEIGHT
    from explore_rl.models.actor_file import read_actor_file, save_actor_file

    actor_file = read_actor_file(path)
    weight = actor_file.weights[INPUT_WEIGHT].clone()
    weight[:, [actor_file.features.index(name) for name in names]] = 0
    actor_file.weights = {**actor_file.weights, INPUT_WEIGHT: weight}
    save_actor_file(path, actor_file)


def episode_fraction(rows: np.ndarray, episodes: np.ndarray, fraction: float, seed: int) -> np.ndarray:
    """The ``rows`` of a seeded random ``fraction`` of the episodes they hold (at least one episode): a smaller
    dataset of whole episodes, for a learning curve."""
    keys, episode_of = np.unique(episodes[rows], axis=0, return_inverse=True)
    chosen = np.random.default_rng(seed).permutation(len(keys))[:max(1, round(fraction * len(keys)))]
    return rows[np.isin(episode_of.ravel(), chosen)]


def on_lots(layouts: np.ndarray, overrides: list[str]) -> np.ndarray:
    """Per row: whether its layout's plan (the building family under ``overrides``, e.g. a collection's lot kind)
    is a parking lot."""
    from by_kind import plan_stats, rows_on_lots

    return rows_on_lots(layouts, plan_stats(sorted(set(int(s) for s in layouts)), overrides))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a dataset folder of benchmarks/collect_decisions.py")
    parser.add_argument("--arm", choices=("all", "late"), required=True)
    parser.add_argument("--actor", default=START, help="the actor file fine-tuned (default: " + START + ")")
    parser.add_argument("--late-from", type=int, default=30, help="arm late: first decision index trained on")
    parser.add_argument("--late-repeat", type=int, default=1,
                        help="draw the late decisions this many times as often (1 = uniform)")
    parser.add_argument("--revisit-repeat", type=int, default=1,
                        help="draw the decisions whose EM choice revisits keyframes this many times as often")
    parser.add_argument("--revisit-kind", choices=("all", "lot"), default="all",
                        help="--revisit-repeat on every layout, or on parking-lot plans only (drawn with --set)")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="the collection's --set overrides, so its layouts' plans are drawn as it drew them")
    parser.add_argument("--fraction", type=float, default=1.0,
                        help="train on a seeded random fraction of the arm's episodes (a learning curve)")
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--lr", type=float, default=3e-4)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--blind", nargs="+", default=[], metavar="NAME",
                        help="node features read as 0 (training and one_step.py's scoring): an actor without them")
    parser.add_argument("--out", type=Path, required=True, help="the fine-tuned actor file to write")
    args = parser.parse_args(argv)
    if not 0 < args.fraction <= 1:
        parser.error(f"--fraction {args.fraction}: give a fraction in (0, 1]")
    if args.steps < 1 or args.late_from < 0 or args.late_repeat < 1 or args.revisit_repeat < 1 or not args.lr > 0:
        parser.error(f"--steps {args.steps} --late-from {args.late_from} --late-repeat {args.late_repeat} "
                     f"--revisit-repeat {args.revisit_repeat} --lr {args.lr}: give steps >= 1, late-from >= 0, "
                     "late-repeat >= 1, revisit-repeat >= 1 and a positive lr")
    if args.set and args.revisit_kind != "lot":
        parser.error(f"--set {' '.join(args.set)}: only --revisit-kind lot draws plans; drop --set or add it")
    if not (args.dataset / "dataset.json").is_file():
        parser.error(f"{args.dataset}: no dataset.json there; give a folder of benchmarks/collect_decisions.py")

    import torch

    from explore_rl.trainer.dataset import DecisionDataset
    from explore_rl.trainer.offline import save_offline_actor, train_offline

    try:
        learner = greedy_learner(args.actor, "algo.distill_target=em_choice", f"algo.lr={args.lr}")
    except ValueError as error:  # CheckpointError: missing, unreadable or not an actor
        parser.error(f"--actor {error}")
    dataset = DecisionDataset(args.dataset)
    stored = dataset.rows()
    try:
        dataset = blinded(dataset, args.blind)
    except ValueError as error:  # a --blind name the dataset lacks
        parser.error(f"--blind {' '.join(args.blind)}: {error}")
    layouts, episode = stored["layout"].numpy(), stored["episode"].numpy()
    episodes = np.stack([layouts, episode], axis=1)
    rows = training_rows(layouts, episodes, args.arm, args.late_from, args.late_repeat)
    if args.fraction < 1:
        rows = episode_fraction(rows, episodes, args.fraction, args.seed)
    if args.revisit_repeat > 1:
        try:
            chosen = em_revisits(stored, dataset.columns_for(["revisits"])[0])
            if args.revisit_kind == "lot":
                chosen &= on_lots(layouts, args.set)
        except ValueError as error:  # a dataset without the extended features, or a bad override
            parser.error(f"--revisit-repeat: {error}")
        rows = repeated(rows, chosen, args.revisit_repeat)
    if len(rows) == 0:
        parser.error(f"{args.dataset}: no decision for arm {args.arm} (late-from {args.late_from}) outside the "
                     "held-out layouts")
    torch.manual_seed(args.seed)
    _, result = train_offline(learner.config, dataset, args.steps, index=torch.from_numpy(rows), learner=learner)
    path = save_offline_actor(learner, args.out, {"dataset": str(args.dataset), "arm": args.arm,
                                                  "late_from": args.late_from, "late_repeat": args.late_repeat,
                                                  "fraction": args.fraction, "steps": args.steps,
                                                  "blind": args.blind, "revisit_repeat": args.revisit_repeat,
                                                  "revisit_kind": args.revisit_kind, "set": args.set},
                                 layouts[rows])
    if args.blind:
        blind_actor_file(path, args.blind)
    tenth = max(1, len(result.losses) // 10)
    print(json.dumps({"arm": args.arm, "fraction": args.fraction, "decisions": int(len(np.unique(rows))),
                      "episodes": int(len(np.unique(episodes[rows], axis=0))), "late_repeat": args.late_repeat,
                      "revisit_repeat": args.revisit_repeat, "revisit_kind": args.revisit_kind, "blind": args.blind,
                      "drawn_rows": int(len(rows)),
                      "steps": args.steps,
                      "seconds": round(result.seconds, 1), "skipped_steps": result.skipped_steps,
                      "loss_first_tenth": round(float(np.mean(result.losses[:tenth])), 4),
                      "loss_last_tenth": round(float(np.mean(result.losses[-tenth:])), 4), "out": str(path)}))


if __name__ == "__main__":
    main()
