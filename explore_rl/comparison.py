"""Policies compared over trials: explorations in parallel worker processes, every decision
recorded, a table of means and spreads, and the paper's plots (Fig. 6: map error and 3D
occupied volume against travel distance).

Shared by ``explore-rl-eval`` (explore_rl/cli.py) and ``benchmarks/study_ordering.py``:

* :class:`Trial` / :func:`trial_config`: one exploration -- a policy on a scene from the
  scene's default start, seeded ``config.seed + trial``;
* :func:`run_trial`: a module-level (picklable) job; a failing trial is reported, not raised;
* :func:`run_trials`: serial (``workers=1``) or spawned worker processes, same results,
  a progress bar over trials;
* :func:`log_trial` / :func:`finished_trials` / :func:`restart_log`: each finished trial appended to a log as it
  comes (``explore-rl-eval`` keeps :data:`PARTIAL` in its output folder), so a study that is
  stopped or crashes resumes with the trials it still lacks instead of starting over;
* :func:`summarise`, :func:`markdown_table`, :func:`decision_rows`, :func:`plot_metric`,
  :func:`write_report`: the table (mean and std per scene and policy), the CSV of every
  decision, the plots (one line per policy: the mean over trials, a band of +-1 std);
* :func:`matched_travel`: every policy's map error after the same distance (EM's mean
  final travel), since policies stop after different distances.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import logging
import multiprocessing
import os
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable, Sequence

import numpy as np

from explore_rl.run_config import POLICIES as POLICIES  # the configs live there
from explore_rl.run_config import EvaluateConfig as EvaluateConfig

if TYPE_CHECKING:
    from explore_rl.config import Config

log = logging.getLogger(__name__)

COLOURS = {"learned": "tab:green", "em": "tab:red", "nearest": "tab:blue", "random": "tab:gray"}
# final figures of a trial summarised per (scene, policy): key, column title, scale, format
SUMMARY_COLUMNS = (
    ("map_error_m", "map error m", 1.0, "{:.3f}"),
    ("volume_m3", "3D volume m3", 1.0, "{:.1f}"),
    ("travel_m", "travel m", 1.0, "{:.1f}"),
    ("explored", "explored %", 100.0, "{:.1f}"),
    ("explored_per_m", "explored %/m", 100.0, "{:.2f}"),
    ("loop_closures", "loop closures", 1.0, "{:.1f}"),
    ("ms_decide", "decision ms", 1.0, "{:.0f}"),
    ("contacts", "contacts", 1.0, "{:.1f}"),
    ("blocked_decisions", "blocked", 1.0, "{:.1f}"),
    ("min_clearance_m", "min clearance m", 1.0, "{:.3f}"),
)
EXTRA_KEYS = ("ate_m", "decisions", "safety_interventions", "capped_paths")


# ---------------------------------------------------------------------- trials


@dataclass
class Trial:
    """One exploration to run: its full config (policy and seed set) and its labels."""

    config: Config
    trial: int

    @property
    def policy(self) -> str:
        return self.config.policy.name

    @property
    def scene(self) -> str:
        return self.config.scene.name


def trial_config(config: Config, policy: str, trial: int) -> Config:
    """``config`` with ``policy`` choosing and seed ``config.seed + trial`` (the scene's
    default start, ``scene.start_index``, as in the paper)."""
    return dataclasses.replace(config, seed=int(config.seed) + int(trial),
                               policy=dataclasses.replace(config.policy, name=policy))


def make_trials(config: Config, policies: Sequence[str], trials: int, first: int = 0) -> list[Trial]:
    """Trials ``first .. first + trials - 1`` of every policy, trial-major (every policy of the
    first trial first), so a partial run is balanced; trial ``t`` is seeded ``config.seed + t``
    in the scene ``config`` holds, so more trials of a study are ``first`` = the trials it has."""
    return [Trial(trial_config(config, policy, t), t) for t in range(first, first + trials) for policy in policies]


def scene_label(config: Config) -> str:
    """The scene's name (a scene file's stem for ``scene=file``, ``building_<seed>`` for a building)."""
    if config.scene.name == "file" and config.scene.path:
        return Path(config.scene.path).stem
    if config.scene.name == "building":  # one plan per seed: keep them apart in a sweep
        return f"building_{config.scene.seed}"
    return config.scene.name


def cpu_model() -> str:
    """The processor's model name (Linux ``/proc/cpuinfo``, else :mod:`platform`'s guess): each
    trial records it, so decision times from different machines are not divided by each other."""
    try:
        with open("/proc/cpuinfo") as info:
            for line in info:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform

    return platform.processor() or platform.machine()


def run_trial(trial: Trial) -> dict:
    """Explore once; the decision table and final figures. An exception is caught and
    reported (``status: "error"``) so one bad trial does not lose a study."""
    from explore_rl.runner import Explorer

    base = {"scene": scene_label(trial.config), "policy": trial.policy, "trial": trial.trial,
            "seed": int(trial.config.seed), "cpu": cpu_model()}
    try:
        explorer = Explorer(trial.config)
        result = explorer.run()
    except Exception as error:  # noqa: BLE001 -- reported in the table, logged with its traceback
        log.error("%s %s trial %d failed:\n%s", base["scene"], base["policy"], trial.trial, traceback.format_exc())
        return {**base, "status": "error", "error": f"{type(error).__name__}: {error}", "rows": []}
    rows = result.table()
    last = rows[-1] if rows else {}
    travel = float(explorer.robot.travelled)
    finals = {key: last.get(key, 0.0) for key in ("explored", "map_error_m", "volume_m3", "loop_closures", "ate_m",
                                                  "contacts", "blocked_decisions", "safety_interventions",
                                                  "capped_paths")}
    finals["min_clearance_m"] = float(last.get("min_clearance_m", float("nan")))
    hybrid = {"em_decisions": explorer.policy.em_decisions} if hasattr(explorer.policy, "em_decisions") else {}
    return {**base, "status": result.status.value, "error": None, "decisions": len(rows), "travel_m": travel,
            **finals, "ms_decide": float(np.mean([r["ms_decide"] for r in rows])) if rows else float("nan"),
            "explored_per_m": finals["explored"] / max(travel, 1e-9), **hybrid, "rows": rows}


def _init_worker(threads: int) -> None:
    import torch

    torch.set_num_threads(threads)


@contextmanager
def _torch_threads(threads: int):
    """Torch's intra-op threads set to ``threads`` for trials run in this process (as the
    workers' initialiser sets theirs), the caller's count restored after. The BLAS of an
    already imported numpy keeps its own: set ``OPENBLAS_NUM_THREADS`` before starting."""
    import torch

    saved = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(saved)


@contextmanager
def _thread_limits(threads: int):
    """BLAS/OpenMP thread counts for the worker processes spawned inside (the parent's
    libraries are already initialised; the variables only reach new processes)."""
    names = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
    saved = {name: os.environ.get(name) for name in names}
    for name in names:
        os.environ.setdefault(name, str(threads))
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def run_trials(trials: Sequence[Trial], workers: int = 1, threads: int = 1, progress: bool = True,
               on_result: Callable[[dict], None] | None = None, desc: str = "trials") -> list[dict]:
    """Run every trial, in spawned worker processes when ``workers > 1`` (the same results
    either way: everything in a trial is seeded). ``on_result`` sees each finished trial
    (e.g. to log it). Results come back in the order of ``trials``."""
    from tqdm import tqdm

    results: list[dict | None] = [None] * len(trials)
    bar = tqdm(total=len(trials), desc=desc, disable=not progress, unit="trial")

    def finished(i: int, result: dict) -> None:
        results[i] = result
        if on_result is not None:
            on_result(result)
        bar.set_postfix_str(f"{result['scene']} {result['policy']} #{result['trial']}: {result['status']}")
        bar.update(1)

    try:
        if workers <= 1 or len(trials) <= 1:
            with _torch_threads(threads):
                for i, trial in enumerate(trials):
                    finished(i, run_trial(trial))
        else:
            context = multiprocessing.get_context("spawn")
            with _thread_limits(threads), ProcessPoolExecutor(max_workers=workers, mp_context=context,
                                                              initializer=_init_worker, initargs=(threads,)) as pool:
                futures = {pool.submit(run_trial, trial): i for i, trial in enumerate(trials)}
                for future in as_completed(futures):
                    finished(futures[future], future.result())
    finally:
        bar.close()
    return [r for r in results if r is not None]


# ---------------------------------------------------------------------- resuming

# explore-rl-eval's log of the trials finished so far (removed once the report is written)
PARTIAL = "trials.partial.jsonl"


def trial_key(item: Trial | dict) -> tuple[str, int, int]:
    """``(policy, trial, seed)`` of a :class:`Trial` or of a finished trial's record."""
    if isinstance(item, Trial):
        return item.policy, int(item.trial), int(item.config.seed)
    return str(item["policy"]), int(item["trial"]), int(item["seed"])


