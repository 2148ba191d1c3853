"""Fit ``r_lc`` and loop-closure acceptance rates from logged attempts of the icp front end.

Drives the scripted office tour (``conf/tour/office.yaml``) over several seeds with the
real loop closer in a *calibration* setting -- wider candidate search and gate, no
"worth it" filter, more attempts per keyframe -- so every revisit within
``--search-radius`` of an older keyframe's estimate is tried, and logs every attempt
(with its true error from the keyframes' ground truth). Optionally also explores other
scenes with the nearest-frontier policy (``--explore street``).

Fits, per source (pose matching, segment matching):

* acceptance per *revisit* (what ``predict_revisits`` predicts: one revisit = the
  attempts of consecutive query keyframes against one run of older keyframes) against
  the closest estimated distance of the revisit, as a logistic curve
  ``P(accept | d) = 1 / (1 + exp(-(a + b d)))`` plus binned rates;
* acceptance per attempt against distance (binned);
* the error of accepted closures against ground truth (what the ``model`` front end
  should sample) and the time per attempt.

``r_lc`` is the distance at which the pose-matching revisit acceptance falls to 50 %
(the logistic fit; clamped to the searched range). Writes
``conf/calibration/loop_closures.yaml`` (format at its top) and the attempt log as CSV.

    python scripts/calibrate_loop_closures.py [--seeds 0-7] [--quick | --smoke] [--explore street]

The last stdout line is JSON (r_lc and the revisit counts). ``--smoke`` (a few seconds:
seed 0, the tour's first 4 goals) writes to a temporary directory unless ``--out`` and
``--csv`` are given, never to ``conf/calibration``.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import sys
import tempfile
import time
from typing import Sequence
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.common import seed_list  # noqa: E402
from explore_rl.config import load_config  # noqa: E402
from explore_rl.slam.loop_closure import (  # noqa: E402
    POSE_MATCHING, SOURCES, LoopClosureAttempt, write_attempts_csv)

OUT = ROOT / "conf" / "calibration" / "loop_closures.yaml"
CSV = ROOT / "out" / "calibration" / "loop_closure_attempts.csv"
BIN_WIDTH = 0.25  # m
# Refusals that count as failed revisits (the others mean "not in range" or "no budget").
TRIED = ("no_structure", "gate_uncertain", "no_consensus")

# Calibration setting: try every revisit in range (no "worth it" filter), closures live.
CALIBRATION_OVERRIDES = {
    "search_radius": 3.0,
    "overlap_radius": 3.0,
    "min_sigma_translation": 0.0,
    "min_sigma_rotation_deg": 0.0,
    "max_candidates": 4,
    "max_attempts_per_keyframe": 4,
    "segment_search_radius": 10.0,
    "segment_overlap_radius": 8.0,
}

HEADER = """\
# Loop-closure calibration of the icp front end: fitted r_lc and acceptance rates.
# Written by scripts/calibrate_loop_closures.py (do not edit by hand; re-run it).
# Read by the `model` front end and for planning.revisits.r_lc.
#
# Format (version 1):
#   version: 1
#   keyframe_spacing: {distance_m, angle_deg}: the keyframes of the runs (the model samples per
#         keyframe: a fit holds for its spacing; missing in files written before 2026-11-28)
#   r_lc: m. Revisit radius for predict_revisits: distance between a predicted pose and
#         an older keyframe's estimate at which a pose-matching revisit is accepted with
#         50 % probability (logistic fit below; clamped to [0, searched radius]).
#   sources:                       one entry per loop-closure source (factor kind)
#     <pose_matching|segment_matching>:
#       revisits: int              revisits (groups of attempts) in the data
#       accepted_revisits: int     revisits with at least one accepted closure
#       acceptance_logistic:       P(accept | d) = 1 / (1 + exp(-(intercept + slope * d)))
#         intercept: float         per revisit, d = closest estimated distance (m) of the
#         slope: float             revisit; null when there were too few revisits to fit
#       per_revisit:               binned: revisits whose closest distance is in
#         bin_edges_m: [..]        [edge_k, edge_k+1); rate = accepted / revisits (null if
#         revisits: [..]           a bin is empty)
#         accepted: [..]
#         rate: [..]
#       per_attempt:               the same per registration attempt (distance = the
#         bin_edges_m: [..]        attempt's estimated distance)
#         attempts: [..]
#         accepted: [..]
#         rate: [..]
#       accepted_error:            accepted closures against ground truth (errors null when
#                                  count is 0: the source then never accepts)
#         count: int
#         rms_translation_m: float   planar translation error (RMS over closures)
#         rms_rotation_deg: float    yaw error (RMS)
#         max_translation_m: float
#         max_rotation_deg: float
#         false_closures: int        above 0.3 m or 3 deg
#       ms_per_attempt_median: float
#   provenance: how the data were produced (command, seeds, scenes, overrides, date)
"""


def calibration_config(seed: int, overrides: Sequence[str]):
    """The icp config of one run in the calibration setting; ``overrides``: --set and the run's scene."""
    config = load_config([f"seed={seed}", "slam=icp", *overrides])
    config.slam.loop_closure = dataclasses.replace(config.slam.loop_closure, **CALIBRATION_OVERRIDES)
    return config


