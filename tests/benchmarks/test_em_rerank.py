"""em_rerank/topk_probe.py on a small made-up dataset and a tiny actor: per k, EM's best reward among the
actor's k most probable frontiers, computed here from the actor's logits; k = 1 is the actor's greedy pick and a
k beyond every action set is EM's own choice; bad arguments are refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from tests.benchmarks.smoke import script_runner
from tests.benchmarks.test_selection_v6 import revisit_dataset

SCRIPT = "benchmarks/results/em_rerank/topk_probe.py"


@pytest.fixture
def topk(capsys):
    return script_runner(SCRIPT, capsys)


def test_the_probe_lets_em_pick_among_the_actors_k_most_probable_frontiers(tmp_path, topk):
    from explore_rl.config import load_config
    from explore_rl.models.actor_file import load_actor
    from explore_rl.trainer.dataset import DecisionDataset, padded_batch
    from tests.policy_files import TINY_MODEL, actor_file

    decisions, best = revisit_dataset(tmp_path / "data")
    actor_path, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    result = topk("--dataset", str(tmp_path / "data"), "--actor", str(actor_path), "--k", "1", "2", "50")
    assert result.returncode == 0, result.stderr
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]  # torchrl logs too
    rows, summary = lines[:-1], lines[-1]
    assert [row["k"] for row in rows] == [1, 2, 50]
    probe = [i for i, d in enumerate(decisions) if int(d["layout"]) % 4 == 3]
    assert summary["probe_decisions"] == len(probe) and summary["probe_layouts"] == 2
    actor, _ = load_actor(actor_path)
    batch = padded_batch(DecisionDataset(tmp_path / "data").rows(torch.tensor(probe)))
    with torch.no_grad():
        logits = actor(batch["x"], batch["adj"], batch["node_mask"]).numpy()
    for row in rows:
        gains, stakes, same, share = [], [], [], []
        for position, index in enumerate(probe):
            d = decisions[index]
            rewards, mask = d["action_rewards"].numpy(), d["action_mask"].numpy()
            valid = np.flatnonzero(mask)
            shortlist = valid[np.argsort(-logits[position, :len(mask)][valid], kind="stable")][:row["k"]]
            pick = shortlist[np.argmax(rewards[shortlist])]
            gains.append(rewards[pick] - rewards[mask].mean())
            stakes.append(rewards[best[index]] - rewards[mask].mean())
            same.append(pick == best[index])
            share.append(len(shortlist) / len(valid))
        assert row["gap_closed"] == pytest.approx(sum(gains) / sum(stakes), abs=1e-3)
        assert row["same_choice"] == pytest.approx(np.mean(same), abs=1e-4)
        assert row["evaluated_share"] == pytest.approx(np.mean(share), abs=1e-4)
    assert rows[2]["same_choice"] == 1.0 and rows[2]["gap_closed"] == pytest.approx(1.0, abs=1e-4)
    assert rows[2]["evaluated_share"] == 1.0


@pytest.mark.parametrize("bad", [["--k", "0"], ["--dataset", "/nonexistent/data"], ["--actor", "/nonexistent.pt"]])
def test_the_probe_refuses_bad_arguments_in_one_line(bad, topk):
    result = topk(*bad)
    assert result.returncode != 0 and "Traceback" not in result.stderr
    assert bad[0] in result.stderr.strip().splitlines()[-1]
