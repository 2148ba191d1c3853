"""keyframes_45deg/wall_time.py: seconds per building from run.sh's stream logs, paired over the buildings both
runs finished, against figures worked out here; a missing separator is refused in one line."""

from __future__ import annotations

import json

from tests.benchmarks.smoke import run_main

SCRIPT = "benchmarks/results/keyframes_45deg/wall_time.py"


def stream_log(path, spans: dict[int, tuple[int, int | None]]):
    """A stream log: for each building its start line and, if it finished, its end line, among other output."""
    lines = []
    for seed, (start, end) in spans.items():
        lines += [f"building {seed} start {start}", "[INFO] 2 trials ... writing to ..."]
        if end is not None:
            lines.append(f"building {seed} end {end}")
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_wall_time_pairs_the_buildings_both_runs_finished(tmp_path, capsys):
    a = [stream_log(tmp_path / "a_even.log", {1010: (0, 40), 1012: (40, 100)}),
         stream_log(tmp_path / "a_odd.log", {1011: (0, 30), 1013: (30, None)})]
    b = [stream_log(tmp_path / "b_even.log", {1010: (0, 60), 1012: (60, 150)}),
         stream_log(tmp_path / "b_odd.log", {1011: (0, 60), 1013: (60, 200)})]
    code, out, _ = run_main(SCRIPT, [*a, "--", *b], capsys)
    result = json.loads(out.strip().splitlines()[-1])
    # 1013 did not finish in a: buildings 1010-1012, a 40/60/30 s, b 60/90/60 s
    assert code == 0 and result["buildings"] == 3
    assert result["mean_s_a"] == round(130 / 3, 1) and result["mean_s_b"] == 70.0
    assert result["total_ratio_b_over_a"] == round(210 / 130, 3) and result["median_ratio_b_over_a"] == 1.5
    code, _, err = run_main(SCRIPT, a, capsys)
    assert code == 1 and "LOGS_A... -- LOGS_B..." in err
