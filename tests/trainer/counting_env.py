"""A stand-in TorchRL env for the async collector's test (tests/trainer/test_async_collector.py),
in a module of its own so that the spawned workers that import it stay light."""

from __future__ import annotations

import time

import torch
from tensordict import TensorDict
from torchrl.data import Composite, Unbounded
from torchrl.envs import EnvBase


class CountingEnv(EnvBase):
    """Stand-in env (this test only): observes its worker and its step count, sleeps
    ``delay`` s per step (worker speeds), never ends."""

    def __init__(self, worker: int, delay: float):
        super().__init__()
        self.worker, self.delay, self.steps = worker, delay, 0
        self.observation_spec = Composite(worker_seen=Unbounded((), dtype=torch.int64),
                                          count=Unbounded((), dtype=torch.int64), one=Unbounded((1,)))
        self.action_spec = Unbounded((1,))
        self.reward_spec = Unbounded((1,))

    def observe(self) -> TensorDict:
        return TensorDict(worker_seen=torch.tensor(self.worker), count=torch.tensor(self.steps), one=torch.ones(1))

    def _reset(self, tensordict=None, **kwargs):
        return self.observe()

    def _step(self, tensordict):
        time.sleep(self.delay)
        self.steps += 1
        out = self.observe()
        out.update(reward=torch.zeros(1), done=torch.zeros(1, dtype=torch.bool),
                   terminated=torch.zeros(1, dtype=torch.bool))
        return out

    def _set_seed(self, seed):
        pass


class CountingEnvFactory:
    """Picklable factory of worker ``worker``'s stand-in env (spawned workers call it)."""

    def __init__(self, worker: int, delay: float):
        self.worker, self.delay = worker, delay

    def __call__(self) -> CountingEnv:
        return CountingEnv(self.worker, self.delay)
