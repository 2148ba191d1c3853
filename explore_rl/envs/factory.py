"""Picklable environment factories for TorchRL collectors.

Importing torchrl switches multiprocessing to ``spawn``: a worker process receives the
factory by pickling and calls it. :class:`EnvFactory` holds only the (plain dataclass)
config, so it pickles; lambdas and env instances do not travel well.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Optional

import numpy as np

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from explore_rl.config import Config


def make_env(config: Config, device: str = "cpu", worker: int = 0) -> EnvBase:
    """The exploration environment for ``config`` (``explore_rl.config.load_config``).

    ``worker`` (0, 1, ...) gives each parallel worker its own episode seeds.
    """
    from explore_rl.envs.explore_env import ExplorationEnv

    env = ExplorationEnv(config, device=device)
    env.set_seed(worker_seed(config.seed, worker))
    return env


def worker_seed(seed: int, worker: int) -> int:
    """Seed of worker ``worker``'s env; worker 0 keeps ``seed`` itself."""
    return int(seed) if worker == 0 else int(np.random.SeedSequence([seed, worker]).generate_state(1)[0])


POLICY_STREAM = 1  # tags the policy-sampling seeds apart from the env seeds


def policy_seed(seed: int, worker: int, start_frame: int = 0) -> int:
    """Seed of the torch RNG with which worker ``worker`` samples its actions, in its own
    process, for a collector started after ``start_frame`` decisions of the run (a resumed
    or restarted collector does not draw the same samples again). Independent of the env
    seeds (:func:`worker_seed`): a different entropy length."""
    return int(np.random.SeedSequence([seed, worker, start_frame, POLICY_STREAM]).generate_state(1)[0])


@dataclass
class EnvFactory:
    """``EnvFactory(config)()`` builds the environment (in whichever process calls it).

    ``replay=(episode, actions)``: the env starts by re-running that episode up to where
    a killed training run stopped (``ExplorationEnv.restore``).

    ``torch_seed``: seeds the torch RNG of the process that builds the env, i.e. a
    collector worker's action sampling (:func:`policy_seed`), so that a multi-worker
    collection is reproducible; None (an in-process collector) leaves the caller's RNG alone.
    """

    config: Config
    device: str = "cpu"
    worker: int = 0
    replay: Optional[tuple[int, list[int]]] = None
    torch_seed: Optional[int] = None

    def __call__(self) -> EnvBase:
        if self.torch_seed is not None:
            import torch  # the worker's process; torch is loaded there already by TorchRL

            torch.manual_seed(self.torch_seed)
        env = make_env(self.config, self.device, self.worker)
        if self.replay is not None:
            env.restore(*self.replay)
        return env
