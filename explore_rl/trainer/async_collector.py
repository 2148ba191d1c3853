"""``collector.kind=async``: TorchRL's ``MultiAsyncCollector`` with a bounded policy lag.

Why: with the synchronous collector every update waits for the slower worker's batch, and
on this work (per-batch times of one worker vary 3-10 s) that caps two workers at ~1.7x
one (benchmarks/RESULTS.md, Collection). Here each worker's batch of ``T`` decisions goes
to the learner as it arrives and the worker goes on at once with the weights it has.

What TorchRL gives: the spawned workers, their queue, the shared-memory weights (each
``update_policy_weights_`` writes the learner's weights into the workers' policies in
place, so a worker acts with the newest weights from its next decision on). What it does
not give, and this module adds:

* **Which worker a batch came from.** TorchRL 0.14's queue carries the worker index but
  its async batches do not; :class:`LagBoundedAsyncCollector` writes it into the batch
  (``WORKER``, explore_rl/envs/keys.py), which the episode bookkeeping and the resume need.
* **A bound on the policy lag.** Without it a fast worker's batches could be taken many
  times in a row while a slow worker acts with ever older weights. :class:`PolicyLagGate`
  holds a finished batch back (its worker waits) when taking it would let another worker's
  batch exceed ``max_lag`` updates (written into the batch as ``POLICY_LAG``).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import torch
from tensordict import TensorDictBase
from torchrl.collectors import MultiAsyncCollector

from explore_rl.envs.keys import POLICY_LAG, WORKER


class PolicyLagGate:
    """Which finished worker batch the learner may take next, so that no batch's policy lag
    exceeds ``max_lag`` updates.

    Versions count the batches handed out: the learner updates on each batch and sends
    its weights before asking for the next, so when the ``h``-th batch is handed out the
    workers act with version ``h``, and the worker whose batch it was starts its next batch
    with it (``start``). That next batch, handed out as the ``m``-th, was acted by versions
    ``>= start``: its lag is at most ``m - start`` updates.

    A batch is handed out only if, afterwards, every worker could still be handed out in
    time, oldest start first. Handing out the oldest worker's batch always keeps that true
    when ``max_lag >= workers`` (the others follow one per version, the oldest ``workers``
    versions later), so the gate never blocks a worker that every other worker waits for:
    when all are held, the oldest goes. With two workers and ``max_lag = 2`` it alternates
    strictly; 3 lets a worker be one batch ahead.
    """

    def __init__(self, workers: int, max_lag: int):
        if max_lag < workers:
            raise ValueError(f"collector.max_policy_lag={max_lag}: {workers} workers need >= {workers}")
        self.max_lag = max_lag
        self.start = [0] * workers  # the version each worker's current batch started with
        self.handed = 0  # batches handed out = the version the workers act with now
        self.held: dict[int, Any] = {}  # finished batches by worker, in arrival order

    def hold(self, worker: int, item: Any) -> None:
        """Worker ``worker`` finished a batch (it waits until the batch is handed out)."""
        self.held[worker] = item

    def release(self) -> tuple[int, Any, int] | None:
        """The first held batch (in arrival order) that can go now: ``(worker, item, lag)``;
        None if every held batch must wait for another worker's."""
        for worker in self.held:
            if self.in_time_after(worker):
                lag = self.handed - self.start[worker]
                self.start[worker] = self.handed
                self.handed += 1
                return worker, self.held.pop(worker), lag
        return None

    def in_time_after(self, worker: int) -> bool:
        """After handing out ``worker``'s batch now, can every worker's next batch still be
        handed out within the bound, one per version, oldest start first?"""
        starts = sorted(start for w, start in enumerate(self.start) if w != worker) + [self.handed]
        return all(self.handed + 1 + k - start <= self.max_lag for k, start in enumerate(starts))


def gated_schedule(durations: list[list[float]], max_lag: int, update_s: float = 0.0
                   ) -> Iterator[tuple[int, int, float]]:
    """The gate at work on workers whose ``k``-th batches take ``durations[w][k]`` seconds
    (cycling through the list): ``(worker, lag, time)`` of each batch handed out, in order.
    A worker starts its next batch when its last one is handed out; the learner then
    updates for ``update_s`` seconds, handing nothing out meanwhile. What bench_collect
    bounds the async speed-up with, and what the gate's tests run."""
    workers, gate = len(durations), PolicyLagGate(len(durations), max_lag)
    done_at, taken, clock = [d[0] for d in durations], [0] * workers, 0.0
    while True:
        released = gate.release()
        if released is None:  # wait for the next worker to finish a batch
            collecting = [w for w in range(workers) if w not in gate.held]
            if not collecting:
                raise RuntimeError("the policy-lag gate holds every worker")  # PolicyLagGate says why not
            worker = min(collecting, key=done_at.__getitem__)
            clock = max(clock, done_at[worker])
            gate.hold(worker, None)
            continue
        worker, _, lag = released
        yield worker, lag, clock
        taken[worker] += 1
        done_at[worker] = clock + durations[worker][taken[worker] % len(durations[worker])]
        clock += update_s


class LagBoundedAsyncCollector(MultiAsyncCollector):
    """TorchRL's ``MultiAsyncCollector`` whose batches say their worker and policy lag, and
    whose order of batches keeps the lag within ``max_policy_lag`` (:class:`PolicyLagGate`).

    TorchRL's iterator tells a worker to go on when it takes that worker's batch from the
    queue (``_get_from_queue``); taking them through the gate is what holds a worker back.
    """

    def __init__(self, create_env_fn: list, policy, *, max_policy_lag: int, **kwargs):
        self.gate = PolicyLagGate(len(create_env_fn), max_policy_lag)
        super().__init__(create_env_fn, policy, **kwargs)

    def _get_from_queue(self, timeout: float | None = None) -> tuple[int, int, TensorDictBase]:
        """The next batch the gate lets through, tagged with its worker and lag; finished
        batches that must wait are held (TorchRL's queue raises ``Empty`` on ``timeout``,
        which its iterator retries)."""
        while (released := self.gate.release()) is None:
            worker, j, batch = super()._get_from_queue(timeout=timeout)
            self.gate.hold(worker, (j, batch))
        worker, (j, batch), lag = released
        return worker, j, tag_batch(batch, worker, lag)


def tag_batch(batch: TensorDictBase, worker: int, lag: int) -> TensorDictBase:
    """``batch`` with ``WORKER`` and ``POLICY_LAG`` set for each of its decisions."""
    for key, value in ((WORKER, worker), (POLICY_LAG, lag)):
        batch.set(key, torch.full(batch.shape, value, dtype=torch.int64, device=batch.device))
    return batch
