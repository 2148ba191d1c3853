"""Config groups of the trainer: ``algo`` (A2C), ``collector``, ``logger`` and ``train``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

ESTIMATORS = ("gae", "td_lambda", "td0")
IMITATION_TARGETS = ("em_choice", "rewards")
BACKENDS = ("local", "ray")
LOGGERS = ("csv", "tensorboard")


@dataclass
class AlgoConfig:
    """A2C (paper Sec. III-B): TorchRL's ``A2CLoss`` with a value estimator, Adam."""

    lr: float = 1e-4
    gamma: float = 0.99
    estimator: str = "gae"  # gae | td_lambda | td0 (TorchRL value estimators)
    lmbda: float = 0.95  # GAE / TD(lambda)
    value_coef: float = 0.5  # beta: weight of the critic loss
    entropy_coef: float = 0.01  # eta: weight of the entropy bonus
    # Weight of a cross-entropy term towards EM's choice at the same decision (the env
    # computes it for the reward anyway): 0 is the paper's plain A2C.
    imitation_coef: float = 0.0
    # What it imitates: em_choice (cross-entropy towards EM's pick) | rewards (maximise the
    # expected Algorithm 1 reward over every frontier node, which the env evaluates)
    imitation_target: str = "em_choice"
    # Extra supervised steps per update on decisions replayed from a buffer of the last
    # ``imitation_buffer`` EM-labelled ones (explore_rl/trainer/imitation.py; 0 = none).
    imitation_replay_steps: int = 0
    imitation_batch: int = 16  # decisions per replayed minibatch
    imitation_buffer: int = 3000  # labelled decisions kept (saved in checkpoints/last.pt)
    max_grad_norm: float = 1.0  # gradient clipping (L2 norm over all parameters)
    steps_per_update: int = 10  # decisions per worker between updates (paper: 10)


@dataclass
class CollectorConfig:
    """Where decisions are collected: ``workers`` env processes, locally or on Ray."""

    workers: int = 1  # 1: TorchRL Collector in this process; >1: MultiSyncCollector
    backend: str = "local"  # local | ray (TorchRL's RayCollector, `pip install explore_rl[ray]`)
    ray_address: Optional[str] = None  # e.g. "ray://head:10001"; None starts a local Ray instance


@dataclass
class LoggerConfig:
    """TorchRL logger of the training curves (under ``<out>/logs``)."""

    kind: str = "csv"  # csv | tensorboard


@dataclass
class TrainConfig:
    """The training run: budget, checkpoints, threads."""

    frames: int = 20_000  # decisions in all, over every worker
    checkpoint_every: int = 10  # updates between checkpoints (the last one is always saved)
    # updates between numbered snapshots checkpoints/update_<k>.pt (learning curves); 0 = none
    snapshot_every: int = 0
    threads: int = 1  # torch threads of the learner (each env worker uses one core anyway)
    progress_bar: bool = True