def log_trial(path: Path, run: dict) -> None:
    """Append one finished trial to ``path`` (one JSON object a line), flushed at once."""
    with open(path, "a") as handle:
        handle.write(json.dumps(run) + "\n")
        handle.flush()
        os.fsync(handle.fileno())


def finished_trials(path: Path) -> dict[tuple[str, int, int], dict]:
    """The trials :func:`log_trial` wrote to ``path``, by :func:`trial_key` (none if there is no
    such file). A last line cut short by a crash is left out, with a warning; a damaged line
    before it is refused in one line (the log is not this module's)."""
    path = Path(path)
    if not path.exists():
        return {}
    lines = [line for line in path.read_text().splitlines() if line.strip()]
    found = {}
    for number, line in enumerate(lines, start=1):
        try:
            run = json.loads(line)
        except json.JSONDecodeError:
            if number == len(lines):
                log.warning("%s: its last line is cut short (the run stopped while writing it); that trial runs again",
                            path)
                break
            raise ValueError(f"{path}: line {number} is not a trial record; delete the file to start the trials over")
        found[trial_key(run)] = run
    return found


def write_trials(path: Path, runs: Iterable[dict]) -> None:
    """``runs`` to ``path``, one JSON object a line (what :func:`read_trials` reads)."""
    Path(path).write_text("".join(json.dumps(run) + "\n" for run in runs))


