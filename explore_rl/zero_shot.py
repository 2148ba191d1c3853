"""Issue 24's zero-shot targets checked on an ``explore-rl-eval`` report, with intervals.

The targets compare a policy (the learned one) with a reference (EM) on scenes neither was
tuned on: its **travel to reach the stop coverage** at most ``max_travel_ratio`` times the
reference's, its **map error at that point** at most ``max_error_ratio`` times the
reference's, and its decisions at least ``min_speedup`` times faster. Map error alone does
not rank policies (a policy that covers little keeps its error low), so every figure here
is taken at the same coverage:

* the **common coverage** of a scene: the stop coverage, or less if some trial of either
  policy never got there (EM often does not within the travel budget), i.e. the least any
  trial of the two explored, floored to a whole percent; every trial reached it;
* per trial, the travel to reach it (:func:`comparison.travel_to_reach`) and the map error
  there; the reference's map error also **at the policy's mean travel** (equal travel: the
  comparison of "lower map error at the same distance");
* a behaviour figure beside them: loop closures (plus one, so a run without any still has a
  ratio) per metre up to the common coverage, as a ratio of means -- the learned policies' map
  error is not told apart from EM's by ~20 explorations, their fewer closures per metre are
  (benchmarks/RESULTS.md, session 34); NaN for reports whose rows lack ``loop_closures``;
* ratios of means over trials, with 95 % percentile intervals from resampling each
  policy's trials independently (the trials of two policies are separate explorations),
  expanded for few trials (:mod:`explore_rl.intervals`; the smaller group's count).
  A target is met only when the whole interval is on the right side of it.

Several scenes are also pooled: the geometric mean of the per-scene ratios, the interval
from a two-stage resampling -- scenes, then each drawn scene's trials (a sweep over generated
buildings with one trial each resamples scenes only; two named scenes with ten trials each
keep both their trials' spread and the spread between them, so two similar scene ratios do
not make a narrow interval), its percentiles expanded for the number of scenes.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Callable, Sequence

import numpy as np

from explore_rl.comparison import travel_to_reach, value_at_travel
from explore_rl.intervals import percentile_levels

RESAMPLES = 2000


@dataclass(frozen=True)
class ZeroShotTargets:
    """The thresholds of issue 24's zero-shot target (travel and map error at the stop
    coverage within 10 % of EM's, decisions 5x faster)."""

    coverage: float = 0.85
    max_travel_ratio: float = 1.1
    max_error_ratio: float = 1.1
    min_speedup: float = 5.0


@dataclass(frozen=True)
class TrialPoint:
    """One trial at the common coverage: the travel to reach it, the map error there, the
    mean decision time, (loop closures + 1) per metre up to there, and the trial's (travel,
    map error) rows for equal-travel reads."""

    travel_m: float
    map_error_m: float
    ms_decide: float
    run: dict
    closures_per_m: float


def common_coverage(runs: Sequence[dict], target: float) -> float:
    """``target``, or the least final coverage of any trial in ``runs`` if lower, floored
    to a whole percent (so every trial reached it)."""
    least = min(max(row["explored"] for row in run["rows"]) for run in runs)
    return min(target, math.floor(100.0 * least + 1e-9) / 100.0)


def trial_point(run: dict, coverage: float) -> TrialPoint:
    travel = travel_to_reach(run, coverage)
    closures = value_at_travel(run, "loop_closures", travel) if "loop_closures" in run["rows"][0] else float("nan")
    return TrialPoint(travel, value_at_travel(run, "map_error_m", travel), float(run["ms_decide"]), run,
                      (closures + 1.0) / max(travel, 1e-9))


def _ratios(policy: Sequence[TrialPoint], reference: Sequence[TrialPoint]) -> dict[str, float]:
    """Travel, map-error, equal-travel map-error and decision-time ratios of two groups of trials."""
    travel = float(np.mean([p.travel_m for p in policy]))
    error = float(np.mean([p.map_error_m for p in policy]))
    reference_at_travel = float(np.mean([value_at_travel(p.run, "map_error_m", travel) for p in reference]))
    return {"travel_ratio": travel / float(np.mean([p.travel_m for p in reference])),
            "error_ratio": error / float(np.mean([p.map_error_m for p in reference])),
            "equal_travel_error_ratio": error / reference_at_travel,
            "closures_ratio": float(np.mean([p.closures_per_m for p in policy]))
            / float(np.mean([p.closures_per_m for p in reference])),
            "speedup": float(np.mean([p.ms_decide for p in reference])) / float(np.mean([p.ms_decide for p in policy]))}


