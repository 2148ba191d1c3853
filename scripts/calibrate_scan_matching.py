"""Fit the scan-matching error model of the ``model`` front end from ``icp`` runs.

Drives the scripted office tour over several seeds and nearest-frontier explorations of
the office, street and garage with the real (kiss-icp) front end and loop closures off,
and records every sequential scan match next to the ground truth: the planar error of
the measured motion (from the last anchored keyframe, ``ScanMatch.span_relative``)
against the true motion, whether the match was degenerate, its weak directions, the
covariance it reported, whether the keyframe turned, and what the scan saw (the number of
points in the obstacle height band). Then it fits (see ``conf/calibration/scan_matching.yaml``
for the format):

* the degenerate rate per bin of that statistic, after a usable and after a degenerate
  keyframe (degenerate keyframes come in runs: a scan with little overlap is not added
  to the submap, so the next one has even less);
* P(weak directions = 0, 1, 2 | usable, bin);
* per condition (weak count x straight/turned): zero-mean two-normal scale mixtures of the
  yaw error and of the error along the constrained translation directions, the
  direction of the weak (or constrained) translation axis in the body frame, the raw
  error standard deviations and the median reported standard deviations;
* how honest the icp covariance is: Mahalanobis distances of the errors along the
  constrained directions (mean d^2 per degree of freedom, fraction beyond the 99 %
  chi-square quantile).

    python scripts/calibrate_scan_matching.py [--tour-seeds 0-5] [--explore-seeds 0-1]
        [--scenes office,street,garage] [--max-decisions 40] [--out PATH] [--quick | --smoke]

The last stdout line is JSON (the fit's honesty figures). ``--smoke`` (a few seconds: the
tour's first 2 goals on seed 0 and a 2-decision office exploration) writes to a temporary
directory unless ``--out`` is given, never to ``conf/calibration``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
import tempfile
import time
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml
from scipy.stats import chi2

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.common import seed_list  # noqa: E402
from explore_rl.config import load_config  # noqa: E402
from explore_rl.geometry import matrix_to_se2, se2_between  # noqa: E402
from explore_rl.slam import session as session_module  # noqa: E402
from explore_rl.slam.calibration import SCAN_MATCHING_FILE, condition_name, load_scan_matching  # noqa: E402
from explore_rl.slam.frontend import PLANAR  # noqa: E402
from explore_rl.slam.frontend_model import obstacle_points  # noqa: E402

BIN_EDGES = [0, 100, 300, 600, 1000, 1500, 2500, 4000, 100000]
ANGLE_EDGES = [0, 15, 30, 45, 60, 75, 90]
SIGMA_LEVELS = [0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 1.0]
TURN_THRESHOLD_DEG = 5.0
MIN_CONDITION_SAMPLES = 30  # fewer: pool straight and turned for that weak count
PSEUDO_COUNTS = 2.0  # rates per bin shrink towards the pooled rate by this many samples
WEAK_SUBSPACE_VARIANCE = 0.25  # covariance eigenvalues above this (weak_sigma^2 = 1) are weak

HEADER = """\
# Scan-matching calibration of the icp front end, for the `model` front end
# (explore_rl/slam/frontend_model.py). Written by scripts/calibrate_scan_matching.py
# (do not edit by hand; re-run it). Units: m, deg; counts are keyframes.
#
# Format (version 1):
#   statistic: what a scan "sees": the number of its points between min_height and
#     max_height above the floor (sensor z + mount_height, the obstacle band).
#   degenerate: P(match degenerate | statistic bin [bin_edges[k], bin_edges[k+1]))
#     rate: after a usable keyframe; rate_after_degenerate: after a degenerate one
#     (forced submap restarts, every max_span degenerate keyframes, are not counted).
#   weak_probabilities[k]: P(0, 1, 2 weak planar directions | usable, bin k).
#   turn_threshold_deg: a keyframe "turned" when |wheel-odometry yaw| exceeds it.
#   conditions.weak<W>_<straight|turned>: usable matches with W weak directions:
#     count; yaw_deg and translation (m): zero-mean scale mixtures of two normals
#     {core_sigma, tail_sigma, tail_fraction} of the yaw error and of the error along
#     each constrained translation direction (both axes for weak0, the axis
#     perpendicular to the weak one for weak1, the constrained axis for weak2);
#     weak_angle_deg: histogram of the angle (0..90) from body x of the weak (weak1) or
#     constrained (weak2) translation axis; along weak directions the icp front end
#     keeps the wheel-odometry prior, so the error there is the odometry error;
#     reported_sigma_*: medians of the standard deviations the icp front end reported;
#     reported_sigma_quantiles: their quantiles {levels, yaw_deg, translation} (the
#     model draws one level for both), and yaw_z / translation_z: mixtures of the
#     errors divided by the reported sigma (what the model samples: sigma x z);
#     error_std: raw standard deviations of the body-frame errors {yaw_deg, x_m, y_m}.
#     Conditions with fewer than 30 matches pool straight and turned.
#   fit: how honest the icp covariance is along constrained directions (Mahalanobis
#     d^2 per degree of freedom; fraction above the chi-square 99 % quantile, 0.01 if
#     Gaussian and honest) and the error statistics overall.
#   provenance: scenes, seeds, scan-matcher settings and the command.
"""


# ------------------------------------------------------------------------------ recording


@dataclass
class Record:
    run: str
    keyframe: int
    degenerate: bool
    forced_restart: bool  # the matcher restarted its submap (max_span) at this keyframe
    after_degenerate: bool
    weak: int
    span: int
    statistic: int
    turned: bool
    error: np.ndarray  # planar (yaw, x, y) error of span_relative vs the true span motion
    wheel_error: np.ndarray  # the same for wheel odometry over the span
    covariance: np.ndarray  # 3x3 planar (yaw, x, y) reported covariance
    ms: float


class RecordingFrontend:
    """Wraps the icp front end; records each match against the true motion."""

    def __init__(self, inner, config, sink: list[Record], run: str):
        self.inner, self.sink, self.run = inner, sink, run
        self.mount = 0.4  # replaced by the session's LiDAR mount height below
        self.max_span = config.scan_matcher.max_span
        self.true, self.wheel = [np.eye(4)], [np.eye(4)]
        self.since_anchor, self.previous_degenerate = 0, False
        self.first = True

    def register(self, points_sensor, wheel_delta, true_delta):
        forced = self.since_anchor >= self.max_span
        match = self.inner.register(points_sensor, wheel_delta, true_delta)
        if self.first:  # the first keyframe starts the submap; nothing to measure
            self.first = False
            return match
        self.true.append(self.true[-1] @ true_delta)
        self.wheel.append(self.wheel[-1] @ wheel_delta)
        k = len(self.true) - 1
        span = match.span if match.usable else 1
        truth = matrix_to_se2(np.linalg.inv(self.true[k - span]) @ self.true[k])
        wheel = matrix_to_se2(np.linalg.inv(self.wheel[k - span]) @ self.wheel[k])
        measured = matrix_to_se2(match.span_relative)
        self.sink.append(Record(
            run=self.run, keyframe=k, degenerate=match.degenerate, forced_restart=forced,
            after_degenerate=self.previous_degenerate, weak=int(match.weak_directions), span=span,
            statistic=obstacle_points(points_sensor, self.mount),
            turned=bool(abs(np.rad2deg(matrix_to_se2(wheel_delta)[2])) > TURN_THRESHOLD_DEG),
            error=se2_between(truth, measured)[[2, 0, 1]],
            wheel_error=se2_between(truth, wheel)[[2, 0, 1]],
            covariance=match.covariance[np.ix_(PLANAR, PLANAR)].copy(), ms=match.ms))
        self.since_anchor = 0 if (match.usable or forced) else self.since_anchor + 1
        self.previous_degenerate = match.degenerate
        return match


@contextmanager
def recording(sink: list[Record], run: str, mount_height: float):
    """While active, every new SlamSession's front end is recorded into ``sink``."""
    original = session_module.make_frontend

    def make(config):
        frontend = RecordingFrontend(original(config), config, sink, run)
        frontend.mount = mount_height
        return frontend

    session_module.make_frontend = make
    try:
        yield
    finally:
        session_module.make_frontend = original


