"""revisit_bias/calibrate.py on a small made-up dataset and a tiny actor: the grid's figures against ones
computed here, the calibrated value is the first that revisits as much as EM's best, bad arguments refused."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from tests.benchmarks.smoke import ROOT
from tests.benchmarks.test_selection_v6 import revisit_dataset

SCRIPT = ROOT / "benchmarks" / "results" / "revisit_bias" / "calibrate.py"


def test_calibrate_picks_the_first_bias_that_revisits_as_much_as_em(tmp_path):
    """With a bias far above the logits' spread the choice revisits the most keyframes of each decision
    (computed here from the dataset); EM's side is its best-rewarded frontier's; the calibrated bias is the
    first grid value whose choice revisits at least as much as EM's best, and the grid's first row is the
    actor alone (bias 0)."""
    from explore_rl.config import load_config
    from explore_rl.graph.features import feature_names
    from tests.policy_files import TINY_MODEL, actor_file

    decisions, best = revisit_dataset(tmp_path / "data")
    actor, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    result = subprocess.run([sys.executable, str(SCRIPT), "--dataset", str(tmp_path / "data"), "--actor", str(actor),
                             "--step", "500", "--top", "1000"], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.strip().splitlines()]
    rows, summary = lines[:-1], lines[-1]
    assert [row["revisit_bias"] for row in rows] == [0.0, 500.0, 1000.0]
    column = feature_names("extended").index("revisits")
    revisits = [d["x"][:, column][d["action_mask"]].numpy() for d in decisions]
    em = np.mean([float(d["x"][row, column]) for d, row in zip(decisions, best)])
    assert all(row["em_revisits"] == pytest.approx(em, abs=1e-3) for row in rows)
    assert rows[-1]["policy_revisits"] == pytest.approx(np.mean([r.max() for r in revisits]), abs=1e-3)
    enough = [row["revisit_bias"] for row in rows if row["policy_revisits"] >= row["em_revisits"]]
    assert enough and summary["revisit_bias"] == enough[0]
    assert summary["alone"] == rows[0] and summary["at_bias"]["revisit_bias"] == enough[0]


@pytest.mark.parametrize("bad", [["--step", "0"], ["--top", "-1"], ["--dataset", "/nonexistent/data"]])
def test_calibrate_refuses_bad_arguments_in_one_line(bad):
    result = subprocess.run([sys.executable, str(SCRIPT), *bad], capture_output=True, text=True, cwd=ROOT)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert bad[0] in result.stderr.strip().splitlines()[-1] or bad[1] in result.stderr.strip().splitlines()[-1]