def _interval(draws: Sequence[dict[str, float]], key: str, units: int) -> list[float]:
    """The 95 % interval of ``key`` over the bootstrap ``draws`` of ``units`` independent units."""
    values = np.array([d[key] for d in draws], dtype=float)
    values = values[np.isfinite(values)]
    if len(values) == 0:
        return [float("nan"), float("nan")]
    return [float(v) for v in np.percentile(values, percentile_levels(units))]


def _bootstrap(statistic: Callable[[np.random.Generator], dict[str, float]], resamples: int, seed: int
               ) -> list[dict[str, float]]:
    rng = np.random.default_rng(seed)
    with np.errstate(divide="ignore", invalid="ignore"):
        return [statistic(rng) for _ in range(resamples)]


def trials_to_resolve(ratio: float, interval: Sequence[float], trials: int, bound: float, upper: bool) -> float:
    """How many trials (scenes, for a pool) would put the 95 % interval on the target's side of
    ``bound`` (``upper``: below it) if the ratio held and the interval's half-width in log shrank
    as ``1/sqrt(n)``: a planning figure, not a result. ``inf`` when the ratio itself is on the
    wrong side (no number of trials shows it), ``nan`` without an interval."""
    low, high = interval
    if not (np.isfinite(low) and np.isfinite(high)):
        return float("nan")
    if (ratio >= bound) if upper else (ratio <= bound):
        return float("inf")
    half_width = math.log(high / ratio) if upper else math.log(ratio / low)
    margin = math.log(bound / ratio) if upper else math.log(ratio / bound)
    return float(math.ceil(trials * (half_width / margin) ** 2))


def _trials_needed(entry: dict, targets: ZeroShotTargets, trials: int) -> dict:
    return {"trials_to_resolve": {
        "travel": trials_to_resolve(entry["travel_ratio"], entry["travel_ratio_ci95"], trials,
                                    targets.max_travel_ratio, upper=True),
        "error": trials_to_resolve(entry["error_ratio"], entry["error_ratio_ci95"], trials,
                                   targets.max_error_ratio, upper=True),
        "speed": trials_to_resolve(entry["speedup"], entry["speedup_ci95"], trials, targets.min_speedup,
                                   upper=False)}}


SEVERAL_MACHINES = "several machines"


def decision_times_of(points: Sequence[TrialPoint]) -> str:
    """Where the trials' decision times were measured: ``one machine`` (every trial records
    the same processor), ``several machines`` (their ratio compares machines, not policies;
    also when only some trials record one: those come from code before session 59, whose
    decision time held the stop check's metrics) or ``unrecorded`` (no trial records it)."""
    cpus = {p.run.get("cpu") for p in points}
    if cpus == {None}:
        return "unrecorded"
    return "one machine" if len(cpus) == 1 else SEVERAL_MACHINES


def _verdicts(entry: dict, targets: ZeroShotTargets) -> dict:
    """A target is met only when its whole 95 % interval is on the right side (never
    without an interval); the speed target never on decision times of several machines."""
    return {"travel_met": bool(entry["travel_ratio_ci95"][1] <= targets.max_travel_ratio),
            "error_met": bool(entry["error_ratio_ci95"][1] <= targets.max_error_ratio),
            "speed_met": bool(entry["speedup_ci95"][0] >= targets.min_speedup)
            and entry["decision_times"] != SEVERAL_MACHINES}


KEYS = ("travel_ratio", "error_ratio", "equal_travel_error_ratio", "closures_ratio", "speedup")


