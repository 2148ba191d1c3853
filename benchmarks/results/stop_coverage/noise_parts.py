"""How much of the protocol's spread is trial noise, and how many buildings or trials a target needs (plan.md,
session 76; descriptive).

On a pool where EM ran twice (``--em-first``, ``--em-second``: folders of ``building_SEED/trials.jsonl``), every
building's two EM trials give the noise of one trial: half the variance of the log difference of their map errors
(and of their travels) at the building's common coverage. Each ``--variant NAME=FOLDER`` (its learned trials on the
same buildings) is read against the mean log of EM's two trials: its mean log ratio, its spread over buildings, the
spread that trial noise alone would give if its own trials were as noisy as EM's (1.5 x EM's one-trial variance),
and the excess (a building-specific loss or gain; 95 % bootstrap interval over buildings). ``--scene
NAME=FILE[:POLICY]`` (a named scene's trials.jsonl, default policy em) gives the coefficient of variation of one
trial's map error and travel at the trials' common coverage, the ratio-of-means statistic the scenes use.

Last line, the planning table: how many buildings (one trial per policy, against one or two EM trials) and how
many trials per scene (against the given scenes' own number of EM trials, and against 200) put the upper 95 %
bound of the map-error ratio at or below 1.10 if the true ratio is 1.00, 1.03 or 1.05 (normal approximation in
log; a planning figure, not a result). Its ``screen`` part (session 77) gives, from the same one-trial noise, the
probability that a candidate of true ratio 0.90-1.10 passes session 76's validation screen (point estimate <=
``--screen`` on ``--validation-buildings`` with ``--validation-trials`` per building and policy) and then the
held-out rule (upper bound <= 1.10 on ``--test-buildings`` with ``--test-trials`` per building and policy), for map
error and travel apart, and that it passes the rule in each ``--scene`` with ``--scene-trials`` of its own against
``--scene-reference`` of EM's (the scene's coefficient of variation for both). The building counts above are where
the expected upper bound meets 1.10: about even odds, not a sure pass.

    python benchmarks/results/stop_coverage/noise_parts.py --em-first runs/val runs/val2 \
        --em-second runs/em_replicate_val90 --variant dagger9k=runs/dagger9k_val90 \
        --scene garage=runs/street_garage50/1_garage/trials.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from explore_rl import zero_shot
from explore_rl.comparison import read_trials

COVERAGE = 0.85  # the protocol's stop coverage
BOUND = 1.10  # the ratio target
TRUE_RATIOS = (1.00, 1.03, 1.05)
SCREEN_RATIOS = (0.90, 0.95, 1.00, 1.03, 1.05, 1.10)  # the true ratios the screen's pass probabilities are given for
Z95 = 1.96
RESAMPLES = 2000


def first_trial(folder: Path, building: str, policy: str) -> dict | None:
    path = folder / building / "trials.jsonl"
    if not path.exists():
        return None
    trials = [t for t in read_trials(path) if t.get("policy") == policy and t.get("rows")]
    return trials[0] if trials else None


def log_point(run: dict, coverage: float) -> tuple[float, float]:
    """log travel and log map error of a trial at ``coverage``."""
    point = zero_shot.trial_point(run, coverage)
    return math.log(point.travel_m), math.log(point.map_error_m)


def building_logs(first: list[Path], second: Path, variants: dict[str, Path]
                  ) -> tuple[list[str], np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """The buildings every run finished, EM's two trials' and each variant's (log travel, log map error) there,
    all at one common coverage per building."""
    buildings, em_a, em_b, theirs = [], [], [], {name: [] for name in variants}
    for path in sorted(second.glob("building_*/trials.jsonl")):
        building = path.parent.name
        a = next((t for f in first if (t := first_trial(f, building, "em")) is not None), None)
        b = first_trial(second, building, "em")
        mine = {name: first_trial(folder, building, "learned") for name, folder in variants.items()}
        if a is None or b is None or any(m is None for m in mine.values()):
            continue
        coverage = zero_shot.common_coverage([a, b, *mine.values()], COVERAGE)
        buildings.append(building)
        em_a.append(log_point(a, coverage))
        em_b.append(log_point(b, coverage))
        for name, run in mine.items():
            theirs[name].append(log_point(run, coverage))
    return buildings, np.array(em_a), np.array(em_b), {k: np.array(v) for k, v in theirs.items()}


def one_trial_variance(em_a: np.ndarray, em_b: np.ndarray) -> np.ndarray:
    """Per column (log travel, log map error): the variance of one trial, half that of the two trials' difference."""
    return np.var(em_a - em_b, axis=0, ddof=1) / 2.0


