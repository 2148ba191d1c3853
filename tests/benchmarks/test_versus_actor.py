"""closure_probe/versus_actor.py on a small made-up loops dataset and a tiny loops actor: the actor's figure equals
one computed here from its logits, a ridge model and the paired difference are reported; bad actors are refused
in one line."""

from __future__ import annotations


import numpy as np
import pytest
import torch

from tests.benchmarks.smoke import json_lines, script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset

@pytest.fixture()
def run(capsys):
    """The script's main in this process (tests/benchmarks/smoke.py: run_main)."""
    return script_runner("benchmarks/results/closure_probe/versus_actor.py", capsys)


def tiny_actor(directory, features: str):
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    return actor_file(directory, load_config([*TINY_MODEL, f"graph.features={features}"]))[0]


def test_ridge_and_actor_on_the_same_held_out_decisions(tmp_path, run):
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset, padded_batch

    decisions, best = revisit_dataset(tmp_path / "data", count=64, features="loops")
    actor_path = tiny_actor(tmp_path / "actor", "loops")
    result = run(str(actor_path), "--dataset", str(tmp_path / "data"))
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout)
    assert [line["model"] for line in lines[:3]] == ["ridge loops", "ridge loops, pairwise", str(actor_path)]
    probe = [i for i, d in enumerate(decisions) if int(d["layout"]) % 4 == 3]
    batch = padded_batch(DecisionDataset(tmp_path / "data").rows(torch.tensor(probe)), list(range(11)))
    actor, _ = load_actor(actor_path)
    with torch.no_grad():
        logits = actor(batch["x"], batch["adj"], batch["node_mask"]).numpy()
    gains, stakes = [], []
    for row, index in enumerate(probe):
        rewards, mask = decisions[index]["action_rewards"].numpy(), decisions[index]["action_mask"].numpy()
        pick = int(np.flatnonzero(mask)[np.argmax(logits[row, :len(mask)][mask])])
        gains.append(rewards[pick] - rewards[mask].mean())
        stakes.append(rewards[best[index]] - rewards[mask].mean())
    assert lines[2]["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)
    summary = lines[3]
    assert summary["held_out_decisions"] == len(probe) and summary["best_actor"] == str(actor_path)
    for name, line in (("ridge loops", lines[0]), ("ridge loops, pairwise", lines[1])):
        assert summary["ridge_minus_best_actor"][name]["gap_closed"] == pytest.approx(
            line["gap_closed"] - lines[2]["gap_closed"], abs=2e-4)


def test_an_actor_of_other_features_is_refused_in_one_line(tmp_path, run):
    revisit_dataset(tmp_path / "data", features="loops")
    result = run(str(tiny_actor(tmp_path / "e", "extended")), "--dataset", str(tmp_path / "data"))
    assert result.returncode == 1 and "give loops actors" in result.stderr.strip().splitlines()[-1]