def restart_log(path: Path, runs: Iterable[dict]) -> None:
    """Rewrite the log ``path`` with ``runs`` only (what :func:`finished_trials` kept): a last
    line cut short by a crash would otherwise run into the next record :func:`log_trial` adds."""
    write_trials(path, runs)


# ---------------------------------------------------------------------- summaries


def policy_order(policies: Iterable[str]) -> list[str]:
    """Known policies in the paper's order, then any others alphabetically."""
    policies = set(policies)
    return [p for p in POLICIES if p in policies] + sorted(policies - set(POLICIES))


def summarise(runs: Sequence[dict]) -> list[dict]:
    """Mean and std (over trials) of each final figure, per scene and policy; trials that
    raised are counted (``errors``) and left out."""
    table = []
    keys = [key for key, *_ in SUMMARY_COLUMNS] + list(EXTRA_KEYS)
    for scene in sorted({r["scene"] for r in runs}):
        for policy in policy_order(r["policy"] for r in runs if r["scene"] == scene):
            group = [r for r in runs if r["scene"] == scene and r["policy"] == policy]
            good = [r for r in group if r["status"] != "error"]
            entry = {"scene": scene, "policy": policy, "trials": len(good), "errors": len(group) - len(good),
                     "statuses": {s: sum(r["status"] == s for r in good) for s in sorted({r["status"] for r in good})}}
            for key in keys:
                values = np.array([r.get(key, np.nan) for r in good], dtype=float)
                finite = values[np.isfinite(values)]
                entry[key] = float(finite.mean()) if len(finite) else float("nan")
                entry[key + "_std"] = float(finite.std()) if len(finite) else float("nan")
            table.append(entry)
    return table


