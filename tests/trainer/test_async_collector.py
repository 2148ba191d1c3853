"""``collector.kind=async``: the policy-lag gate, worker tags on TorchRL's async batches,
per-worker episode bookkeeping of interleaved batches, the config's checks, and (slow) a
real asynchronous training run that finishes and resumes."""

from __future__ import annotations

import itertools
import random

import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torchrl.envs.utils import ExplorationType

from explore_rl.config import load_config
from explore_rl.envs.keys import EM_ACTION, POLICY_LAG, WORKER
from explore_rl.models.checkpoint import read_checkpoint
from explore_rl.trainer.async_collector import LagBoundedAsyncCollector, PolicyLagGate, gated_schedule
from explore_rl.trainer.episodes import EpisodeTracker
from tests.trainer.counting_env import CountingEnvFactory
from tests.trainer.test_a2c import config_for

# ---------------------------------------------------------------------- the gate (pure)


def simulate_gate(durations: list[list[float]], max_lag: int, batches: int) -> list[tuple[int, int]]:
    """``(worker, lag)`` of the first ``batches`` batches the gate hands out (``gated_schedule``)."""
    return [(worker, lag) for worker, lag, _ in itertools.islice(gated_schedule(durations, max_lag), batches)]


@pytest.mark.parametrize("workers", [1, 2, 3, 4])
def test_the_gate_bounds_the_lag_and_never_deadlocks(workers):
    rng = random.Random(workers)
    for max_lag in (workers, workers + 1, workers + 3):
        for _ in range(20):
            durations = [[rng.choice([0.3, 1, 3, 10]) for _ in range(100)] for _ in range(workers)]
            order = simulate_gate(durations, max_lag, batches=30)
            assert max(lag for _, lag in order) <= max_lag


def test_the_gate_holds_a_fast_worker_back_only_as_far_as_the_bound():
    fast_slow = [[1.0] * 30, [10.5] * 30]  # worker 0 ten times as fast
    # both workers start with version 0, so the fast one goes once more at the start
    strict = [w for w, _ in simulate_gate(fast_slow, max_lag=2, batches=8)]
    assert strict == [0, 0, 1, 0, 1, 0, 1, 0]  # two workers, lag 2: they alternate
    one_ahead = [w for w, _ in simulate_gate(fast_slow, max_lag=3, batches=8)]
    assert one_ahead == [0, 0, 0, 1, 0, 0, 1, 0]  # lag 3: one batch ahead
    free = [w for w, _ in simulate_gate(fast_slow, max_lag=100, batches=11)]
    assert free == [0] * 10 + [1]  # no bound in reach: arrival order


def test_a_lag_below_the_number_of_workers_is_refused():
    with pytest.raises(ValueError, match="max_policy_lag=1: 2 workers need >= 2"):
        PolicyLagGate(2, 1)


# ---------------------------------------------------------------------- TorchRL's async workers


def test_async_batches_name_their_worker_and_stay_within_the_lag():
    """Two spawned workers, one 4x slower. The policy's action is its bias, which is set to
    the number of batches handed out before each weight sync: an action shows the weights
    that took it. Each batch names its worker (= the worker its env observed), no batch of a
    worker is lost (its step counts run on), and no decision is older than the bound."""
    policy = TensorDictModule(torch.nn.Linear(1, 1), in_keys=["one"], out_keys=["action"])
    torch.nn.init.zeros_(policy.module.weight)
    torch.nn.init.zeros_(policy.module.bias)
    max_lag, steps = 2, 4
    collector = LagBoundedAsyncCollector([CountingEnvFactory(0, 0.02), CountingEnvFactory(1, 0.08)], policy,
                                         max_policy_lag=max_lag, frames_per_batch=steps, total_frames=-1,
                                         exploration_type=ExplorationType.DETERMINISTIC)
    counts, order = {0: [], 1: []}, []
    try:
        for handed, batch in enumerate(itertools.islice(collector, 10)):
            worker = int(batch[WORKER][0])
            assert batch.shape == (steps,) and (batch[WORKER] == worker).all()
            assert (batch["worker_seen"] == worker).all()
            counts[worker].extend(batch["count"].tolist())
            order.append(worker)
            acted_with = batch["action"].round().long()  # the version of the weights of each decision
            assert int(batch[POLICY_LAG][0]) <= max_lag
            assert handed - int(acted_with.min()) <= int(batch[POLICY_LAG][0])
            with torch.no_grad():
                policy.module.bias.fill_(handed + 1)  # the update on this batch
            collector.update_policy_weights_()
    finally:
        collector.shutdown()
    second = order.index(1 - order[0])  # lag 2 with two workers: they alternate once both went
    assert second <= 2 and all(a != b for a, b in zip(order[second:], order[second + 1:]))
    for worker in (0, 1):
        assert counts[worker] == list(range(len(counts[worker])))


