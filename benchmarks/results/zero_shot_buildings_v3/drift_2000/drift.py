"""Why does the learned run drift early in building 2000? Re-run both policies' first 40 m, print closures' errors."""
import sys, numpy as np
from explore_rl.config import load_config
from explore_rl.runner import Explorer
pol = sys.argv[1]; budget = float(sys.argv[2]) if len(sys.argv) > 2 else 40
cfg = load_config(["scene=building", "scene.seed=2000", "slam=icp", "graph.max_nodes=1024", f"policy={pol}",
                   f"explore.travel_budget={budget}"])
ex = Explorer(cfg)
res = ex.run()
rows = res.table()
for r in rows:
    print(f"{r['travel_m']:6.1f} err {r['map_error_m']:.3f} ate {r['ate_m']:.3f} lc {r['loop_closures']} kf {r['keyframes']}")
att = getattr(ex.session.loop_closer, "attempts", [])
acc = [a for a in att if a.accepted]
print("attempts", len(att), "accepted", len(acc))
bad = sorted(acc, key=lambda a: -a.error_translation)[:8]
for a in bad:
    print(vars(a) if hasattr(a, "__dict__") else a)
