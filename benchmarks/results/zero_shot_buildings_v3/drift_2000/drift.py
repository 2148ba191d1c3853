"""Why does the learned run drift early in building 2000? Re-run one policy's first metres
of the session-28 sweep's trial 0 (same config) and print the map error, ATE and loop
closures per decision, then the accepted closures furthest from the truth.

    python benchmarks/results/zero_shot_buildings_v3/drift_2000/drift.py learned|em [budget_m]
"""

import sys

from explore_rl.config import load_config
from explore_rl.runner import Explorer

policy = sys.argv[1]
budget = float(sys.argv[2]) if len(sys.argv) > 2 else 40.0
config = load_config(["scene=building", "scene.seed=2000", "slam=icp", "graph.max_nodes=1024", f"policy={policy}",
                      f"explore.travel_budget={budget}"])
explorer = Explorer(config)
for row in explorer.run().table():
    print(f"{row['travel_m']:6.1f} err {row['map_error_m']:.3f} ate {row['ate_m']:.3f} "
          f"lc {row['loop_closures']} kf {row['keyframes']}")
attempts = getattr(explorer.session.loop_closer, "attempts", [])
accepted = [a for a in attempts if a.accepted]
print("attempts", len(attempts), "accepted", len(accepted))
for attempt in sorted(accepted, key=lambda a: -a.error_translation)[:8]:
    print(vars(attempt))
