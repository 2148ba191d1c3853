"""A2C on exploration graphs (paper Sec. III-B) with TorchRL collectors, losses and loggers.

One iteration: every worker takes ``algo.steps_per_update`` decisions with the current
policy (TorchRL ``Collector`` / ``MultiSyncCollector`` / ``RayCollector``; with
``collector.kind=async``, one worker's batch as it arrives: explore_rl/trainer/async_collector.py),
the batch ``[workers, T]`` (async: ``[1, T]``) gets its advantages from a TorchRL value
estimator (GAE by default, per worker so trajectories never join), ``A2CLoss`` (weight
``algo.a2c_coef``) plus an optional *distillation* term (``algo.distill_coef``: EM's
evaluation of every frontier of the same decisions; not A2C) gives one Adam step, optionally followed by
``algo.dagger_steps`` distillation steps on EM-labelled decisions replayed from a buffer
(DAgger, explore_rl/trainer/imitation.py), and the collectors receive the new weights.

What is TorchRL's: collectors, ``ProbabilisticActor``/``MaskedCategorical``/``ValueOperator``
(explore_rl/models), ``A2CLoss`` and its value estimators, ``CSVLogger``/``TensorboardLogger``.
What is written here, and why: the loop itself (``torchrl.trainers.A2CTrainer`` is a
prototype that warns on construction, and its checkpoints restore neither the
environments' mid-episode state nor the RNG, which an exact resume needs); the NaN guard
(skip an update, count it); the distillation term and its replay; per-episode exploration
figures.

Exact resume: a checkpoint holds the weights, the optimiser, the torch RNG, the counters
and, per worker, the current episode's index and the actions taken in it (``last.pt`` also
holds the DAgger buffer). Resuming
rebuilds each worker's env from a factory that replays that episode (every part of it is
seeded), so with one worker the next update equals the uninterrupted run's.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import torch
from tensordict import TensorDictBase
from tensordict.nn import set_skip_existing
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.envs.utils import ExplorationType
from torchrl.objectives import A2CLoss, ValueEstimators

from explore_rl.config import Config
from explore_rl.envs.factory import EnvFactory, make_env, policy_seed
from explore_rl.envs.keys import ACTION_REWARDS, EM_ACTION, WORKER
from explore_rl.graph.features import feature_names
from explore_rl.models.actor_critic import (FEATURE_SCALE, OBSERVATION_KEYS, make_actor, make_critic,
                                            selected_inputs)
from explore_rl.models.actor_file import TRAINING_PREFIX, build_actor, read_actor_file
from explore_rl.models.checkpoint import (Checkpoint, CheckpointError, check_weights, load_checkpoint,
                                           save_checkpoint)
from explore_rl.trainer.async_collector import LagBoundedAsyncCollector
from explore_rl.trainer.episodes import EpisodeTracker
from explore_rl.trainer.imitation import DatasetLabels, compact_decisions, make_labels
from explore_rl.trainer.logs import RunLogger

log = logging.getLogger(__name__)

ESTIMATOR_TYPES = {"gae": ValueEstimators.GAE, "td_lambda": ValueEstimators.TDLambda,
                   "td0": ValueEstimators.TD0}
STAKES_FLOOR = 1e-6  # em_choice_stakes: a minibatch whose decisions all have ~0 stakes teaches nothing
BEST_WINDOW = 20  # finished episodes averaged for the "best" checkpoint
MAX_COLLECTOR_RESTARTS = 5  # per run: more means something is broken, not unlucky


# ---------------------------------------------------------------------- the learner


def resolve_device(name: str) -> torch.device:
    """``train.device``: auto (CUDA if there is one, else CPU), cpu or cuda[:k]; a device
    that is not there is a one-line error before anything runs."""
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cpu":
        return torch.device("cpu")
    if name.startswith("cuda"):
        if not torch.cuda.is_available():
            raise ValueError(f"train.device={name}: no CUDA device here (torch.cuda.is_available() is False); "
                             "use train.device=cpu or auto")
        device = torch.device(name)
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise ValueError(f"train.device={name}: only {torch.cuda.device_count()} CUDA device(s) here")
        return device
    raise ValueError(f"train.device={name!r}: choose auto, cpu or cuda[:index]")


def cpu_state(module: torch.nn.Module) -> dict[str, torch.Tensor]:
    """``module``'s state dict on the CPU (checkpoints and collectors are device-free)."""
    return {key: value.detach().cpu() for key, value in module.state_dict().items()}