def run_tour_attempts(seed: int, goals_limit: int | None = None,
                      overrides: Sequence[str] = ()) -> tuple[list[LoopClosureAttempt], dict]:
    from explore_rl.tour import run_tour

    config = calibration_config(seed, overrides)
    start = time.perf_counter()
    run = run_tour(config, goals_limit)
    session = run.session
    info = {"seed": seed, "kind": "tour", "status": run.status.value, "keyframes": len(session.keyframes),
            "seconds": round(time.perf_counter() - start, 1)}
    return list(session.loop_closer.attempts), info


def run_explore_attempts(seed: int, scene: str, overrides: Sequence[str] = ()) -> tuple[list[LoopClosureAttempt], dict]:
    from explore_rl.runner import Explorer

    config = calibration_config(seed, [*overrides, f"scene={scene}", "policy=nearest", "explore.progress_bar=false"])
    start = time.perf_counter()
    explorer = Explorer(config)
    result = explorer.run()
    session = explorer.session
    status = getattr(result, "status", "")
    info = {"seed": seed, "kind": f"explore:{scene}", "status": getattr(status, "value", str(status)),
            "keyframes": len(session.keyframes), "seconds": round(time.perf_counter() - start, 1)}
    return list(session.loop_closer.attempts), info


# ------------------------------------------------------------------ fitting


def revisits(attempts: list[LoopClosureAttempt], query_gap: int = 2,
             candidate_gap: int = 6) -> list[list[LoopClosureAttempt]]:
    """Group one run's attempts (one source) into revisits: attempts whose query
    keyframes are at most ``query_gap`` apart and whose candidates are at most
    ``candidate_gap`` apart belong together (union-find over the pairs)."""
    n = len(attempts)
    parent = list(range(n))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    order = sorted(range(n), key=lambda k: attempts[k].query)
    for a_pos, a in enumerate(order):
        for b in order[a_pos + 1:]:
            if attempts[b].query - attempts[a].query > query_gap:
                break
            if abs(attempts[b].candidate - attempts[a].candidate) <= candidate_gap:
                parent[find(a)] = find(b)
    groups: dict[int, list[LoopClosureAttempt]] = {}
    for k in range(n):
        groups.setdefault(find(k), []).append(attempts[k])
    return list(groups.values())


def fit_logistic(d: np.ndarray, y: np.ndarray, ridge: float = 1e-3) -> tuple[float, float] | None:
    """Maximum-likelihood ``(intercept, slope)`` of ``P(y=1 | d)`` (Newton, tiny ridge)."""
    if len(d) < 5 or y.min() == y.max():
        return None
    X = np.column_stack([np.ones_like(d), d])
    w = np.zeros(2)
    for _ in range(100):
        p = 1.0 / (1.0 + np.exp(-X @ w))
        gradient = X.T @ (y - p) - ridge * w
        hessian = X.T @ (X * (p * (1 - p))[:, None]) + ridge * np.eye(2)
        step = np.linalg.solve(hessian, gradient)
        w += step
        if np.abs(step).max() < 1e-9:
            break
    return float(w[0]), float(w[1])