def icp_without_loops(overrides: list[str]):
    return load_config(["slam=icp", "slam.loop_closure.enabled=false", *overrides])


def collect(tour_seeds: list[int], explore_seeds: list[int], scenes: list[str], max_decisions: int,
            overrides: list[str], goals_limit: int | None = None) -> tuple[list[Record], list[dict], object]:
    from explore_rl.runner import Explorer
    from explore_rl.tour import run_tour

    records: list[Record] = []
    runs = []
    config = None
    for seed in tour_seeds:
        config = icp_without_loops([f"seed={seed}", *overrides])
        start = time.perf_counter()
        with recording(records, f"tour/office/{seed}", config.lidar.mount_height):
            run = run_tour(config, goals_limit)
        runs.append(_run_summary(f"tour/office/{seed}", run.session, time.perf_counter() - start))
        print(runs[-1], flush=True)
    for scene in scenes:
        for seed in explore_seeds:
            config = icp_without_loops([f"scene={scene}", f"seed={seed}", "explore.progress_bar=false",
                                  f"explore.max_decisions={max_decisions}", *overrides])
            start = time.perf_counter()
            with recording(records, f"explore/{scene}/{seed}", config.lidar.mount_height):
                explorer = Explorer(config)
                explorer.run()
            runs.append(_run_summary(f"explore/{scene}/{seed}", explorer.session, time.perf_counter() - start))
            print(runs[-1], flush=True)
    return records, runs, config


