"""Decisions per second collected by the trainer's TorchRL collectors: 1 vs 2 workers, sync and async.

The real environment (office, ``slam=model``) and the default actor sampling its
actions, as in training. Both runs do the **same work**: the trainer's two worker
factories (each worker's env seed and action-sampling seed, ``env_factories``), the same
fixed weights, the same number of batches per worker after one warm-up batch each
(worker start-up and the first reset excluded), so both take the same decisions in the
same episodes (``same_actions`` checks it):

* 1 worker: TorchRL's ``Collector`` in this process, running worker 0's batches, then
  worker 1's (one core does all of it);
* 2 workers: the trainer's ``MultiSyncCollector`` over two spawned workers;
* 2 workers async (``collector.kind=async``): the trainer's ``LagBoundedAsyncCollector``
  over the same two workers, the learner updating on each batch as it arrives, on the
  same cores, as in training (its weights not sent, so that the work stays the same).
  ``same_actions_async``: each worker took the same decisions as in the 1-worker run.

``dps_1``, ``dps_2`` are decisions/s over the timed batches, ``scaling`` their ratio.
``dps_async``: each worker's timed decisions over its own window (from its warm-up batch
handed out to its last timed batch handed out; waits at the policy-lag gate included),
summed over the two workers running side by side; a round's speedup is ``dps_async / dps_1``.
``sync_bound``: the scaling a synchronous collector could reach on this work if two
workers ran as fast as one, from the 1-worker per-batch times (each batch waits for the
slower worker); ``async_bound``: the same if no worker ever waited for the other (an
asynchronous collector; the slower worker's total); ``gated_bounds``: the same with the
trainer's policy-lag gate at lag 2 and 3 (``gated_schedule``). ``cpu_1``: the 1-worker
process's CPU fraction; ``speedup_async_per_cpu``: the async run's decisions per CPU-second
over the 1-worker run's, times 2 (an estimate for a loaded machine). ``cpu_2``: during the 2-worker
batches, the CPU fraction of this process (the learner's; it should idle) and of each
worker, and each worker's busy threads (more than one would mean torch/BLAS/GTSAM threads
oversubscribing the cores). The learner's
update (timed on each 2-worker batch, its weights not sent to the collectors so that the
work stays the same) shows the collection/update split.

**The machine's ceiling** (``--ceiling``): each round also runs the two workers' batches as
two independent processes at the same time (each as in the 1-worker run: its env and the
actor in one process, no collector process, no learner, no IPC; a barrier after each one's
warm-up batch; the one that finishes first goes on collecting until the other has, as the
async run's faster worker does; their rates summed as ``dps_async``'s). ``ceiling`` is their summed decisions/s over the 1-worker run's: what any
2-worker collector could reach on this machine, the cores' contention (shared caches,
memory bandwidth, the host) included; ``speedup_async_of_ceiling`` is the async run's
decisions/s over theirs (1.0: the collector and the learner cost nothing beyond it).

**Paired rounds** (``--rounds``, 4 by default): the 1-worker and the async run are repeated,
the same work each time, in alternating order (1-worker first in even rounds, async first
in odd ones), so that the host's drift over minutes (the same 1-worker work took 123 s and
139 s in two quiet runs ten minutes apart) falls on both sides of each round's ratio.
``speedup_async`` is the mean of the rounds' ratios, ``speedup_async_ci95`` its 95 %
Student-t interval over rounds; the sync run and the per-batch figures are round 0's.

    python benchmarks/bench_collect.py [--quick | --smoke] [--rounds N] [--ceiling]
"""

from __future__ import annotations

import copy
import multiprocessing
import os
import queue
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, mean_ci95, parse_args  # noqa: E402

import torch  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.envs import make_env  # noqa: E402
from explore_rl.envs.keys import POLICY_LAG, WORKER  # noqa: E402
from explore_rl.trainer.async_collector import gated_schedule  # noqa: E402
from explore_rl.trainer.a2c import (Learner, as_workers_by_time, env_factories, local_collector,  # noqa: E402
                                    make_collector)

WORKERS = 2


