"""The learner's A2C update on collected office batches: its value targets by TorchRL's
estimator alone (the reference: the critic on the roots and on every next observation of
the batch) against :meth:`Learner.value_targets` (the critic once per distinct
observation: a next observation equal to the following root takes that root's value).

The batches are the trainer's: two workers' ``algo.steps_per_update`` decisions each
(``env_factories``, TorchRL's ``Collector`` in this process, the default actor with fixed
weights), stacked ``[workers, T]`` as the learner gets them. Both sides start from the same
weights and take the same updates on the same batches, taking turns, one torch thread (the
learner beside the workers); each figure is each batch's fastest of the repeats, averaged over
the batches (their sizes differ, so the fastest single update would be the smallest batch's). ``same_targets``:
the two sides' advantages and value targets agree within ``TOLERANCE`` on every batch;
``same_losses``: so do the updates' losses (the weights stay equal to that tolerance).

    python benchmarks/bench_update.py [--quick | --smoke]
"""

from __future__ import annotations

import copy
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

import torch  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.envs import make_env  # noqa: E402
from explore_rl.trainer.a2c import Learner, env_factories, local_collector  # noqa: E402

TOLERANCE = 1e-5  # relative (and absolute, on values of order 1): far below any change of the estimator


class ReferenceLearner(Learner):
    """The learner with TorchRL's estimator calling the critic itself."""

    def value_targets(self, batch):
        return self.value_targets_reference(batch)


def collected_batches(config, policy, batches: int) -> list:
    """``batches`` learner batches ``[workers, T]``, each worker's after one warm-up batch."""
    per_worker = []
    for factory in env_factories(config):
        collector = local_collector(factory, policy, config.algo.steps_per_update)
        iterator = iter(collector)
        next(iterator)
        per_worker.append([next(iterator) for _ in range(batches)])
        collector.shutdown()
    return [torch.stack(rows) for rows in zip(*per_worker)]


def close(a: torch.Tensor, b: torch.Tensor) -> bool:
    return bool(torch.allclose(a, b, rtol=TOLERANCE, atol=TOLERANCE))


def timed_updates(learners: dict, data: list, repeats: int) -> tuple[dict, dict]:
    """Per side, ms of an update and of its value targets alone: each batch's fastest over the
    repeats (batches differ: graph sizes, resets), averaged over the batches; the sides take
    turns. And per side the losses of every update, in order."""
    update_ms, targets_ms, losses = ({name: [[] for _ in data] for name in learners} for _ in range(3))
    for _ in range(repeats):  # the updates alone, as the trainer takes them
        for name, learner in learners.items():
            for index, batch in enumerate(data):
                start = time.perf_counter()
                stats = learner.update(batch.clone())
                update_ms[name][index].append(1e3 * (time.perf_counter() - start))
                losses[name][index].append([stats.loss_objective, stats.loss_critic])
    for _ in range(repeats):  # then the value targets alone
        for name, learner in learners.items():
            for index, batch in enumerate(data):
                start = time.perf_counter()
                learner.value_targets(batch.clone())
                targets_ms[name][index].append(1e3 * (time.perf_counter() - start))
    per_update = {f"{kind}_ms{'' if name == 'fast' else '_reference'}":
                  round(sum(map(min, times[name])) / len(data), 1)
                  for kind, times in (("update", update_ms), ("targets", targets_ms)) for name in learners}
    return per_update, {name: [loss for repeat in zip(*per_batch) for loss in repeat]
                        for name, per_batch in losses.items()}


def main() -> None:
    args = parse_args(__doc__.splitlines()[0], quick_help="2 batches, 2 repeats (~2 min)")
    batches, repeats = (1, 1) if args.smoke else (2, 2) if args.quick else (4, 3)
    overrides = ["algo.steps_per_update=3", "planning.actions.max_frontiers=2", "model.hidden=16",
                 "model.mlp_hidden=16"] if args.smoke else []
    config = load_config(["scene=office", "slam=model", "collector.workers=2", *overrides])
    torch.set_num_threads(config.train.threads)
    torch.manual_seed(0)
    fast = Learner(config, make_env(config).action_spec)
    reference = ReferenceLearner(config, make_env(config).action_spec)
    reference.loss.load_state_dict(fast.loss.state_dict())
    data = collected_batches(config, copy.deepcopy(fast.actor), batches)
    same_targets = True
    for batch in data:
        got, expected = fast.value_targets(batch.clone()), reference.value_targets(batch.clone())
        same_targets &= all(close(got[key], expected[key]) for key in ("advantage", "value_target"))
    per_update, losses = timed_updates({"fast": fast, "reference": reference}, data, repeats)
    same_losses = close(torch.tensor(losses["fast"]), torch.tensor(losses["reference"]))
    resets = sum(int(batch["next", "done"][:, :-1].sum()) for batch in data)
    speedup = per_update["update_ms_reference"] / per_update["update_ms"]
    print(f"update: {per_update['update_ms']:.0f} ms, reference {per_update['update_ms_reference']:.0f} ms "
          f"({speedup:.2f}x); value targets {per_update['targets_ms']:.0f} ms, reference "
          f"{per_update['targets_ms_reference']:.0f} ms; same targets {same_targets}, same losses {same_losses}")
    emit({"benchmark": "update", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          "batches": len(data), "batch_shape": list(data[0].shape), "resets_inside_rows": resets,
          "nodes_max": int(max(batch["node_mask"].sum(-1).max() for batch in data)), **per_update,
          "speedup": round(speedup, 3),
          "targets_speedup": round(per_update["targets_ms_reference"] / per_update["targets_ms"], 3),
          "same_targets": same_targets, "same_losses": same_losses})


if __name__ == "__main__":
    main()