def variant_entry(name: str, mine: np.ndarray, em_a: np.ndarray, em_b: np.ndarray, rng: np.random.Generator) -> dict:
    """A variant's log map-error ratio to EM's two-trial mean: its mean, spread, the spread noise alone gives and
    the excess variance (bootstrap over buildings)."""
    def parts(index: np.ndarray) -> tuple[float, float]:
        ratio = mine[index, 1] - (em_a[index, 1] + em_b[index, 1]) / 2.0
        noise = one_trial_variance(em_a[index], em_b[index])[1]
        return float(np.var(ratio, ddof=1)), float(noise)

    every = np.arange(len(mine))
    variance, noise = parts(every)
    draws = [parts(rng.integers(0, len(mine), len(mine))) for _ in range(RESAMPLES)]
    excess = [v - 1.5 * n for v, n in draws]
    ratio = mine[:, 1] - (em_a[:, 1] + em_b[:, 1]) / 2.0
    return {"variant": name, "buildings": len(mine), "error_ratio_geomean": round(math.exp(float(ratio.mean())), 4),
            "log_error_ratio_sd": round(math.sqrt(variance), 4),
            "log_error_ratio_sd_from_noise": round(math.sqrt(1.5 * noise), 4),
            "excess_variance": round(variance - 1.5 * noise, 4),
            "excess_variance_ci95": [round(float(q), 4) for q in np.percentile(excess, [2.5, 97.5])]}


def scene_entry(name: str, paths: list[Path], policy: str) -> dict:
    """One named scene's trials (from one or more files): the coefficient of variation of one trial's map error and
    travel."""
    runs = [t for path in paths for t in read_trials(path) if t.get("policy") == policy and t.get("rows")]
    if len(runs) < 2:
        raise SystemExit(f"--scene {name}: {'+'.join(map(str, paths))} holds {len(runs)} finished {policy} "
                         "trial(s); give at least two")
    coverage = zero_shot.common_coverage(runs, COVERAGE)
    points = [zero_shot.trial_point(r, coverage) for r in runs]
    errors, travels = np.array([p.map_error_m for p in points]), np.array([p.travel_m for p in points])
    return {"scene": name, "policy": policy, "trials": len(runs), "coverage": coverage,
            "map_error_cv": round(float(errors.std(ddof=1) / errors.mean()), 4),
            "travel_cv": round(float(travels.std(ddof=1) / travels.mean()), 4)}


def units_needed(sd_one: float, true_ratio: float, reference_share: float) -> int:
    """Units (buildings or trials) whose pooled log ratio, with one unit's variance ``sd_one**2 * (1 +
    reference_share)``, has its upper 95 % bound at ``BOUND`` when the truth is ``true_ratio``."""
    margin = math.log(BOUND / true_ratio)
    return int(math.ceil((Z95 * sd_one * math.sqrt(1.0 + reference_share) / margin) ** 2))


def trials_needed(cv: float, true_ratio: float, reference_trials: int) -> int | None:
    """Policy trials in a scene for the ratio of means to show <= ``BOUND`` against ``reference_trials`` of EM's
    with the same coefficient of variation; None if no number of policy trials is enough."""
    margin = (math.log(BOUND / true_ratio) / Z95) ** 2  # the variance the log ratio may have
    left = margin - cv ** 2 / reference_trials
    return int(math.ceil(cv ** 2 / left)) if left > 0 else None


