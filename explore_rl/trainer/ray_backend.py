"""``collector.backend=ray``: TorchRL's ``RayCollector`` over the same env factories.

Weights reach the Ray workers through TorchRL's ``RayWeightUpdater`` (the learner puts
the actor's weights in Ray's object store, each remote collector loads them before its
next batch). Not through TorchRL 0.14's default ``RayWeightSyncScheme``: its first
``update_policy_weights_()`` waits for a connection handshake with the remote collectors
that, with sync collection, never completes (the run hung at its first update).
``RayWeightUpdater`` needs the remote collectors, which exist only once ``RayCollector``
has built them; :class:`CollectorBoundRayWeightUpdater` takes them when the collector
registers it.
"""

from __future__ import annotations

import os

from torchrl.collectors.distributed import RayCollector
from torchrl.collectors.weight_update import RayWeightUpdater

from explore_rl.trainer.config import CollectorConfig

UNBOUNDED_FRAMES = 2**62  # the trainer stops collecting by its own budget (train.frames)


class CollectorBoundRayWeightUpdater(RayWeightUpdater):
    """TorchRL's ``RayWeightUpdater``, bound to the ``RayCollector`` that registers it."""

    def __init__(self):  # noqa: D107 -- the weights and workers come in register_collector
        pass

    def register_collector(self, collector: RayCollector) -> None:
        super().register_collector(collector)
        RayWeightUpdater.__init__(self, policy_weights=collector.policy_weights,
                                  remote_collectors=collector.remote_collectors)


def make_ray_collector(factories: list, actor, collector: CollectorConfig, **common) -> RayCollector:
    """A synchronous ``RayCollector`` with one remote collector per env factory, on the
    cluster at ``collector.ray_address`` or on a local Ray instance sized to this machine."""
    if common.get("total_frames", -1) < 0:
        common["total_frames"] = UNBOUNDED_FRAMES  # RayCollector reads -1 as "already done"
    ray_init = ({"address": collector.ray_address} if collector.ray_address
                else {"num_cpus": os.cpu_count()})
    return RayCollector(factories, actor, sync=True, ray_init_config=ray_init,
                        weight_updater=CollectorBoundRayWeightUpdater(), **common)