def thread_cpu_s(pid: int) -> list[float]:
    """CPU seconds (user + system) of each thread of process ``pid`` (Linux ``/proc``; [] elsewhere)."""
    tasks = Path(f"/proc/{pid}/task")
    if not tasks.is_dir():
        return []
    ticks = os.sysconf("SC_CLK_TCK")
    fields = [(tasks / tid / "stat").read_text().rsplit(")", 1)[1].split() for tid in os.listdir(tasks)]
    return [(int(f[11]) + int(f[12])) / ticks for f in fields]


class CpuMeter:
    """Where the CPU went since it was started: this process's CPU fraction, and per worker
    process of ``collector`` (if any) its CPU fraction and how many of its threads did > 5 %
    of its work (oversubscription check)."""

    def __init__(self, collector):
        self.pids = [proc.pid for proc in getattr(collector, "procs", [])]
        self.workers = [thread_cpu_s(pid) for pid in self.pids]
        self.main, self.start = time.process_time(), time.perf_counter()

    def usage(self) -> dict:
        wall = time.perf_counter() - self.start
        usage = {"main_cpu_fraction": round((time.process_time() - self.main) / wall, 3)}
        after = [thread_cpu_s(pid) for pid in self.pids]
        if self.pids and all(after):
            work = [sum(threads) - sum(before) for before, threads in zip(self.workers, after)]
            usage["worker_cpu_fraction"] = [round(w / wall, 3) for w in work]
            usage["worker_busy_threads"] = [sum(t > 0.05 * w for t in threads) for w, threads in zip(work, after)]
        return usage


def timed_batches(collector, batches: int) -> tuple[list, list[float], dict]:
    """A warm-up batch, then ``batches`` batches and the seconds each took, and where the
    CPU went meanwhile (:class:`CpuMeter`)."""
    iterator = iter(collector)
    next(iterator)
    meter, data, seconds = CpuMeter(collector), [], []
    for _ in range(batches):
        start = time.perf_counter()
        data.append(next(iterator))
        seconds.append(time.perf_counter() - start)
    usage = meter.usage()
    collector.shutdown()
    return data, seconds, usage


def one_worker(config, policy, batches: int) -> tuple[torch.Tensor, list[list[float]], list[float]]:
    """Each worker's batches, one worker after the other, in this process: the actions
    ``[workers, batches, T]``, each worker's per-batch seconds and the CPU fraction this
    process got while collecting them."""
    actions, seconds, cpu = [], [], []
    for factory in env_factories(config):
        data, times, usage = timed_batches(local_collector(factory, policy, config.algo.steps_per_update), batches)
        actions.append(torch.stack([batch["action"] for batch in data]))
        seconds.append(times)
        cpu.append(usage["main_cpu_fraction"])
    return torch.stack(actions), seconds, cpu


def two_workers(config, policy, learner: Learner, batches: int) -> tuple[torch.Tensor, list[float], dict, float]:
    """The trainer's 2-worker collector: the actions ``[workers, batches, T]``, per-batch
    seconds, CPU use, and ms per learner update on those batches."""
    data, seconds, usage = timed_batches(make_collector(config, policy), batches)
    data = [as_workers_by_time(batch, WORKERS) for batch in data]
    start = time.perf_counter()
    for batch in data:
        learner.update(batch)
    ms_update = 1e3 * (time.perf_counter() - start) / batches
    return torch.stack([batch["action"] for batch in data], dim=1), seconds, usage, ms_update


def async_workers(config, policy, learner: Learner, batches: int) -> dict:
    """The trainer's async collector over the same two workers, the learner updating on
    each batch as it arrives (weights not sent: the same work). Each worker's actions
    ``[batches, T]`` after its warm-up batch, its decisions/s over its own window, the CPU
    use, the largest policy lag of a batch and ms per update."""
    collector = make_collector(config, policy)
    handed: dict[int, list] = {w: [] for w in range(WORKERS)}  # (time handed out, batch) per worker
    meter, updates_s = CpuMeter(collector), []
    for batch in collector:
        handed[int(batch[WORKER][0])].append((time.perf_counter(), batch))
        start = time.perf_counter()
        learner.update(as_workers_by_time(batch, WORKERS))  # as the trainer does, beside the workers
        updates_s.append(time.perf_counter() - start)
        if min(map(len, handed.values())) > batches:
            break
    usage = meter.usage()
    collector.shutdown()
    steps = config.algo.steps_per_update
    rates = [batches * steps / (runs[batches][0] - runs[0][0]) for runs in handed.values()]
    return {"actions": torch.stack([torch.stack([b["action"] for _, b in runs[1:batches + 1]])
                                    for runs in handed.values()]),
            "dps_per_worker": rates, "cpu": usage, "ms_update": 1e3 * sum(updates_s) / len(updates_s),
            "policy_lag_max": max(int(b[POLICY_LAG].max()) for runs in handed.values() for _, b in runs),
            "batches_handed": sum(map(len, handed.values()))}


