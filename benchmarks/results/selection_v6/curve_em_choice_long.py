"""Issue 24's curve for the shipped policy's last stage: 10-decision validation gap_closed of
em_choice_long's snapshots against training wall-clock (descriptive; nothing was picked from it).

Reads the committed logs only: the previous default (update 0) from selection_v4's validation,
the snapshots from ``curve_em_choice_long.log``, the last checkpoint from ``em_choice_long.log``,
each snapshot's wall-clock from the run's scalars (``em_choice_long_run/``). Writes
``curve_em_choice_long.csv`` and ``.png`` beside this file (or into OUT).

    python benchmarks/results/selection_v6/curve_em_choice_long.py [OUT]
"""

from __future__ import annotations

import csv
import json
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
KINDS = ("office", "building", "lots", "sparse")
PREVIOUS_MINUTES = 164.0  # the previous default's training, in all (its card)
HEADER = re.compile(r"^== em_choice_long (?:update (?P<snapshot>\d+) )?(?P<kind>office|building|lots|sparse)$")


def logged_gaps(log: Path, header: re.Pattern = HEADER, default: str = "") -> dict[tuple[str, str], float]:
    """``(snapshot, kind) -> gap_closed`` from a validation log: each header line (``header``, with the
    groups ``snapshot`` and ``kind``) is followed (after the study's own lines) by its JSON result;
    ``default`` names the snapshot of headers without one."""
    gaps, key = {}, None
    for line in log.read_text().splitlines():
        match = header.match(line)
        if match:
            key = (match.group("snapshot") or default, match.group("kind"))
        elif line.startswith("{") and key is not None:
            gaps[key] = json.loads(line)["gap_closed"]
            key = None
    return gaps


def minutes_by_update(folder: Path) -> dict[int, float]:
    """A run's wall-clock minutes at each update, from its kept scalars (decisions -> update,
    decisions -> s); update 0 is the start."""
    seconds = {int(frames): float(s) for frames, s in csv.reader((folder / "wall_s.csv").open())}
    return {0: 0.0} | {int(float(u)): seconds[int(frames)] / 60.0
                       for frames, u in csv.reader((folder / "updates.csv").open())}


def curve_row(gaps: dict[str, float], **columns) -> dict:
    """One row of a curve: ``columns`` (update, minutes, ...), then the four sets' gap_closed and their mean."""
    values = [gaps[kind] for kind in KINDS]
    return columns | {kind: round(v, 3) for kind, v in zip(KINDS, values)} | {"mean": round(sum(values) / 4, 3)}


def write_curve(rows: list[dict], out: Path, stem: str, minutes_key: str, xlabel: str, title: str,
                marks: dict[str, float] | None = None) -> None:
    """``stem.csv`` (the rows) and ``stem.png`` (each set and their mean against ``rows[minutes_key]``;
    ``marks``: labelled vertical lines, e.g. a stage's end)."""
    with (out / f"{stem}.csv").open("w", newline="") as table:
        writer = csv.DictWriter(table, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    x = [row[minutes_key] for row in rows]
    for kind in KINDS:
        ax.plot(x, [row[kind] for row in rows], marker=".", alpha=0.6, label=kind)
    ax.plot(x, [row["mean"] for row in rows], marker="o", color="black", label="mean of the four")
    for label, minutes in (marks or {}).items():
        ax.axvline(minutes, ls=":", color="gray")
        ax.annotate(label, (minutes, 0.02), xycoords=("data", "axes fraction"), fontsize="small", color="gray")
    ax.set(xlabel=xlabel, ylabel="validation gap_closed (10 decisions)", title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(out / f"{stem}.png", dpi=120)
    for row in rows:
        print(row)


def main(out: Path = HERE) -> None:
    gaps = {(0, kind): json.loads((HERE.parent / "selection_v4" / kind / "dagger_sparse_last" / "protocol.json")
                                  .read_text())["gap_closed"] for kind in KINDS}
    logged = logged_gaps(HERE / "curve_em_choice_long.log") | logged_gaps(HERE / "em_choice_long.log", default="825")
    gaps |= {(int(snapshot), kind): gap for (snapshot, kind), gap in logged.items()}
    minutes_at, rows = minutes_by_update(HERE / "em_choice_long_run"), []
    for update in sorted({update for update, _ in gaps}):
        minutes = minutes_at[update]
        rows.append(curve_row({kind: gaps[(update, kind)] for kind in KINDS}, update=update,
                              stage_minutes=round(minutes, 1), total_minutes=round(PREVIOUS_MINUTES + minutes, 1)))
    write_curve(rows, out, "curve_em_choice_long", "total_minutes",
                xlabel="training wall-clock in all [min] (2-core CPU)",
                title="em_choice DAgger from the previous default (164 min)")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE)