@dataclass
class UpdateStats:
    """Figures of one update (all floats, for the logger)."""

    loss_objective: float
    loss_critic: float
    loss_entropy: float
    loss_distill: float
    entropy: float
    grad_norm: float
    loss_replay: float | None = None  # mean distillation loss of the replayed minibatches


class Learner:
    """Actor, critic, ``A2CLoss`` with its value estimator, and Adam."""

    def __init__(self, config: Config, action_spec=None):
        algo = config.algo
        self.config = config
        n_features = len(feature_names(config.graph.features))
        self.device = resolve_device(config.train.device)
        self.actor = make_actor(config.model, n_features, action_spec).to(self.device)
        self.critic = make_critic(config.model, n_features).to(self.device)
        # what the collectors act with: the actor itself on a CPU learner, else a CPU copy
        # that receives the learner's weights after every step (collectors stay on CPU)
        self.acting_actor = self.actor if self.device.type == "cpu" else copy.deepcopy(self.actor).cpu()
        self.loss = A2CLoss(self.actor, self.critic, entropy_coeff=algo.entropy_coef,
                            critic_coeff=algo.value_coef, loss_critic_type="smooth_l1")
        # the g-U-Net trims padding with a data-dependent size, which torch.vmap cannot trace
        hyper = {"gamma": algo.gamma, "deactivate_vmap": True}
        if algo.estimator in ("gae", "td_lambda"):
            hyper["lmbda"] = algo.lmbda
        self.loss.make_value_estimator(ESTIMATOR_TYPES[algo.estimator], **hyper)
        self.optimizer = torch.optim.Adam(self.loss.parameters(), lr=algo.lr)
        self.labels = make_labels(config)  # in memory, or the dataset at train.dataset
        self.skipped_updates = 0
        self.set_training(False)

    def load_initial_actor(self, path: str | Path) -> None:
        """Start from the actor of an actor file or checkpoint (``train.init_actor``), e.g.
        an offline-distilled one that A2C then fine-tunes; the critic starts fresh. The
        file must be of this run's model and read this run's node features or the first of
        them (e.g. an ``extended`` actor in a ``loops`` run: the new columns start with weight
        0, so it decides as before until it trains); else a one-line error."""
        actor_file = read_actor_file(path)
        wanted = list(feature_names(self.config.graph.features))
        if actor_file.features != wanted[:len(actor_file.features)]:
            raise CheckpointError(f"train.init_actor={path}: the actor reads graph.features="
                                  f"{actor_file.feature_set}, this run {self.config.graph.features}: "
                                  f"set graph.features={actor_file.feature_set}")
        weights = build_actor(path, actor_file, self.config.model).state_dict()  # model and weights checked
        if len(wanted) > len(actor_file.features):
            weights = selected_inputs(weights, actor_file.features, wanted,
                                      self.actor.state_dict()[TRAINING_PREFIX + FEATURE_SCALE])
            log.info("%s reads graph.features=%s: widened to %s with zero weights on %s", path,
                     actor_file.feature_set, self.config.graph.features, ", ".join(wanted[len(actor_file.features):]))
        self.actor.load_state_dict({TRAINING_PREFIX + key: value for key, value in weights.items()})
        self.sync_acting_actor()
        log.info("initial actor weights from %s", path)

    def set_training(self, on: bool) -> None:
        """Dropout on (supervised replay steps) or off (acting, evaluation, the A2C update)."""
        self.actor.train(on)
        self.critic.train(on)

    def update(self, batch: TensorDictBase) -> UpdateStats | None:
        """One step on ``batch`` ``[workers, T]``: ``a2c_coef`` x the A2C terms plus
        ``distill_coef`` x distillation on the same decisions; None (and a warning) if the
        loss or the gradient is not finite: that update is skipped and counted.

        The A2C terms are computed with the network in the mode it acted in (dropout
        off): with dropout on, the policy being differentiated would not be the one that
        sampled the actions. Dropout regularises only the replayed distillation steps."""
        algo = self.config.algo
        self.set_training(False)
        batch = batch.to(self.device)
        batch = self.value_targets(batch)
        losses = self.loss(batch)
        total = algo.a2c_coef * sum(value for key, value in losses.items() if key.startswith("loss_"))
        distill = self.distill_loss(batch)
        total = total + algo.distill_coef * distill
        grad_norm, why_not = self.gradient_step(total)
        if grad_norm is None:
            return self.skip(why_not)
        zero = torch.zeros(())  # A2CLoss leaves out the entropy terms when entropy_coef is 0
        return UpdateStats(
            loss_objective=losses["loss_objective"].item(), loss_critic=losses["loss_critic"].item(),
            loss_entropy=losses.get("loss_entropy", zero).item(), loss_distill=distill.item(),
            entropy=losses.get("entropy", zero).item(), grad_norm=grad_norm.item(),
            loss_replay=self.replay(batch))

    def value_targets(self, batch: TensorDictBase) -> TensorDictBase:
        """``batch`` ``[workers, T]`` with the estimator's advantage and value target, the
        critic run once per distinct observation (:func:`write_state_values`), not on all
        ``2 T`` of each row as the estimator would. The estimator gets the batch without its
        observations (it would stack both halves' dense adjacencies to hand the critic,
        which finds the values written and skips)."""
        observations = [*OBSERVATION_KEYS, *(("next", key) for key in OBSERVATION_KEYS)]
        with torch.no_grad():
            write_state_values(self.critic, batch)
            with set_skip_existing(True):
                estimated = self.loss.value_estimator(batch.exclude(*observations))
        return batch.update(estimated)

    def value_targets_reference(self, batch: TensorDictBase) -> TensorDictBase:
        """The same as :meth:`value_targets` by TorchRL's estimator alone, which calls the
        critic on both halves of the batch (roots and next observations): the reference of
        the test and of ``benchmarks/bench_update.py``."""
        with torch.no_grad():
            return self.loss.value_estimator(batch)

    def gradient_step(self, loss: torch.Tensor) -> tuple[torch.Tensor | None, str]:
        """Backward, clipping and one Adam step on ``loss``: ``(grad_norm, "")``; or, if the
        loss or the gradient is not finite, no step and ``(None, why)`` (the NaN guard)."""
        if not torch.isfinite(loss):
            return None, f"loss is {loss.item()}"
        self.optimizer.zero_grad()
        loss.backward()
        grad_norm = torch.nn.utils.clip_grad_norm_(self.loss.parameters(), self.config.algo.max_grad_norm)
        if not torch.isfinite(grad_norm):
            self.optimizer.zero_grad()
            return None, f"gradient norm is {grad_norm.item()}"
        self.optimizer.step()
        self.sync_acting_actor()
        return grad_norm, ""

    def sync_acting_actor(self) -> None:
        """The collectors' CPU copy takes the learner's weights (nothing to do on a CPU learner)."""
        if self.acting_actor is not self.actor:
            self.acting_actor.load_state_dict(cpu_state(self.actor))

    def replay(self, batch: TensorDictBase) -> float | None:
        """DAgger: keep ``batch``'s EM-labelled decisions (states the policy visited), then
        take ``algo.dagger_steps`` Adam steps on the distillation loss of minibatches drawn
        from all kept ones. Returns the mean loss (None when replay is off); a non-finite
        step is skipped."""
        algo = self.config.algo
        on_disk = isinstance(self.labels, DatasetLabels)  # train.dataset: keep every labelled decision
        if algo.dagger_steps == 0 and not on_disk:
            return None
        decisions = compact_decisions(batch)
        if decisions:
            self.labels.extend(decisions)
        if algo.dagger_steps == 0 or len(self.labels) == 0:
            return None
        losses = []
        self.set_training(True)
        try:
            for _ in range(algo.dagger_steps):
                loss = algo.distill_coef * self.distill_loss(self.labels.sample().to(self.device))
                grad_norm, why_not = self.gradient_step(loss)
                if grad_norm is None:
                    log.warning("a replayed distillation step was skipped (%s)", why_not)
                    continue
                losses.append(loss.item())
        finally:
            self.set_training(False)
        return sum(losses) / len(losses) if losses else None

    def distill_loss(self, batch: TensorDictBase) -> torch.Tensor:
        """Distillation of EM's evaluation on the decisions EM evaluated (0 if none, or if
        ``algo.distill_coef`` is 0: then the actor is not run twice). Not A2C.

        ``algo.distill_target``: ``expected_reward`` is minus the policy's expected
        Algorithm 1 reward over *every* frontier node (the env evaluates them all): a
        one-step, full-information objective with no sampling noise and no credit for
        EM's exact tie-breaks; ``em_choice`` is the cross-entropy towards EM's choice;
        ``em_choice_stakes`` is that cross-entropy with each decision weighted by its stakes
        (:func:`decision_stakes`), so that the decisions where EM's pick is worth much more
        than a typical frontier count most."""
        labels = batch[EM_ACTION]
        known = labels >= 0
        if self.config.algo.distill_coef == 0 or not known.any():
            return torch.zeros(())
        dist = self.actor.get_dist(batch)
        target = self.config.algo.distill_target
        if target == "expected_reward":
            expected = (dist.probs * batch[ACTION_REWARDS]).sum(-1)
            return -expected[known].mean()
        log_prob = dist.log_prob(labels.clamp_min(0))[known]
        if target == "em_choice_stakes":
            weights = decision_stakes(batch[ACTION_REWARDS], batch["action_mask"])[known]
            return -(weights * log_prob).sum() / weights.sum().clamp_min(STAKES_FLOOR)
        return -log_prob.mean()

    def skip(self, reason: str) -> None:
        self.skipped_updates += 1
        log.warning("update skipped (%s); %d skipped so far", reason, self.skipped_updates)
        return None


