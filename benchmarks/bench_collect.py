"""Decisions per second collected by the trainer's TorchRL collectors: 1 vs 2 workers.

The real environment (office, ``slam=model``) and the default actor sampling its
actions, as in training: ``collector.workers=1`` is TorchRL's ``Collector`` in this
process, ``collector.workers=2`` a ``MultiSyncCollector`` over two spawned workers. Each
is timed over the same number of batches after one warm-up batch (worker start-up and
the first reset excluded), and the learner's update on those batches is timed too, so
the split of a training iteration between collection and update is visible.

    python benchmarks/bench_collect.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

import torch  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.envs import make_env  # noqa: E402
from explore_rl.trainer.a2c import Learner, as_workers_by_time, make_collector  # noqa: E402


def measure(workers: int, batches: int, overrides: list[str]) -> dict:
    """Decisions/s of ``workers`` collectors over ``batches`` batches, and ms per update."""
    config = load_config(["scene=office", "slam=model", f"collector.workers={workers}", *overrides])
    torch.manual_seed(0)
    learner = Learner(config, make_env(config).action_spec)
    collector = make_collector(config, learner.actor)
    iterator = iter(collector)
    next(iterator)  # warm-up: worker start-up, first reset
    decisions, collect_s, update_s = 0, 0.0, 0.0
    for _ in range(batches):
        start = time.perf_counter()
        batch = as_workers_by_time(next(iterator), workers)
        collect_s += time.perf_counter() - start
        decisions += batch.numel()
        start = time.perf_counter()
        learner.update(batch)
        update_s += time.perf_counter() - start
        collector.update_policy_weights_()
    collector.shutdown()
    return {"workers": workers, "decisions": decisions, "collect_s": round(collect_s, 1),
            "decisions_per_s": round(decisions / collect_s, 3),
            "ms_update_per_batch": round(1e3 * update_s / batches, 1),
            "update_fraction": round(update_s / (update_s + collect_s), 3)}


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    batches = 1 if args.smoke else 3 if args.quick else 12
    overrides = ["algo.steps_per_update=2", "planning.actions.max_frontiers=2", "model.hidden=16",
                 "model.mlp_hidden=16"] if args.smoke else []
    one = measure(1, batches, overrides)
    two = measure(2, batches, overrides)
    for r in (one, two):
        print(f"{r['workers']} worker(s): {r['decisions']} decisions in {r['collect_s']} s = "
              f"{r['decisions_per_s']} /s; update {r['ms_update_per_batch']} ms per batch "
              f"({100 * r['update_fraction']:.0f} % of an iteration)")
    emit({"benchmark": "collect", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          "dps_1": one["decisions_per_s"], "dps_2": two["decisions_per_s"],
          "scaling": round(two["decisions_per_s"] / one["decisions_per_s"], 3),
          "one_worker": one, "two_workers": two})


if __name__ == "__main__":
    main()
