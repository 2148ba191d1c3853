"""The imitation replay buffer: compact decisions round-trip to the same actor outputs."""

from __future__ import annotations

import pytest
import torch

from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION
from explore_rl.trainer.a2c import Learner
from explore_rl.trainer.imitation import compact_decisions, make_label_buffer, pad_graphs
from tests.trainer.test_a2c import batch, config_for  # noqa: F401 -- the module's real batch fixture


def test_compact_decisions_pad_back_to_the_same_graphs(batch):  # noqa: F811
    decisions = compact_decisions(batch)
    flat = batch.reshape(-1)
    labelled = torch.nonzero((flat[EM_ACTION] >= 0) & flat["action_mask"].any(-1)).flatten()
    assert len(decisions) == len(labelled) > 0
    padded = pad_graphs(decisions)
    width = padded["x"].shape[1]
    assert width == int(flat["node_mask"][labelled].sum(-1).max())
    for row, index in enumerate(labelled.tolist()):
        for key in ("x", "adj", "node_mask", "action_mask", ACTION_REWARDS):
            original = flat[key][index]
            original = original[:width, :width] if key == "adj" else original[:width]
            assert torch.equal(padded[key][row], original.to(padded[key].dtype)), key
        assert padded[EM_ACTION][row] == flat[EM_ACTION][index]


def test_the_actor_scores_a_replayed_decision_as_it_scored_the_original(batch):  # noqa: F811
    config = config_for()
    torch.manual_seed(0)
    learner = Learner(config)
    flat = batch.reshape(-1)
    replayed = pad_graphs(compact_decisions(batch))
    labelled = torch.nonzero((flat[EM_ACTION] >= 0) & flat["action_mask"].any(-1)).flatten()
    with torch.no_grad():
        original = learner.actor.get_dist(flat[labelled]).log_prob(flat[EM_ACTION][labelled])
        again = learner.actor.get_dist(replayed).log_prob(replayed[EM_ACTION])
    torch.testing.assert_close(again, original, rtol=1e-5, atol=1e-5)


def test_the_buffer_keeps_only_the_last_capacity_decisions_and_survives_a_state_dict(batch):  # noqa: F811
    decisions = compact_decisions(batch)
    buffer = make_label_buffer(capacity=3, batch_size=2)
    buffer.extend(decisions)
    assert len(buffer) == min(3, len(decisions))
    copy = make_label_buffer(capacity=3, batch_size=2)
    copy.load_state_dict(buffer.state_dict())
    torch.manual_seed(1)
    first = buffer.sample()
    torch.manual_seed(1)
    second = copy.sample()
    assert torch.equal(first["x"], second["x"]) and torch.equal(first[EM_ACTION], second[EM_ACTION])


def test_replay_steps_fill_the_buffer_and_lower_the_distill_loss(batch):  # noqa: F811
    torch.manual_seed(0)
    config = config_for("algo.distill_coef=1.0", "algo.dagger_steps=30", "algo.lr=1e-2",
                        "algo.dagger_batch=4", "model.dropout=0.0")
    learner = Learner(config)
    replayed = pad_graphs(compact_decisions(batch))
    with torch.no_grad():
        before = learner.distill_loss(replayed).item()
    stats = learner.update(batch.clone())
    with torch.no_grad():
        after = learner.distill_loss(replayed).item()
    assert len(learner.labels) == len(compact_decisions(batch))
    assert stats.loss_replay is not None and after < 0.5 * before


def test_the_rewards_target_raises_the_expected_reward_of_every_replayed_decision(batch):  # noqa: F811
    """distill_target=expected_reward: the loss is minus the policy's expected Algorithm 1 reward
    (checked against a direct sum over the frontier rows), and Adam steps raise it."""
    torch.manual_seed(0)
    config = config_for("algo.distill_coef=1.0", "algo.distill_target=expected_reward", "model.dropout=0.0")
    learner = Learner(config)
    replayed = pad_graphs(compact_decisions(batch))
    with torch.no_grad():
        probs = torch.softmax(learner.actor.get_dist(replayed).logits, -1)
        by_hand = [float(sum(p[row] * r[row] for row in torch.nonzero(m).flatten()))
                   for p, r, m in zip(probs, replayed[ACTION_REWARDS], replayed["action_mask"])]
        before = learner.distill_loss(replayed).item()
    assert before == pytest.approx(-sum(by_hand) / len(by_hand), abs=1e-5)
    optimizer = torch.optim.Adam(learner.actor.parameters(), lr=1e-2)
    for _ in range(30):
        loss = learner.distill_loss(replayed)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    best = (replayed[ACTION_REWARDS] + torch.where(replayed["action_mask"], 0.0, -9.0)).max(-1).values
    assert learner.distill_loss(replayed).item() < before
    assert -learner.distill_loss(replayed).item() <= best.mean().item() + 1e-6
