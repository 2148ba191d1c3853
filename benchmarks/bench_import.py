"""How long ``import explore_rl.config`` takes in a fresh process, and what it loads.

Baseline in the same run: importing the runtime modules the config used to live in
(runner, comparison, sensors.lidar, tour, graph.encode -- what ``explore_rl.config``
pulled in before its dataclasses moved to config-only modules, issue 20 item 6). Each
import runs in its own fresh interpreter; the median over the repeats is reported.

    python benchmarks/bench_import.py [--quick|--smoke]

Last stdout line (JSON): ``s_import_config``, ``s_import_runtime`` (the baseline),
``speedup``, ``heavy_modules_config`` (which of mujoco, gtsam, kiss_icp, scipy, torch,
torchrl the config import loaded: none expected), ``heavy_modules_runtime``.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine, parse_args  # noqa: E402

HEAVY = ("mujoco", "gtsam", "kiss_icp", "scipy", "torch", "torchrl")
CONFIG = ("explore_rl.config",)
RUNTIME = ("explore_rl.runner", "explore_rl.comparison", "explore_rl.sensors.lidar", "explore_rl.tour",
           "explore_rl.graph.encode")


def import_once(modules: tuple[str, ...]) -> tuple[float, list[str]]:
    """Seconds to import ``modules`` in a fresh interpreter, and the heavy packages it loaded."""
    code = ("import importlib, json, sys, time\n"
            "start = time.perf_counter()\n"
            f"for name in {list(modules)!r}:\n"
            "    importlib.import_module(name)\n"
            "seconds = time.perf_counter() - start\n"
            f"heavy = sorted(m for m in {list(HEAVY)!r} if m in sys.modules)\n"
            "print(json.dumps({'seconds': seconds, 'heavy': heavy}))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    result = json.loads(out.strip().splitlines()[-1])
    return result["seconds"], result["heavy"]


def median_import(modules: tuple[str, ...], repeats: int) -> tuple[float, list[str]]:
    """Median seconds over ``repeats`` fresh processes (after one warm-up for the file cache)."""
    import_once(modules)
    runs = [import_once(modules) for _ in range(repeats)]
    return statistics.median(seconds for seconds, _ in runs), runs[-1][1]


def main() -> None:
    args = parse_args(__doc__.splitlines()[0])
    repeats = 1 if args.smoke else 5 if args.quick else 11
    config_s, config_heavy = median_import(CONFIG, repeats)
    runtime_s, runtime_heavy = median_import(RUNTIME, repeats)
    print(f"import explore_rl.config: {config_s:.3f} s (loads {config_heavy or 'none'} of {', '.join(HEAVY)}); "
          f"the runtime modules it used to import: {runtime_s:.3f} s ({', '.join(runtime_heavy)}); median of "
          f"{repeats} fresh processes")
    emit({"s_import_config": round(config_s, 4), "s_import_runtime": round(runtime_s, 4),
          "speedup": round(runtime_s / config_s, 2), "heavy_modules_config": config_heavy,
          "heavy_modules_runtime": runtime_heavy, "repeats": repeats, "smoke": args.smoke, "quick": args.quick,
          "machine": machine()})


if __name__ == "__main__":
    main()
