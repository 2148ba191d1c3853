"""The actor's one-step choice against EM's, by exploration phase and building size (descriptive).

Reads a dataset of EM-labelled decisions (``benchmarks/collect_decisions.py``: EM's Algorithm 1 reward of every
frontier of each decision, whole episodes with the actor in the loop) and scores an actor file on it. Per group of
decisions, the pooled one-step gap closed ``(E[r_pick] - E[r_uniform]) / (E[r_best] - E[r_uniform])`` of

* ``greedy``: the actor's most probable frontier (what the runner plays),
* ``expected``: the reward expected under its distribution (what the offline studies report),
* ``em``: EM's stored choice, 1 by construction (a check that rows and labels line up),

with a bootstrap 95 % interval over episodes. Groups: all decisions; by the decision's index in its episode
(``--bands``); by the area tercile of the episode's building (``generate_building`` of the default family, or of
the family under ``--set``, as ``by_kind.py``); by the decision's number of frontiers (``--frontiers``: a harder
choice when there are more; 10 is the action set's default cap); with ``--set`` (the collection's own overrides, e.g.
its lot kind: the plans are drawn with them) also by kind, ``kind lot`` and ``kind building``, when the scored
layouts hold parking lots (session 71). Groups are post hoc: descriptive only (plan.md, session 55). ``--held-out``:
only the layouts no fine-tuning of ``late_probe.py`` saw; ``--training``: only the others (session 56); ``--versus FILE``:
also each group's difference to another actor, with a bootstrap that draws the same episodes for both (paired);
``--gate F ...`` (session 59): over all scored decisions, the greedy gap when the fraction F of decisions the actor is
least sure of (lowest top probability) take EM's stored choice instead, beside the same fraction drawn at random (a
seeded control): what the actor's confidence knows about its own mistakes, i.e. what a hybrid that calls EM only there
would close (``confidence_cut``: the ``policy.em_below_confidence`` that hands those decisions to EM). One JSON line per group (and per gate fraction).

    python benchmarks/results/stop_coverage/one_step.py /work/data/s55_phases [--actor FILE] [--bands 0 15 30] [--frontiers 1 8 10]
        [--held-out | --training] [--versus FILE] [--set KEY=VALUE ...]
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
from common import cluster_bootstrap  # noqa: E402  (the episode is what is resampled)

BOOTSTRAP = 2000
CHUNK = 64
HELD_OUT_MODULUS, HELD_OUT_REMAINDER = 4, 3  # held-out layouts: the probe split of stakes_distill/probe.py (sessions 42-45)


def held_out(layouts: np.ndarray) -> np.ndarray:
    """Which rows' layouts are held out of any fine-tuning (``layout % 4 == 3``)."""
    return np.asarray(layouts) % HELD_OUT_MODULUS == HELD_OUT_REMAINDER


def gap_closed(picked: np.ndarray, uniform: np.ndarray, best: np.ndarray) -> float:
    """Pooled ``(mean picked - mean uniform) / (mean best - mean uniform)``; NaN if EM gains nothing."""
    spread = best.mean() - uniform.mean()
    return float((picked.mean() - uniform.mean()) / spread) if spread > 0 else float("nan")


def decision_index(episodes: np.ndarray) -> np.ndarray:
    """Each row's index within its episode, in storage order (an episode's rows are stored together, in order)."""
    index = np.zeros(len(episodes), dtype=int)
    seen: dict = {}
    for row, key in enumerate(map(tuple, episodes)):
        index[row] = seen.get(key, 0)
        seen[key] = index[row] + 1
    return index


def rewards_of(dataset, actor, columns: list[int], scored: np.ndarray) -> dict[str, np.ndarray]:
    """Per decision: the greedy pick's, the expected, EM's stored choice's, a uniform pick's and the best reward;
    computed for the ``scored`` rows only (a boolean mask over the dataset), NaN for the others."""
    import torch

    from explore_rl.envs.keys import ACTION_REWARDS
    from explore_rl.trainer.dataset import padded_batch

    out: dict[str, list] = {"greedy": [], "expected": [], "em": [], "uniform": [], "best": [], "confidence": []}
    with torch.no_grad():
        for chunk in torch.from_numpy(np.flatnonzero(scored)).split(CHUNK):
            rows = dataset.rows(chunk)
            batch = padded_batch(rows, columns)
            rewards, mask = batch[ACTION_REWARDS], batch["action_mask"]
            logits = actor(batch["x"], batch["adj"], batch["node_mask"]).masked_fill(~mask, -torch.inf)
            probs = torch.softmax(logits, -1)
            out["greedy"].append(rewards.gather(-1, logits.argmax(-1, keepdim=True))[:, 0])
            out["expected"].append((probs.nan_to_num() * rewards).sum(-1))
            out["em"].append(rewards.gather(-1, rows["em_action"][:, None])[:, 0])
            out["uniform"].append((rewards * mask).sum(-1) / mask.sum(-1))
            out["best"].append(rewards.masked_fill(~mask, -torch.inf).max(-1).values)
            out["confidence"].append(probs.max(-1).values)
    full = {key: np.full(len(scored), np.nan) for key in out}
    for key, values in out.items():
        full[key][scored] = torch.cat(values).double().numpy()
    return full


