"""opening_prior/probe.py on a small made-up dataset (the loops node features) and a tiny actor: each column's
row is loop_bias/calibrate.py's calibration with that column as the prior (computed here for a bias far above
the logits' spread), the actor alone is the same on every row, bad arguments refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from tests.benchmarks.smoke import script_runner
from tests.benchmarks.test_loop_bias import run_on_loops_dataset
from tests.benchmarks.test_selection_v6 import revisit_dataset

SCRIPT = "benchmarks/results/opening_prior/probe.py"


@pytest.fixture
def probe(capsys):
    return script_runner(SCRIPT, capsys)


def test_each_column_as_a_prior_scores_its_largest_or_smallest_value(tmp_path, probe):
    from explore_rl.graph.features import FRONTIER_EXTRAS, LOOP_EXTRAS, feature_names

    decisions, best, rows, summary = run_on_loops_dataset(probe, tmp_path, "--step", "1000", "--top", "1000")
    columns = FRONTIER_EXTRAS + LOOP_EXTRAS
    assert [(row["column"], row["sign"]) for row in rows] == [(c, s) for c in columns for s in (1.0, -1.0)]
    assert len({(row["alone_gap_closed"], row["alone_same_choice"]) for row in rows}) == 1
    names = feature_names("loops")
    for row in rows:
        values = [d["x"][:, names.index(row["column"])].numpy() for d in decisions]
        gains, stakes = [], []
        for d, value, em_row in zip(decisions, values, best):
            mask, rewards = d["action_mask"].numpy(), d["action_rewards"].numpy()
            frontier = np.flatnonzero(mask)
            pick = frontier[(row["sign"] * value[mask]).argmax()]
            gains.append(rewards[pick] - rewards[mask].mean())
            stakes.append(rewards[em_row] - rewards[mask].mean())
        ties = any(len(np.unique(v[d["action_mask"].numpy()])) < int(d["action_mask"].sum())
                   for d, v in zip(decisions, values))  # (revisits: the actor's logits break them)
        if row["bias"] != 0 and not ties:  # the calibrated bias is the far one: the choice is the column's extreme
            assert row["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)
        assert row["gap_closed"] >= row["alone_gap_closed"]  # the grid holds 0, the actor alone
    assert sum(row["bias"] != 0 and row["column"] != "revisits" for row in rows) >= 3
    assert summary["largest_gain"]["gain_over_alone"] == max(row["gain_over_alone"] for row in rows)


@pytest.mark.parametrize("bad", [["--step", "0"], ["--dataset", "/nonexistent/data"]])
def test_probe_refuses_bad_arguments_in_one_line(bad, probe):
    args = bad if "--dataset" in bad else ["--dataset", "/nonexistent/data", *bad]
    result = probe(*args)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert bad[0] in last


def test_probe_refuses_a_dataset_without_the_loop_column(tmp_path, probe):
    revisit_dataset(tmp_path / "data")  # the extended set: no loop_length
    result = probe("--dataset", str(tmp_path / "data"))
    assert result.returncode != 0 and "loop_length" in result.stderr.strip().splitlines()[-1]