def binned(distance: np.ndarray, accepted: np.ndarray, edges: np.ndarray, count_name: str) -> dict:
    idx = np.digitize(distance, edges) - 1
    counts = [int(np.sum(idx == k)) for k in range(len(edges) - 1)]
    hits = [int(np.sum((idx == k) & accepted)) for k in range(len(edges) - 1)]
    return {"bin_edges_m": [round(float(e), 3) for e in edges], count_name: counts, "accepted": hits,
            "rate": [round(h / c, 3) if c else None for h, c in zip(hits, counts)]}


def fit_source(runs: list[list[LoopClosureAttempt]], source: str, edges: np.ndarray) -> dict:
    """Statistics of one source over all runs (revisits never span two runs)."""
    registered = [a for run in runs for a in run if a.source == source and a.registered]
    # Revisits: every candidate that would be tried (registered, or refused for lack of
    # structure or certainty), not those out of range or left over by the budget.
    tried = [[a for a in run if a.source == source and (a.registered or a.reason in TRIED)]
             for run in runs]
    events = [group for run in tried for group in revisits(run)]
    d_event = np.array([min(a.distance for a in g) for g in events])
    y_event = np.array([any(a.accepted for a in g) for g in events], dtype=bool)
    d_attempt = np.array([a.distance for a in registered])
    y_attempt = np.array([a.accepted for a in registered], dtype=bool)
    logistic = fit_logistic(d_event, y_event.astype(float))
    accepted = [a for a in registered if a.accepted]
    et = np.array([a.error_translation for a in accepted])
    er = np.array([a.error_rotation_deg for a in accepted])
    return {
        "revisits": len(events),
        "accepted_revisits": int(y_event.sum()),
        "acceptance_logistic": {"intercept": round(logistic[0], 4), "slope": round(logistic[1], 4)}
        if logistic else {"intercept": None, "slope": None},
        "per_revisit": binned(d_event, y_event, edges, "revisits"),
        "per_attempt": binned(d_attempt, y_attempt, edges, "attempts"),
        "accepted_error": {
            "count": len(accepted),
            "rms_translation_m": round(float(np.sqrt(np.mean(et**2))), 4) if len(et) else None,
            "rms_rotation_deg": round(float(np.sqrt(np.mean(er**2))), 4) if len(er) else None,
            "max_translation_m": round(float(et.max()), 4) if len(et) else None,
            "max_rotation_deg": round(float(er.max()), 4) if len(er) else None,
            "false_closures": int(np.sum((et > 0.3) | (er > 3.0))),
        },
        "ms_per_attempt_median": round(float(np.median([a.ms for a in registered])), 2) if registered else None,
    }


def r_lc_from(fit: dict, searched: float) -> float:
    """Where the logistic revisit acceptance crosses 50 %, clamped to ``[0, searched]``;
    without a fit, the upper edge of the last bin with a rate of at least 50 %."""
    a, b = fit["acceptance_logistic"]["intercept"], fit["acceptance_logistic"]["slope"]
    if a is not None and b is not None and b < 0:
        return float(np.clip(-a / b, 0.0, searched))
    rates = fit["per_revisit"]["rate"]
    edges = fit["per_revisit"]["bin_edges_m"]
    good = [edges[k + 1] for k, r in enumerate(rates) if r is not None and r >= 0.5]
    return float(max(good)) if good else 0.0


# ------------------------------------------------------------------ main


