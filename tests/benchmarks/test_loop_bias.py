"""loop_bias/calibrate.py on a small made-up dataset (the loops node features) and a tiny actor: the grid's
figures against ones computed here, the calibrated value is the grid's best, bad arguments refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.benchmarks.smoke import script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset

SCRIPT = "benchmarks/results/loop_bias/calibrate.py"


def run_on_loops_dataset(runner, tmp_path, *args: str):
    """``runner`` (a script_runner) on a made-up dataset of the loops set and a tiny extended-set actor, made here;
    returns the decisions, EM's best rows, the script's JSON rows and its summary (the last line)."""
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    decisions, best = revisit_dataset(tmp_path / "data", features="loops")
    actor, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    result = runner("--dataset", str(tmp_path / "data"), "--actor", str(actor), *args)
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]  # torchrl logs too
    return decisions, best, lines[:-1], lines[-1]


@pytest.fixture
def calibrate(capsys):
    return script_runner(SCRIPT, capsys)


def test_calibrate_scores_the_biased_choice_and_picks_the_best_bias(tmp_path, calibrate):
    """With a bias far above the logits' spread the choice is each decision's longest loop (computed here);
    EM's side is its best-rewarded frontier's; each row's gap closed is the pooled gain of its choice (here,
    for the largest bias); the calibrated bias is the row of the largest gap closed, row 0 the actor alone."""
    from explore_rl.graph.features import feature_names

    decisions, best, rows, summary = run_on_loops_dataset(calibrate, tmp_path, "--step", "500", "--top", "1000")
    assert [row["loop_bias"] for row in rows] == [0.0, 500.0, 1000.0]
    column = feature_names("loops").index("loop_length")
    loops = [d["x"][:, column][d["action_mask"]].numpy() for d in decisions]
    em = np.mean([float(d["x"][row, column]) for d, row in zip(decisions, best)])
    assert all(row["em_loop_m"] == pytest.approx(em, abs=1e-3) for row in rows)
    assert rows[-1]["loop_m"] == pytest.approx(np.mean([values.max() for values in loops]), abs=1e-3)
    gains, stakes = [], []
    for d, row in zip(decisions, best):
        mask, rewards = d["action_mask"].numpy(), d["action_rewards"].numpy()
        mean = rewards[mask].mean()
        pick = np.flatnonzero(mask)[d["x"][:, column].numpy()[mask].argmax()]
        gains.append(rewards[pick] - mean)
        stakes.append(rewards[row] - mean)
    assert rows[-1]["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)
    top = max(row["gap_closed"] for row in rows)
    assert summary["at_bias"]["gap_closed"] == top and summary["loop_bias"] == summary["at_bias"]["loop_bias"]
    assert summary["alone"] == rows[0] and summary["decisions"] == len(decisions) and summary["layouts"] == 8
    low, high = summary["gain_ci"]
    assert low <= high


@pytest.mark.parametrize("bad", [["--step", "0"], ["--top", "-1"], ["--dataset", "/nonexistent/data"]])
def test_calibrate_refuses_bad_arguments_in_one_line(bad, calibrate):
    result = calibrate(*bad)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert bad[0] in last or bad[1] in last


def test_calibrate_refuses_a_dataset_without_the_loop_column(tmp_path, calibrate):
    revisit_dataset(tmp_path / "data")  # the extended set: no loop_length
    result = calibrate("--dataset", str(tmp_path / "data"))
    assert result.returncode != 0 and "loop_length" in result.stderr.strip().splitlines()[-1]
