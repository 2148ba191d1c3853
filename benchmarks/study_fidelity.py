"""Fidelity of the ``model`` front end to ``icp`` on the building family (the training scenes), paired by building.

``bench_frontends.py`` and ``study_keyframes.py`` judge the model on the scripted office tours, where it was
calibrated. The shipped policies train on generated buildings. Per building (``scene=building
scene.seed=B``): one live exploration with ``slam=icp`` (steering by its belief; ``--policy``, default random
valid frontiers, at most ``--decisions``) records every motion step its SLAM session observed; the same steps
are replayed into ``slam=model`` sessions (``--draws`` noise draws) on the same scene, once per model variant
(each ``--model-set``; none: the default model). Per building: keyframes, ATE, map error and loop closures of
icp and of each variant (mean over draws). Pooled, per variant: the geometric mean over buildings of model / icp
for each, with a 95 % Student-t interval of the mean log ratio (buildings are the independent units).

    python benchmarks/study_fidelity.py [--quick | --smoke] [--seeds 100-111] [--decisions 30] [--draws 2]
        [--policy random] [--workers 2] [--set KEY=VALUE ...] [--model-set KEY=VALUE ... [--model-set ...]]

``--set``: overrides of both front ends (e.g. ``slam.loop_closure.enabled=false``: odometry alone);
``--model-set``: one variant of the model's replays (e.g. ``slam.scan_matcher.calibration_file=...``), repeatable
(``--model-set`` with no value: the default model as one of them). Buildings run on ``--workers`` spawned
processes; the last stdout line is JSON.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_frontends import new_session, redraw, scores  # noqa: E402
from common import emit, machine, mean_ci95, parse_args, seed_list, spawned_results  # noqa: E402

from explore_rl.config import load_config  # noqa: E402

COMPARED = ("ate_m", "map_error_m", "loop_closures", "keyframes")  # per building, icp and model


@dataclass(frozen=True)
class Task:
    """One building: its seed, the exploration's length and policy, the replays' draws and overrides."""

    building: int
    decisions: int
    policy: str
    draws: int
    overrides: tuple[str, ...]
    model_variants: tuple[tuple[str, ...], ...]


def building_config(task: Task, frontend: str, extra: tuple[str, ...] = ()):
    return load_config(["scene=building", f"scene.seed={task.building}", f"seed={task.building}",
                        f"slam={frontend}", f"policy={task.policy}", "explore.progress_bar=false",
                        f"explore.max_decisions={task.decisions}", *task.overrides, *extra])


def compared(session) -> dict:
    """The :data:`COMPARED` figures of one session (its metrics computed once)."""
    figures = scores(session, 1.0)
    return {key: figures[key] for key in COMPARED}


def compare_building(task: Task) -> dict:
    """The live icp exploration of one building and the model's replays of its motion steps."""
    from explore_rl.runner import Explorer

    explorer = Explorer(building_config(task, "icp"))
    steps: list = []
    observe = explorer.session.observe

    def recording_observe(step) -> bool:
        steps.append(step)
        return observe(step)

    explorer.session.observe = recording_observe
    explorer.run()
    icp = compared(explorer.session)
    models = [replay_model(task, explorer.scene, steps, variant) for variant in task.model_variants]
    travel = steps[-1].travelled if steps else 0.0
    return {"building": task.building, "travel_m": round(travel, 2), "icp": icp,
            "models": [{key: float(np.mean([d[key] for d in draws])) for key in COMPARED} for draws in models],
            "model_draws": models}


def replay_model(task: Task, scene, steps: list, variant: tuple[str, ...]) -> list[dict]:
    """The compared figures of ``task.draws`` model sessions (config ``variant``) fed the recorded steps."""
    config = building_config(task, "model", variant)
    draws = []
    for draw in range(task.draws):
        session = new_session(config, scene, "model")
        redraw(session, task.building, draw)
        for step in steps:
            session.observe(step)
        draws.append(compared(session))
    return draws


