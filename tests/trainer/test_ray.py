"""collector.backend=ray on a local Ray instance: collection and the weight sync (slow;
needs the optional extra `pip install -e .[ray]`, which `make test-slow` installs)."""

from __future__ import annotations

import pytest
import torch

from explore_rl.envs import make_env
from explore_rl.trainer.a2c import Learner, make_collector, train
from tests.trainer.test_a2c import config_for

def batches_around_a_weight_change(config, change, between=None):
    """The learner, and the Ray collector's batches before and after ``change(learner)`` and a
    weight sync; ``between(collector)`` runs after the first batch (e.g. to ask the workers)."""
    torch.manual_seed(0)
    learner = Learner(config, make_env(config).action_spec)
    collector = make_collector(config, learner.actor)
    try:
        collector.update_policy_weights_()
        batches = iter(collector)
        first = next(batches)
        if between is not None:
            between(collector)
        change(learner, first)
        collector.update_policy_weights_()
        second = next(batches)
    finally:
        collector.shutdown()
    return learner, first, second


def assert_acted_with_the_new_weights(learner, first, second) -> None:
    """The second batch's log-probabilities are the learner's current actor's, the first's not."""
    with torch.no_grad():
        local = learner.actor.get_dist(second).log_prob(second["action"])
        before = learner.actor.get_dist(first).log_prob(first["action"])
    torch.testing.assert_close(second["action_log_prob"], local, rtol=1e-4, atol=1e-4)
    assert not torch.allclose(first["action_log_prob"], before, atol=1e-4)


def negate_and_double(learner, _batch) -> None:
    with torch.no_grad():
        for parameter in learner.actor.parameters():
            parameter.mul_(-2.0)  # a different policy


@pytest.mark.slow
def test_ray_workers_act_with_the_learners_new_weights():
    """After ``update_policy_weights_()`` the remote workers' log-probabilities are the
    learner's own on the same observations: the new weights arrived."""
    config = config_for("collector=ray", "collector.workers=2", "algo.steps_per_update=3")
    learner, first, second = batches_around_a_weight_change(config, negate_and_double)
    assert first.numel() == 6
    assert_acted_with_the_new_weights(learner, first, second)


@pytest.mark.slow
def test_a_training_run_on_ray_gets_past_its_updates(tmp_path):
    config = config_for("collector=ray", "collector.workers=2", "algo.steps_per_update=3", "train.frames=12")
    state = train(config, tmp_path / "run")
    assert state.updates == 2 and state.frames == 12
    assert (tmp_path / "run" / "checkpoints" / "last.pt").is_file()