def decision_stakes(rewards: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Per decision, EM's best reward minus the mean reward of its frontier rows
    (``rewards``, ``mask``: ``(..., N)``): what picking a typical frontier instead of EM's
    would lose. 0 for a decision with one frontier (nothing to choose)."""
    count = mask.sum(-1).clamp_min(1)
    mean = (rewards * mask).sum(-1) / count
    best = rewards.masked_fill(~mask, -torch.inf).amax(-1)
    return torch.where(mask.any(-1), best - mean, torch.zeros_like(mean))


# ---------------------------------------------------------------------- collectors


def make_collector(config: Config, actor, replays: list | None = None, start_frame: int = 0):
    """The TorchRL collector of ``collector.workers`` env workers (see the module docstring)
    over :func:`env_factories` (``replays``, ``start_frame``: see there)."""
    factories = env_factories(config, replays, start_frame)
    steps = config.algo.steps_per_update
    if config.collector.backend == "ray":
        from explore_rl.trainer.ray_backend import make_ray_collector  # ray is an optional extra

        return make_ray_collector(factories, actor, config.collector, **collector_kwargs(len(factories) * steps))
    if config.collector.kind == "async":  # each worker's batch of `steps` decisions as it arrives
        return LagBoundedAsyncCollector(factories, actor, max_policy_lag=config.collector.policy_lag(),
                                        auto_register_policy_transforms=False, **collector_kwargs(steps))
    if len(factories) == 1:
        return local_collector(factories[0], actor, steps)
    return MultiSyncCollector(factories, actor, cat_results="stack", auto_register_policy_transforms=False,
                              **collector_kwargs(len(factories) * steps))


def env_factories(config: Config, replays: list | None = None, start_frame: int = 0) -> list[EnvFactory]:
    """One env factory per worker of ``collector.workers``.

    ``replays[i]``: the episode worker ``i`` resumes (``EnvFactory.replay``), or None.
    Workers in other processes (``workers > 1``, async, Ray) seed their action sampling from
    ``(seed, worker, start_frame)`` (:func:`policy_seed`), so a multi-worker run is
    reproducible; one local worker samples with this process's RNG (checkpointed, which
    makes its resume exact). TorchRL's ``set_seed`` of the multi collectors is not used:
    it re-seeds and resets every env, which would undo the per-worker env seeds and the
    replayed episodes.
    """
    workers = config.collector.workers
    replays = replays or [None] * workers
    own_processes = workers > 1 or config.collector.backend == "ray" or config.collector.kind == "async"
    return [EnvFactory(config, worker=i, replay=replays[i],
                       torch_seed=policy_seed(config.seed, i, start_frame) if own_processes else None)
            for i in range(workers)]


def collector_kwargs(frames_per_batch: int) -> dict:
    """What every collector of the trainer shares: sampled actions, no frame budget of its own."""
    return dict(frames_per_batch=frames_per_batch, total_frames=-1, exploration_type=ExplorationType.RANDOM)


def local_collector(factory: EnvFactory, actor, steps: int) -> Collector:
    """TorchRL's ``Collector`` of one env in this process, ``steps`` decisions per batch."""
    return Collector(factory, actor, auto_register_policy_transforms=False,  # our env needs none
                     **collector_kwargs(steps))