def chance_at_most(limit: float, truth: float, sd: float) -> float:
    """P(X <= limit) for X normal about ``truth`` with ``sd`` (a step where the sd is 0)."""
    if sd == 0:
        return float(truth <= limit)
    return 0.5 * (1.0 + math.erf((limit - truth) / (sd * math.sqrt(2.0))))


def chance_bound_passes(true_ratio: float, sd: float) -> float:
    """The chance that a pooled log ratio with ``sd`` about log ``true_ratio`` has its upper 95 % bound at or below
    log ``BOUND`` (the held-out and named-scene rule)."""
    return chance_at_most(math.log(BOUND) - Z95 * sd, math.log(true_ratio), sd)


def pass_probabilities(sd_one: float, true_ratio: float, screen: float, validation: int, test: int,
                       test_trials: int = 1, validation_trials: int = 1) -> dict:
    """The chance that a candidate of ``true_ratio`` passes the screen (its pooled log ratio over ``validation``
    buildings with ``validation_trials`` per building and policy at or below log ``screen``) and the held-out rule
    (the upper 95 % bound over ``test`` buildings with ``test_trials`` per building and policy at or below log
    ``BOUND``); normal approximation in log."""
    def spread(buildings: int, trials: int) -> float:
        return sd_one * math.sqrt(2.0 / (buildings * trials))

    screen_p = chance_at_most(math.log(screen), math.log(true_ratio), spread(validation, validation_trials))
    test_p = chance_bound_passes(true_ratio, spread(test, test_trials))
    return {"passes_screen": round(screen_p, 3), "passes_test": round(test_p, 3), "both": round(screen_p * test_p, 3)}


def scene_pass_probability(cv: float, true_ratio: float, trials: int, reference_trials: int) -> float:
    """The chance that the ratio of means over ``trials`` against ``reference_trials`` of EM's (both with the
    coefficient of variation ``cv``) has its upper 95 % bound at or below ``BOUND`` (normal approximation in log)."""
    return round(chance_bound_passes(true_ratio, cv * math.sqrt(1.0 / trials + 1.0 / reference_trials)), 3)


def screen_table(noise_sd: np.ndarray, screen: float, validation: int, test: int, scenes: list[dict],
                 scene_trials: int, scene_reference: int, test_trials: int = 1, validation_trials: int = 1) -> dict:
    """:func:`pass_probabilities` for travel and map error apart (their log sds ``noise_sd``) at each true ratio,
    and :func:`scene_pass_probability` of the map error in each scene."""
    table = {"screen": screen, "validation_buildings": validation, "test_buildings": test,
             "validation_trials_per_building": validation_trials, "test_trials_per_building": test_trials,
             "scene_trials": scene_trials, "scene_reference_trials": scene_reference}
    keys = {f"{r:.2f}": r for r in SCREEN_RATIOS}
    for column, name in enumerate(("travel", "map_error")):
        table[name] = {key: pass_probabilities(float(noise_sd[column]), r, screen, validation, test, test_trials,
                                               validation_trials) for key, r in keys.items()}
    every = {key: table["map_error"][key]["both"] for key in keys}  # screen, pool and scenes, taken as independent
    for scene in scenes:
        chances = {key: scene_pass_probability(scene["map_error_cv"], r, scene_trials, scene_reference)
                   for key, r in keys.items()}
        table[f"{scene['scene']}_map_error"] = chances
        every = {key: p * chances[key] for key, p in every.items()}
    table["map_error_every_part"] = {key: round(p, 3) for key, p in every.items()}
    return table


def planning(noise_sd: float, scenes: list[dict]) -> dict:
    table = {"bound": BOUND, "em_one_trial_log_error_sd": round(noise_sd, 4), "buildings": {}, "scenes": {}}
    for r in TRUE_RATIOS:
        table["buildings"][f"{r:.2f}"] = {"one_em_trial": units_needed(noise_sd, r, 1.0),
                                          "two_em_trials": units_needed(noise_sd, r, 0.5)}
        for scene in scenes:
            table["scenes"].setdefault(scene["scene"], {})[f"{r:.2f}"] = {
                f"vs_{scene['trials']}_em": trials_needed(scene["map_error_cv"], r, scene["trials"]),
                "vs_200_em": trials_needed(scene["map_error_cv"], r, 200)}
    return table


