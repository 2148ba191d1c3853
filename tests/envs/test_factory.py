"""Env factories: the per-worker seeds of the envs and of the workers' action sampling."""

from __future__ import annotations

import torch

from explore_rl.config import load_config
from explore_rl.envs import EnvFactory
from explore_rl.envs.factory import policy_seed, worker_seed


def test_a_factory_seeds_its_process_torch_rng_only_when_given_a_seed():
    config = load_config(["scene=street", "slam=model"])
    torch.manual_seed(123)
    EnvFactory(config)()  # an in-process collector's factory: the caller's RNG stays as it was
    assert torch.initial_seed() == 123
    EnvFactory(config, worker=1, torch_seed=policy_seed(0, 1))()
    assert torch.initial_seed() == policy_seed(0, 1)


def test_policy_seeds_differ_per_worker_and_start_and_from_the_env_seeds():
    seeds = {policy_seed(seed, worker, start) for seed in (0, 1) for worker in (0, 1) for start in (0, 10)}
    assert len(seeds) == 8
    assert policy_seed(0, 1, 10) == policy_seed(0, 1, 10)
    assert not seeds & {worker_seed(seed, worker) for seed in (0, 1) for worker in (0, 1)}