def same_observation(first: TensorDictBase, second: TensorDictBase) -> torch.Tensor:
    """``[..]`` True where the two hold the same observation (every key the critic reads)."""
    same = torch.ones(first.shape, dtype=torch.bool, device=first.device)
    for key in OBSERVATION_KEYS:
        a, b = first[key], second[key]
        same &= (a == b).reshape(*first.shape, -1).all(-1)
    return same


def write_state_values(critic, batch: TensorDictBase) -> None:
    """The critic's ``state_value`` of every root and next observation of ``batch``
    ``[workers, T]``. Within a row, the next observation of step ``t`` is the root one of
    ``t + 1`` unless the episode ended at ``t`` (a collector's reset): where the two are
    the same (checked key by key, exactly) the root value is reused, and only the others
    (row ends, resets) go through the critic. The values equal a critic call on the whole
    next half up to the last bits of a differently sized batch (the test's tolerance)."""
    root_values = critic(batch.select(*OBSERVATION_KEYS))["state_value"]
    next_obs = batch["next"]
    shifted = torch.zeros(batch.shape, dtype=torch.bool, device=batch.device)
    shifted[:, :-1] = same_observation(next_obs[:, :-1], batch[:, 1:])
    next_values = torch.zeros_like(root_values)
    next_values[:, :-1] = root_values[:, 1:]
    fresh = ~shifted
    if fresh.any():
        next_values[fresh] = critic(next_obs[fresh].select(*OBSERVATION_KEYS))["state_value"]
    batch["state_value"] = root_values
    batch["next", "state_value"] = next_values


