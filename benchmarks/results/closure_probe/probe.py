"""Per-frontier ridge probe of ``loop_uncertainty`` and ``path_map`` (session 45, closure_probe/plan.md): does the
relative loop uncertainty, or the virtual map along the path, add to the ``loops`` features what EM's choice
depends on?

Reads ``decisions.jsonl`` of ``collect.py``. Each frontier is a row: its features, and EM's Algorithm 1 reward
centred on its decision's mean (the target); a model scores the frontiers of a decision and picks the top one.
Trained on layouts ``layout % 4 != 3``, measured on the others (held out): offline gap closed (the pick's reward
above the decision's mean over EM's best above it, pooled) with a bootstrap interval over layouts, and the paired
difference of each ``+ GROUP`` model (``--extras``: ``loop_uncertainty``, ``path_map``) to its ``loops`` twin. The ridge penalty of every model is chosen
by a 4-fold cross-validation by layout within the training layouts. One JSON line per model; the last line is
the summary.

    python benchmarks/results/closure_probe/probe.py [--decisions /work/runs/closure_probe/decisions.jsonl] \
        [--extras loop_uncertainty path_map]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from common import cluster_bootstrap as bootstrap  # noqa: E402  (a bootstrap over layouts)
from common import layout_clusters  # noqa: E402

DECISIONS = "/work/runs/closure_probe/decisions.jsonl"
PROBE_EVERY = 4  # layouts with layout % 4 == 3 are held out
FOLDS = 4
PENALTIES = (1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0, 1000.0)
DROPPED = ("identity", "bearing")
EXTRAS = ("loop_uncertainty", "path_map")  # identity is 1 on every frontier; bearing enters as cos and sin


def load(path: Path) -> list[dict]:
    """The decisions with at least two frontiers (a single frontier has nothing at stake)."""
    rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return [row for row in rows if len(row["rewards"]) >= 2]


def frontier_columns(row: dict, extras: tuple[str, ...]) -> np.ndarray:
    """``(F, C)`` one decision's frontier features: the ``loops`` columns but identity, the bearing as cos/sin,
    log1p of the non-negative ones; then each group of ``extras`` (``loop_uncertainty``; ``path_map``'s
    landmarks, uncertainty and gain), each with its log."""
    x = np.asarray(row["x"], float)
    names = row["features"]
    keep = [i for i, name in enumerate(names) if name not in DROPPED]
    bearing = x[:, names.index("bearing")]
    columns = [x[:, keep], np.cos(bearing)[:, None], np.sin(bearing)[:, None]]
    positive = [i for i in keep if (x[:, i] >= 0).all()]
    columns.append(np.log1p(np.abs(x[:, positive])))
    if "loop_uncertainty" in extras:
        loop = np.asarray(row["loop_uncertainty"], float)[:, None]
        columns += [loop, np.log1p(1e3 * loop)]
    if "path_map" in extras:
        path = np.column_stack([row["path_map"][key] for key in ("landmarks", "uncertainty", "gain")]).astype(float)
        columns += [path, np.log1p(np.abs(path))]
    return np.hstack(columns)


def design(rows: list[dict], extras: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every frontier's features ``(R, C)``, centred reward ``(R,)`` and decision number ``(R,)``."""
    features = [frontier_columns(row, extras) for row in rows]
    width = {f.shape[1] for f in features}
    if len(width) != 1:
        raise ValueError(f"decisions disagree on their feature columns ({sorted(width)})")
    x = np.vstack(features)
    rewards = np.concatenate([np.asarray(row["rewards"], float) - np.mean(row["rewards"]) for row in rows])
    decision = np.repeat(np.arange(len(rows)), [len(row["rewards"]) for row in rows])
    return x, rewards, decision


def expand(x: np.ndarray, mean: np.ndarray, scale: np.ndarray, pairwise: bool) -> np.ndarray:
    """Standardised columns (and their pairwise products, squares included), with an intercept."""
    z = (x - mean) / scale
    if pairwise:
        i, j = np.triu_indices(z.shape[1])
        z = np.hstack([z, z[:, i] * z[:, j]])
    return np.hstack([np.ones((len(z), 1)), z])


def fit(x: np.ndarray, y: np.ndarray, penalty: float, pairwise: bool):
    """A ridge model ``x -> score`` (the intercept not penalised)."""
    mean, scale = x.mean(0), x.std(0) + 1e-12
    z = expand(x, mean, scale, pairwise)
    regular = penalty * len(z) * np.eye(z.shape[1])
    regular[0, 0] = 0.0
    weights = np.linalg.solve(z.T @ z + regular, z.T @ y)
    return lambda new: expand(new, mean, scale, pairwise) @ weights


