"""Session 81: the paired rounds of bench_collect's logs pooled per code version (bench_collect_rounds4_*s81_r*.log):
the mean async-over-one-worker ratio and its 95 % Student-t interval over all rounds, and the decisions/s of each side.

    python benchmarks/results/decide_time/collect_pool_s81.py [--logs DIR]
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
    pooled = {"speedup": [], "dps_1": [], "dps_async": []}
    for path in sorted(logs.glob(pattern)):
        last = json.loads([line for line in path.read_text().splitlines() if line.startswith("{")][-1])
        pooled["speedup"] += last["speedup_async_rounds"]
        pooled["dps_1"] += last["dps_1_rounds"]
        pooled["dps_async"] += last["dps_async_rounds"]
    return pooled


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--logs", type=Path, default=HERE, help="the folder of the bench_collect logs")
    logs = parser.parse_args(argv).logs
    result = {"benchmark": "collect_pool_s81"}
    for name, pattern in (("session80", "bench_collect_rounds4_before_s81_r*.log"),
                          ("session81", "bench_collect_rounds4_s81_r*.log")):
        pooled = rounds(logs, pattern)
        if not pooled["speedup"]:
            raise SystemExit(f"no logs match {logs / pattern}: give --logs the folder of bench_collect's logs")
        mean, ci = mean_ci95(pooled["speedup"])
        result[name] = {"rounds": len(pooled["speedup"]), "speedup_async": round(mean, 3),
                        "speedup_async_ci95": [round(x, 3) for x in ci] if ci else None,
                        "dps_1": [min(pooled["dps_1"]), max(pooled["dps_1"])],
                        "dps_async": [min(pooled["dps_async"]), max(pooled["dps_async"])]}
        print(name, result[name])
    emit(result)


if __name__ == "__main__":
    main()
