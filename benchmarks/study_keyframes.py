"""Keyframe spacing of ``slam=model`` (and ``icp``): is 0.5 m / 15 deg needed?

On the office tours of ``benchmarks/bench_frontends.py``: per seed, the icp front end
drives the tour once at the default spacing (loop closures on, steering by its belief) and
its motion steps are recorded; the same steps are then replayed, each in a fresh process,
into sessions with other ``slam.keyframe_distance`` / ``slam.keyframe_angle_deg``:
``model`` (the training front end; ``draws`` noise draws) and ``icp`` (the evaluation
front end). Per run: keyframes, ATE, map error, loop closures, explored fraction and
wall time per keyframe and per metre. Fidelity as bench_frontends judges it: the model's
mean ATE, map error and loop closures within the spread (min..max over seeds) of icp's at
the default spacing; and how far the model's keyframes per metre (its graph size) stray
from icp's at the default spacing (the learned policy sees one pose node per keyframe).

    python benchmarks/study_keyframes.py [--quick | --smoke] [--seeds 0-7] [--spacings 0.5:45 ...]
        [--set KEY=VALUE ...] [--model-set KEY=VALUE ...]

``--set``: config overrides of both front ends' replays at every spacing but the default one
(e.g. the loop-closure budgets of ``slam=icp_45deg``); ``--model-set``: of the model's only
(e.g. the rest of ``slam=model_45deg``: a loop-closure fit made at that spacing and its
"worth it" stand-in), to check them against icp at the same spacing.
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
from bench_frontends import drive_icp, in_fresh_process, new_session, redraw, scores  # noqa: E402
from common import emit, machine, parse_args, seed_list  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.scene.build import make_scene  # noqa: E402

DEFAULT = (0.5, 15.0)
SPACINGS = [DEFAULT, (0.5, 30.0), (0.5, 45.0), (0.75, 45.0), (1.0, 45.0)]


def replay(seed: int, steps: list, frontend: str, spacing: tuple[float, float], draw: int,
           overrides: tuple[str, ...] = ()) -> dict:
    """The recorded steps into a ``frontend`` session at ``spacing`` (metres, degrees), with
    config ``overrides``."""
    config = load_config([f"seed={seed}", "slam=icp", f"slam.keyframe_distance={spacing[0]}",
                          f"slam.keyframe_angle_deg={spacing[1]}", *overrides])
    config.scene.start_index = config.tour.start_index
    scene = make_scene(config.scene, config.robot, config.lidar)
    session = new_session(config, scene, frontend)
    redraw(session, seed, draw)
    start = time.perf_counter()
    for step in steps:
        session.observe(step)
    seconds = time.perf_counter() - start
    travel = steps[-1].travelled if steps else 0.0
    return {**scores(session, seconds), "explored": session.metrics().explored, "travel_m": travel,
            "ms_per_metre": 1e3 * seconds / max(travel, 1e-9),
            "keyframes_per_metre": len(session.keyframes) / max(travel, 1e-9)}


def mean(rows: list[dict], key: str) -> float:
    return float(np.mean([r[key] for r in rows]))


def summarise(runs: dict, seeds: list[int]) -> list[dict]:
    """One row per (front end, spacing): means over seeds and draws; model rows judged
    against icp at the default spacing."""
    icp_default = [runs[("icp", DEFAULT)][s][0] for s in seeds]
    rows = []
    for (frontend, spacing), per_seed in runs.items():
        flat = [r for s in seeds for r in per_seed[s]]
        row = {"frontend": frontend, "keyframe_distance": spacing[0], "keyframe_angle_deg": spacing[1]}
        for key in ("keyframes", "keyframes_per_metre", "ate_m", "map_error_m", "loop_closures", "explored",
                    "ms_per_keyframe", "ms_per_metre"):
            row[key] = round(mean(flat, key), 4)
        within = {}
        for key in ("ate_m", "map_error_m", "loop_closures"):
            values = [r[key] for r in icp_default]
            within[key] = min(values) <= row[key] <= max(values)
        row["within_icp_default_spread"] = within
        row["fidelity_ok"] = all(within.values())
        row["keyframes_vs_icp_default"] = round(row["keyframes_per_metre"] / mean(icp_default, "keyframes_per_metre"), 3)
        rows.append(row)
    return rows


def spacing_arg(text: str) -> tuple[float, float]:
    """``0.5:45`` -> (0.5, 45.0): metres, degrees."""
    distance, angle = text.split(":")
    return float(distance), float(angle)


def add_arguments(parser) -> None:
    parser.add_argument("--spacings", nargs="+", type=spacing_arg, metavar="METRES:DEG",
                        help="spacings besides the default 0.5:15 (default: the study's grid)")
    parser.add_argument("--set", nargs="+", default=[], metavar="KEY=VALUE",
                        help="config overrides of both front ends' replays at the non-default spacings")
    parser.add_argument("--model-set", nargs="+", default=[], metavar="KEY=VALUE",
                        help="config overrides of the model's replays at the non-default spacings")
    parser.add_argument("--seeds", type=seed_list, help="tour seeds, e.g. 0-7 (default 0-4)")


def main() -> None:
    args = parse_args(__doc__.splitlines()[0], add_arguments=add_arguments)
    seeds, goals_limit, draws, spacings = [0, 1, 2, 3, 4], None, 2, SPACINGS
    if args.spacings:
        spacings = [DEFAULT, *[s for s in args.spacings if s != DEFAULT]]
    if args.seeds:
        seeds = args.seeds
    if args.quick:
        seeds, goals_limit, draws = [0, 1, 2], 6, 1
    if args.smoke:
        seeds, goals_limit, draws = [0], 1, 1
        spacings = spacings if args.spacings else [DEFAULT, (1.0, 45.0)]
    runs: dict = {}
    for seed in seeds:
        steps = in_fresh_process(drive_icp, seed, goals_limit)["steps"]
        for spacing in spacings:
            for frontend, n in (("icp", 1), ("model", draws)):
                overrides = () if spacing == DEFAULT else (*args.set, *(args.model_set if frontend == "model" else ()))
                rows = [in_fresh_process(replay, seed, steps, frontend, spacing, d, overrides) for d in range(n)]
                runs.setdefault((frontend, spacing), {})[seed] = rows
                r = rows[0]
                print(f"seed {seed} {frontend:5s} {spacing[0]:.2f} m {spacing[1]:4.0f} deg: {r['keyframes']:4d} kf  "
                      f"ATE {r['ate_m']:.3f}  map error {r['map_error_m']:.3f}  closures {r['loop_closures']:3d}  "
                      f"explored {r['explored']:.3f}  {r['ms_per_metre']:.1f} ms/m", flush=True)
    table = summarise(runs, seeds)
    for row in table:
        print({k: v for k, v in row.items() if k != "within_icp_default_spread"}, flush=True)
    emit({"study": "keyframes", "quick": args.quick, "smoke": args.smoke, "seeds": seeds, "draws": draws,
          "set": args.set, "model_set": args.model_set,
          "machine": machine(), "table": table})


if __name__ == "__main__":
    main()
