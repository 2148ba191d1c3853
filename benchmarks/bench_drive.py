"""Driving cost per decision: the maps' incremental corrections against the reference rebuild.

Office, ``slam=model``, random valid frontiers (the setting of issue 22's profile). Per
seed, one live exploration records every decision's motion steps and times the robot's
side of driving (path following and the local safety layer: ``follow``). The same steps
are then driven through ``Explorer.move`` (LiDAR, SLAM, loop closures, maps, belief) by
two fresh explorers with the same seeds: ``mapping.updates=rebuild`` (the reference: every
keyframe re-projected whenever any moved by more than a cell, sorted-key voxel set) and
``incremental`` (only the keyframes that moved, voxel counts, kept beam cells). Drive
per decision = follow + move. Figures are per decision, summed over the seeds, in CPU
time of this process (the machine is shared: under a load of 8 on 2 cores wall times of
the same replay varied by 25 %; the wall-clock figures are reported too, and the
per-stage figures are wall time); each replay runs ``repeats`` times, the modes
alternating, and the fastest counts (the replays are deterministic).

Map checks: the fast run's maps against the reference code's full rebuild at its map
poses (``max_abs_logodds_diff``, ``same_voxels``: exact up to float order), and against
the reference run (``same_explored``: explored fractions within 1 point; the modes' maps
differ by at most a cell per keyframe, and the model loop closer reads the map, so the
runs' SLAM estimates drift apart a little).

``--fast-set KEY=VALUE ...`` applies overrides to the incremental replays only: e.g.
``slam=model_45deg`` (0.5 m / 45 deg keyframes) against the reference rebuild at the default
0.5 m / 15 deg, the drive before issue 22 (its map checks hold within the fast run).

``--profile PATH`` also writes a cProfile table (by own time) of one more incremental
replay of the first seed to PATH (not part of the timed figures).

    python benchmarks/bench_drive.py [--quick | --smoke] [--set KEY=VALUE ...] [--fast-set KEY=VALUE ...]
        [--profile PATH]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import cProfile  # noqa: E402
import io  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.runner import Explorer  # noqa: E402
from explore_rl.slam.session import reference_maps  # noqa: E402

MODES = ("rebuild", "incremental")


class TimedSteps:
    """Iterates a motion-step generator, timing only the generator (the robot's side)."""

    def __init__(self, steps, record: list):
        self.steps, self.record, self.seconds = iter(steps), record, 0.0

    def __iter__(self):
        return self

    def __next__(self):
        start = time.process_time()
        try:
            step = next(self.steps)
        finally:
            self.seconds += time.process_time() - start
        self.record.append(step)
        return step


def make_config(seed: int, decisions: int, mode: str, extra: list[str]):
    return load_config(["scene=office", "slam=model", "policy=random", f"seed={seed}",
                        "explore.progress_bar=false", f"explore.max_decisions={decisions}",
                        f"mapping.updates={mode}", *extra])


def record_episode(seed: int, decisions: int, extra: list[str]) -> tuple[list[list], float, int]:
    """A live exploration: the motion steps of every ``move`` (decisions and escapes), the
    seconds spent making them, and the number of decisions."""
    explorer = Explorer(make_config(seed, decisions, "incremental", extra))
    paths, follow_seconds = [], 0.0
    move = explorer.move

    def recording_move(steps) -> None:
        nonlocal follow_seconds
        timed = TimedSteps(steps, [])
        move(timed)
        paths.append(timed.record)
        follow_seconds += timed.seconds

    explorer.move = recording_move
    result = explorer.run()
    return paths, follow_seconds, len(result.records)


def replay(seed: int, decisions: int, mode: str, paths: list[list], extra: list[str]) -> dict:
    """The recorded steps through ``Explorer.move`` with one map-update mode."""
    explorer = Explorer(make_config(seed, decisions, mode, extra))
    start, start_wall = time.process_time(), time.perf_counter()
    for steps in paths:
        explorer.move(steps)
    return {"explorer": explorer, "seconds": time.process_time() - start,
            "wall_seconds": time.perf_counter() - start_wall, "stages": dict(explorer.session.timer.seconds)}


# Native calls both modes make alike per keyframe (the LiDAR cast, iSAM2, its estimates and
# the delta they are read at, the cloud down-sampling): their time bounds what any
# map-update mode can save.
SHARED_NATIVE = ("mj_multiRay", "update", "calculateEstimate", "calculateEstimatePose3", "extractPose3",
                 "getDelta", "vector", "getMarkedKeys", "_voxel_down_sample")


def write_profile(path: Path, seed: int, decisions: int, paths: list[list], extra: list[str]) -> dict:
    """cProfile of one incremental replay, the top functions by own time, to ``path``; returns
    the profiled CPU seconds and the own seconds of the :data:`SHARED_NATIVE` calls."""
    profiler = cProfile.Profile()
    profiler.enable()
    run = replay(seed, decisions, "incremental", paths, extra)
    profiler.disable()
    stats = pstats.Stats(profiler)
    native = {name: 0.0 for name in SHARED_NATIVE}
    for (_, _, function), (_, _, own, _, _) in stats.stats.items():
        for name in SHARED_NATIVE:
            if function.startswith("<built-in method ") and function.endswith(f".{name}>"):
                native[name] += own
    text = io.StringIO()
    keyframes = len(run["explorer"].session.keyframes)
    text.write(f"incremental replay, seed {seed}, {len(paths)} moves, {keyframes} keyframes, "
               f"{run['seconds']:.2f} s CPU under the profiler; shared native calls (own s): "
               f"{ {k: round(v, 3) for k, v in native.items()} }\n")
    stats.stream = text
    stats.sort_stats("tottime").print_stats(40)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text.getvalue())
    return {"seed": seed, "keyframes": keyframes, "profiled_cpu_s": round(run["seconds"], 3),
            "shared_native_s": {k: round(v, 3) for k, v in native.items()},
            "shared_native_total_s": round(sum(native.values()), 3)}