def pooled_ratios(rows: list[dict], variant: int = 0) -> dict:
    """Per compared quantity: the geometric mean over buildings of model variant ``variant`` / icp and its 95 %
    interval (loop closures counted +1, so that a building where one front end closes none stays in; a building
    where either error is 0 is left out of that quantity, and counted)."""
    pooled = {}
    for key in COMPARED:
        shift = 1.0 if key == "loop_closures" else 0.0
        pairs = [(r["models"][variant][key] + shift, r["icp"][key] + shift) for r in rows]
        logs = [np.log(model / icp) for model, icp in pairs if model > 0 and icp > 0]
        mean, interval = mean_ci95(logs) if logs else (None, None)
        pooled[key] = {"model_over_icp": None if mean is None else round(float(np.exp(mean)), 3),
                       "ci95": None if interval is None else [round(float(np.exp(v)), 3) for v in interval],
                       "buildings": len(logs)}
    return pooled


def add_arguments(parser) -> None:
    parser.add_argument("--seeds", type=seed_list, default=None,
                        help="building seeds (scene.seed), e.g. 100-111 (default 100-111: training buildings)")
    parser.add_argument("--decisions", type=int, default=30, help="decisions per exploration")
    parser.add_argument("--draws", type=int, default=2, help="model noise draws per building")
    parser.add_argument("--policy", default="random", help="the exploring policy (a policy= config option)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", nargs="+", default=[], metavar="KEY=VALUE", help="overrides of both front ends")
    parser.add_argument("--model-set", nargs="*", action="append", default=None, metavar="KEY=VALUE",
                        help="overrides of the model's replays only: one variant (repeatable; empty: the default)")


def main() -> None:
    args = parse_args(__doc__.splitlines()[0], add_arguments=add_arguments)
    seeds, decisions, draws = args.seeds or list(range(100, 112)), args.decisions, args.draws
    if args.quick:
        seeds, decisions, draws = seeds[:2], min(decisions, 10), 1
    if args.smoke:
        seeds, decisions, draws = seeds[:1], 2, 1
    for name, value in (("--decisions", decisions), ("--draws", draws), ("--workers", args.workers)):
        if value < 1:
            sys.exit(f"{name} {value}: give at least 1")
    variants = tuple(tuple(v) for v in (args.model_set or [[]]))
    try:  # a bad override fails here, in one line, before any run
        for variant in variants:
            building_config(Task(seeds[0], decisions, args.policy, draws, tuple(args.set), ()), "model", variant)
    except Exception as error:  # noqa: BLE001 -- Hydra's and validate()'s errors alike
        sys.exit(f"--set/--model-set/--policy: {str(error).splitlines()[0]}")
    tasks = [Task(b, decisions, args.policy, draws, tuple(args.set), variants) for b in seeds]
    rows = []
    for row in spawned_results(compare_building, tasks, min(args.workers, len(tasks))):
        rows.append(row)
        icp = row["icp"]
        models = "; ".join(f"model {v} ATE {m['ate_m']:.3f} map error {m['map_error_m']:.3f} closures "
                           f"{m['loop_closures']:.1f}" for v, m in enumerate(row["models"]))
        print(f"building {row['building']}: {row['travel_m']:.0f} m, icp ATE {icp['ate_m']:.3f} map error "
              f"{icp['map_error_m']:.3f} closures {icp['loop_closures']}; {models}", flush=True)
    if not rows:
        sys.exit("no building finished (see the errors above)")
    rows.sort(key=lambda r: r["building"])
    pooled = [pooled_ratios(rows, v) for v in range(len(variants))]
    for v, (variant, ratios) in enumerate(zip(variants, pooled)):
        print(f"model {v} ({' '.join(variant) or 'default'}):")
        for key, value in ratios.items():
            print(f"  {key}: model / icp {value['model_over_icp']} {value['ci95']} over {value['buildings']} buildings")
    emit({"study": "fidelity", "quick": args.quick, "smoke": args.smoke, "seeds": seeds, "decisions": decisions,
          "draws": draws, "policy": args.policy, "set": args.set, "model_sets": [list(v) for v in variants],
          "machine": machine(), "pooled": pooled, "buildings": rows})


if __name__ == "__main__":
    main()
