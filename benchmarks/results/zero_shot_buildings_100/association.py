"""Does the learned policy's map error, relative to EM's, go with how often it closes loops relative to EM?

The learned policies close fewer loops per metre than EM in every whole-exploration check so far, and the
zero-shot map-error target is not met; whether the first explains the second decides what to try next
(a policy that revisits more, or something else). Across paired scenes of ``explore-rl-eval`` reports
(one trial per scene and policy, as the held-out building sweeps), at the coverage both reach
(:func:`explore_rl.zero_shot.common_coverage`, as the zero-shot check): per scene the log ratios of the
policy's figures over the reference's -- map error there, (loop closures + 1) per metre up to there,
travel to reach it -- and their rank correlations, with 95 % intervals from resampling scenes (expanded
for the number of scenes, :mod:`explore_rl.intervals`). Also the geometric-mean map-error ratio of the
scenes where the policy closed at least as many loops per metre as the reference and of the others.
Descriptive: an association across scenes, not a cause.

    python benchmarks/results/zero_shot_buildings_100/association.py REPORT [REPORT ...] \
        [--policy learned] [--reference em] [--resamples 2000]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy.stats import spearmanr

from explore_rl.intervals import percentile_levels
from explore_rl.zero_shot import ZeroShotTargets, common_coverage, trial_point

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from study_zero_shot import read_report  # noqa: E402  (benchmarks/: how the zero-shot study reads a report)

FIGURES = {"error": "map_error_m", "closures": "closures_per_m", "travel": "travel_m"}  # name -> TrialPoint field


def paired_trials(reports: list[Path], policy: str, reference: str) -> dict[str, tuple[dict, dict]]:
    """Scene -> (the policy's trial, the reference's trial), for every scene of ``reports`` with both (one
    trial per scene and policy, as the building sweeps run; of several, the last read)."""
    by_scene: dict[str, dict[str, dict]] = {}
    for report in reports:
        for run in read_report(report):
            by_scene.setdefault(run["scene"], {})[run["policy"]] = run
    return {scene: (runs[policy], runs[reference]) for scene, runs in sorted(by_scene.items())
            if policy in runs and reference in runs}


def log_ratios(pairs: dict[str, tuple[dict, dict]], stop_coverage: float) -> dict[str, np.ndarray]:
    """Per figure, the scenes' log ratios of the policy's value over the reference's, at the common coverage."""
    out: dict[str, list[float]] = {key: [] for key in FIGURES}
    for mine, theirs in pairs.values():
        coverage = common_coverage([mine, theirs], stop_coverage)
        a, b = trial_point(mine, coverage), trial_point(theirs, coverage)
        for key, field in FIGURES.items():
            out[key].append(math.log(getattr(a, field) / getattr(b, field)))
    return {key: np.array(values) for key, values in out.items()}


def rank_correlation(x: np.ndarray, y: np.ndarray, resamples: int, seed: int = 0) -> tuple[float, list[float]]:
    """Spearman's rho of ``x`` and ``y`` and its 95 % interval from resampling scenes; NaN where a figure
    does not vary (no ranks to correlate)."""
    if np.ptp(x) == 0 or np.ptp(y) == 0:
        return float("nan"), [float("nan"), float("nan")]
    rho = float(spearmanr(x, y).statistic)
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(resamples):
        pick = rng.integers(0, len(x), len(x))
        if np.ptp(x[pick]) > 0 and np.ptp(y[pick]) > 0:
            draws.append(spearmanr(x[pick], y[pick]).statistic)
    if not draws:  # every resample left a figure constant
        return rho, [float("nan"), float("nan")]
    low, high = np.percentile(draws, percentile_levels(len(x)))
    return rho, [float(low), float(high)]


def split_by_closures(ratios: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """The geometric-mean map-error ratio of the scenes where the policy closed at least as many loops per
    metre as the reference (``closes_as_many``) and of the others (``closes_fewer``)."""
    as_many = ratios["closures"] >= 0.0
    return {name: {"scenes": int(mask.sum()),
                   "error_ratio": float(math.exp(ratios["error"][mask].mean())) if mask.any() else float("nan")}
            for name, mask in (("closes_as_many", as_many), ("closes_fewer", ~as_many))}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reports", nargs="+", type=Path, help="explore-rl-eval output folders")
    parser.add_argument("--policy", default="learned", help="the policy checked (default learned)")
    parser.add_argument("--reference", default="em", help="the policy it is compared with (default em)")
    parser.add_argument("--resamples", type=int, default=2000, help="bootstrap resamples")
    args = parser.parse_args(argv)
    for report in args.reports:
        if not report.is_dir():
            parser.error(f"report {report} is not a folder: pass explore-rl-eval output folders")
    if args.resamples < 1:
        parser.error(f"--resamples={args.resamples}: pass a positive count")
    return args


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    pairs = paired_trials(args.reports, args.policy, args.reference)
    if len(pairs) < 3:
        sys.exit(f"association.py: {len(pairs)} scenes with a trial of both '{args.policy}' and "
                 f"'{args.reference}' in {', '.join(map(str, args.reports))}: pass reports holding both policies")
    ratios = log_ratios(pairs, ZeroShotTargets().coverage)
    result: dict = {"scenes": len(pairs)}
    print(f"{len(pairs)} scenes, {args.policy} over {args.reference} at the coverage both reach")
    for key in FIGURES:
        values = ratios[key]
        result[f"{key}_ratio"] = float(math.exp(values.mean()))
        result[f"{key}_sd_log"] = float(values.std(ddof=1))
        print(f"  {key:9s} geometric-mean ratio {result[f'{key}_ratio']:.3f}  (sd of log ratio "
              f"{result[f'{key}_sd_log']:.2f})")
    for other in ("closures", "travel"):
        rho, interval = rank_correlation(ratios[other], ratios["error"], args.resamples)
        result[f"rho_error_{other}"], result[f"rho_error_{other}_ci95"] = rho, interval
        print(f"  Spearman rho(map-error ratio, {other} ratio) = {rho:+.2f} [{interval[0]:+.2f}, {interval[1]:+.2f}]")
    result["by_closures"] = split_by_closures(ratios)
    for name, entry in result["by_closures"].items():
        print(f"  {name:15s} {entry['scenes']:3d} scenes, map-error ratio {entry['error_ratio']:.3f}")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