def alone_in_a_process(worker: int, factory, policy, steps: int, batches: int, threads: int, barrier, stop,
                       results) -> None:
    """One worker's batches in a process of its own, as the 1-worker run takes them, timed
    after the barrier that the other such process waits at too (both warmed up). It goes on
    collecting after its timed batches until ``stop`` is set (when both have reported), so
    that the other one never runs alone: as in the async run, whose faster worker goes on."""
    torch.set_num_threads(threads)
    collector = local_collector(factory, policy, steps)
    iterator = iter(collector)
    next(iterator)
    barrier.wait()
    actions, seconds = [], []
    for _ in range(batches):
        start = time.perf_counter()
        actions.append(next(iterator)["action"])
        seconds.append(time.perf_counter() - start)
    results.put((worker, torch.stack(actions).numpy(), seconds))  # by value, not a shared tensor
    while not stop.is_set():
        next(iterator)
    collector.shutdown()


def independent_workers(config, policy, batches: int) -> dict:
    """Both workers' batches in two independent processes side by side (:func:`alone_in_a_process`):
    the actions ``[workers, batches, T]`` and each worker's decisions/s."""
    context = multiprocessing.get_context("spawn")
    barrier, stop, results = context.Barrier(WORKERS), context.Event(), context.Queue()
    processes = [context.Process(target=alone_in_a_process,
                                 args=(worker, factory, policy, config.algo.steps_per_update, batches,
                                       config.train.threads, barrier, stop, results),
                                 daemon=True)  # they end with this process, even if it is interrupted
                 for worker, factory in enumerate(env_factories(config))]
    for process in processes:
        process.start()
    outcome = []
    while len(outcome) < len(processes):  # before join: a full queue blocks a child's exit
        try:
            outcome.append(results.get(timeout=5))
        except queue.Empty:
            failed = [process.exitcode for process in processes if process.exitcode not in (None, 0)]
            if failed:
                for process in processes:
                    process.kill()
                raise SystemExit(f"an independent worker process failed (exit code {failed[0]}): see its traceback above")
    stop.set()
    for process in processes:
        process.join()
    outcome.sort(key=lambda result: result[0])
    return {"actions": torch.stack([torch.from_numpy(actions) for _, actions, _ in outcome]),
            "dps_per_worker": [actions.size / sum(seconds) for _, actions, seconds in outcome]}


def gated_bound(seconds_1: list[list[float]], max_lag: int) -> float:
    """``async_bound`` with the policy-lag gate: the 1-worker time of both workers' batches
    over the time the gate (``gated_schedule``, updates taking no time) needs to hand out
    all of them when the two workers run side by side."""
    quota, handed = len(seconds_1[0]), [0] * len(seconds_1)
    for worker, _, time_handed in gated_schedule(seconds_1, max_lag):
        handed[worker] += 1
        if min(handed) == quota:  # the last worker handed out its last batch
            return sum(map(sum, seconds_1)) / time_handed


def per_cpu_speedup(dps_1: float, cpu_1: list[float], dps_async: float, cpu_async: dict) -> float | None:
    """What ``speedup_async`` would be if every process had got what it used at the rate it
    used it: decisions per CPU-second (learner included) of the async run over those of the
    1-worker run, times 2 cores. An upper estimate for a loaded machine, where the measured
    ratio says more about the other jobs than about the code: it leaves out the time a
    worker waits (no CPU used then). None without per-worker figures."""
    if "worker_cpu_fraction" not in cpu_async:
        return None
    used_async = sum(cpu_async["worker_cpu_fraction"]) + cpu_async["main_cpu_fraction"]
    return round(WORKERS * (dps_async / used_async) / (dps_1 / (sum(cpu_1) / len(cpu_1))), 3)


