"""revisit_bias/calibrate.py on a small made-up dataset and a tiny actor: the grid's figures against ones
computed here, the calibrated value is the first that revisits as much as EM's best, bad arguments refused."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.benchmarks.smoke import script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset

SCRIPT = "benchmarks/results/revisit_bias/calibrate.py"
DIAL = "benchmarks/results/revisit_bias/dial.py"


@pytest.fixture
def calibrate(capsys):
    return script_runner(SCRIPT, capsys)


@pytest.fixture
def dial(capsys):
    return script_runner(DIAL, capsys)


def test_calibrate_picks_the_first_bias_that_revisits_as_much_as_em(tmp_path, calibrate):
    """With a bias far above the logits' spread the choice revisits the most keyframes of each decision
    (computed here from the dataset); EM's side is its best-rewarded frontier's; the calibrated bias is the
    first grid value whose choice revisits at least as much as EM's best, and the grid's first row is the
    actor alone (bias 0)."""
    from explore_rl.config import load_config
    from explore_rl.graph.features import feature_names
    from tests.policy_files import TINY_MODEL, actor_file

    decisions, best = revisit_dataset(tmp_path / "data")
    actor, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    result = calibrate("--dataset", str(tmp_path / "data"), "--actor", str(actor), "--step", "500", "--top", "1000")
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]  # torchrl logs too
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
def test_calibrate_refuses_bad_arguments_in_one_line(bad, calibrate):
    result = calibrate(*bad)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert bad[0] in result.stderr.strip().splitlines()[-1] or bad[1] in result.stderr.strip().splitlines()[-1]


def targets_file(path, travel: float, equal_travel: float):
    """A targets.json of study_zero_shot.py's shape: a building's row and the pooled row."""
    def row(scene):
        figures = {"travel_ratio": travel, "error_ratio": equal_travel + 0.02, "equal_travel_error_ratio": equal_travel,
                   "closures_ratio": 1.0}
        return {"scene": scene, "scenes": 30, **figures, **{f"{k}_ci95": [v - 0.1, v + 0.1] for k, v in figures.items()}}
    path.mkdir(parents=True)
    (path / "targets.json").write_text(json.dumps({"targets": {}, "entries": [row("b/building_1"), row("all 30 scenes")]}))
    return path


@pytest.mark.parametrize("points, adopted", [
    ({0: (0.97, 1.23), 0.1: (1.01, 1.24), 0.2: (1.14, 1.09), 0.5: (1.46, 0.94)}, None),  # only 0.1 fits, no gain
    ({0: (0.97, 1.23), 0.1: (1.01, 1.20), 0.2: (1.08, 1.10), 0.3: (1.09, 1.15)}, 0.2),  # the lowest admissible
    ({0: (0.97, 1.23), 0.1: (1.01, 1.19)}, None),  # lower, but not by more than the margin
])
def test_the_dial_writes_the_pooled_rows_and_applies_the_validation_rule(tmp_path, points, adopted, dial):
    args = []
    for bias, (travel, equal) in points.items():
        args += ["--entry", f"{bias}={targets_file(tmp_path / f'b{bias}', travel, equal)}"]
    result = dial(*args, "--out", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]  # torchrl logs too
    rows, summary = lines[:-1], lines[-1]
    assert [row["revisit_bias"] for row in rows] == sorted(float(b) for b in points)
    assert [(row["travel_ratio"], row["equal_travel_error_ratio"]) for row in rows] == [points[b] for b in sorted(points)]
    assert all(row["travel_ratio_low"] == pytest.approx(row["travel_ratio"] - 0.1) for row in rows)
    assert summary["adopted_revisit_bias"] == adopted
    assert (tmp_path / "out" / "dial.csv").read_text().count("\n") == len(points) + 1
    assert (tmp_path / "out" / "dial.png").stat().st_size > 1000


@pytest.mark.parametrize("bad", [["--entry", "x=targets.json"], ["--entry", "0.1=/nonexistent/targets.json"]])
def test_the_dial_refuses_bad_entries_in_one_line(bad, dial):
    result = dial(*bad)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert "--entry" in result.stderr.strip().splitlines()[-1]