def group_line(name: str, rows: np.ndarray, rewards: dict[str, np.ndarray], episodes: np.ndarray,
               versus: dict[str, np.ndarray] | None = None) -> dict:
    """The group's gaps and their bootstrap intervals over the episodes it holds (``common.cluster_bootstrap``);
    with ``versus`` (another actor's rewards on the same decisions) also the difference of the two actors' gaps,
    paired: the same draw of episodes for both."""
    _, episode_of = np.unique(episodes[rows], axis=0, return_inverse=True)
    members = [rows[episode_of.ravel() == e] for e in range(episode_of.max() + 1)]
    line: dict = {"group": name, "decisions": int(len(rows)), "episodes": len(members)}

    def gap(source: dict[str, np.ndarray], column: str, at: np.ndarray) -> float:
        return gap_closed(source[column][at], source["uniform"][at], source["best"][at])

    for column in ("greedy", "expected", "em"):
        line[column] = round(gap(rewards, column, rows), 4)
        line[f"{column}_ci95"] = cluster_bootstrap(lambda at: gap(rewards, column, at), members, draws=BOOTSTRAP)
        if versus is not None and column != "em":
            line[f"{column}_minus_versus"] = round(gap(rewards, column, rows) - gap(versus, column, rows), 4)
            line[f"{column}_minus_versus_ci95"] = cluster_bootstrap(
                lambda at: gap(rewards, column, at) - gap(versus, column, at), members, draws=BOOTSTRAP)
    return line


def gate_line(fraction: float, rows: np.ndarray, rewards: dict[str, np.ndarray], episodes: np.ndarray,
              seed: int = 0) -> dict:
    """The greedy gap over ``rows`` when the ``fraction`` of them with the lowest actor confidence take EM's stored
    choice, and when the same number drawn at random (``seed``) do; intervals by the episode bootstrap."""
    count = int(round(fraction * len(rows)))
    order = np.argsort(rewards["confidence"][rows], kind="stable")
    unsure = rows[order[:count]]
    # the policy.em_below_confidence that hands these decisions over (those strictly below it; ties aside)
    cut = float(rewards["confidence"][rows][order[count]]) if count < len(rows) else 1.0
    drawn = np.random.default_rng(seed).choice(rows, size=count, replace=False)
    _, episode_of = np.unique(episodes[rows], axis=0, return_inverse=True)
    members = [rows[episode_of.ravel() == e] for e in range(episode_of.max() + 1)]
    line: dict = {"group": "all", "gate": fraction, "decisions": int(len(rows)), "handed_to_em": count,
                  "confidence_cut": round(cut, 6)}
    for name, handed in (("gated", unsure), ("random_gated", drawn)):
        picked = rewards["greedy"].copy()
        picked[handed] = rewards["em"][handed]

        def gap(at: np.ndarray, picked: np.ndarray = picked) -> float:
            return gap_closed(picked[at], rewards["uniform"][at], rewards["best"][at])

        line[name] = round(gap(rows), 4)
        line[f"{name}_ci95"] = cluster_bootstrap(gap, members, draws=BOOTSTRAP)
    return line


def ranges(starts: list[int]) -> list[tuple[str, float, float]]:
    """``(label, low, high)`` of the half-open ranges that begin at ``starts`` (the last one open)."""
    ends = [*starts[1:], np.inf]
    return [(f"{low}-{'' if high == np.inf else int(high) - 1}", low, high) for low, high in zip(starts, ends)]