def one_round(config, async_config, policy, learner: Learner, batches: int, async_first: bool,
              ceiling: bool) -> dict:
    """The 1-worker run and the async run on the same work (and with ``ceiling`` the two
    independent processes), in the order asked for (async first: the reverse order); their
    decisions/s and ratios."""
    modes = ["one", "async", "independent"] if ceiling else ["one", "async"]
    runs = {}
    for mode in (modes[::-1] if async_first else modes):
        runs[mode] = (async_workers(async_config, policy, learner, batches) if mode == "async"
                      else independent_workers(config, policy, batches) if mode == "independent"
                      else one_worker(config, policy, batches))
    actions_1, seconds_1, cpu_1 = runs["one"]
    dps_1 = actions_1.numel() / sum(map(sum, seconds_1))
    dps_async = sum(runs["async"]["dps_per_worker"])
    result = {"actions_1": actions_1, "seconds_1": seconds_1, "cpu_1": cpu_1, "async": runs["async"],
              "dps_1": dps_1, "dps_async": dps_async, "speedup_async": dps_async / dps_1,
              "same_actions_async": bool(torch.equal(actions_1, runs["async"]["actions"]))}
    if ceiling:
        alone = runs["independent"]
        dps_independent = sum(alone["dps_per_worker"])
        result |= {"dps_independent": dps_independent, "ceiling": dps_independent / dps_1,
                   "speedup_async_of_ceiling": dps_async / dps_independent,
                   "same_actions_independent": bool(torch.equal(actions_1, alone["actions"]))}
    return result


def ceiling_figures(paired: list[dict]) -> dict:
    """The rounds' ceiling and the async run's share of it: per round, their mean and 95 % interval."""
    figures = {"dps_independent_rounds": [round(r["dps_independent"], 3) for r in paired],
               "same_actions_independent": all(r["same_actions_independent"] for r in paired)}
    for key in ("ceiling", "speedup_async_of_ceiling"):
        mean, interval = mean_ci95([r[key] for r in paired])
        figures |= {key: round(mean, 3), f"{key}_rounds": [round(r[key], 3) for r in paired],
                    f"{key}_ci95": None if interval is None else [round(v, 3) for v in interval]}
    return figures


def add_rounds(parser) -> None:
    parser.add_argument("--rounds", type=int, default=None, metavar="N",
                        help="paired 1-worker/async rounds (default 4; 1 with --quick or --smoke)")
    parser.add_argument("--ceiling", action="store_true",
                        help="each round also runs the two workers as independent processes side by side")