def _run_summary(name: str, session, seconds: float) -> dict:
    slam, odometry = session.metrics(), session.metrics(session.odometry_poses())
    return {"run": name, "keyframes": len(session.keyframes), "ate_m": round(slam.ate_m, 4),
            "ate_m_odometry": round(odometry.ate_m, 4), "seconds": round(seconds, 1)}


# ------------------------------------------------------------------------------ fitting


def fit_mixture(x: np.ndarray, iterations: int = 200) -> dict:
    """Zero-mean two-normal scale mixture by EM (core = the narrower component)."""
    x = np.asarray(x, float)
    if len(x) < 5:
        s = float(np.sqrt(np.mean(x**2))) if len(x) else 0.0
        return {"core_sigma": s, "tail_sigma": s, "tail_fraction": 0.0}
    core = max(1.4826 * float(np.median(np.abs(x))), 1e-9)
    tail, frac = max(3.0 * core, float(np.sqrt(np.mean(x**2)))), 0.1
    for _ in range(iterations):
        pc = (1 - frac) * np.exp(-0.5 * (x / core) ** 2) / core
        pt = frac * np.exp(-0.5 * (x / tail) ** 2) / tail
        w = pt / np.maximum(pc + pt, 1e-300)
        frac = float(np.clip(w.mean(), 1e-3, 0.5))
        core = float(np.sqrt(np.sum((1 - w) * x**2) / max(np.sum(1 - w), 1e-9)))
        tail = float(np.sqrt(np.sum(w * x**2) / max(np.sum(w), 1e-9)))
        core, tail = max(core, 1e-9), max(tail, core)
    return {"core_sigma": core, "tail_sigma": tail, "tail_fraction": frac}