def markdown_table(table: Sequence[dict]) -> str:
    """The summary as a Markdown table, ``mean ± std`` per column."""
    header = ["scene", "policy", "trials"] + [title for _, title, _, _ in SUMMARY_COLUMNS]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for entry in table:
        cells = [entry["scene"], entry["policy"], str(entry["trials"]) + (f" ({entry['errors']} failed)"
                                                                         if entry["errors"] else "")]
        for key, _, scale, fmt in SUMMARY_COLUMNS:
            mean, std = scale * entry[key], scale * entry[key + "_std"]
            cells.append("n/a" if not np.isfinite(mean) else f"{fmt.format(mean)} ± {fmt.format(std)}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def decision_rows(runs: Sequence[dict]) -> list[dict]:
    """Every decision of every trial: scene, policy, trial, seed + the runner's DecisionRecord."""
    return [{"scene": r["scene"], "policy": r["policy"], "trial": r["trial"], "seed": r["seed"], **row}
            for r in runs for row in r["rows"]]


def write_csv(path: Path, rows: Sequence[dict]) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fields = list(dict.fromkeys(key for row in rows for key in row))
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)
    return path


def value_at_travel(run: dict, metric: str, travel: float) -> float:
    """``metric`` of one trial after ``travel`` metres: interpolated between its decisions,
    its final value if it ended sooner (the robot stopped; its map stays as it was)."""
    if not run["rows"]:
        return float("nan")
    distances = [row["travel_m"] for row in run["rows"]]
    return float(np.interp(travel, distances, [row[metric] for row in run["rows"]]))


def travel_to_reach(run: dict, coverage: float) -> float:
    """Travel (m) at which one trial first explored ``coverage``, interpolated between its
    decisions (from 0 m and 0 % at the start); its final travel if it never got there."""
    travel = np.array([0.0] + [row["travel_m"] for row in run["rows"]])
    explored = np.maximum.accumulate(np.array([0.0] + [row["explored"] for row in run["rows"]]))
    index = int(np.searchsorted(explored, coverage - 1e-12))
    if index >= len(explored):
        return float(travel[-1])
    if index == 0 or explored[index] == explored[index - 1]:
        return float(travel[index])
    share = (coverage - explored[index - 1]) / (explored[index] - explored[index - 1])
    return float(travel[index - 1] + share * (travel[index] - travel[index - 1]))


def matched_travel(runs: Sequence[dict], reference: str = "em", metric: str = "map_error_m") -> list[dict]:
    """Per scene, every policy's ``metric`` (mean and std over trials) at the ``reference``
    policy's mean final travel: policies that stop after different distances compared at
    the same distance. Scenes without the reference policy are left out."""
    table = []
    for scene in sorted({r["scene"] for r in runs}):
        good = [r for r in runs if r["scene"] == scene and r["status"] != "error"]
        reference_runs = [r for r in good if r["policy"] == reference]
        if not reference_runs:
            continue
        travel = float(np.mean([r["travel_m"] for r in reference_runs]))
        entry = {"scene": scene, "reference": reference, "travel_m": travel, "metric": metric}
        for policy in policy_order(r["policy"] for r in good):
            values = np.array([value_at_travel(r, metric, travel) for r in good if r["policy"] == policy])
            entry[policy], entry[policy + "_std"] = float(np.nanmean(values)), float(np.nanstd(values))
        table.append(entry)
    return table