def main() -> None:
    args = parse_args(__doc__.splitlines()[0], add_arguments=add_rounds,
                      quick_help="1 round of 2 batches per worker in each of the three modes (~75 s: each mode spawns its workers)")
    batches = 1 if args.smoke else 2 if args.quick else 12
    rounds = args.rounds if args.rounds is not None else 1 if args.quick or args.smoke else 4
    if rounds < 1:
        raise SystemExit(f"--rounds must be at least 1 (got {rounds}): give --rounds 1 or more")
    overrides = ["algo.steps_per_update=2", "planning.actions.max_frontiers=2", "model.hidden=16",
                 "model.mlp_hidden=16"] if args.smoke else []
    config = load_config(["scene=office", "slam=model", f"collector.workers={WORKERS}", *overrides])
    async_config = load_config(["scene=office", "slam=model", f"collector.workers={WORKERS}", "collector.kind=async",
                                *overrides])
    torch.set_num_threads(config.train.threads)  # as the trainer (TrainingRun) does
    torch.manual_seed(0)
    learner = Learner(config, make_env(config).action_spec)
    policy = copy.deepcopy(learner.actor)  # fixed weights: the same work in every run
    first = one_round(config, async_config, policy, learner, batches, async_first=False, ceiling=args.ceiling)
    actions_2, seconds_2, usage, ms_update = two_workers(config, policy, learner, batches)
    later = [one_round(config, async_config, policy, learner, batches, async_first=r % 2 == 1, ceiling=args.ceiling)
             for r in range(1, rounds)]
    paired = [first, *later]
    speedup_async, speedup_ci = mean_ci95([r["speedup_async"] for r in paired])
    actions_1, seconds_1, cpu_1, run_async = first["actions_1"], first["seconds_1"], first["cpu_1"], first["async"]
    dps_1, dps_async = first["dps_1"], first["dps_async"]
    decisions = actions_2.numel()
    dps_2 = decisions / sum(seconds_2)
    per_cpu = per_cpu_speedup(dps_1, cpu_1, dps_async, run_async["cpu"])
    sync_bound = sum(map(sum, seconds_1)) / sum(max(times) for times in zip(*seconds_1))
    async_bound = sum(map(sum, seconds_1)) / max(map(sum, seconds_1))
    update_fraction = ms_update / (ms_update + 1e3 * sum(seconds_2) / batches)
    print(f"1 worker: {decisions} decisions in {sum(map(sum, seconds_1)):.1f} s = {dps_1:.3f} /s")
    print(f"2 workers: {decisions} decisions in {sum(seconds_2):.1f} s = {dps_2:.3f} /s; a synchronous "
          f"collector's bound {sync_bound:.2f}x; update {ms_update:.0f} ms per batch "
          f"({100 * update_fraction:.1f} % of an iteration)")
    print(f"2 workers async: {dps_async:.3f} /s = {dps_async / dps_1:.2f}x one worker (bound {async_bound:.2f}x); "
          f"largest policy lag {run_async['policy_lag_max']} (max_policy_lag {async_config.collector.policy_lag()})")
    for r, result in enumerate(paired):
        print(f"round {r} ({'async' if r % 2 else '1 worker'} first): 1 worker {result['dps_1']:.3f} /s, "
              f"async {result['dps_async']:.3f} /s = {result['speedup_async']:.3f}x")
    interval = "" if speedup_ci is None else f", 95 % CI [{speedup_ci[0]:.3f}, {speedup_ci[1]:.3f}]"
    print(f"async over 1 worker, mean of {rounds} paired rounds: {speedup_async:.3f}x{interval}")
    ceiling = ceiling_figures(paired) if args.ceiling else {}
    if ceiling:
        print(f"two independent processes over 1 worker (the machine's ceiling): {ceiling['ceiling']:.3f}x "
              f"{ceiling['ceiling_ci95']}; async over them {ceiling['speedup_async_of_ceiling']:.3f} "
              f"{ceiling['speedup_async_of_ceiling_ci95']}")
    emit({"benchmark": "collect", "quick": args.quick, "smoke": args.smoke, "machine": machine(),
          "decisions": decisions, "batches_per_worker": batches, "steps_per_update": config.algo.steps_per_update,
          "same_actions": bool(torch.equal(actions_1, actions_2)),
          "s_per_batch_1": [[round(t, 2) for t in times] for times in seconds_1],
          "s_per_batch_2": [round(t, 2) for t in seconds_2],
          "cpu_2": usage, "sync_bound": round(sync_bound, 3), "async_bound": round(async_bound, 3), "ms_update_per_batch": round(ms_update, 1),
          "update_fraction": round(update_fraction, 4),
          "gated_bounds": {lag: round(gated_bound(seconds_1, lag), 3) for lag in (WORKERS, WORKERS + 1)},
          "dps_1": round(dps_1, 3), "dps_2": round(dps_2, 3), "scaling": round(dps_2 / dps_1, 3),
          "same_actions_async": all(r["same_actions_async"] for r in paired),
          "dps_async_per_worker": [round(r, 3) for r in run_async["dps_per_worker"]], "cpu_async": run_async["cpu"],
          "ms_update_async": round(run_async["ms_update"], 1), "batches_handed_async": run_async["batches_handed"],
          "max_policy_lag": async_config.collector.policy_lag(),
          "policy_lag_max_async": max(r["async"]["policy_lag_max"] for r in paired),
          "dps_async": round(dps_async, 3), "rounds": rounds,
          "dps_1_rounds": [round(r["dps_1"], 3) for r in paired],
          "dps_async_rounds": [round(r["dps_async"], 3) for r in paired],
          "speedup_async_rounds": [round(r["speedup_async"], 3) for r in paired],
          "speedup_async": round(speedup_async, 3),
          "speedup_async_ci95": None if speedup_ci is None else [round(v, 3) for v in speedup_ci],
          "cpu_1": cpu_1, "speedup_async_per_cpu": per_cpu, **ceiling})


if __name__ == "__main__":
    main()
