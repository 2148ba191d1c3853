"""Session 81: the paired rounds of bench_collect's logs pooled per code version (bench_collect_rounds4_*s81_r*.log):
the mean async-over-one-worker ratio and its 95 % Student-t interval over all rounds, and the decisions/s of each side;
where the logs have it (``bench_collect.py --ceiling``), the machine's ceiling and async's share of it, pooled alike.
``--side NAME=GLOB`` (repeatable) names other sides (session 82: ``--side session81=bench_collect_rounds4_before_s82_r*.log
--side session82=bench_collect_rounds4_s82_r*.log``).

    python benchmarks/results/decide_time/collect_pool_s81.py [--logs DIR] [--side NAME=GLOB ...]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))
from common import emit, mean_ci95  # noqa: E402


def rounds(logs: Path, pattern: str) -> dict[str, list[float]]:
    """Each round's ratio and rates over the logs in ``logs`` matching ``pattern`` (their JSON last lines)."""
    pooled = {"speedup": [], "dps_1": [], "dps_async": [], "ceiling": [], "of_ceiling": []}
    for path in sorted(logs.glob(pattern)):
        last = json.loads([line for line in path.read_text().splitlines() if line.startswith("{")][-1])
        pooled["speedup"] += last["speedup_async_rounds"]
        pooled["dps_1"] += last["dps_1_rounds"]
        pooled["dps_async"] += last["dps_async_rounds"]
        pooled["ceiling"] += last.get("ceiling_rounds", [])
        pooled["of_ceiling"] += last.get("speedup_async_of_ceiling_rounds", [])
    return pooled


def pooled_mean(values: list[float]) -> dict:
    """The rounds' mean and 95 % interval."""
    mean, ci = mean_ci95(values)
    return {"rounds": len(values), "mean": round(mean, 3), "ci95": [round(x, 3) for x in ci] if ci else None}


def side(text: str) -> tuple[str, str]:
    """``NAME=GLOB`` of ``--side``."""
    name, _, pattern = text.partition("=")
    if not name or not pattern:
        raise argparse.ArgumentTypeError(f"--side {text!r}: give NAME=GLOB, e.g. session82=bench_collect_rounds4_s82_r*.log")
    return name, pattern


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", type=Path, default=HERE, help="the folder of the bench_collect logs")
    parser.add_argument("--side", type=side, action="append", metavar="NAME=GLOB",
                        help="a code version's name and its logs (default: session 81's pair)")
    args = parser.parse_args(argv)
    logs = args.logs
    sides = args.side or [("session80", "bench_collect_rounds4_before_s81_r*.log"),
                          ("session81", "bench_collect_rounds4_s81_r*.log")]
    result = {"benchmark": "collect_pool_s81"}
    for name, pattern in sides:
        pooled = rounds(logs, pattern)
        if not pooled["speedup"]:
            raise SystemExit(f"no logs match {logs / pattern}: give --logs the folder of bench_collect's logs")
        mean, ci = mean_ci95(pooled["speedup"])
        result[name] = {"rounds": len(pooled["speedup"]), "speedup_async": round(mean, 3),
                        "speedup_async_ci95": [round(x, 3) for x in ci] if ci else None,
                        "dps_1": [min(pooled["dps_1"]), max(pooled["dps_1"])],
                        "dps_async": [min(pooled["dps_async"]), max(pooled["dps_async"])]}
        if pooled["ceiling"]:
            result[name] |= {"ceiling": pooled_mean(pooled["ceiling"]),
                             "speedup_async_of_ceiling": pooled_mean(pooled["of_ceiling"])}
        print(name, result[name])
    emit(result)


if __name__ == "__main__":
    main()