# ---------------------------------------------------------------------- episodes of tagged batches


def tagged_batch(worker: int, episodes: list[int], actions: list[int], done: list[bool]) -> TensorDict:
    """An async batch ``[1, T]`` of ``worker`` with the keys the episode tracker reads."""
    t = len(actions)
    nxt = {key: torch.zeros(1, t) for key in ("reward", "explored", "map_error", "travel")}
    nxt.update(loop_closures=torch.zeros(1, t, dtype=torch.int64), failed=torch.zeros(1, t, dtype=torch.bool),
               done=torch.tensor([done]), terminated=torch.tensor([done]))
    nxt["reward"] += 1.0
    return TensorDict({"episode": torch.tensor([episodes]), "action": torch.tensor([actions]),
                       EM_ACTION: torch.tensor([actions]), WORKER: torch.full((1, t), worker),
                       "next": TensorDict(nxt, [1, t])}, [1, t])


def test_interleaved_async_batches_are_tracked_per_worker():
    tracker = EpisodeTracker(workers=2)
    tracker.add(tagged_batch(1, [0, 0, 0], [5, 6, 7], [False, False, False]))
    finished = tracker.add(tagged_batch(0, [0, 0, 1], [1, 2, 3], [False, True, False]))
    assert [(e.worker, e.episode, e.decisions) for e in finished] == [(0, 0, 2)]
    finished = tracker.add(tagged_batch(1, [0, 1, 1], [8, 9, 4], [True, False, False]))
    assert [(e.worker, e.episode, e.decisions) for e in finished] == [(1, 0, 4)]
    tracker.add(tagged_batch(0, [1, 1, 1], [4, 4, 4], [False, False, False]))
    assert tracker.replays() == [(1, [3, 4, 4, 4]), (1, [9, 4])]  # what a resumed run replays


# ---------------------------------------------------------------------- config


@pytest.mark.parametrize("overrides, message", [
    (["collector.kind=asink"], r"^collector.kind='asink': choose one of sync, async$"),
    (["collector=async", "collector.max_policy_lag=1"], r"^collector.max_policy_lag=1: .* needs >= 2"),
    (["collector=ray", "collector.kind=async"], r"^collector.kind=async runs local workers only"),
])
def test_bad_collector_configs_fail_in_one_line_naming_the_key(overrides, message):
    with pytest.raises(ValueError, match=message) as error:
        load_config(overrides)
    assert "\n" not in str(error.value)


def test_collector_async_defaults_to_two_workers_one_batch_ahead():
    collector = load_config(["collector=async"]).collector
    assert (collector.kind, collector.workers, collector.policy_lag()) == ("async", 2, 3)


# ---------------------------------------------------------------------- a real run


@pytest.mark.slow  # two spawned real workers, twice: ~1-2 min on 2 cores
def test_an_async_training_run_finishes_and_resumes(tmp_path):
    from explore_rl.trainer.a2c import train

    common = ["collector=async", "algo.steps_per_update=2", "train.checkpoint_every=1"]
    state = train(config_for(*common, "train.frames=8"), tmp_path)
    assert state.frames == 8 and state.updates == 4  # one update per worker batch of 2
    first = read_checkpoint(tmp_path / "checkpoints" / "last.pt")["state"]["episodes"]
    assert sum(len(r["actions"]) for r in first["running"] if r) + sum(
        e["decisions"] for e in first["finished"]) == 8
    state = train(config_for(*common, "train.frames=16", "resume=true"), tmp_path)
    assert state.frames == 16 and state.updates == 8
    lags = (tmp_path / "logs" / "a2c" / "scalars" / "policy_lag.csv").read_text().splitlines()
    assert len(lags) == 8 and max(int(float(row.split(",")[1])) for row in lags) <= 3
