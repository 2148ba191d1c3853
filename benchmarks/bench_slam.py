"""SLAM with and without loop closures, and dead reckoning, on the scripted office tour.

Each seed drives the tour (it revisits rooms and comes back to its start) with the full
SLAM session -- loop closures on -- steering by the SLAM belief, and records every motion
step. The same steps are then replayed into a second session with
``slam.loop_closure.enabled=false``: the same trajectory, odometry and scans (the LiDAR
and map-error sample generators are re-seeded identically), so the two estimates differ
only by the loop closures. Dead reckoning (wheel odometry alone) is scored on the same
keyframes and map-error sample points.

Loop closures are scored against ground truth: *false* = error of the measured relative
pose above 0.3 m or 3 deg. Targets (issue 4): no false closure, at least one true closure
per trajectory, lower ATE and map error than without loop closures, at least 10
keyframes/s end to end (one thread: BLAS/OpenMP pools are pinned to one thread below).

    python benchmarks/bench_slam.py [--quick | --smoke]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.robot import MotionStep, Robot  # noqa: E402
from explore_rl.scene.build import make_scene  # noqa: E402
from explore_rl.sensors.lidar import Lidar  # noqa: E402
from explore_rl.slam.loop_closure import SOURCES  # noqa: E402
from explore_rl.slam.session import SlamSession  # noqa: E402
from explore_rl.tour import TourRun, drive_with_slam, plan_tour, tour_paths  # noqa: E402

FALSE_TRANSLATION = 0.3  # m
FALSE_ROTATION_DEG = 3.0


class RecordingSession:
    """Forwards to a :class:`SlamSession` and keeps every motion step it observes."""

    def __init__(self, session: SlamSession):
        self.session = session
        self.steps: list[MotionStep] = []

    def observe(self, step: MotionStep) -> bool:
        self.steps.append(step)
        return self.session.observe(step)

    def belief(self, odom_pose: np.ndarray) -> np.ndarray:
        return self.session.belief(odom_pose)


def new_session(config, scene) -> SlamSession:
    """A session seeded like ``run_tour``'s (same LiDAR noise, same map-error samples)."""
    lidar = Lidar(scene, config.lidar, np.random.default_rng([config.seed, 1]))
    return SlamSession(config.slam, config.mapping, scene, lidar, scene.start_pose,
                       np.random.default_rng([config.seed, 3]))


def drive_tour(config, goals_limit: int | None) -> tuple[TourRun, list[MotionStep]]:
    """``explore_rl.tour.run_tour``, also returning the motion steps."""
    config.scene.start_index = config.tour.start_index
    scene = make_scene(config.scene, config.robot, config.lidar)
    goals = config.tour.goals[:goals_limit] if goals_limit else config.tour.goals
    waypoints = plan_tour(scene, scene.start_pose[:2], goals, config.robot.radius, tour_paths(config))
    robot = Robot(config.robot, scene.start_pose, scene.is_free, np.random.default_rng([config.seed, 2]))
    recorder = RecordingSession(new_session(config, scene))
    status = drive_with_slam(robot, recorder, waypoints)
    return TourRun(scene, robot, recorder.session, status), recorder.steps


def replay(config, scene, steps: list[MotionStep]) -> SlamSession:
    """Feed recorded motion steps to a fresh session built from ``config``."""
    session = new_session(config, scene)
    for step in steps:
        session.observe(step)
    return session


def closure_stats(session: SlamSession) -> dict:
    """Accepted/false closures, registrations and time per registration, per source."""
    attempts = getattr(session.loop_closer, "attempts", [])
    out: dict = {}
    registered_ms = []
    for source in SOURCES:
        mine = [a for a in attempts if a.source == source]
        accepted = [a for a in mine if a.accepted]
        false = [a for a in accepted if a.error_translation > FALSE_TRANSLATION
                 or a.error_rotation_deg > FALSE_ROTATION_DEG]
        registered = [a for a in mine if a.registered]
        registered_ms += [a.ms for a in registered]
        out[f"loop_closures_{source}"] = len(accepted)
        out[f"false_loop_closures_{source}"] = len(false)
        out[f"attempts_{source}"] = len(registered)
        out[f"candidates_{source}"] = len(mine)
        out[f"max_error_m_{source}"] = max((a.error_translation for a in accepted), default=0.0)
        out[f"max_error_deg_{source}"] = max((a.error_rotation_deg for a in accepted), default=0.0)
    out["loop_closures"] = sum(out[f"loop_closures_{s}"] for s in SOURCES)
    out["false_loop_closures"] = sum(out[f"false_loop_closures_{s}"] for s in SOURCES)
    out["true_loop_closures"] = out["loop_closures"] - out["false_loop_closures"]
    out["attempts"] = len(registered_ms)
    out["ms_per_attempt"] = float(np.mean(registered_ms)) if registered_ms else 0.0
    return out