def keyframe_spacing(config) -> dict:
    """The spacing the fit holds for: the model front end samples per keyframe."""
    return {"distance_m": config.slam.keyframe_distance, "angle_deg": config.slam.keyframe_angle_deg}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-7", help="e.g. 0-7 or 0,2,5")
    parser.add_argument("--quick", action="store_true", help="seeds 0-1 only")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: seed 0, the tour's first 4 goals, no exploration; "
                             "writes to a temporary directory unless --out/--csv are given")
    parser.add_argument("--explore", default="", help="also explore these scenes, e.g. street,garage")
    parser.add_argument("--out", default=None, help=f"default {OUT}")
    parser.add_argument("--csv", default=None, help=f"default {CSV}")
    parser.add_argument("--set", nargs="*", action="extend", default=[], metavar="KEY=VALUE",
                        help="config overrides of every run, e.g. slam.keyframe_angle_deg=45 (recorded in "
                             "the file's provenance; write such a fit with --out, not over the default)")
    args = parser.parse_args()
    if args.set and args.out is None and not args.smoke:
        parser.error(f"--set fits another config: give --out (the default {OUT} is the fit slam=model reads)")
    seeds = [0, 1] if args.quick else seed_list(args.seeds)
    goals_limit = None
    if args.smoke:  # never overwrite the committed calibration
        seeds, goals_limit, args.explore = [0], 4, ""
        if args.out is None or args.csv is None:
            scratch = Path(tempfile.mkdtemp(prefix="calibrate_loop_closures_smoke_"))
            args.out = args.out or str(scratch / "loop_closures.yaml")
            args.csv = args.csv or str(scratch / "loop_closure_attempts.csv")
    args.out, args.csv = args.out or str(OUT), args.csv or str(CSV)

    runs, infos = [], []
    for seed in seeds:
        attempts, info = run_tour_attempts(seed, goals_limit, args.set)
        runs.append(attempts)
        infos.append(info)
        print(f"tour seed {seed}: {info['status']}, {info['keyframes']} keyframes, "
              f"{sum(a.registered for a in attempts)} attempts, {sum(a.accepted for a in attempts)} "
              f"accepted ({info['seconds']} s)", flush=True)
        for scene in filter(None, args.explore.split(",")):
            attempts, info = run_explore_attempts(seed, scene, args.set)
            runs.append(attempts)
            infos.append(info)
            print(f"explore {scene} seed {seed}: {info['status']}, {info['keyframes']} keyframes, "
                  f"{sum(a.registered for a in attempts)} attempts, "
                  f"{sum(a.accepted for a in attempts)} accepted ({info['seconds']} s)", flush=True)

    searched = CALIBRATION_OVERRIDES["search_radius"]
    edges = np.arange(0.0, searched + 1e-9, BIN_WIDTH)
    segment_edges = np.arange(0.0, CALIBRATION_OVERRIDES["segment_search_radius"] + 1e-9, 1.0)
    sources = {POSE_MATCHING: fit_source(runs, POSE_MATCHING, edges)}
    for source in SOURCES:
        if source != POSE_MATCHING:
            sources[source] = fit_source(runs, source, segment_edges)
    r_lc = r_lc_from(sources[POSE_MATCHING], searched)
    result = {
        "version": 1,
        "r_lc": round(r_lc, 3),
        "keyframe_spacing": keyframe_spacing(calibration_config(seeds[0], args.set)),
        "sources": sources,
        "provenance": {
            "command": "python scripts/calibrate_loop_closures.py " + " ".join(sys.argv[1:]),
            "date": datetime.date.today().isoformat(),
            "runs": infos,
            "overrides": args.set,
            "calibration_overrides": CALIBRATION_OVERRIDES,
            "revisit_grouping": "query keyframes <= 2 apart, candidates <= 6 apart",
        },
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(HEADER + yaml.safe_dump(result, sort_keys=False, default_flow_style=None, width=100))
    write_attempts_csv([a for run in runs for a in run], args.csv)

    print(f"\nr_lc = {r_lc:.2f} m (pose-matching revisits accepted with 50 % probability)")
    for source, fit in sources.items():
        print(f"{source}: {fit['accepted_revisits']}/{fit['revisits']} revisits accepted, "
              f"logistic {fit['acceptance_logistic']}, errors {fit['accepted_error']}, "
              f"{fit['ms_per_attempt_median']} ms/attempt")
        for name in ("per_revisit", "per_attempt"):
            table = fit[name]
            count = table.get("revisits", table.get("attempts"))
            cells = [f"{lo:.2f}-{hi:.2f}: {h}/{c}" for lo, hi, h, c in
                     zip(table["bin_edges_m"][:-1], table["bin_edges_m"][1:], table["accepted"], count) if c]
            print(f"  {name}: " + ", ".join(cells))
    print(f"wrote {out} and {args.csv}")
    print(json.dumps({
        "script": "calibrate_loop_closures", "quick": args.quick, "smoke": args.smoke, "seeds": seeds,
        "r_lc": result["r_lc"], "attempts": sum(a.registered for run in runs for a in run),
        **{f"{kind}_{source}": fit[kind] for source, fit in sources.items()
           for kind in ("revisits", "accepted_revisits")},
        "false_closures": sum(fit["accepted_error"]["false_closures"] for fit in sources.values()),
        "out": str(out), "csv": str(args.csv)}), flush=True)


if __name__ == "__main__":
    main()
