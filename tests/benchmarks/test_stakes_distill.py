"""stakes_distill/probe.py on a small made-up dataset and a tiny actor: the probe split is the layouts
``% 4 == 3``, the untrained actor's figures equal ones computed here, both targets train and write actor files,
bad arguments are refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from tests.benchmarks.smoke import script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset

SCRIPT = "benchmarks/results/stakes_distill/probe.py"


@pytest.fixture
def probe(capsys):
    return script_runner(SCRIPT, capsys)


def test_the_probe_scores_the_start_on_the_held_out_layouts_and_trains_both_targets(tmp_path, probe):
    """Step 0's agreement and offline gap closed are the tiny actor's greedy picks on the decisions of layouts
    3 and 7, computed here with the actor; both targets write an actor file; the difference is second - first."""
    from explore_rl.config import load_config
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset, padded_batch
    from tests.policy_files import TINY_MODEL, actor_file

    decisions, best = revisit_dataset(tmp_path / "data")
    actor_path, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    result = probe("--dataset", str(tmp_path / "data"), "--actor", str(actor_path), "--steps", "4", "--every", "2",
                   "--out", str(tmp_path / "out"))
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]  # torchrl logs too
    rows, summary = lines[:-1], lines[-1]
    assert [(row["target"], row["steps"]) for row in rows] == [
        ("em_choice", 0), ("em_choice", 2), ("em_choice", 4),
        ("em_choice_stakes", 0), ("em_choice_stakes", 2), ("em_choice_stakes", 4)]
    probe = [i for i, d in enumerate(decisions) if int(d["layout"]) % 4 == 3]
    assert summary["probe_decisions"] == len(probe) and summary["probe_layouts"] == 2
    assert summary["train_decisions"] == len(decisions) - len(probe)
    actor, _ = load_actor(actor_path)
    batch = padded_batch(DecisionDataset(tmp_path / "data").rows(torch.tensor(probe)))
    with torch.no_grad():
        logits = actor(batch["x"], batch["adj"], batch["node_mask"]).numpy()
    gains, stakes, same = [], [], []
    for row, index in enumerate(probe):
        d = decisions[index]
        rewards, mask = d["action_rewards"].numpy(), d["action_mask"].numpy()
        mean = rewards[mask].mean()
        pick = int(np.flatnonzero(mask)[np.argmax(logits[row, :len(mask)][mask])])
        gains.append(rewards[pick] - mean)
        stakes.append(rewards[best[index]] - mean)
        same.append(pick == best[index])
    start = rows[0]
    assert start["same_choice"] == pytest.approx(np.mean(same), abs=1e-4)
    assert start["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)
    assert rows[3] == rows[0] | {"target": "em_choice_stakes"}  # both start from the same actor
    for target in ("em_choice", "em_choice_stakes"):
        assert (tmp_path / "out" / f"{target}.pt").is_file()
        assert load_actor(tmp_path / "out" / f"{target}.pt")[1].meta["kind"] == f"offline distillation ({target})"
    difference = summary["em_choice_stakes"]["gap_closed"] - summary["em_choice"]["gap_closed"]
    assert summary["difference"]["gap_closed"] == pytest.approx(difference, abs=2e-4)


@pytest.mark.parametrize("bad", [["--steps", "0"], ["--lr", "0"], ["--dataset", "/nonexistent/data"]])
def test_the_probe_refuses_bad_arguments_in_one_line(bad, probe):
    result = probe(*bad)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert bad[0] in result.stderr.strip().splitlines()[-1]