def run_seed(seed: int, goals_limit: int | None, overrides: list[str]) -> dict:
    config = load_config([f"seed={seed}", *overrides])
    start = time.perf_counter()
    run, steps = drive_tour(config, goals_limit)
    wall = time.perf_counter() - start
    session = run.session
    no_loops = replay(load_config([f"seed={seed}", *overrides, "slam.loop_closure.enabled=false"]), run.scene, steps)
    assert np.array_equal(no_loops.true_poses(), session.true_poses()), "replay diverged"
    slam = session.metrics()
    odometry = session.metrics(session.odometry_poses())
    without = no_loops.metrics()
    keyframes = len(session.keyframes)
    registration_ms = [k.match.ms for k in session.keyframes if k.match is not None]
    return {
        "seed": seed,
        "status": run.status.value,
        "travel_m": round(run.robot.travelled, 2),
        "keyframes": keyframes,
        "ms_per_keyframe": 1e3 * wall / keyframes,
        "keyframes_per_s": keyframes / wall,
        "ms_registration_median": float(np.median(registration_ms)),
        "stage_ms_per_keyframe": {k: 1e3 * v / keyframes for k, v in session.timer.seconds.items()},
        "ate_m": slam.ate_m,
        "ate_m_odometry": odometry.ate_m,
        "ate_m_no_loops": without.ate_m,
        "map_error_m": slam.map_error_m,
        "map_error_m_odometry": odometry.map_error_m,
        "map_error_m_no_loops": without.map_error_m,
        "degenerate_registrations": slam.degenerate_registrations,
        **closure_stats(session),
    }


def summarise(runs: list[dict]) -> dict:
    stages = {k: round(float(np.mean([r["stage_ms_per_keyframe"][k] for r in runs])), 2)
              for k in runs[0]["stage_ms_per_keyframe"]}
    mean = lambda key: round(float(np.mean([r[key] for r in runs])), 4)  # noqa: E731
    total = lambda key: int(sum(r[key] for r in runs))  # noqa: E731
    registered = [r["attempts"] for r in runs]
    return {
        "seeds": [r["seed"] for r in runs],
        "keyframes": total("keyframes"),
        "ms_per_keyframe": mean("ms_per_keyframe"),
        "keyframes_per_s": mean("keyframes_per_s"),
        "keyframes_per_s_min": round(float(min(r["keyframes_per_s"] for r in runs)), 2),
        "ms_registration_median": round(float(np.median([r["ms_registration_median"] for r in runs])), 2),
        "ate_m": mean("ate_m"),
        "ate_m_odometry": mean("ate_m_odometry"),
        "ate_m_no_loops": mean("ate_m_no_loops"),
        "map_error_m": mean("map_error_m"),
        "map_error_m_odometry": mean("map_error_m_odometry"),
        "map_error_m_no_loops": mean("map_error_m_no_loops"),
        "degenerate_registrations": total("degenerate_registrations"),
        "loop_closures": total("loop_closures"),
        "true_loop_closures": total("true_loop_closures"),
        "false_loop_closures": total("false_loop_closures"),
        **{f"{kind}_{s}": total(f"{kind}_{s}") for s in SOURCES
           for kind in ("loop_closures", "false_loop_closures", "attempts", "candidates")},
        "attempts": total("attempts"),
        "ms_per_attempt": round(float(np.average([r["ms_per_attempt"] for r in runs],
                                                 weights=np.maximum(registered, 1e-9))), 2),
        "stage_ms_per_keyframe": stages,
        "slam_beats_odometry_every_seed": all(
            r["ate_m"] < r["ate_m_odometry"] and r["map_error_m"] < r["map_error_m_odometry"] for r in runs),
        "loops_beat_no_loops_every_seed": all(
            r["ate_m"] < r["ate_m_no_loops"] and r["map_error_m"] < r["map_error_m_no_loops"] for r in runs),
        "true_closure_every_seed": all(r["true_loop_closures"] > 0 for r in runs),
        "no_false_closures": all(r["false_loop_closures"] == 0 for r in runs),
        "tours_completed": sum(r["status"] == "reached" for r in runs),
    }


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    # --quick: the first 6 goals (the west loop and the first return to the start);
    # --smoke: one seed, the first 4 goals (loop-closure attempts, no closure yet).
    if args.smoke:
        seeds, goals_limit = [0], 4
    else:
        seeds, goals_limit = ([0, 1, 2], 6) if args.quick else ([0, 1, 2, 3, 4], None)
    runs = [run_seed(seed, goals_limit, ["slam=icp"]) for seed in seeds]
    for r in runs:
        print(f"seed {r['seed']}: {r['status']:8s} {r['travel_m']:6.1f} m {r['keyframes']:4d} kf  "
              f"ATE {r['ate_m']:.3f} (no loops {r['ate_m_no_loops']:.3f}, odom {r['ate_m_odometry']:.3f})  "
              f"map error {r['map_error_m']:.3f} (no loops {r['map_error_m_no_loops']:.3f}, "
              f"odom {r['map_error_m_odometry']:.3f})  closures {r['loop_closures']} "
              f"(pm {r['loop_closures_pose_matching']}, sm {r['loop_closures_segment_matching']}, "
              f"false {r['false_loop_closures']}) of {r['attempts']} attempts "
              f"({r['ms_per_attempt']:.0f} ms)  degenerate {r['degenerate_registrations']}  "
              f"{r['keyframes_per_s']:.1f} kf/s")
    summary = summarise(runs)
    print("per-keyframe stages (ms):", summary["stage_ms_per_keyframe"])
    emit({"benchmark": "slam", "quick": args.quick, "smoke": args.smoke, "machine": machine(), **summary,
          "per_seed": runs})


if __name__ == "__main__":
    main()
