"""Helpers shared by the benchmark scripts: timing, argument parsing, the JSON last line."""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator

import numpy as np
from scipy import stats


def parse_args(description: str, quick_help: str = "a run that finishes in under a minute",
               add_arguments: Callable[[argparse.ArgumentParser], None] | None = None) -> argparse.Namespace:
    """``--quick`` and ``--smoke``, and what ``add_arguments`` adds for one benchmark."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--smoke", action="store_true",
                        help="a few seconds, for the test suite: checks that it runs; figures are meaningless")
    if add_arguments is not None:
        add_arguments(parser)
    return parser.parse_args()


def seed_list(text: str) -> list[int]:
    """Seeds from the command line: ``0-7`` -> 0..7, ``0,3,5-6`` -> [0, 3, 5, 6]."""
    seeds: list[int] = []
    for part in text.split(","):
        if "-" in part:
            first, last = part.split("-")
            seeds.extend(range(int(first), int(last) + 1))
        elif part:
            seeds.append(int(part))
    return seeds


def mean_ci95(values: list[float]) -> tuple[float, list[float] | None]:
    """The mean of ``values`` and its 95 % Student-t interval (None for fewer than 2 values)."""
    mean = float(np.mean(values))
    if len(values) < 2:
        return mean, None
    half = float(stats.t.ppf(0.975, len(values) - 1) * np.std(values, ddof=1) / np.sqrt(len(values)))
    return mean, [mean - half, mean + half]


def layout_clusters(layouts: np.ndarray) -> list[np.ndarray]:
    """The rows of each distinct layout (the unit of :func:`cluster_bootstrap`)."""
    return [np.flatnonzero(layouts == layout) for layout in np.unique(layouts)]


def cluster_bootstrap(statistic: Callable[[np.ndarray], float], groups: list[np.ndarray], seed: int = 0,
                      draws: int = 2000) -> list[float]:
    """95 % percentile interval of ``statistic(rows)`` over ``groups`` (e.g. layouts) drawn with replacement:
    decisions of one layout are not independent, so the layout is what is resampled."""
    rng = np.random.default_rng(seed)
    values = [statistic(np.concatenate([groups[i] for i in rng.integers(len(groups), size=len(groups))]))
              for _ in range(draws)]
    return [round(float(v), 4) for v in np.percentile(values, [2.5, 97.5])]


def add_bias_grid(parser: argparse.ArgumentParser, step: float, top: float) -> None:
    """``--step`` and ``--top`` of a grid of prior strengths ``0, step, ..., top`` (:func:`bias_grid`)."""
    parser.add_argument("--step", type=float, default=step, help="grid step of the bias (> 0)")
    parser.add_argument("--top", type=float, default=top, help="largest bias of the grid (>= 0)")


def bias_grid(parser: argparse.ArgumentParser, args: argparse.Namespace) -> np.ndarray:
    """The grid ``0, step, ..., top`` of :func:`add_bias_grid`'s arguments; a bad step or top is a one-line
    argparse error."""
    if not args.step > 0 or not args.top >= 0:
        parser.error(f"--step {args.step} --top {args.top}: give a step > 0 and a top >= 0")
    return np.round(np.arange(0.0, args.top + args.step / 2, args.step), 9)


def output_dir(out: str | Path | None, default: Path, trial: bool, name: str) -> Path:
    """Where a script writes: ``out`` if given; a new temporary folder for a ``--quick`` or ``--smoke`` run
    (``trial``), so a trial run never overwrites the committed results; else ``default``."""
    if out is not None:
        return Path(out)
    return Path(tempfile.mkdtemp(prefix=f"{name}_trial_")) if trial else default


def named_paths(specs: Iterable[str], flag: str = "") -> dict[str, Path]:
    """``NAME=PATH`` arguments as ``{name: path}`` in their order; ValueError naming the
    first malformed one (``flag``: the option they came with, for the message)."""
    named = {}
    for spec in specs:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"{flag}{spec!r}: give NAME=PATH")
        named[name] = Path(path)
    return named


def module_at(path: Path, name: str):
    """The script at ``path`` as a module named ``name`` (several result folders hold a ``probe.py`` or a
    ``calibrate.py``, so each gets a name of its own); registered while it runs, as an import would be
    (dataclasses look their module up)."""
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def time_call(fn: Callable[[], Any], repeats: int = 1) -> float:
    """Seconds per call of ``fn`` (one warm-up call first)."""
    fn()
    start = time.perf_counter()
    for _ in range(repeats):
        fn()
    return (time.perf_counter() - start) / repeats


def new_observation(fn: Callable[[], Any]) -> Callable[[], Any]:
    """``fn`` as on a new decision: the g-U-Net's cached input level (kept for the critic
    reading the actor's observation) forgotten first, so a repeat packs its graph again."""
    from explore_rl.models.graph_unet import INPUT_LEVELS

    def call() -> Any:
        INPUT_LEVELS.clear()
        return fn()
    return call


def machine() -> dict:
    """What the figures were measured on, including how busy the machine was (1-min load)."""
    return {"cpus": os.cpu_count(), "python": platform.python_version(), "machine": platform.machine(),
            "load_average_1min": round(os.getloadavg()[0], 2)}


def pin_to_one_core() -> int | None:
    """Run this process on one CPU (targets quoted "on one core"); returns it, or None if
    the platform cannot pin."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    core = max(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    return core


def emit(result: dict) -> None:
    """Print the benchmark's single JSON line; it must be the last line of stdout."""
    print(json.dumps(result, sort_keys=False), flush=True)


def spawned_results(play: Callable[[Any], Any], tasks: Iterable[Any], workers: int, deadline: float = float("inf"),
                    full: Callable[[], bool] = lambda: False) -> Iterator[Any]:
    """``play(task)`` of each task on ``workers`` spawned processes, at most ``workers`` at once; yields each
    result as it finishes. No task starts after ``deadline`` (``time.perf_counter``) or once ``full()``; a task
    that raises is reported on stderr and skipped (one bad episode must not end a collection)."""
    import sys
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from multiprocessing import get_context

    tasks = iter(tasks)
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
        running: set = set()
        while True:
            while len(running) < workers and time.perf_counter() < deadline and not full():
                task = next(tasks, None)
                if task is None:
                    break
                running.add(pool.submit(play, task))
            if not running:
                return
            finished, running = wait(running, return_when=FIRST_COMPLETED)
            for future in finished:
                try:
                    result = future.result()
                except Exception as error:  # noqa: BLE001 -- logged, the other tasks go on
                    print(f"a task failed: {type(error).__name__}: {error}", file=sys.stderr, flush=True)
                    continue
                yield result