def named(text: str, flag: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(f"{flag} {text!r}: give NAME=PATH")
    return name, value


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--em-first", nargs="+", type=Path, required=True, metavar="FOLDER",
                        help="EM's first trials (building_SEED/trials.jsonl), one or more folders")
    parser.add_argument("--em-second", type=Path, required=True, metavar="FOLDER", help="EM's second trials")
    parser.add_argument("--variant", action="append", default=[], metavar="NAME=FOLDER",
                        type=lambda t: named(t, "--variant"), help="a variant's learned trials on the same buildings")
    parser.add_argument("--scene", action="append", default=[], metavar="NAME=FILE[+FILE][:POLICY]",
                        type=lambda t: named(t, "--scene"),
                        help="a named scene's trials.jsonl, or several joined by + (default policy em)")
    parser.add_argument("--screen", type=float, default=1.03, help="the validation screen's point-estimate limit")
    parser.add_argument("--validation-buildings", type=int, default=90, help="buildings the screen reads")
    parser.add_argument("--test-buildings", type=int, default=200, help="buildings of the held-out pool")
    parser.add_argument("--validation-trials", type=int, default=1, help="trials per validation building and policy")
    parser.add_argument("--test-trials", type=int, default=1, help="trials per held-out building and policy")
    parser.add_argument("--scene-trials", type=int, default=120, help="a candidate's trials per named scene")
    parser.add_argument("--scene-reference", type=int, default=200, help="EM's trials per named scene")
    args = parser.parse_args(argv)
    if args.screen <= 0:
        parser.error(f"--screen {args.screen}: give a positive ratio (session 76's screen: 1.03)")
    if min(args.validation_buildings, args.validation_trials, args.test_buildings, args.test_trials,
           args.scene_trials, args.scene_reference) < 1:
        parser.error("--validation-buildings, --validation-trials, --test-buildings, --test-trials, --scene-trials "
                     "and --scene-reference: give at least 1 building or trial each")
    for folder in [*args.em_first, args.em_second, *(Path(f) for _, f in args.variant)]:
        if not folder.is_dir():
            parser.error(f"{folder}: not a folder; give a folder of building_SEED/trials.jsonl")
    if len({n for n, _ in args.variant}) != len(args.variant):
        parser.error("--variant: two variants share a NAME; give each its own")
    scenes = []
    for name, value in args.scene:
        files, _, policy = value.partition(":")
        paths = [Path(f) for f in files.split("+")]
        for path in paths:
            if not path.is_file():
                parser.error(f"--scene {name}: {path} is no file; give a named scene's trials.jsonl")
        scenes.append(scene_entry(name, paths, policy or "em"))
    variants = {name: Path(folder) for name, folder in args.variant}
    buildings, em_a, em_b, theirs = building_logs(args.em_first, args.em_second, variants)
    if len(buildings) < 3:
        parser.error(f"{len(buildings)} building(s) have both EM trials and every variant's; give runs of the "
                     "same pool (at least 3)")
    noise = one_trial_variance(em_a, em_b)
    rng = np.random.default_rng(0)
    print(json.dumps({"buildings": len(buildings), "em_one_trial_log_error_sd": round(math.sqrt(noise[1]), 4),
                      "em_one_trial_log_travel_sd": round(math.sqrt(noise[0]), 4),
                      "em_second_over_first_geomean": round(math.exp(float((em_b - em_a)[:, 1].mean())), 4)}))
    for name, mine in theirs.items():
        print(json.dumps(variant_entry(name, mine, em_a, em_b, rng)))
    for scene in scenes:
        print(json.dumps(scene))
    table = planning(math.sqrt(noise[1]), scenes)
    table["screen"] = screen_table(np.sqrt(noise), args.screen, args.validation_buildings, args.test_buildings,
                                   scenes, args.scene_trials, args.scene_reference, args.test_trials,
                                   args.validation_trials)
    print(json.dumps(table))


if __name__ == "__main__":
    main()
