"""The revisit prior as a travel/accuracy dial, and the validation rule's pick (plan.md, session 42).

Per value b of ``policy.revisit_bias``: the pooled ratios against EM on the validation buildings (travel, map
error, equal-travel map error, closures per metre, with their intervals) from ``study_zero_shot.py``'s
``targets.json``; a CSV and a PNG of map error against travel. The rule: among the values whose travel ratio is at
most ``--max-travel``, the one with the lowest equal-travel ratio is adopted if that ratio is lower than b = 0's by
more than ``--margin``; the last line (JSON) names it, or none.

    python benchmarks/results/revisit_bias/dial.py [--entry B=targets.json ...] [--out DIR]
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
ENTRIES = {0.0: "targets_val_shipped/val_shipped", 0.1: "targets_val_biased/val_biased",
           0.15: "targets_val_sweep_0.15/val_sweep_0.15", 0.2: "targets_val_sweep_0.2/val_sweep_0.2",
           0.3: "targets_val_sweep_0.3/val_sweep_0.3", 0.5: "targets_val_dose/val_dose"}
FIGURES = ("travel_ratio", "error_ratio", "equal_travel_error_ratio", "closures_ratio")


def pooled(path: Path) -> dict:
    """The pooled row ("all N scenes") of a targets.json."""
    entries = json.loads(path.read_text())["entries"]
    rows = [entry for entry in entries if entry["scene"].startswith("all ")]
    if len(rows) != 1:
        raise ValueError(f"{path}: expected one pooled row ('all N scenes'), found {len(rows)}")
    return rows[0]


def dial_rows(entries: dict[float, Path]) -> list[dict]:
    """One row per bias, in increasing order: the pooled figures and their 95 % intervals."""
    rows = []
    for bias in sorted(entries):
        row = pooled(entries[bias])
        out = {"revisit_bias": bias, "scenes": row["scenes"]}
        for key in FIGURES:
            low, high = row[f"{key}_ci95"]
            out |= {key: round(row[key], 4), f"{key}_low": round(low, 4), f"{key}_high": round(high, 4)}
        rows.append(out)
    return rows


def rule_pick(rows: list[dict], max_travel: float, margin: float) -> float | None:
    """The bias the validation rule adopts (None: keep b = 0)."""
    alone = next((row for row in rows if row["revisit_bias"] == 0.0), None)
    if alone is None:
        raise ValueError("the rule compares with b = 0 (the actor alone): give an entry 0=...")
    admissible = [row for row in rows if row["revisit_bias"] > 0 and row["travel_ratio"] <= max_travel]
    if not admissible:
        return None
    best = min(admissible, key=lambda row: row["equal_travel_error_ratio"])
    adopted = best["equal_travel_error_ratio"] < alone["equal_travel_error_ratio"] - margin
    return best["revisit_bias"] if adopted else None


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    for key, label, marker in (("error_ratio", "map error at the common coverage", "o"),
                               ("equal_travel_error_ratio", "map error at equal travel", "s")):
        x = [row["travel_ratio"] for row in rows]
        y = [row[key] for row in rows]
        err = [[row[key] - row[f"{key}_low"] for row in rows], [row[f"{key}_high"] - row[key] for row in rows]]
        ax.errorbar(x, y, yerr=err, marker=marker, capsize=3, label=label)
    for row in rows:
        ax.annotate(f"b={row['revisit_bias']:g}", (row["travel_ratio"], row["error_ratio"]),
                    textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.axhline(1.0, color="grey", lw=0.8)
    ax.axvline(1.1, color="grey", lw=0.8, ls="--")
    ax.set_xlabel("travel to the common coverage / EM's")
    ax.set_ylabel("map error / EM's")
    ax.set_title("policy.revisit_bias on 30 validation buildings")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def parse_entry(text: str) -> tuple[float, Path]:
    bias, separator, path = text.partition("=")
    try:
        value = float(bias)
    except ValueError:
        value = math.nan
    if not separator or not path or not value >= 0:
        raise argparse.ArgumentTypeError(f"--entry {text!r}: give B=PATH with B >= 0")
    return value, Path(path)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--entry", type=parse_entry, action="append",
                        help="B=targets.json or its folder (repeat; default: the committed validation runs)")
    parser.add_argument("--max-travel", type=float, default=1.1, help="the rule's travel bound (ratio to EM's)")
    parser.add_argument("--margin", type=float, default=0.05, help="the rule's margin on the equal-travel ratio")
    parser.add_argument("--out", default=str(HERE), help="folder of dial.csv and dial.png")
    args = parser.parse_args(argv)
    entries = dict(args.entry) if args.entry else {bias: HERE / path for bias, path in ENTRIES.items()}
    entries = {bias: path / "targets.json" if path.is_dir() else path for bias, path in entries.items()}
    missing = [str(path) for path in entries.values() if not path.is_file()]
    if missing:
        parser.error(f"--entry: no targets.json at {missing[0]} (run study.sh first)")
    try:
        rows = dial_rows(entries)
        pick = rule_pick(rows, args.max_travel, args.margin)
    except (ValueError, KeyError) as error:
        parser.error(f"--entry: {error}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with (out / "dial.csv").open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    plot(rows, out / "dial.png")
    for row in rows:
        print(json.dumps(row))
    print(json.dumps({"adopted_revisit_bias": pick, "max_travel": args.max_travel, "margin": args.margin,
                      "csv": str(out / "dial.csv"), "png": str(out / "dial.png")}))


if __name__ == "__main__":
    main()