def _scene_points(runs: Sequence[dict], policy: str, reference: str, targets: ZeroShotTargets
                  ) -> tuple[float, list[TrialPoint], list[TrialPoint]] | None:
    """One scene's common coverage and both policies' trial points there; None if either
    policy has no finished trial."""
    mine = [r for r in runs if r["policy"] == policy and r["status"] != "error" and r["rows"]]
    theirs = [r for r in runs if r["policy"] == reference and r["status"] != "error" and r["rows"]]
    if not mine or not theirs:
        return None
    coverage = common_coverage(mine + theirs, targets.coverage)
    return coverage, [trial_point(r, coverage) for r in mine], [trial_point(r, coverage) for r in theirs]


def _resample(points: Sequence[TrialPoint], rng: np.random.Generator) -> list[TrialPoint]:
    """The trials drawn with replacement (one trial stays itself, drawing nothing)."""
    if len(points) < 2:
        return list(points)
    return [points[i] for i in rng.integers(0, len(points), len(points))]


def scene_check(scene: str, coverage: float, points: Sequence[TrialPoint], reference_points: Sequence[TrialPoint],
                policy: str, reference: str, targets: ZeroShotTargets, resamples: int = RESAMPLES,
                seed: int = 0) -> dict:
    """The targets on one scene's trial points at its common ``coverage``."""
    entry = {"scene": scene, "policy": policy, "reference": reference, "coverage": coverage,
             "at_stop_coverage": bool(coverage >= targets.coverage), "trials": len(points),
             "reference_trials": len(reference_points),
             "decision_times": decision_times_of([*points, *reference_points]),
             "travel_m": float(np.mean([p.travel_m for p in points])),
             "reference_travel_m": float(np.mean([p.travel_m for p in reference_points])),
             "map_error_m": float(np.mean([p.map_error_m for p in points])),
             "reference_map_error_m": float(np.mean([p.map_error_m for p in reference_points])),
             **_ratios(points, reference_points)}
    entry["reference_map_error_at_equal_travel_m"] = entry["map_error_m"] / entry["equal_travel_error_ratio"]

    def resampled(rng: np.random.Generator) -> dict[str, float]:
        return _ratios(_resample(points, rng), _resample(reference_points, rng))

    units = min(len(points), len(reference_points))  # the smaller group's trials
    if units < 2:  # one trial has no spread: no interval, no verdict
        entry.update({f"{key}_ci95": [float("nan"), float("nan")] for key in KEYS})
    else:
        draws = _bootstrap(resampled, resamples, seed)
        entry.update({f"{key}_ci95": _interval(draws, key, units) for key in KEYS})
    return entry | _verdicts(entry, targets) | _trials_needed(entry, targets, units)


def pooled_check(entries: Sequence[dict], scenes: Sequence[tuple[list[TrialPoint], list[TrialPoint]]],
                 targets: ZeroShotTargets, resamples: int = RESAMPLES, seed: int = 0) -> dict:
    """The geometric mean of the per-scene ratios of ``entries``; the interval resamples
    scenes, then the trials (``scenes``: each entry's policy and reference trial points)."""
    logs = {key: np.log([e[key] for e in entries]) for key in KEYS}
    pooled = {"scene": f"all {len(entries)} scenes", "policy": entries[0]["policy"],
              "reference": entries[0]["reference"], "scenes": len(entries),
              "at_stop_coverage": all(e["at_stop_coverage"] for e in entries),
              "decision_times": decision_times_of([p for mine, theirs in scenes for p in (*mine, *theirs)]),
              **{key: float(np.exp(values.mean())) for key, values in logs.items()}}

    def resampled(rng: np.random.Generator) -> dict[str, float]:
        drawn = [_ratios(_resample(scenes[i][0], rng), _resample(scenes[i][1], rng))
                 for i in rng.integers(0, len(scenes), len(scenes))]
        return {key: float(np.exp(np.mean(np.log([d[key] for d in drawn])))) for key in KEYS}

    draws = _bootstrap(resampled, resamples, seed)
    pooled.update({f"{key}_ci95": _interval(draws, key, len(scenes)) for key in KEYS})
    return pooled | _verdicts(pooled, targets) | _trials_needed(pooled, targets, len(entries))


