"""closure_prior/calibrate.py: the matched strength on made-up columns (hand computation), a one-building smoke run
as a user runs it, and bad arguments refused in one line."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from tests.benchmarks.smoke import ROOT, load_script, run_script

SCRIPT = "benchmarks/results/closure_prior/calibrate.py"


def test_the_matched_bias_equalises_the_mean_within_decision_spread():
    summary = load_script(SCRIPT).summary
    buildings = [{"seed": 0, "decisions": [{"loop_length": [0.0, 4.0], "gain": [0.0, 0.1]},
                                           {"loop_length": [2.0, 2.0, 8.0], "gain": [0.3, 0.0, 0.0]}]}]
    result = summary(buildings, loop_bias=0.05)
    spread_loop = np.mean([np.std([0.0, 4.0]), np.std([2.0, 2.0, 8.0])])
    spread_gain = np.mean([np.std([0.0, 0.1]), np.std([0.3, 0.0, 0.0])])
    assert result["closure_bias"] == pytest.approx(0.05 * spread_loop / spread_gain)
    assert result["decisions"] == 2 and result["informative_decisions"] == 2
    assert result["same_largest_frontier"] == pytest.approx(0.5)  # the first decision agrees, the second does not


def test_smoke_run(tmp_path):
    result = run_script(SCRIPT, "--smoke", cwd=tmp_path, timeout=300)
    assert result["buildings"] == 1 and result["decisions"] >= 1
    assert result["closure_bias"] == pytest.approx(
        result["loop_bias"] * result["mean_spread_loop_length_m"] / result["mean_spread_gain_m"])
    assert 0.0 <= result["same_largest_frontier"] <= 1.0


@pytest.mark.parametrize("args", [["--seeds", "a-b"], ["--decisions", "0"], ["--loop-bias", "-1"]])
def test_bad_arguments_are_refused_in_one_line(args):
    proc = subprocess.run([sys.executable, str(ROOT / SCRIPT), *args], capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 2
    lines = [line for line in proc.stderr.splitlines() if "error:" in line]
    assert len(lines) == 1 and args[0] in lines[0]
