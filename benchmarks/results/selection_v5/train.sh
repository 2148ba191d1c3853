#!/usr/bin/env bash
# plan.md: the wide offline-distilled candidate (main's code), then the actor file in the older format.
set -e
cd /work/main
OUT=/work/runs/wide_s33
.venv/bin/explore-rl-distill --dataset /work/runs/data_s33_relative --out $OUT/actor_new_format.pt --steps 12000 \
  --seed 0 --set graph.features=extended algo.lr=1e-3 model.hidden=256
.venv/bin/python - <<PY
import torch
payload = torch.load("$OUT/actor_new_format.pt", map_location="cpu", weights_only=False)
assert payload["model"].pop("relative_features") == []
torch.save(payload, "$OUT/actor.pt")
PY