def decision_groups(index: np.ndarray, areas: np.ndarray, building_areas: list[float], frontiers: np.ndarray,
                    bands: list[int], sizes: list[int], lots: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Rows of each group: all; by decision index (``bands``); by area tercile of the buildings (``areas`` per row,
    terciles of ``building_areas``; a NaN row is in none); by the number of frontiers (``sizes``); with ``lots`` (per
    row, whether its layout is a parking lot) by kind."""
    groups = {"all": np.arange(len(index))}
    for label, low, high in ranges(bands):
        groups[f"decisions {label}"] = np.flatnonzero((index >= low) & (index < high))
    cuts = np.quantile(building_areas, [1 / 3, 2 / 3])
    for name, chosen in (("area small", areas <= cuts[0]), ("area medium", (areas > cuts[0]) & (areas <= cuts[1])),
                         ("area large", areas > cuts[1])):
        groups[name] = np.flatnonzero(chosen)
    for label, low, high in ranges(sizes):
        groups[f"frontiers {label}"] = np.flatnonzero((frontiers >= low) & (frontiers < high))
    if lots is not None:
        groups["kind lot"], groups["kind building"] = np.flatnonzero(lots), np.flatnonzero(~lots)
    return groups


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="a dataset folder of benchmarks/collect_decisions.py")
    parser.add_argument("--actor", default=None, help="actor file (default: the shipped policy)")
    parser.add_argument("--bands", type=int, nargs="+", default=[0, 15, 30],
                        help="first decision index of each band, ascending from 0")
    split = parser.add_mutually_exclusive_group()
    split.add_argument("--held-out", action="store_true",
                       help="score only the layouts held out of fine-tuning (layout %% 4 == 3; late_probe.py)")
    split.add_argument("--training", action="store_true",
                       help="score only the layouts fine-tuning trains on (the others; in-sample for late_probe.py)")
    parser.add_argument("--versus", default=None,
                        help="another actor file: also each group's gap difference to it, paired by episode")
    parser.add_argument("--frontiers", type=int, nargs="+", default=[1, 8, 10],
                        help="smallest action-set size of each group, ascending from 1")
    parser.add_argument("--gate", type=float, nargs="+", default=[], metavar="F",
                        help="fractions of the least confident decisions handed to EM's stored choice (0 < F <= 1)")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="the collection's --set overrides, so its layouts' plans are drawn as it drew them")
    args = parser.parse_args(argv)
    if args.frontiers[0] != 1 or any(b <= a for a, b in zip(args.frontiers, args.frontiers[1:])):
        parser.error(f"--frontiers {' '.join(map(str, args.frontiers))}: give ascending sizes starting at 1")
    if args.bands[0] != 0 or any(b <= a for a, b in zip(args.bands, args.bands[1:])):
        parser.error(f"--bands {' '.join(map(str, args.bands))}: give ascending indices starting at 0")
    if not all(0 < f <= 1 for f in args.gate):
        parser.error(f"--gate {' '.join(map(str, args.gate))}: give fractions in (0, 1]")
    if not (args.dataset / "dataset.json").is_file():
        parser.error(f"{args.dataset}: no dataset.json there; give a folder of benchmarks/collect_decisions.py")

    from explore_rl.graph.features import feature_names
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset

    actors = {}
    for flag, path in (("--actor", args.actor), ("--versus", args.versus)):
        if flag == "--versus" and path is None:
            continue
        try:
            actors[flag] = load_actor(path)
        except ValueError as error:  # CheckpointError: missing, unreadable or not an actor, in one line
            parser.error(f"{flag} {error}")
    dataset = DecisionDataset(args.dataset)
    stored = dataset.rows()
    episodes = np.stack([stored["layout"].numpy(), stored["episode"].numpy()], axis=1)
    index = decision_index(episodes)
    scored = np.ones(len(index), dtype=bool)
    if args.held_out or args.training:
        scored = held_out(episodes[:, 0]) == args.held_out
    if not scored.any():
        which = "held-out" if args.held_out else "training"
        parser.error(f"{args.dataset}: no {which} layout (held out: layout % 4 == 3) in the dataset")
    scores = {flag: rewards_of(dataset, actor.eval(), dataset.columns_for(feature_names(file.feature_set)), scored)
              for flag, (actor, file) in actors.items()}
    rewards, versus = scores["--actor"], scores.get("--versus")
    layouts = sorted(set(int(s) for s in episodes[scored, 0]))
    try:
        plans = plan_stats(layouts, args.set)
    except ValueError as error:  # a bad override, in one line
        parser.error(f"--set: {error}")
    area = {seed: stats["area"] for seed, stats in plans.items()}
    areas = np.array([area.get(int(s), np.nan) for s in episodes[:, 0]])  # NaN: a layout not scored
    lots = rows_on_lots(episodes[:, 0], plans)
    lots = lots if lots.any() else None
    frontiers = stored["action_mask"].sum(-1).numpy()
    groups = decision_groups(index, areas, [area[s] for s in layouts], frontiers, args.bands, args.frontiers, lots)
    for name, rows in groups.items():
        rows = rows[scored[rows]]
        if len(rows):
            print(json.dumps(group_line(name, rows, rewards, episodes, versus)))
    for fraction in args.gate:
        print(json.dumps(gate_line(fraction, np.flatnonzero(scored), rewards, episodes)))


if __name__ == "__main__":
    main()
