"""loop_feature/probe.py on a small made-up loops dataset and a tiny extended actor: the widened actor starts as
the actor (the same figures, equal to ones computed here from its logits), both arms train and write actor
files, the pair's difference is loops - extended; bad arguments are refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from tests.benchmarks.smoke import json_lines, script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset


@pytest.fixture()
def run(capsys):
    """The script's main in this process (tests/benchmarks/smoke.py: run_main)."""
    return script_runner("benchmarks/results/loop_feature/probe.py", capsys)


@pytest.fixture()
def files(tmp_path):
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    decisions, best = revisit_dataset(tmp_path / "data", features="loops")
    actor_path, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    return tmp_path, decisions, best, actor_path


def test_the_widened_actor_starts_as_the_actor_and_both_arms_train(files, run):
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset, padded_batch

    tmp_path, decisions, best, actor_path = files
    result = run("--arm", "widened", "--dataset", str(tmp_path / "data"), "--actor", str(actor_path),
                 "--steps", "2", "--every", "2", "--in-sample", "5", "--out", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout)
    rows, pair, summary = lines[:4], lines[4], lines[5]
    assert [(row["actor"], row["steps"]) for row in rows] == [
        ("widened_extended_seed0", 0), ("widened_extended_seed0", 2),
        ("widened_loops_seed0", 0), ("widened_loops_seed0", 2)]
    assert rows[2]["held_out"] == rows[0]["held_out"] and rows[2]["in_sample"] == rows[0]["in_sample"]
    probe = [i for i, d in enumerate(decisions) if int(d["layout"]) % 4 == 3]
    assert summary["probe_decisions"] == len(probe) and summary["probe_layouts"] == 2
    actor, _ = load_actor(actor_path)
    batch = padded_batch(DecisionDataset(tmp_path / "data").rows(torch.tensor(probe)), list(range(10)))
    with torch.no_grad():
        logits = actor(batch["x"], batch["adj"], batch["node_mask"]).numpy()
    gains, stakes, same = [], [], []
    for row, index in enumerate(probe):
        rewards, mask = decisions[index]["action_rewards"].numpy(), decisions[index]["action_mask"].numpy()
        pick = int(np.flatnonzero(mask)[np.argmax(logits[row, :len(mask)][mask])])
        gains.append(rewards[pick] - rewards[mask].mean())
        stakes.append(rewards[best[index]] - rewards[mask].mean())
        same.append(pick == best[index])
    assert rows[0]["held_out"]["same_choice"] == pytest.approx(np.mean(same), abs=1e-4)
    assert rows[0]["held_out"]["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)
    difference = pair["loops"]["held_out"]["gap_closed"] - pair["extended"]["held_out"]["gap_closed"]
    assert pair["loops_minus_extended"]["gap_closed"] == pytest.approx(difference, abs=2e-4)
    low, high = pair["loops_minus_extended"]["gap_closed_ci"]
    assert low <= high
    for feature_set, width in (("extended", 10), ("loops", 11)):
        saved = torch.load(pair[feature_set]["actor"], weights_only=False)
        assert saved["features"][-1] == ("loop_length" if feature_set == "loops" else "landmark_uncertainty")
        assert len(saved["features"]) == width


def test_the_scratch_arm_trains_a_pair_per_seed(files, run):
    tmp_path, _, _, actor_path = files
    result = run("--arm", "scratch", "--dataset", str(tmp_path / "data"), "--actor", str(actor_path),
                 "--seeds", "0", "1", "--steps", "1", "--every", "1", "--in-sample", "5", "--out", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert [pair["seed"] for pair in summary["pairs"]] == [0, 1]
    assert all((tmp_path / "out" / f"scratch_{s}_seed{k}.pt").is_file() for s in ("extended", "loops") for k in (0, 1))


@pytest.mark.parametrize("bad", [["--steps", "0"], ["--actor", "/nonexistent.pt"], ["--dataset", "/nonexistent/data"]])
def test_the_probe_refuses_bad_arguments_in_one_line(bad, run):
    result = run("--arm", "widened", *bad)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert bad[0] in result.stderr.strip().splitlines()[-1]


def test_one_feature_set_with_another_network(files, run):
    tmp_path, _, _, actor_path = files
    result = run("--arm", "scratch", "--dataset", str(tmp_path / "data"), "--actor", str(actor_path),
                 "--feature-sets", "loops", "--dropout", "0", "--hidden", "6", "--steps", "2", "--every", "1",
                 "--in-sample", "5", "--out", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout)
    assert [(row["actor"], row["steps"]) for row in lines[:3]] == [
        ("scratch_loops_seed0", 0), ("scratch_loops_seed0", 1), ("scratch_loops_seed0", 2)]
    pair, summary = lines[3], lines[4]
    assert "loops" in pair and "extended" not in pair and "loops_minus_extended" not in pair
    assert summary["model"]["dropout"] == 0.0 and summary["model"]["hidden"] == 6
    saved = torch.load(pair["loops"]["actor"], weights_only=False)
    assert len(saved["features"]) == 11


@pytest.mark.parametrize("args, message", [
    (["--arm", "widened", "--dropout", "0"], "--dropout/--hidden change the scratch arm"),
    (["--arm", "scratch", "--dropout", "1.5"], "--dropout 1.5"),
    (["--arm", "scratch", "--hidden", "0"], "--hidden 0"),
])
def test_bad_network_arguments_are_refused_in_one_line(files, run, args, message):
    tmp_path, _, _, actor_path = files
    result = run(*args, "--dataset", str(tmp_path / "data"), "--actor", str(actor_path))
    assert result.returncode == 2 and message in result.stderr.strip().splitlines()[-1]


def test_the_extended_scratch_arm_alone_reads_an_extended_dataset(tmp_path, run):
    """An extended dataset (no loop_length column) serves ``--arm scratch --feature-sets extended``; asking for
    ``loops`` on it is refused in one line naming the column."""
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    revisit_dataset(tmp_path / "data", features="extended")
    actor_path, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    common = ["--arm", "scratch", "--dataset", str(tmp_path / "data"), "--actor", str(actor_path), "--hidden", "6",
              "--steps", "1", "--every", "1", "--in-sample", "5", "--out", str(tmp_path / "out")]
    result = run(*common, "--feature-sets", "extended")
    assert result.returncode == 0, result.stderr
    assert json_lines(result.stdout)[-1]["model"]["hidden"] == 6
    result = run(*common, "--feature-sets", "loops")
    assert result.returncode == 1 and "loop_length" in result.stderr.strip().splitlines()[-1]
