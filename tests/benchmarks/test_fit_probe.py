"""fit_probe/ensemble.py on a small made-up loops dataset and tiny loops actors: each member's figures and the
ensemble's (the members' log-probabilities averaged) equal ones computed here from the actors' logits; bad
arguments are refused in one line."""

from __future__ import annotations


import numpy as np
import pytest
import torch

from tests.benchmarks.smoke import json_lines, run_main, script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset

@pytest.fixture()
def run(capsys):
    """The script's main in this process (tests/benchmarks/smoke.py: run_main)."""
    return script_runner("benchmarks/results/fit_probe/ensemble.py", capsys)


def tiny_actor(directory, features: str, seed: int):
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    path, _ = actor_file(directory, load_config([*TINY_MODEL, f"graph.features={features}"]), seed=seed)
    return path


def test_members_and_ensemble_figures(tmp_path, run):
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset, padded_batch

    decisions, best = revisit_dataset(tmp_path / "data", features="loops")
    paths = [tiny_actor(tmp_path / f"a{seed}", "loops", seed) for seed in (0, 1)]
    result = run(*map(str, paths), "--dataset", str(tmp_path / "data"))
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout)
    probe = [i for i, d in enumerate(decisions) if int(d["layout"]) % 4 == 3]
    batch = padded_batch(DecisionDataset(tmp_path / "data").rows(torch.tensor(probe)), list(range(11)))
    log_probs = []
    with torch.no_grad():
        for path in paths:
            actor, _ = load_actor(path)
            logits = actor(batch["x"], batch["adj"], batch["node_mask"]).masked_fill(~batch["action_mask"], -torch.inf)
            log_probs.append(torch.log_softmax(logits, -1).numpy())
    for row, probabilities in zip(lines[:2] + [lines[2]], log_probs + [np.mean(log_probs, axis=0)]):
        gains, stakes, same = [], [], []
        for k, index in enumerate(probe):
            rewards, mask = decisions[index]["action_rewards"].numpy(), decisions[index]["action_mask"].numpy()
            pick = int(np.argmax(probabilities[k, :len(mask)]))
            gains.append(rewards[pick] - rewards[mask].mean())
            stakes.append(rewards[best[index]] - rewards[mask].mean())
            same.append(pick == best[index])
        assert row["held_out"]["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)
        assert row["held_out"]["same_choice"] == pytest.approx(np.mean(same), abs=1e-4)
    summary = lines[3]
    assert lines[2]["actor"] == "ensemble" and summary["members"] == 2 and summary["probe_decisions"] == len(probe)
    best_member = max(lines[:2], key=lambda line: line["held_out"]["gap_closed"])
    assert summary["ensemble_minus_best"]["gap_closed"] == pytest.approx(
        lines[2]["held_out"]["gap_closed"] - best_member["held_out"]["gap_closed"], abs=2e-4)


def test_bad_arguments_are_refused_in_one_line(tmp_path, run):
    revisit_dataset(tmp_path / "data", features="loops")
    loops, extended = tiny_actor(tmp_path / "l", "loops", 0), tiny_actor(tmp_path / "e", "extended", 0)
    one = run(str(loops), "--dataset", str(tmp_path / "data"))
    assert one.returncode == 2 and "give two or more" in one.stderr.strip().splitlines()[-1]
    mixed = run(str(loops), str(extended), "--dataset", str(tmp_path / "data"))
    assert mixed.returncode == 1 and "read different node features" in mixed.stderr.strip().splitlines()[-1]
    missing = run(str(loops), str(tmp_path / "nope.pt"), "--dataset", str(tmp_path / "data"))
    assert missing.returncode == 1 and missing.stderr.strip().startswith("actors:")
    assert len(missing.stderr.strip().splitlines()) == 1


def test_memory_script_reports_the_growth_per_100_steps(tmp_path, capsys):
    revisit_dataset(tmp_path / "data", features="loops")
    script = "benchmarks/results/fit_probe/memory.py"
    code, out, err = run_main(script, ["--dataset", str(tmp_path / "data"), "--steps", "3", "--every", "1"], capsys)
    assert code == 0, err
    lines = json_lines(out)
    assert [line["steps"] for line in lines[:3]] == [1, 2, 3] and all(line["resident_mb"] > 0 for line in lines[:3])
    summary = lines[3]
    assert summary["first_mb"] == lines[0]["resident_mb"] and summary["last_mb"] == lines[2]["resident_mb"]
    assert summary["mb_per_100_steps"] == pytest.approx((lines[2]["resident_mb"] - lines[0]["resident_mb"]) / 2 * 100,
                                                        abs=6)  # the lines round to 0.1 MB
    code, _, err = run_main(script, ["--steps", "2", "--every", "5"], capsys)
    assert code == 2 and "--every 5" in err.strip().splitlines()[-1]
