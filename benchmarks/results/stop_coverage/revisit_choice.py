"""Which of EM's choices does the actor miss? Revisits against exploration, by kind (descriptive; plan.md, session 72).

On a dataset of EM-labelled decisions (``benchmarks/collect_decisions.py``, extended features), a frontier *revisits*
when its path passes keyframes of the pose graph (node feature ``revisits`` > 0): choosing it can close a loop. Per
kind of layout (``kind lot``, ``kind building``: the plans drawn with the collection's ``--set`` overrides, as
``one_step.py``), over the decisions that offer at least one revisiting frontier:

* ``em_revisits`` / ``actor_revisits``: how often EM's stored choice / the actor's most probable frontier revisits;
* ``actor_revisits_when_em_revisits``: the actor's revisit rate on the decisions where EM revisits;
* ``agree_when_em_revisits`` / ``agree_when_em_explores``: the actor's agreement with EM's choice on each;

each with a bootstrap 95 % interval over episodes (an episode's decisions are not independent). ``--held-out`` (the
default) scores the layouts no fine-tuning saw (``layout % 4 == 3``), ``--training`` the others (in sample). One
JSON line per kind.

    python benchmarks/results/stop_coverage/revisit_choice.py /work/data/s71_glots --actor FILE \\
        --set scene.building.lot_probability=0.5
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from by_kind import plan_stats, rows_on_lots  # noqa: E402
from common import cluster_bootstrap  # noqa: E402
from one_step import CHUNK, held_out  # noqa: E402

BOOTSTRAP = 2000
REVISITS = "revisits"  # the node feature: keyframes the frontier's path revisits


def em_revisits(stored, column: int) -> np.ndarray:
    """Per stored decision (a dataset's rows): whether EM's choice revisits keyframes, i.e. its node's ``revisits``
    feature (in ``x`` column ``column``) is above 0. Shared with ``late_probe.py --revisit-repeat``."""
    import torch

    return (stored["x"][torch.arange(len(stored)), stored["em_action"].long(), column] > 0).numpy()


def chosen_revisits(dataset, actor, columns: list[int], rows: np.ndarray) -> dict[str, np.ndarray]:
    """Per row: whether EM's choice and the actor's greedy choice revisit, whether they agree, and whether any
    frontier of the decision revisits."""
    import torch

    from explore_rl.trainer.dataset import padded_batch

    revisit_column = dataset.columns_for([REVISITS])[0]
    out: dict[str, list] = {"em": [], "actor": [], "agree": [], "offered": []}
    with torch.no_grad():
        for chunk in torch.from_numpy(rows).split(CHUNK):
            stored = dataset.rows(chunk)
            batch = padded_batch(stored, columns)
            mask = batch["action_mask"]
            revisits = stored["x"][:, :mask.shape[1], revisit_column] > 0
            picked = actor(batch["x"], batch["adj"], batch["node_mask"]).masked_fill(~mask, -torch.inf).argmax(-1)
            out["em"].append(torch.from_numpy(em_revisits(stored, revisit_column)))
            out["actor"].append(revisits.gather(1, picked[:, None])[:, 0])
            out["agree"].append(picked == stored["em_action"].long())
            out["offered"].append((revisits & mask).any(-1))
    return {key: torch.cat(values).numpy() for key, values in out.items()}


def rates(choice: dict[str, np.ndarray]) -> dict[str, float]:
    """The pooled rates of :func:`chosen_revisits`'s arrays (NaN where a condition holds nowhere)."""
    em, actor, agree = choice["em"], choice["actor"], choice["agree"]

    def mean(values: np.ndarray) -> float:
        return float(values.mean()) if len(values) else float("nan")

    return {"em_revisits": mean(em), "actor_revisits": mean(actor),
            "actor_revisits_when_em_revisits": mean(actor[em]), "agree_when_em_revisits": mean(agree[em]),
            "agree_when_em_explores": mean(agree[~em])}


def kind_line(name: str, rows: np.ndarray, choice: dict[str, np.ndarray], episodes: np.ndarray) -> dict:
    """One kind's rates over ``rows`` (positions into ``choice``) and their intervals over its episodes."""
    _, episode_of = np.unique(episodes[rows], axis=0, return_inverse=True)
    members = [rows[episode_of.ravel() == e] for e in range(episode_of.max() + 1)]
    line: dict = {"kind": name, "decisions": int(len(rows)), "episodes": len(members)}
    for key, value in rates({k: v[rows] for k, v in choice.items()}).items():
        line[key] = round(value, 4)
        line[f"{key}_ci95"] = cluster_bootstrap(
            lambda at, key=key: rates({k: v[at] for k, v in choice.items()})[key], members, draws=BOOTSTRAP)
    return line


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a dataset folder of benchmarks/collect_decisions.py")
    parser.add_argument("--actor", default=None, help="actor file (default: the shipped policy)")
    split = parser.add_mutually_exclusive_group()
    split.add_argument("--held-out", action="store_true", default=True,
                       help="score the layouts held out of fine-tuning (layout %% 4 == 3; the default)")
    split.add_argument("--training", action="store_true", help="score the other layouts (in sample)")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="the collection's --set overrides, so its layouts' plans are drawn as it drew them")
    args = parser.parse_args(argv)
    if not (args.dataset / "dataset.json").is_file():
        parser.error(f"{args.dataset}: no dataset.json there; give a folder of benchmarks/collect_decisions.py")

    from explore_rl.graph.features import feature_names
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset

    try:
        actor, actor_file = load_actor(args.actor)
    except ValueError as error:  # CheckpointError: missing, unreadable or not an actor, in one line
        parser.error(f"--actor {error}")
    dataset = DecisionDataset(args.dataset)
    try:
        columns = dataset.columns_for(feature_names(actor_file.feature_set))
        dataset.columns_for([REVISITS])
    except ValueError as error:  # a dataset without the extended features
        parser.error(str(error))
    stored = dataset.rows()
    episodes = np.stack([stored["layout"].numpy(), stored["episode"].numpy()], axis=1)
    scored = np.flatnonzero(held_out(episodes[:, 0]) != args.training)
    if not len(scored):
        parser.error(f"{args.dataset}: no {'training' if args.training else 'held-out'} layout in the dataset")
    try:
        plans = plan_stats(sorted(set(int(s) for s in episodes[scored, 0])), args.set)
    except ValueError as error:  # a bad override, in one line
        parser.error(f"--set: {error}")
    choice = chosen_revisits(dataset, actor.eval(), columns, scored)
    is_lot = rows_on_lots(episodes[scored, 0], plans)
    for name, kind in (("lot", is_lot), ("building", ~is_lot)):
        rows = np.flatnonzero(kind & choice["offered"])
        if len(rows):
            print(json.dumps(kind_line(name, rows, choice, episodes[scored])))


if __name__ == "__main__":
    main()