def as_workers_by_time(batch: TensorDictBase, workers: int) -> TensorDictBase:
    """``[rows, T]``, one worker's decisions per row, whatever the collector returned:
    ``[workers, T]``, ``[T]`` of one worker, ``[workers * T]``, or an async batch ``[T]``
    of the worker named in it (``WORKER``) as ``[1, T]``."""
    if batch.ndim == 2:
        return batch
    if WORKER in batch.keys(include_nested=True):
        return batch.unsqueeze(0)
    return batch.reshape(workers, -1)


class CollectionError(RuntimeError):
    """The collector (a worker, its env outside a step, the weight sync) failed."""


def collect(batches, sync_weights=None) -> TensorDictBase:
    """The next batch, after sending the learner's weights (``sync_weights``); any failure
    there is a :class:`CollectionError`."""
    try:
        if sync_weights is not None:
            sync_weights()
        return next(batches)
    except Exception as error:  # noqa: BLE001 -- whatever a worker raised, it is the collection's
        raise CollectionError(f"collection failed: {type(error).__name__}: {error}") from error


# ---------------------------------------------------------------------- the run


@dataclass
class RunState:
    """Counters of a training run (saved in every checkpoint)."""

    updates: int = 0
    frames: int = 0
    skipped_updates: int = 0
    wall_s: float = 0.0
    best_reward: float = -math.inf
    episodes: dict = field(default_factory=dict)  # EpisodeTracker.state_dict()


