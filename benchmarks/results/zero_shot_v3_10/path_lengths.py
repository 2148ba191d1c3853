"""Path length per decision of each policy in the committed zero-shot reports (each on its own
states): how far each policy chooses to go at a decision, and how many candidates it saw.

    python benchmarks/results/zero_shot_v3_10/path_lengths.py
"""

import csv
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPORTS = {"street": HERE / "0_street", "garage": HERE / "1_garage",
           "10 buildings": HERE.parent / "zero_shot_buildings_v3"}

print("| scene | policy | decisions | path m per decision: mean / median | candidates |")
print("|---|---|---|---|---|")
for name, folder in REPORTS.items():
    rows = [row for path in sorted(folder.glob("**/decisions.csv")) for row in csv.DictReader(open(path))]
    for policy in ("learned", "em", "nearest", "random"):
        mine = [r for r in rows if r["policy"] == policy]
        length = np.array([float(r["path_length_m"]) for r in mine])
        candidates = np.array([float(r["candidates"]) for r in mine])
        print(f"| {name} | {policy} | {len(mine)} | {length.mean():.1f} / {np.median(length):.1f} | "
              f"{candidates.mean():.1f} |")
