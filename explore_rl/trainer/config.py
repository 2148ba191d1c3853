"""Config groups of the trainer: ``algo`` (A2C), ``collector``, ``logger`` and ``train``."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

ESTIMATORS = ("gae", "td_lambda", "td0")
DISTILL_TARGETS = ("expected_reward", "em_choice", "em_choice_stakes")
# options renamed so that nobody mistakes distillation for A2C: old name -> new name
RENAMED = {
    "imitation_coef": "distill_coef",
    "imitation_target": "distill_target",
    "imitation_replay_steps": "dagger_steps",
    "imitation_batch": "dagger_batch",
    "imitation_buffer": "dagger_buffer",
}
RENAMED_VALUES = {"imitation_target": {"rewards": "expected_reward"}}
BACKENDS = ("local", "ray")
COLLECTOR_KINDS = ("sync", "async")
LOGGERS = ("csv", "tensorboard")


@dataclass
class AlgoConfig:
    """The learning objective: the paper's A2C (TorchRL's ``A2CLoss`` with a value
    estimator, Adam), optionally plus *distillation* of EM's one-step utility.

    Distillation is not A2C: with ``distill_target=expected_reward`` it maximises the
    policy's expected Algorithm 1 reward over every frontier node, using EM's scores of
    the actions not taken (a full-information, one-step objective; the policy gradient
    only when gamma = 0); ``em_choice`` is the cross-entropy towards EM's pick;
    ``em_choice_stakes`` weights that cross-entropy by each decision's stakes (EM's best
    reward minus the mean over the frontiers: the decisions where the choice matters). DAgger
    replay (``dagger_steps``) adds supervised steps of the distillation loss on decisions
    kept from the policy's own states. ``distill_coef=0`` is the paper's plain A2C;
    ``a2c_coef=0`` is distillation alone.
    """

    lr: float = 1e-4
    gamma: float = 0.99
    estimator: str = "gae"  # gae | td_lambda | td0 (TorchRL value estimators)
    lmbda: float = 0.95  # GAE / TD(lambda)
    a2c_coef: float = 1.0  # weight of the A2C terms (policy, critic, entropy); 0 = distillation alone
    value_coef: float = 0.5  # beta: weight of the critic loss
    entropy_coef: float = 0.01  # eta: weight of the entropy bonus
    distill_coef: float = 0.0  # weight of the distillation term on the collected decisions
    distill_target: str = "expected_reward"  # expected_reward | em_choice | em_choice_stakes
    # DAgger: supervised distillation steps per update on decisions replayed from a buffer of
    # the last ``dagger_buffer`` EM-labelled ones (explore_rl/trainer/imitation.py; 0 = none)
    dagger_steps: int = 0
    dagger_batch: int = 16  # decisions per replayed minibatch
    dagger_buffer: int = 3000  # labelled decisions kept (saved in checkpoints/last.pt)
    max_grad_norm: float = 1.0  # gradient clipping (L2 norm over all parameters)
    steps_per_update: int = 10  # decisions per worker between updates (paper: 10)
    # the old names, kept only to say the new ones (explore_rl/config.py:validate)
    imitation_coef: Optional[float] = None
    imitation_target: Optional[str] = None
    imitation_replay_steps: Optional[int] = None
    imitation_batch: Optional[int] = None
    imitation_buffer: Optional[int] = None


@dataclass
class CollectorConfig:
    """Where decisions are collected: ``workers`` env processes, locally or on Ray, and
    whether each update waits for every worker (``sync``) or takes each worker's batch as
    it arrives (``async``, local only; explore_rl/trainer/async_collector.py)."""

    workers: int = 1  # sync: 1 = TorchRL Collector in this process, >1 = MultiSyncCollector; async: spawned workers
    backend: str = "local"  # local | ray (TorchRL's RayCollector, `pip install explore_rl[ray]`)
    ray_address: Optional[str] = None  # "HEAD_IP:6379" on a cluster node, "ray://HEAD_IP:10001" from outside; None: local Ray
    # sync: an update on every worker's batch at once, acted by the current weights (policy lag 0);
    # async: an update on each worker's batch as it arrives (TorchRL's MultiAsyncCollector)
    kind: str = "sync"
    # async: the most updates between the weights that took a batch's oldest decision and the
    # update on it; None = workers + 1. At least ``workers`` (each other worker's batch and the
    # worker's own previous one may land in between)
    max_policy_lag: Optional[int] = None

    def policy_lag(self) -> int:
        """The async collector's bound on the policy lag (see ``max_policy_lag``)."""
        return self.workers + 1 if self.max_policy_lag is None else self.max_policy_lag

    def validate(self) -> None:
        """One-line ValueError naming the key for a bad backend, kind or lag bound."""
        if self.backend not in BACKENDS:
            raise ValueError(f"collector.backend={self.backend!r}: choose one of {', '.join(BACKENDS)}")
        if self.kind not in COLLECTOR_KINDS:
            raise ValueError(f"collector.kind={self.kind!r}: choose one of {', '.join(COLLECTOR_KINDS)}")
        if self.kind == "async" and self.backend != "local":
            raise ValueError(f"collector.kind=async runs local workers only: use collector.backend=local "
                             f"or collector.kind=sync with collector.backend={self.backend}")
        if self.kind == "async" and self.policy_lag() < self.workers:
            raise ValueError(f"collector.max_policy_lag={self.max_policy_lag}: async collection with "
                             f"{self.workers} workers needs >= {self.workers} (or null = workers + 1)")


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
    # where the actor-critic and its update run: auto (CUDA if present) | cpu | cuda[:k];
    # the collectors' env workers always act on CPU with CPU copies of the weights
    device: str = "auto"
    # wall-clock budget in minutes (resumed runs count their earlier time); 0 = none. The run
    # stops after the update that crosses it (equal-wall-clock comparisons)
    max_minutes: float = 0.0
    progress_bar: bool = True
    # folder of an on-disk dataset of EM-labelled decisions (explore_rl/trainer/dataset.py): the
    # run appends its labelled decisions there and DAgger replays from all of it; None = in memory
    dataset: Optional[str] = None
    dataset_capacity: int = 200_000  # decisions a new dataset holds (sparse memory-mapped files)
    dataset_max_edges: int = 2048  # edges per stored decision (a larger graph is skipped and logged)
    # actor file (or training checkpoint) whose actor weights start a new run, e.g. an
    # offline-distilled actor fine-tuned with A2C; None = random initial weights. A resumed
    # run takes its weights from its own checkpoint instead
    init_actor: Optional[str] = None

    def validate(self) -> None:
        """One-line ValueError naming the key for a bad dataset or initial-actor setting."""
        if self.init_actor is not None and not Path(self.init_actor).is_file():
            raise ValueError(f"train.init_actor={self.init_actor}: no such file (give an actor file from "
                             "explore-rl-export or an offline run, or null for random initial weights)")
        if self.dataset_capacity < 1 or self.dataset_max_edges < 1:
            raise ValueError(f"train.dataset_capacity and train.dataset_max_edges must be >= 1, got "
                             f"{self.dataset_capacity}, {self.dataset_max_edges}")
        if self.dataset is not None:
            if not str(self.dataset).strip():
                raise ValueError("train.dataset is empty: give a folder (new or an existing dataset) or null")
            check_dataset_path(self.dataset)


DATASET_SCHEMA_FILE = "dataset.json"  # what makes a folder a dataset (explore_rl/trainer/dataset.py)


def check_dataset_path(path: str | Path) -> Path:
    """``path`` can hold a dataset: absent, an empty folder, or a dataset folder; ValueError
    in one line otherwise."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"train.dataset={path}: is a file, not a dataset folder (give a new or dataset folder)")
    if path.is_dir() and any(path.iterdir()) and not (path / DATASET_SCHEMA_FILE).is_file():
        raise ValueError(f"train.dataset={path}: a non-empty folder with no {DATASET_SCHEMA_FILE} is no dataset "
                         "(give a new folder or an existing dataset)")
    if not path.exists() and path.parent.exists() and not path.parent.is_dir():
        raise ValueError(f"train.dataset={path}: {path.parent} is a file, not a folder")
    return path