class TrainingRun:
    """One run folder: ``config.yaml``, ``checkpoints/``, ``logs/`` (see :func:`train`)."""

    def __init__(self, config: Config, run_dir: Path):
        self.config = config
        self.dir = Path(run_dir)
        self.checkpoints = self.dir / "checkpoints"
        torch.set_num_threads(config.train.threads)
        torch.manual_seed(config.seed)  # initial weights; a resumed run restores the RNG later
        probe = make_env(config)  # specs only; builds no scene
        self.learner = Learner(config, probe.action_spec)
        self.state = RunState()
        self.episodes = EpisodeTracker(config.collector.workers)
        self.torch_rng: torch.Tensor | None = None
        self.failed_collections = 0
        if config.resume:
            self.restore()
        elif config.train.init_actor:
            self.learner.load_initial_actor(config.train.init_actor)
        self.logger = RunLogger(self.dir / "logs", config.logger.kind, resume_at=self.state.frames,
                                progress_total=config.train.frames if config.train.progress_bar else None,
                                progress_start=self.state.frames)

    def restore(self) -> None:
        path = self.checkpoints / "last.pt"
        checkpoint = load_checkpoint(path, self.config)
        check_weights(path, "actor", checkpoint.actor, self.learner.actor)
        check_weights(path, "critic", checkpoint.critic, self.learner.critic)
        self.learner.actor.load_state_dict(checkpoint.actor)
        self.learner.sync_acting_actor()
        self.learner.critic.load_state_dict(checkpoint.critic)
        self.learner.optimizer.load_state_dict(checkpoint.optimizer)
        if checkpoint.label_buffer is not None:
            self.learner.labels.load_state_dict(checkpoint.label_buffer)
        self.state = RunState(**checkpoint.state)
        self.learner.skipped_updates = self.state.skipped_updates
        self.episodes.load_state_dict(self.state.episodes)
        self.torch_rng = checkpoint.torch_rng
        log.info("resuming %s at update %d (%d decisions)", path, self.state.updates, self.state.frames)

    def run(self) -> RunState:
        """Collect and update until ``train.frames`` decisions; checkpoint on the way.

        A collector that raises (a worker died: an env error outside a step, e.g. at a
        reset) is rebuilt with fresh episodes, up to ``MAX_COLLECTOR_RESTARTS`` times.
        """
        if self.finished():
            log.info("nothing to do: %d of %d decisions, %.1f min already", self.state.frames,
                     self.config.train.frames, self.state.wall_s / 60)
            return self.state
        collector = make_collector(self.config, self.learner.acting_actor, self.episodes.replays(),
                                   self.state.frames)
        collector.update_policy_weights_()  # remote (Ray) collectors wait for a first sync
        if self.torch_rng is not None:
            torch.set_rng_state(self.torch_rng)  # after building the collector, before acting
        start, restarts = time.perf_counter() - self.state.wall_s, 0
        try:
            while not self.finished():
                try:
                    self.collect_and_update(collector, start)
                except CollectionError:  # a worker died: the run goes on with new workers
                    restarts += 1
                    if restarts > MAX_COLLECTOR_RESTARTS:
                        raise
                    log.exception("collector failed; restarting it with fresh episodes (%d/%d)",
                                  restarts, MAX_COLLECTOR_RESTARTS)
                    self.failed_collections += 1
                    collector.shutdown()
                    collector = make_collector(self.config, self.learner.acting_actor,
                                               self.episodes.abandon_running(), self.state.frames)
                    collector.update_policy_weights_()
            self.save("last")
        finally:
            collector.shutdown()
            self.logger.close()
        return self.state

    def finished(self) -> bool:
        """``train.frames`` decisions collected, or ``train.max_minutes`` used."""
        budget = self.config.train.max_minutes
        out_of_time = budget > 0 and self.state.wall_s >= 60 * budget
        return self.state.frames >= self.config.train.frames or out_of_time

    def collect_and_update(self, collector, start: float) -> None:
        """Batches from ``collector`` and an update on each. Only a failure of the
        collection is a :class:`CollectionError`; a learner or checkpoint error is a bug
        and ends the run."""
        batches, synced = iter(collector), True  # run() synced before the first batch
        while not self.finished():
            batch = collect(batches, None if synced else collector.update_policy_weights_)
            self.iteration(as_workers_by_time(batch, self.config.collector.workers), start)
            synced = False

    def iteration(self, batch: TensorDictBase, start: float) -> None:
        """One update on a collected batch, then logs and checkpoints."""
        update_start = time.perf_counter()
        stats = self.learner.update(batch)
        ms_update = 1e3 * (time.perf_counter() - update_start)
        finished = self.episodes.add(batch)
        state = self.state
        state.frames += batch.numel()
        state.updates += stats is not None
        state.skipped_updates = self.learner.skipped_updates
        state.wall_s = time.perf_counter() - start
        self.logger.update(state.frames, batch, stats, finished, ms_update, state)
        recent = self.episodes.recent_mean_reward(BEST_WINDOW)
        if recent is not None and recent > state.best_reward and len(self.episodes.finished) >= BEST_WINDOW:
            state.best_reward = recent
            self.save("best")
        if stats is not None and state.updates % self.config.train.checkpoint_every == 0:
            self.save("last")
        snapshot = self.config.train.snapshot_every
        if stats is not None and snapshot and state.updates % snapshot == 0:
            self.save(f"update_{state.updates:05d}")

    def save(self, name: str) -> Path:
        self.state.episodes = self.episodes.state_dict()
        return save_checkpoint(self.checkpoints / f"{name}.pt", Checkpoint(
            config=self.config, actor=cpu_state(self.learner.actor), critic=cpu_state(self.learner.critic),
            optimizer=self.learner.optimizer.state_dict(), state=dataclasses.asdict(self.state),
            torch_rng=torch.get_rng_state(),
            # the replay buffer only where a resume reads it: snapshots stay small
            label_buffer=self.learner.labels.state_dict() if name == "last" else None))


def train(config: Config, run_dir: str | Path) -> RunState:
    """Train (or, with ``config.resume``, continue) the run in ``run_dir``."""
    return TrainingRun(config, Path(run_dir)).run()
