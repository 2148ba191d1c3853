"""Keep a training run's actors in the repository: each checkpoint without its critic, optimiser,
RNG state and label buffer (~0.5 MB instead of ~2.9 MB), still a training checkpoint that
``policy.checkpoint=`` and ``study_learning.py --policy`` load, with the same actor weights.

Why: a run's folder lives outside the repository (``/work/runs``) and is lost with its machine
(session 36's run was); the candidate and its snapshots are what later sessions evaluate.

    python benchmarks/results/selection_v6/keep_actors.py RUN/checkpoints OUT_DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

KEPT = ("format", "model", "config", "actor", "state")


def strip(checkpoint: Path, out: Path) -> Path:
    """``checkpoint`` reduced to the parts an actor needs, written to ``out``; the weights are checked equal."""
    payload = torch.load(checkpoint, map_location="cpu", weights_only=False)
    missing = [key for key in KEPT if key not in payload]
    if missing:
        raise SystemExit(f"{checkpoint}: not a training checkpoint (no {', '.join(missing)})")
    kept = {key: payload[key] for key in KEPT}
    out.parent.mkdir(parents=True, exist_ok=True)
    torch.save(kept, out)
    again = torch.load(out, map_location="cpu", weights_only=False)["actor"]
    if again.keys() != payload["actor"].keys() or not all(torch.equal(again[k], payload["actor"][k]) for k in again):
        raise SystemExit(f"{out}: the kept actor differs from {checkpoint}'s")
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("checkpoints", type=Path, help="a run's checkpoints/ folder")
    parser.add_argument("out", type=Path, help="where the stripped checkpoints go (same file names)")
    args = parser.parse_args(argv)
    files = sorted(p for p in args.checkpoints.glob("*.pt") if p.name != "best.pt")
    if not files:
        raise SystemExit(f"{args.checkpoints}: no *.pt checkpoints there")
    for path in files:
        print(strip(path, args.out / path.name))


if __name__ == "__main__":
    main()
