"""Picklable environment factories for TorchRL collectors.

Importing torchrl switches multiprocessing to ``spawn``: a worker process receives the
factory by pickling and calls it. :class:`EnvFactory` holds only the (plain dataclass)
config, so it pickles; lambdas and env instances do not travel well.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from torchrl.envs import EnvBase

    from explore_rl.config import Config


def make_env(config: Config, device: str = "cpu") -> EnvBase:
    """The exploration environment for ``config`` (``explore_rl.config.load_config``)."""
    from explore_rl.envs.explore_env import ExplorationEnv

    return ExplorationEnv(config, device=device)


@dataclass
class EnvFactory:
    """``EnvFactory(config)()`` builds the environment (in whichever process calls it)."""

    config: Config
    device: str = "cpu"

    def __call__(self) -> EnvBase:
        return make_env(self.config, self.device)