def weak_geometry(covariance: np.ndarray, weak: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit body-frame translation axes (u: weak, v: constrained) of a weak 1/2 match."""
    values, vectors = np.linalg.eigh(covariance)
    if weak == 1:
        u = vectors[1:, int(np.argmax(values))]
        u = u / max(np.linalg.norm(u), 1e-12)
        v = np.array([-u[1], u[0]])
    else:
        v = vectors[1:, int(np.argmin(values))]
        v = v / max(np.linalg.norm(v), 1e-12)
        u = np.array([-v[1], v[0]])
    return u, v


def axis_angle_deg(axis: np.ndarray) -> float:
    return float(np.rad2deg(np.arctan2(abs(axis[1]), abs(axis[0]))))


def smoothed_rates(hits: np.ndarray, totals: np.ndarray) -> list[float]:
    pooled = hits.sum() / max(totals.sum(), 1)
    return [round(float((h + PSEUDO_COUNTS * pooled) / (n + PSEUDO_COUNTS)), 4) for h, n in zip(hits, totals)]


def fit(records: list[Record], matcher) -> dict:
    """The calibration (a plain dict in the YAML layout) from the recorded matches."""
    stat = np.array([r.statistic for r in records])
    bins = np.clip(np.searchsorted(BIN_EDGES, stat, side="right") - 1, 0, len(BIN_EDGES) - 2)
    degenerate = np.array([r.degenerate for r in records])
    after = np.array([r.after_degenerate for r in records])
    free = ~np.array([r.forced_restart for r in records])
    n_bins = len(BIN_EDGES) - 1

    def per_bin(mask):
        hits = np.bincount(bins[mask & degenerate], minlength=n_bins)
        totals = np.bincount(bins[mask], minlength=n_bins)
        return hits, totals

    hits_ok, totals_ok = per_bin(free & ~after)
    hits_after, totals_after = per_bin(free & after)
    usable = ~degenerate
    weak = np.array([min(r.weak, 2) for r in records])
    weak_rows = []
    pooled = np.bincount(weak[usable], minlength=3)[:3] / max(usable.sum(), 1)
    for k in range(n_bins):
        counts = np.bincount(weak[usable & (bins == k)], minlength=3)[:3].astype(float)
        row = (counts + PSEUDO_COUNTS * pooled) / (counts.sum() + PSEUDO_COUNTS)
        row = np.round(row / row.sum(), 4)
        row[-1] = round(1.0 - row[:-1].sum(), 4)
        weak_rows.append([float(v) for v in row])

    conditions = {}
    for w in (0, 1, 2):
        for turned in (False, True):
            chosen = [r for r in records if not r.degenerate and min(r.weak, 2) == w and r.turned == turned]
            pooled_note = len(chosen) < MIN_CONDITION_SAMPLES
            if pooled_note:
                chosen = [r for r in records if not r.degenerate and min(r.weak, 2) == w]
            conditions[condition_name(w, turned)] = fit_condition(chosen, w, pooled_note)

    return {
        "statistic": {"name": "obstacle_points"},
        "degenerate": {"bin_edges": BIN_EDGES, "rate": smoothed_rates(hits_ok, totals_ok),
                       "rate_after_degenerate": smoothed_rates(hits_after, totals_after),
                       "count": [int(v) for v in totals_ok],
                       "count_after_degenerate": [int(v) for v in totals_after]},
        "weak_probabilities": weak_rows,
        "turn_threshold_deg": TURN_THRESHOLD_DEG,
        "max_span": int(matcher.max_span),
        "weak_sigma": float(matcher.weak_sigma),
        "off_plane_sigma": float(matcher.off_plane_sigma),
        "conditions": conditions,
        "fit": honesty(records),
    }


def fit_condition(chosen: list[Record], w: int, pooled: bool) -> dict:
    errors = np.array([r.error for r in chosen]).reshape(-1, 3)
    yaw_deg = np.rad2deg(errors[:, 0])
    translation, translation_z, angles, reported_t = [], [], [], []
    for r in chosen:
        if w == 0:
            sigmas = np.sqrt(np.diag(r.covariance)[1:])
            translation.extend(r.error[1:])
            translation_z.extend(r.error[1:] / sigmas)
            reported_t.append(float(np.sqrt(np.mean(sigmas**2))))
            continue
        u, v = weak_geometry(r.covariance, w)
        sigma = float(np.sqrt(v @ r.covariance[1:, 1:] @ v))
        translation.append(float(r.error[1:] @ v))
        translation_z.append(translation[-1] / sigma)
        angles.append(axis_angle_deg(u if w == 1 else v))
        reported_t.append(sigma)
    reported_yaw = np.array([float(np.rad2deg(np.sqrt(r.covariance[0, 0]))) for r in chosen])
    yaw_z = yaw_deg / np.maximum(reported_yaw, 1e-12)
    out = {
        "count": len(chosen),
        "yaw_deg": _rounded(fit_mixture(yaw_deg)),
        "translation": _rounded(fit_mixture(np.array(translation))),
        "reported_sigma_yaw_deg": round(float(np.median(reported_yaw)) if chosen else 0.0, 5),
        "reported_sigma_translation": round(float(np.median(reported_t)) if chosen else 0.0, 5),
        "error_std": {"yaw_deg": round(float(yaw_deg.std()) if len(chosen) else 0.0, 4),
                      "x_m": round(float(errors[:, 1].std()) if len(chosen) else 0.0, 5),
                      "y_m": round(float(errors[:, 2].std()) if len(chosen) else 0.0, 5),
                      "pooled_straight_and_turned": pooled},
    }
    if len(chosen):
        # The reported sigmas vary a lot within a condition (with the information of the
        # scan) and the errors scale with them: the model draws a sigma (yaw and
        # translation at the same quantile level) and a standardised error.
        out["reported_sigma_quantiles"] = {
            "levels": SIGMA_LEVELS,
            "yaw_deg": [round(float(v), 6) for v in np.quantile(reported_yaw, SIGMA_LEVELS)],
            "translation": [round(float(v), 6) for v in np.quantile(reported_t, SIGMA_LEVELS)]}
        out["yaw_z"] = _rounded(fit_mixture(yaw_z))
        out["translation_z"] = _rounded(fit_mixture(np.array(translation_z)))
    if w > 0:
        hist = np.histogram(angles, bins=ANGLE_EDGES)[0].astype(float) + 0.5  # no empty bin
        probabilities = np.round(hist / hist.sum(), 4)
        probabilities[-1] = round(1.0 - probabilities[:-1].sum(), 4)
        out["weak_angle_deg"] = {"edges": ANGLE_EDGES, "probabilities": [float(p) for p in probabilities]}
    return out


def _rounded(mixture: dict) -> dict:
    return {k: round(float(v), 6) for k, v in mixture.items()}


def honesty(records: list[Record]) -> dict:
    """Mahalanobis distances of usable matches' errors along their constrained directions."""
    d2, dof, p = [], [], []
    for r in records:
        if r.degenerate:
            continue
        values, vectors = np.linalg.eigh(r.covariance)
        strong = values < WEAK_SUBSPACE_VARIANCE
        if not strong.any():
            continue
        z = vectors[:, strong].T @ r.error / np.sqrt(values[strong])
        d2.append(float(z @ z))
        dof.append(int(strong.sum()))
        p.append(float(chi2.sf(d2[-1], dof[-1])))
    d2, dof, p = map(np.array, (d2, dof, p))
    usable = [r for r in records if not r.degenerate]
    errors = np.array([r.error for r in usable]).reshape(-1, 3)
    wheel = np.array([r.wheel_error for r in usable]).reshape(-1, 3)
    return {
        "matches": len(records),
        "degenerate_fraction": round(float(np.mean([r.degenerate for r in records])), 4),
        "mahalanobis_d2_per_dof": round(float(d2.sum() / max(dof.sum(), 1)), 3),
        "fraction_above_chi2_99": round(float(np.mean(p < 0.01)), 4),
        "median_p_value": round(float(np.median(p)), 3),
        "usable_error_std": {"yaw_deg": round(float(np.rad2deg(errors[:, 0].std())), 4),
                             "x_m": round(float(errors[:, 1].std()), 5),
                             "y_m": round(float(errors[:, 2].std()), 5)},
        "usable_error_p99": {"yaw_deg": round(float(np.rad2deg(np.percentile(np.abs(errors[:, 0]), 99))), 4),
                             "translation_m": round(float(np.percentile(np.hypot(errors[:, 1], errors[:, 2]), 99)), 5)},
        "wheel_error_std_same_spans": {"yaw_deg": round(float(np.rad2deg(wheel[:, 0].std())), 4),
                                       "x_m": round(float(wheel[:, 1].std()), 5),
                                       "y_m": round(float(wheel[:, 2].std()), 5)},
        "registration_ms_median": round(float(np.median([r.ms for r in records])), 2),
    }


# ------------------------------------------------------------------------------ main


class _NoAliases(yaml.SafeDumper):
    """Writes repeated lists in full (no YAML anchors)."""

    def ignore_aliases(self, data):
        return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tour-seeds", default="0-5")
    parser.add_argument("--explore-seeds", default="0-1")
    parser.add_argument("--scenes", default="office,street,garage")
    parser.add_argument("--max-decisions", type=int, default=40)
    parser.add_argument("--out", default=None, help=f"default {SCAN_MATCHING_FILE}")
    parser.add_argument("--quick", action="store_true", help="two tour seeds, no exploration")
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds: seed 0, the tour's first 2 goals, a 2-decision office exploration; "
                             "writes to a temporary directory unless --out is given")
    parser.add_argument("overrides", nargs="*", help="Hydra overrides for the icp runs")
    args = parser.parse_args()
    tour_seeds = [0, 1] if args.quick else seed_list(args.tour_seeds)
    explore_seeds = [] if args.quick else seed_list(args.explore_seeds)
    scenes = [s for s in args.scenes.split(",") if s]
    goals_limit = None
    if args.smoke:  # never overwrite the committed calibration
        tour_seeds, explore_seeds, scenes, args.max_decisions, goals_limit = [0], [0], ["office"], 2, 2
        args.out = args.out or str(Path(tempfile.mkdtemp(prefix="calibrate_scan_matching_smoke_"))
                                   / "scan_matching.yaml")
    args.out = args.out or str(SCAN_MATCHING_FILE)

    records, runs, config = collect(tour_seeds, explore_seeds, scenes, args.max_decisions, args.overrides,
                                    goals_limit)
    calibration = fit(records, config.slam.scan_matcher)
    calibration["statistic"].update(
        min_height=float(config.mapping.occupancy.obstacle_min_height),
        max_height=float(config.mapping.occupancy.obstacle_max_height),
        mount_height=float(config.lidar.mount_height))
    matcher = config.slam.scan_matcher
    calibration["provenance"] = {
        "command": "python scripts/calibrate_scan_matching.py " + " ".join(sys.argv[1:]),
        "date": datetime.date.today().isoformat(),
        "runs": runs,
        "scan_matcher": {k: getattr(matcher, k) for k in (
            "voxel_size", "drop_ground_below_z", "min_points", "min_inliers", "max_span",
            "min_information", "max_weak_directions", "covariance_scale",
            "min_sigma_translation", "min_sigma_rotation_deg")},
        "ssm_robust_kernel": config.slam.pose_graph.ssm_robust_kernel,
    }
    document = {"version": 1, **calibration}
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(HEADER + yaml.dump(document, Dumper=_NoAliases, sort_keys=False,
                                      default_flow_style=None, width=100))
    load_scan_matching(out)  # what we wrote must load
    print(yaml.safe_dump({"fit": calibration["fit"]}, sort_keys=False))
    print(f"wrote {out} ({len(records)} matches from {len(runs)} runs)")
    figures = ("matches", "degenerate_fraction", "mahalanobis_d2_per_dof", "fraction_above_chi2_99")
    print(json.dumps({"script": "calibrate_scan_matching", "quick": args.quick, "smoke": args.smoke,
                      "runs": len(runs), **{k: calibration["fit"][k] for k in figures}, "out": str(out)}),
          flush=True)


if __name__ == "__main__":
    main()
