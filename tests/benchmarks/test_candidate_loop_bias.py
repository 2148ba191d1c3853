"""candidate_loop_bias/gated_probe.py on a small made-up dataset (the loops node features) and a tiny actor: the
current pose's uncertainty is read off the current node, a gate of 0 leaves the actor's choice, power 0 is
loop_bias/calibrate.py's calibration, bad arguments refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.benchmarks.smoke import json_lines, load_script, script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset

SCRIPT = "benchmarks/results/candidate_loop_bias/gated_probe.py"


def gated_dataset(tmp_path):
    """revisit_dataset's decisions with the identity column of real graphs (node 0 the current pose, the
    frontier rows frontiers, the rest poses) and the current pose's uncertainty 0 in every other decision;
    returns its folder, the decisions and their current uncertainties."""
    import torch

    from explore_rl.config import load_config
    from explore_rl.graph.exploration_graph import CURRENT, FRONTIER, POSE
    from explore_rl.graph.features import feature_names
    from explore_rl.trainer.dataset import DecisionDataset
    from tests.trainer.test_dataset import schema_for

    decisions, _ = revisit_dataset(tmp_path / "made_up", features="loops")
    names = feature_names("loops")
    identity, uncertainty = names.index("identity"), names.index("uncertainty")
    current = []
    for index, d in enumerate(decisions):
        x = d["x"]
        x[:, identity] = torch.where(d["action_mask"], FRONTIER, POSE)
        x[0, identity] = CURRENT
        x[0, uncertainty] = 0.0 if index % 2 else 0.01 * (1 + index)
        current.append(float(x[0, uncertainty]))
    dataset = DecisionDataset(tmp_path / "data", schema_for(load_config(["graph.features=loops"]),
                                                            capacity=len(decisions)))
    dataset.append(decisions, scene="building")
    return tmp_path / "data", decisions, np.array(current)


@pytest.fixture
def probe(capsys):
    return script_runner(SCRIPT, capsys)


def test_gate_reads_the_current_pose_and_a_zero_gate_keeps_the_actors_choice(tmp_path):
    """At a bias far above the logits' spread, power 1 picks each decision's longest loop where the robot is
    uncertain and the actor's own choice where its uncertainty is 0 (computed here); power 0 the longest loop
    everywhere."""
    from explore_rl.config import load_config
    from explore_rl.graph.features import feature_names
    from explore_rl.trainer.dataset import DecisionDataset
    from tests.policy_files import TINY_MODEL, actor_file

    folder, decisions, current = gated_dataset(tmp_path)
    actor, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    module = load_script(SCRIPT)
    calibration = module.load_calibration()
    dataset = DecisionDataset(folder)
    uncertainty = module.current_uncertainty(dataset, 5)
    assert uncertainty.numpy() == pytest.approx(current, abs=1e-7)
    scored = calibration.scored(str(actor), dataset)
    rows, summary = module.probe(calibration, scored, uncertainty, [0.0, 1.0], np.array([1000.0]),
                                 calibration.CHUNK)
    assert summary["u_ref"] == pytest.approx(current.mean(), abs=1e-7)
    column = feature_names("loops").index("loop_length")
    assert len(scored.logits) == 1  # one chunk: rows are decisions
    logits = scored.logits[0]
    gains, stakes, plain_gains = [], [], []
    for index, d in enumerate(decisions):
        mask, rewards = d["action_mask"].numpy(), d["action_rewards"].numpy()
        mean, frontiers = rewards[mask].mean(), np.flatnonzero(mask)
        longest = frontiers[d["x"][:, column].numpy()[mask].argmax()]
        own = int(logits[index].argmax())
        pick = own if current[index] == 0 else longest
        gains.append(rewards[pick] - mean)
        plain_gains.append(rewards[longest] - mean)
        stakes.append(rewards[mask].max() - mean)
    assert abs(sum(gains) - sum(plain_gains)) / sum(stakes) > 0.01  # the gate changes choices here
    assert rows[0]["gap_closed"] == pytest.approx(sum(plain_gains) / sum(stakes), abs=1e-3)
    assert rows[1]["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)


def test_power_zero_is_the_plain_calibration(tmp_path, probe, capsys):
    """The plain prior's row (power 0) is loop_bias/calibrate.py's calibrated value and figure on the same data."""
    from explore_rl.config import load_config
    from tests.benchmarks.smoke import run_main
    from tests.policy_files import TINY_MODEL, actor_file

    folder, _, _ = gated_dataset(tmp_path)
    actor, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    grid = ["--step", "0.5", "--top", "2"]
    result = probe("--dataset", str(folder), "--actor", str(actor), "--powers", "0", "1", *grid)
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout)
    rows, summary = lines[:-1], lines[-1]
    assert [row["power"] for row in rows] == [0.0, 1.0] and summary["decisions"] == 24
    low, high = summary["gain_over_power_0"]["1.0"]
    assert low <= high
    code, out, err = run_main("benchmarks/results/loop_bias/calibrate.py",
                              ["--dataset", str(folder), "--actor", str(actor), *grid], capsys)
    assert code == 0, err
    calibrated = json.loads([line for line in out.splitlines() if line.startswith("{")][-1])
    assert rows[0]["loop_bias"] == calibrated["loop_bias"]
    assert rows[0]["gap_closed"] == calibrated["at_bias"]["gap_closed"]
    assert rows[0]["actor_alone"] == calibrated["alone"]["gap_closed"]


@pytest.mark.parametrize("bad", [["--powers", "1", "0"], ["--step", "0"], ["--dataset", "/nonexistent/data"]])
def test_refuses_bad_arguments_in_one_line(bad, probe):
    args = bad if bad[0] == "--dataset" else ["--dataset", "/nonexistent/data", *bad]
    result = probe(*args)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert bad[0] in result.stderr.strip().splitlines()[-1]


def test_refuses_a_dataset_without_a_current_pose(tmp_path, probe):
    """No node marked as the current pose: no uncertainty to gate by, refused in one line."""
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    revisit_dataset(tmp_path / "data", features="loops")  # random identity column: no current node
    actor, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    result = probe("--dataset", str(tmp_path / "data"), "--actor", str(actor))
    assert result.returncode != 0 and "current pose" in result.stderr.strip().splitlines()[-1]