def gains(scores: np.ndarray, rewards: np.ndarray, decision: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per decision: the top-scored frontier's centred reward, and EM's best one's (the stakes)."""
    gain, stakes = np.full(n, -np.inf), np.full(n, -np.inf)
    top = np.full(n, -np.inf)
    for k in np.argsort(decision, kind="stable"):
        d = decision[k]
        if scores[k] > top[d]:
            top[d], gain[d] = scores[k], rewards[k]
        stakes[d] = max(stakes[d], rewards[k])
    return gain, stakes


def gap_closed(gain: np.ndarray, stakes: np.ndarray, rows: np.ndarray) -> float:
    return float(gain[rows].sum() / max(stakes[rows].sum(), 1e-12))


def choose_penalty(rows: list[dict], extras: tuple[str, ...], pairwise: bool) -> float:
    """The penalty with the best pooled gap closed over a 4-fold cross-validation by layout."""
    x, y, decision = design(rows, extras)
    fold = np.array([row["layout"] for row in rows]) % FOLDS
    best, best_score = PENALTIES[0], -np.inf
    for penalty in PENALTIES:
        gain_sum = stakes_sum = 0.0
        for k in range(FOLDS):
            train, test = ~(fold == k)[decision], (fold == k)[decision]
            if not train.any() or not test.any():
                continue
            model = fit(x[train], y[train], penalty, pairwise)
            test_decisions = np.unique(decision[test])
            remap = np.searchsorted(test_decisions, decision[test])
            gain, stakes = gains(model(x[test]), y[test], remap, len(test_decisions))
            gain_sum, stakes_sum = gain_sum + gain.sum(), stakes_sum + stakes.sum()
        score = gain_sum / max(stakes_sum, 1e-12)
        if score > best_score:
            best, best_score = penalty, score
    return best


def evaluate(train: list[dict], held_out: list[dict], extras: tuple[str, ...], pairwise: bool) -> dict:
    """One model (the ``loops`` columns and the groups ``extras``): its penalty, and per held-out decision its
    gain and the stakes."""
    penalty = choose_penalty(train, extras, pairwise)
    x, y, _ = design(train, extras)
    model = fit(x, y, penalty, pairwise)
    x_out, y_out, decision = design(held_out, extras)
    gain, stakes = gains(model(x_out), y_out, decision, len(held_out))
    return {"penalty": penalty, "gain": gain, "stakes": stakes}


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--decisions", type=Path, default=Path(DECISIONS), help="collect.py's decisions.jsonl")
    parser.add_argument("--extras", nargs="+", choices=EXTRAS, default=["loop_uncertainty"],
                        help="feature groups tested against the loops columns (each alone, and all together)")
    return parser.parse_args(argv)


def model_name(extras: tuple[str, ...], pairwise: bool) -> str:
    return "loops" + "".join(f" + {group}" for group in extras) + (", pairwise" if pairwise else "")


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    if not args.decisions.is_file():
        sys.exit(f"--decisions {args.decisions}: no such file (run collect.py first)")
    rows = load(args.decisions)
    if "path_map" in args.extras and not all("path_map" in row for row in rows):
        sys.exit(f"--extras path_map: {args.decisions} has decisions without it (collected before it was recorded)")
    held = np.array([row["layout"] % PROBE_EVERY == PROBE_EVERY - 1 for row in rows], dtype=bool)
    train, held_out = [r for r, h in zip(rows, held) if not h], [r for r, h in zip(rows, held) if h]
    if not train or not held_out:
        sys.exit(f"--decisions {args.decisions}: needs layouts on both sides of the split (layout % 4 == 3 or not)")
    groups = layout_clusters(np.array([row["layout"] for row in held_out]))
    every = np.arange(len(held_out))
    sets = [()] + [(group,) for group in args.extras] + ([tuple(args.extras)] if len(args.extras) > 1 else [])
    results = {}
    for pairwise in (False, True):
        for extras in sets:
            result = evaluate(train, held_out, extras, pairwise)
            results[extras, pairwise] = result
            statistic = lambda r, res=result: gap_closed(res["gain"], res["stakes"], r)  # noqa: E731
            print(json.dumps({"model": model_name(extras, pairwise), "penalty": result["penalty"],
                              "gap_closed": round(statistic(every), 4),
                              "gap_closed_ci": bootstrap(statistic, groups)}), flush=True)
    summary = {"train_decisions": len(train), "held_out_decisions": len(held_out), "held_out_layouts": len(groups),
               "differences": {}}
    for pairwise in (False, True):
        base = results[(), pairwise]
        for extras in sets[1:]:
            more = results[extras, pairwise]
            difference = lambda r, a=base, b=more: gap_closed(b["gain"], b["stakes"], r) - gap_closed(a["gain"], a["stakes"], r)  # noqa: E731
            name = " + ".join(extras) + (", pairwise" if pairwise else "")
            summary["differences"][name] = {"gap_closed": round(difference(every), 4),
                                            "gap_closed_ci": bootstrap(difference, groups)}
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
