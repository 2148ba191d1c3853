"""EM's compiled kernels against their numpy baselines, on the inputs of real decisions.

An EM exploration of the office (``slam=model``, the bench_env setting) is driven with the
inputs of four kernels recorded at every decision (the decision context's and the
reward's calls alike):

* ``fusion``: the landmark fusion (:func:`explore_rl.planning.em_fast.fuse_batched`,
  compiled) against the numpy rounds (``fuse_batched_reference``);
* ``layout``: the fusion rounds laid out by counting (``FuseRounds.of``) against numpy's
  sorts (``FuseRounds.of_reference``);
* ``line_of_sight``: the segments near blocked cells walked by the compiled loop
  (``line_of_sight_by_length``) against its numpy batches (``compiled=False``);
* ``in_range``: the virtual landmarks in range of each pose by a compiled walk of its
  window (``VirtualMap.in_range_pairs``) against numpy over every window
  (``in_range_pairs_reference``).

Each recorded call is then run by both (after one warm-up call of each, in alternation,
``REPEATS`` times) and the answers must be the same arrays (``same``). Reported per
kernel: ms per decision of each (the sum over its calls), their ratio (``speedup``), the
calls' sizes; and ``ms_saved_per_decision`` over the four. The whole decision is timed
by bench_env and bench_decision_real (both run against the previous code to show it).

    python benchmarks/bench_kernels.py [--quick | --smoke]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

import explore_rl.planning.em as em  # noqa: E402
import explore_rl.planning.revisits as revisits  # noqa: E402
import explore_rl.planning.virtual_map as virtual_map  # noqa: E402
from explore_rl.config import load_config  # noqa: E402
from explore_rl.mapping.visibility import line_of_sight_by_length  # noqa: E402
from explore_rl.planning.em_fast import FuseRounds, fuse_batched, fuse_batched_reference  # noqa: E402
from explore_rl.planning.virtual_map import VirtualMap  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402

REPEATS = 3


def record_calls(decisions: int) -> dict[str, list[tuple]]:
    """Drive the office with EM for ``decisions`` decisions; the arguments of every call of
    the four kernels (copies), by kernel."""
    calls: dict[str, list[tuple]] = {"fusion": [], "layout": [], "line_of_sight": [], "in_range": []}
    counted = FuseRounds.of.__func__
    walked = VirtualMap.in_range_pairs

    def in_range(vmap, poses):
        calls["in_range"].append((vmap, np.array(poses)))
        return walked(vmap, poses)

    def fusion(rounds, pose_covs, initial):
        calls["fusion"].append((rounds, pose_covs.copy(), initial.copy()))
        return fuse_batched(rounds, pose_covs, initial)

    def layout(cls, observations):
        calls["layout"].append((em.Observations(*(np.array(a) for a in (
            observations.pose_idx, observations.landmark_idx, observations.gain, observations.noise))),))
        return counted(cls, observations)

    def sight(start_xy, end_xy, blocked, grid, step_fraction, end_box=0.0, **kwargs):
        calls["line_of_sight"].append((np.array(start_xy), np.array(end_xy), np.array(blocked), grid,
                                       step_fraction, end_box))
        return line_of_sight_by_length(start_xy, end_xy, blocked, grid, step_fraction, end_box, **kwargs)

    saved = (em.fuse_batched, virtual_map.line_of_sight_by_length, revisits.line_of_sight_by_length)
    try:
        em.fuse_batched = fusion
        FuseRounds.of = classmethod(layout)
        VirtualMap.in_range_pairs = in_range
        virtual_map.line_of_sight_by_length = revisits.line_of_sight_by_length = sight
        config = load_config(["scene=office", "slam=model", "seed=0", "policy=em", "explore.progress_bar=false",
                              f"explore.max_decisions={decisions}"])
        Explorer(config).run()
    finally:
        em.fuse_batched, virtual_map.line_of_sight_by_length, revisits.line_of_sight_by_length = saved
        FuseRounds.of = classmethod(counted)
        VirtualMap.in_range_pairs = walked
    return calls


def numpy_fusion(rounds, pose_covs, initial):
    with np.errstate(divide="ignore", invalid="ignore"):
        return fuse_batched_reference(rounds, pose_covs, initial)


# kernel: (compiled, numpy baseline, the answer as arrays to compare, the call's size)
KERNELS = {
    "fusion": (fuse_batched, numpy_fusion, lambda out: [out],
               lambda rounds, pose_covs, initial: len(rounds.pose_idx) * len(pose_covs)),
    "layout": (FuseRounds.of, FuseRounds.of_reference,
               lambda r: [r.offsets, r.landmarks, r.pose_idx, r.terms], lambda observations: len(observations.pose_idx)),
    "line_of_sight": (lambda *args: line_of_sight_by_length(*args),
                      lambda *args: line_of_sight_by_length(*args, compiled=False), lambda out: [out],
                      lambda start_xy, *rest: len(start_xy)),
    "in_range": (VirtualMap.in_range_pairs, VirtualMap.in_range_pairs_reference, list,
                 lambda vmap, poses: len(poses)),
}


def same_arrays(a: list[np.ndarray], b: list[np.ndarray]) -> bool:
    return all(x.shape == y.shape and np.array_equal(x, y, equal_nan=x.dtype.kind == "f") for x, y in zip(a, b))


def measure(name: str, calls: list[tuple], repeats: int, decisions: int) -> dict:
    """ms per decision of the kernel and its baseline over the recorded ``calls``, alternating."""
    fast, slow, answer, size = KERNELS[name]
    seconds = {"fast": 0.0, "slow": 0.0}
    same = True
    for args in calls:
        same &= same_arrays(answer(fast(*args)), answer(slow(*args)))  # the warm-up calls
        for _ in range(repeats):
            for key, fn in (("fast", fast), ("slow", slow)):
                start = time.perf_counter()
                fn(*args)
                seconds[key] += time.perf_counter() - start
    ms = {key: 1e3 * value / repeats / decisions for key, value in seconds.items()}
    sizes = [size(*args) for args in calls]
    return {"calls": len(calls), "ms_per_decision": round(ms["fast"], 3),
            "ms_per_decision_numpy": round(ms["slow"], 3),
            "speedup": round(ms["slow"] / ms["fast"], 2) if ms["fast"] > 0 else None, "same": bool(same),
            "size_median": float(np.median(sizes)) if sizes else 0.0, "size_max": int(max(sizes, default=0))}


def main() -> None:
    args = parse_args(__doc__.splitlines()[0], "8 decisions")
    decisions = 2 if args.smoke else 8 if args.quick else 30
    repeats = 1 if args.smoke else REPEATS
    calls = record_calls(decisions)
    result = {"benchmark": "kernels", "quick": args.quick, "smoke": args.smoke, "decisions": decisions,
              "repeats": repeats, "machine": machine()}
    for name in KERNELS:
        result[name] = measure(name, calls[name], repeats, decisions)
        r = result[name]
        print(f"{name:14s} {r['calls']:5d} calls  {r['ms_per_decision']:8.2f} ms/decision compiled  "
              f"{r['ms_per_decision_numpy']:8.2f} numpy  {r['speedup']}x  same {r['same']}", flush=True)
    result["same"] = all(result[name]["same"] for name in KERNELS)
    result["ms_saved_per_decision"] = round(sum(result[n]["ms_per_decision_numpy"] - result[n]["ms_per_decision"]
                                                for n in KERNELS), 2)
    emit(result)


if __name__ == "__main__":
    main()