def matched_travel_markdown(table: Sequence[dict]) -> str:
    """:func:`matched_travel` as a Markdown table (one row per scene)."""
    if not table:
        return ""
    policies = policy_order({key.removesuffix("_std") for entry in table for key in entry if key.endswith("_std")})
    lines = [f"{table[0]['metric']} of every policy after the {table[0]['reference']} policy's mean final travel:",
             "", "| scene | travel m | " + " | ".join(policies) + " |", "|" + "---|" * (len(policies) + 2)]
    for entry in table:
        cells = [f"{entry[p]:.3f} ± {entry[p + '_std']:.3f}" if p in entry else "n/a" for p in policies]
        lines.append(f"| {entry['scene']} | {entry['travel_m']:.1f} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def coverage_point(run: dict, target: float) -> dict | None:
    """The first decision of one trial at which ``explored`` reached ``target``: its travel
    and map error; None if the trial never got there."""
    for row in run["rows"]:
        if row.get("explored", 0.0) >= target:
            return {"travel_m": row["travel_m"], "map_error_m": row["map_error_m"]}
    return None


def coverage_reached(runs: Sequence[dict], target: float = 0.85) -> list[dict]:
    """Per scene and policy: how many trials reached ``target`` explored, the mean (and std)
    travel to get there and the map error at that point over those trials, and the mean
    decision time over all trials -- the paper's comparison "at the same coverage"."""
    table = []
    for scene in sorted({r["scene"] for r in runs}):
        good = [r for r in runs if r["scene"] == scene and r["status"] != "error"]
        for policy in policy_order(r["policy"] for r in good):
            mine = [r for r in good if r["policy"] == policy]
            points = [p for p in (coverage_point(r, target) for r in mine) if p is not None]
            travel = np.array([p["travel_m"] for p in points])
            error = np.array([p["map_error_m"] for p in points])
            table.append({"scene": scene, "policy": policy, "target": target, "trials": len(mine),
                          "reached": len(points),
                          "travel_m": float(travel.mean()) if len(points) else float("nan"),
                          "travel_m_std": float(travel.std()) if len(points) else float("nan"),
                          "map_error_m": float(error.mean()) if len(points) else float("nan"),
                          "map_error_m_std": float(error.std()) if len(points) else float("nan"),
                          "ms_decide": float(np.mean([r["ms_decide"] for r in mine]))})
    return table


def coverage_markdown(table: Sequence[dict]) -> str:
    """:func:`coverage_reached` as a Markdown table."""
    if not table:
        return ""
    lines = [f"Travel to {100 * table[0]['target']:.0f} % explored and the map error there (trials that got there):",
             "", "| scene | policy | reached | travel m | map error m | decision ms |", "|---|---|---|---|---|---|"]
    for e in table:
        lines.append(f"| {e['scene']} | {e['policy']} | {e['reached']}/{e['trials']} | {e['travel_m']:.1f} ± "
                     f"{e['travel_m_std']:.1f} | {e['map_error_m']:.3f} ± {e['map_error_m_std']:.3f} | "
                     f"{e['ms_decide']:.0f} |")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------- plots


# the spread band of the plots: these percentiles over the trials (interquartile range).
# Not mean +- std: that goes below zero for a positive quantity with a skewed spread.
BAND_PERCENTILES = (25.0, 75.0)
BAND_LABEL = "line: mean over trials; band: interquartile range (25-75 %)"


def mean_curve(runs: Sequence[dict], metric: str, points: int = 200
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(travel, mean, low, high)`` of ``metric`` against travel over the trials, ``low``
    and ``high`` the :data:`BAND_PERCENTILES` (the interquartile range): each trial's
    decisions linearly interpolated, its final value held once it has ended (the robot
    stopped; its map stays as it was), up to the travel where half of the trials ended."""
    curves = [(np.array([row["travel_m"] for row in r["rows"]]), np.array([row[metric] for row in r["rows"]], float))
              for r in runs if r["rows"]]
    if not curves:
        return np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0)
    end = float(np.median([travel[-1] for travel, _ in curves]))
    grid = np.linspace(min(travel[0] for travel, _ in curves), end, points)
    values = np.full((len(curves), points), np.nan)
    for i, (travel, metric_values) in enumerate(curves):
        started = grid >= travel[0]
        values[i, started] = np.interp(grid[started], travel, metric_values)  # holds the last value
    keep = np.isfinite(values).any(axis=0)
    kept = values[:, keep]
    with np.errstate(invalid="ignore"):
        low, high = np.nanpercentile(kept, BAND_PERCENTILES, axis=0)
        return grid[keep], np.nanmean(kept, axis=0), low, high


def plot_metric(ax, runs: Sequence[dict], metric: str, ylabel: str, title: str = "") -> None:
    """One line per policy (the mean over trials) with an interquartile band (the legend says so)."""
    for policy in policy_order(r["policy"] for r in runs):
        group = [r for r in runs if r["policy"] == policy and r["status"] != "error"]
        travel, mean, low, high = mean_curve(group, metric)
        if not len(travel):
            continue
        colour = COLOURS.get(policy)
        ax.plot(travel, mean, color=colour, label=f"{policy} ({len(group)})")
        ax.fill_between(travel, low, high, color=colour, alpha=0.2, linewidth=0)
    ax.set(xlabel="travel distance [m]", ylabel=ylabel, title=title)
    ax.grid(alpha=0.3)
    ax.legend(title=BAND_LABEL, title_fontsize="small")


PLOTS = (("map_error_m", "map error [m]", "map error"), ("volume_m3", "3D occupied volume [m$^3$]", "3D volume"))


def plot_scene(runs: Sequence[dict], scene: str, out: Path) -> list[Path]:
    """The two paper plots of ``scene``: ``{scene}_map_error.png`` and ``{scene}_volume.png``."""
    from explore_rl import viz

    written = []
    for metric, ylabel, title in PLOTS:
        fig, ax = viz.plt.subplots(figsize=(6, 4))
        plot_metric(ax, [r for r in runs if r["scene"] == scene], metric, ylabel, f"{scene}: {title}")
        written.append(viz.save(fig, Path(out) / f"{scene}_{metric.rsplit('_', 1)[0]}.png"))
    return [Path(p) for p in written]


def write_summary(runs: Sequence[dict], out: Path) -> dict[str, list[Path] | Path]:
    """``summary.md``, ``summary.json`` and the plots of every scene of ``runs`` into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    table, matched, coverage = summarise(runs), matched_travel(runs), coverage_reached(runs)
    text = markdown_table(table) + ("\n" + matched_travel_markdown(matched) if matched else "")
    text += "\n" + coverage_markdown(coverage)
    from explore_rl import zero_shot  # it reads trials with this module's helpers

    targets = zero_shot.check_targets(runs)
    if targets:
        text += "\n" + zero_shot.targets_markdown(targets)
        (out / "targets.json").write_text(json.dumps(zero_shot.targets_json(targets), indent=1))
    (out / "coverage.json").write_text(json.dumps(coverage, indent=1))
    (out / "summary.md").write_text(text)
    (out / "summary.json").write_text(json.dumps(table, indent=1))
    (out / "matched_travel.json").write_text(json.dumps(matched, indent=1))
    plots = [p for scene in sorted({r["scene"] for r in runs}) for p in plot_scene(runs, scene, out)]
    return {"table": out / "summary.md", "plots": plots}


def write_report(runs: Sequence[dict], out: Path) -> dict[str, list[Path] | Path]:
    """:func:`write_summary` plus ``trials.jsonl`` (every trial, its decisions included)
    and ``decisions.csv`` (every decision), into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_trials(out / "trials.jsonl", runs)
    return {**write_summary(runs, out), "csv": write_csv(out / "decisions.csv", decision_rows(runs)),
            "trials": out / "trials.jsonl"}


def combine(parent: Path) -> dict[str, list[Path] | Path] | None:
    """One summary over every report in ``parent``'s subfolders (a sweep over scenes, e.g.
    ``explore-rl-eval -m scene=street,garage out=DIR``), written into ``parent``. None
    (nothing written) if two folders hold the same scene: a sweep over something else,
    whose runs one table by scene and policy would mix."""
    reports = [read_trials(path) for path in sorted(Path(parent).glob("*/trials.jsonl"))]
    scenes = [sorted({run["scene"] for run in runs}) for runs in reports]
    if not reports or len({s for group in scenes for s in group}) < sum(len(group) for group in scenes):
        return None
    return write_summary([run for runs in reports for run in runs], parent)


def read_trials(path: Path) -> list[dict]:
    """Trials written by :func:`write_report` (or logged one JSON object a line)."""
    path = Path(path)
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