def check_targets(runs: Sequence[dict], policy: str = "learned", reference: str = "em",
                  targets: ZeroShotTargets = ZeroShotTargets(), resamples: int = RESAMPLES) -> list[dict]:
    """Per scene (and pooled over scenes when there are several), the zero-shot targets of
    ``policy`` against ``reference``; empty if the report lacks either policy."""
    entries, scenes = [], []
    for scene in sorted({r["scene"] for r in runs}):
        found = _scene_points([r for r in runs if r["scene"] == scene], policy, reference, targets)
        if found is not None:
            coverage, points, reference_points = found
            entries.append(scene_check(scene, coverage, points, reference_points, policy, reference, targets,
                                       resamples))
            scenes.append((points, reference_points))
    if len(entries) > 1:
        entries.append(pooled_check(entries, scenes, targets, resamples))
    return entries


def _ratio_cell(entry: dict, key: str) -> str:
    if not np.isfinite(entry[key]):
        return "n/a"  # e.g. loop closures of a report that did not record them
    low, high = entry[f"{key}_ci95"]
    interval = f" [{low:.2f}, {high:.2f}]" if np.isfinite(low) else " (one trial: no interval)"
    machines = f" ({SEVERAL_MACHINES})" if key == "speedup" and entry.get("decision_times") == SEVERAL_MACHINES else ""
    return f"{entry[key]:.2f}{interval}{machines}"


def targets_markdown(entries: Sequence[dict], targets: ZeroShotTargets = ZeroShotTargets()) -> str:
    """:func:`check_targets` as a Markdown table with the verdicts."""
    if not entries:
        return ""
    first = entries[0]
    lines = [f"Zero-shot targets, {first['policy']} against {first['reference']} (ratios of means, 95 % "
             f"intervals; met only if the whole interval is within: travel <= {targets.max_travel_ratio}x, "
             f"map error <= {targets.max_error_ratio}x, decisions >= {targets.min_speedup}x faster):", "",
             f"| scene | coverage % | travel m ({first['policy']} / {first['reference']}) | travel ratio | "
             f"map error m ({first['policy']} / {first['reference']}) | map error ratio | "
             f"{first['reference']} error at equal travel m | equal-travel error ratio | "
             f"loop closures per m ratio | speedup | met |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        met = ", ".join(name for name, key in (("travel", "travel_met"), ("error", "error_met"),
                                               ("speed", "speed_met")) if e[key]) or "none"
        if not np.isfinite(e["travel_ratio_ci95"][0]):
            met = "n/a"
        if "coverage" in e:
            coverage = f"{100 * e['coverage']:.0f}" + ("" if e["at_stop_coverage"] else " (below stop)")
            travel = f"{e['travel_m']:.1f} / {e['reference_travel_m']:.1f}"
            error = f"{e['map_error_m']:.3f} / {e['reference_map_error_m']:.3f}"
            equal = f"{e['reference_map_error_at_equal_travel_m']:.3f}"
        else:
            coverage, travel, error, equal = "per scene", "", "", ""
        lines.append(f"| {e['scene']} | {coverage} | {travel} | {_ratio_cell(e, 'travel_ratio')} | {error} | "
                     f"{_ratio_cell(e, 'error_ratio')} | {equal} | {_ratio_cell(e, 'equal_travel_error_ratio')} | "
                     f"{_ratio_cell(e, 'closures_ratio')} | {_ratio_cell(e, 'speedup')} | {met} |")
    resolvable = [e for e in entries if np.isfinite(e["travel_ratio_ci95"][0])]
    if resolvable:
        lines += ["", "Trials per policy (scenes, for a pool) that would put each interval within its target if "
                  "the ratio held and the interval shrank as 1/sqrt(n) (a planning figure; never: the ratio "
                  "itself misses the target):", "", "| scene | trials now | travel | map error | speedup |",
                  "|---|---|---|---|---|"]
        for e in resolvable:
            now = e.get("scenes", min(e.get("trials", 0), e.get("reference_trials", 0)))
            cells = [_trials_cell(e["trials_to_resolve"][key]) for key in ("travel", "error", "speed")]
            lines.append(f"| {e['scene']} | {now} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _trials_cell(trials: float) -> str:
    return "never" if trials == float("inf") else f"{trials:.0f}"


def targets_json(entries: Sequence[dict], targets: ZeroShotTargets = ZeroShotTargets()) -> dict:
    return {"targets": asdict(targets), "entries": list(entries)}