def map_checks(fast, reference) -> dict:
    """The fast run's maps against the reference code's rebuild at its map poses, and
    against the reference run."""
    session = fast.session
    occupancy, voxels = reference_maps(session)
    fast_metrics, reference_metrics = session.metrics(), reference.session.metrics()
    known = ~session.occupancy.unknown
    return {
        "max_abs_logodds_diff": float(np.abs(session.occupancy.log_odds - occupancy.log_odds).max()),
        "same_voxels": bool(np.array_equal(session.voxels.keys, voxels.keys)),
        "explored": round(fast_metrics.explored, 4),
        "explored_reference": round(reference_metrics.explored, 4),
        "cells_known_differently_vs_reference_run": int((known != ~reference.session.occupancy.unknown).sum()),
        "volume_m3": round(fast_metrics.volume_m3, 3),
        "volume_m3_reference": round(reference_metrics.volume_m3, 3),
        "loop_closures": fast_metrics.loop_closures,
        "loop_closures_reference": reference_metrics.loop_closures,
        "ate_m": round(fast_metrics.ate_m, 6),
        "ate_m_reference": round(reference_metrics.ate_m, 6),
        "keyframes": fast_metrics.keyframes,
    }


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a run that finishes in under a minute")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds, for the test suite: checks that it runs; figures are meaningless")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="extra config overrides for every run (e.g. slam.keyframe_distance=1.0)")
    parser.add_argument("--fast-set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="overrides of the incremental replays only (e.g. slam=model_45deg)")
    parser.add_argument("--profile", type=Path, default=None, metavar="PATH",
                        help="write a cProfile table of an incremental replay of the first seed here")
    return parser.parse_args()


def overrides(args: argparse.Namespace, mode: str) -> list[str]:
    """Config overrides of a ``mode`` replay: ``--set``, and ``--fast-set`` for the incremental one."""
    return [*args.set, *args.fast_set] if mode == "incremental" else list(args.set)


def main() -> None:
    args = parse_args()
    seeds, decisions, repeats = ([1], 2, 1) if args.smoke else ([1], 12, 2) if args.quick else ([0, 1], 40, 2)
    totals = {"follow": 0.0, **{mode: 0.0 for mode in MODES}}
    wall = {mode: 0.0 for mode in MODES}
    stages = {mode: {} for mode in MODES}
    n_decisions, checks, profile = 0, [], None
    for seed in seeds:
        paths, follow, seed_decisions = record_episode(seed, decisions, args.set)
        best: dict[str, dict] = {}
        for _ in range(repeats):
            for mode in MODES:
                run = replay(seed, decisions, mode, paths, overrides(args, mode))
                if mode not in best or run["seconds"] < best[mode]["seconds"]:
                    best[mode] = run
        if args.profile is not None and seed == seeds[0]:
            profile = write_profile(args.profile, seed, decisions, paths, overrides(args, "incremental"))
        n_decisions += seed_decisions
        totals["follow"] += follow
        for mode, run in best.items():
            totals[mode] += run["seconds"]
            wall[mode] += run["wall_seconds"]
            for stage, seconds in run["stages"].items():
                stages[mode][stage] = stages[mode].get(stage, 0.0) + seconds
        if profile is not None and profile["seed"] == seed:
            # The drive with the shared native calls alone (no Python at all), against the
            # reference's drive on this seed: the speed-up no map-update mode can exceed.
            floor = follow + profile["shared_native_total_s"]
            profile["bound_speedup"] = round((follow + best["rebuild"]["seconds"]) / floor, 2)
        checks.append({"seed": seed, "decisions": seed_decisions,
                       **map_checks(best["incremental"]["explorer"], best["rebuild"]["explorer"])})
        print(f"seed {seed}: {seed_decisions} decisions, follow {follow:.2f} s, move rebuild "
              f"{best['rebuild']['seconds']:.2f} s, incremental {best['incremental']['seconds']:.2f} s", flush=True)

    def per_decision(seconds: float) -> float:
        return round(1e3 * seconds / max(n_decisions, 1), 1)

    drive = per_decision(totals["follow"] + totals["incremental"])
    drive_reference = per_decision(totals["follow"] + totals["rebuild"])
    keyframes = sum(c["keyframes"] for c in checks)
    result = {
        "smoke": args.smoke, "quick": args.quick, "overrides": args.set, "fast_overrides": args.fast_set, "seeds": seeds, "repeats": repeats,
        "decisions": n_decisions, "keyframes": keyframes,
        "keyframes_per_decision": round(keyframes / max(n_decisions, 1), 1),
        "drive_ms_per_decision": drive,
        "drive_ms_per_decision_reference": drive_reference,
        "speedup": round(drive_reference / max(drive, 1e-9), 2),
        "follow_ms_per_decision": per_decision(totals["follow"]),
        "move_ms_per_decision": per_decision(totals["incremental"]),
        "move_ms_per_decision_reference": per_decision(totals["rebuild"]),
        "move_wall_ms_per_decision": per_decision(wall["incremental"]),
        "move_wall_ms_per_decision_reference": per_decision(wall["rebuild"]),
        "move_wall_speedup": round(wall["rebuild"] / max(wall["incremental"], 1e-9), 2),
        "stage_ms_per_decision": {m: {k: per_decision(v) for k, v in s.items()} for m, s in stages.items()},
        "max_abs_logodds_diff": max(c["max_abs_logodds_diff"] for c in checks),
        "same_voxels": all(c["same_voxels"] for c in checks),
        "same_explored": all(abs(c["explored"] - c["explored_reference"]) < 0.01 for c in checks),
        "per_seed": checks,
        "profile": profile,
        "machine": machine(),
    }
    print(f"drive per decision: {drive} ms (reference {drive_reference} ms), speedup {result['speedup']}x; "
          f"{result['keyframes_per_decision']} keyframes per decision", flush=True)
    emit(result)


if __name__ == "__main__":
    main()
