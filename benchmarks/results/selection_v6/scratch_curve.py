"""Issue 24's validation curve for the 2-hour pipeline (session 38's run: em_choice DAgger from a random
initialisation, 25 min office + 95 min sparse-lot buildings): the 10-decision validation gap_closed of the kept
snapshots (``scratch_run/``) against training wall-clock. Descriptive; nothing was picked from it.

Reads the committed files only: ``scratch_curve.log`` (``scratch_curve.sh``) and the run's scalars in
``scratch_run/{office,sparse}/``. Stage 2's minutes and decisions are counted after stage 1's. Snapshots whose
four validation sets are not all in the log are left out. Writes ``scratch_curve.csv`` and ``.png`` beside this
file (or into OUT; LOG: another validation log of the same form).

    python benchmarks/results/selection_v6/scratch_curve.py [OUT [LOG]]
"""

from __future__ import annotations

import csv
import re
import sys
from pathlib import Path

from curve_em_choice_long import KINDS, curve_row, logged_gaps, minutes_by_update, write_curve

HERE = Path(__file__).resolve().parent
RUN = HERE / "scratch_run"
HEADER = re.compile(r"^== scratch_s38(?:_(?P<snapshot>(?:office|sparse)_(?:last|update_\d+)))? "
                    r"(?P<kind>office|building|lots|sparse)$")
STAGES = ("office", "sparse")


def decisions_by_update(folder: Path) -> dict[int, int]:
    """A run's decisions collected at each update (its ``updates.csv``: decisions -> update)."""
    return {int(float(update)): int(frames) for frames, update in csv.reader((folder / "updates.csv").open())}


def snapshot_update(name: str, last: int) -> int:
    """The update a kept snapshot holds: ``update_00080`` -> 80, ``last`` -> the stage's ``last`` update."""
    return last if name == "last" else int(name.removeprefix("update_"))


def main(out: Path = HERE, log: Path = HERE / "scratch_curve.log") -> None:
    gaps = logged_gaps(log, HEADER, default="sparse_last")
    minutes = {stage: minutes_by_update(RUN / stage) for stage in STAGES}
    decisions = {stage: decisions_by_update(RUN / stage) for stage in STAGES}
    stage1_minutes, stage1_decisions = minutes["office"][max(minutes["office"])], max(decisions["office"].values())
    rows = []
    for snapshot in sorted({snapshot for snapshot, _ in gaps}):
        if any((snapshot, kind) not in gaps for kind in KINDS):
            continue
        stage, name = snapshot.split("_", 1)
        update = snapshot_update(name, last=max(decisions[stage]))
        offset_minutes, offset_decisions = (0.0, 0) if stage == "office" else (stage1_minutes, stage1_decisions)
        rows.append(curve_row({kind: gaps[(snapshot, kind)] for kind in KINDS}, stage=stage, update=update,
                              decisions=offset_decisions + decisions[stage][update],
                              total_minutes=round(offset_minutes + minutes[stage][update], 1)))
    rows.sort(key=lambda row: row["total_minutes"])
    write_curve(rows, out, "scratch_curve", "total_minutes",
                xlabel="training wall-clock from a random initialisation [min] (2-core CPU)",
                title="the 2-hour pipeline (session 38's run)", marks={"office -> buildings": stage1_minutes})


if __name__ == "__main__":
    paths = [Path(arg) for arg in sys.argv[1:3]]
    if len(paths) > 1 and not paths[1].is_file():
        sys.exit(f"scratch_curve.py: no validation log at {paths[1]}: give the log scratch_curve.sh wrote")
    main(*paths)
