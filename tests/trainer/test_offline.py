"""Offline distillation on a dataset: the learner's own loss, lowered; actor files that load."""

from __future__ import annotations

import pytest
import torch

from explore_rl.envs.keys import ACTION_REWARDS
from explore_rl.models.actor_file import load_actor
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.dataset import DecisionDataset, padded_batch
from explore_rl.trainer.evaluate import actor_training_config, training_layouts
from explore_rl.trainer.imitation import compact_decisions, pad_graphs
from explore_rl.trainer.offline import distill_loss_of, offline_config, save_offline_actor, train_offline
from tests.trainer.test_a2c import batch, config_for  # noqa: F401 -- the module's real batch fixture
from tests.trainer.test_dataset import schema_for


@pytest.fixture
def dataset(batch, tmp_path):  # noqa: F811
    data = DecisionDataset(tmp_path / "ds", schema_for(config_for()))
    data.append(compact_decisions(batch), scene="street")
    return data


def test_the_offline_loss_is_the_learners_distillation_loss(batch, dataset):  # noqa: F811
    """Measured on the dataset it equals ``Learner.distill_loss`` on the in-memory padded
    decisions, and minus the mean over decisions of sum_k p_k r_k computed by hand."""
    torch.manual_seed(0)
    learner = Learner(offline_config(config_for()))
    everything = torch.arange(len(dataset))
    on_disk = distill_loss_of(learner, dataset, everything, list(range(4)))
    direct = pad_graphs(compact_decisions(batch))
    with torch.no_grad():
        assert on_disk == pytest.approx(learner.distill_loss(direct).item(), abs=1e-6)
        probs = torch.softmax(learner.actor.get_dist(direct).logits, -1)
    by_hand = -(probs * direct[ACTION_REWARDS]).sum(-1).mean().item()
    assert on_disk == pytest.approx(by_hand, abs=1e-5)


def test_offline_training_lowers_the_distillation_loss_on_a_fixed_dataset(dataset):
    torch.manual_seed(0)
    config = config_for("algo.lr=1e-2", "algo.dagger_batch=4", "model.dropout=0.0")
    everything = torch.arange(len(dataset))
    before_learner = Learner(offline_config(config))
    before = distill_loss_of(before_learner, dataset, everything, list(range(4)))
    torch.manual_seed(0)
    learner, result = train_offline(config, dataset, steps=40)
    after = distill_loss_of(learner, dataset, everything, list(range(4)))
    assert result.steps == 40 and len(result.losses) == 40 and result.rows == len(dataset)
    best = padded_batch(dataset.rows())
    best = (best[ACTION_REWARDS] + torch.where(best["action_mask"], 0.0, -9.0)).max(-1).values.mean().item()
    assert after < before - 0.1 * abs(before) and -after <= best + 1e-6


@pytest.mark.parametrize("target", ["em_choice", "em_choice_stakes"])
def test_offline_training_distills_the_configured_target(dataset, tmp_path, target):
    """``algo.distill_target`` is kept offline (``expected_reward`` only by default): training on EM's
    choice lowers the cross-entropy to it, and the actor file names the target."""
    assert offline_config(config_for()).algo.distill_target == "expected_reward"
    config = config_for("algo.lr=1e-2", "algo.dagger_batch=4", "model.dropout=0.0", f"algo.distill_target={target}")
    assert offline_config(config).algo.distill_target == target
    everything = torch.arange(len(dataset))
    torch.manual_seed(0)
    before = distill_loss_of(Learner(offline_config(config)), dataset, everything, list(range(4)))
    torch.manual_seed(0)
    learner, _ = train_offline(config, dataset, steps=40)
    assert distill_loss_of(learner, dataset, everything, list(range(4))) < 0.8 * before
    path = save_offline_actor(learner, tmp_path / "actor.pt")
    assert load_actor(path)[1].meta["kind"] == f"offline distillation ({target})"


def test_an_offline_actor_file_loads_and_scores_like_the_learner(dataset, tmp_path):
    torch.manual_seed(0)
    learner, _ = train_offline(config_for(), dataset, steps=2)
    path = save_offline_actor(learner, tmp_path / "actor.pt", meta={"rows": len(dataset)})
    actor, actor_file = load_actor(path)
    assert actor_file.feature_set == "paper" and actor_file.meta["rows"] == len(dataset)
    sample = padded_batch(dataset.rows())
    with torch.no_grad():
        expected = learner.actor.get_dist(sample).logits
        logits = actor(sample["x"], sample["adj"], sample["node_mask"])
    mask = sample["action_mask"]
    normalised = logits.masked_fill(~mask, -torch.inf).log_softmax(-1)  # MaskedCategorical's logits
    torch.testing.assert_close(normalised[mask], expected[mask], rtol=0, atol=1e-6)


def test_bad_offline_inputs_fail_in_one_line(dataset, tmp_path):
    outside = torch.tensor([0, len(dataset)])
    for kwargs, message in (({"steps": 0}, "steps must be >= 1"), ({"steps": 1, "index": outside}, "outside"),
                            ({"steps": 1, "index": torch.tensor([], dtype=torch.int64)}, "no decisions chosen")):
        with pytest.raises(ValueError, match=message) as error:
            train_offline(config_for(), dataset, **kwargs)
        assert "\n" not in str(error.value)
    empty = DecisionDataset(tmp_path / "empty", schema_for(config_for()))
    with pytest.raises(ValueError, match="holds no decisions"):
        train_offline(config_for(), empty, steps=1)
    with pytest.raises(ValueError, match="no node feature"):
        train_offline(config_for("graph.features=extended"), dataset, steps=1)


def test_the_distill_command_writes_an_actor_file_of_the_chosen_scenes(dataset, tmp_path, capsys):  # noqa: F811
    import json

    from explore_rl.trainer.offline import main

    out = tmp_path / "distilled" / "actor.pt"
    main(["--dataset", str(dataset.path), "--out", str(out), "--steps", "3", "--scenes", "street",
          *FAST_OVERRIDES])
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["decisions"] == len(dataset) and summary["steps"] == 3 and summary["scenes"] == ["street"]
    _, actor_file = load_actor(out)
    assert actor_file.meta["decisions"] == len(dataset) and actor_file.meta["kind"].startswith("offline distillation")
    layouts = dataset.rows()["layout"]  # what it trained on: the protocol refuses that span, and only it
    assert actor_file.meta["train_layouts"] == [int(layouts.min()), int(layouts.max()) + 1]
    trained_scene, trained = training_layouts(actor_training_config(out))
    assert trained == range(int(layouts.min()), int(layouts.max()) + 1)
    for bad, message in ((["--scenes", "office"], "--scenes office: the dataset"),
                         (["--steps", "0"], "--steps must be >= 1"),
                         (["--dataset", str(tmp_path / "none")], "no dataset there")):
        arguments = {"--dataset": str(dataset.path), "--out": str(tmp_path / "x.pt"), "--steps": "1"}
        arguments.update(dict(zip(bad[::2], bad[1::2])))
        with pytest.raises(SystemExit) as stopped:
            main([item for pair in arguments.items() for item in pair] + FAST_OVERRIDES)
        assert stopped.value.code == 2
        error = capsys.readouterr().err.strip()
        assert message in error and len(error.splitlines()) == 1


FAST_OVERRIDES = ["--set", "scene=street", "slam=model", "model.hidden=32", "model.mlp_hidden=32"]
