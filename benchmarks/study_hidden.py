"""Which hidden size for the CPU? The same supervised objective at several sizes, same data.

Actors of each ``--hidden`` size are trained on the EM-evaluated decisions one training
run kept (its imitation replay buffer, ``checkpoints/last.pt``; ``distill_target=expected_reward``:
maximise the expected Algorithm 1 reward) and scored on another run's decisions, which
they never saw: the greedy pick's Algorithm 1 reward, next to a random frontier's and the
best one's (EM's) on the same decisions. Also the time per Adam step.

    python benchmarks/study_hidden.py --train runs/office_rewards_s0 --test runs/office_rewards_s1 \\
        [--hidden 64 128 256] [--steps 600] [--smoke]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import emit, machine  # noqa: E402

from explore_rl.config import load_config  # noqa: E402
from explore_rl.envs.keys import ACTION_REWARDS  # noqa: E402
from explore_rl.trainer.a2c import Learner  # noqa: E402
from explore_rl.models.checkpoint import CheckpointError, read_checkpoint  # noqa: E402
from explore_rl.trainer.imitation import make_label_buffer, pad_graphs  # noqa: E402

BATCH = 16


def kept_decisions(run_dir: Path) -> list:
    """The labelled decisions in ``run_dir``'s replay buffer."""
    try:
        payload = read_checkpoint(Path(run_dir) / "checkpoints" / "last.pt")
    except CheckpointError as error:
        raise SystemExit(f"error: {error}") from None
    if payload.get("label_buffer") is None:
        raise SystemExit(f"{run_dir}: no replay buffer in last.pt (train with algo.dagger_steps > 0)")
    buffer = make_label_buffer(10**6, BATCH)
    buffer.load_state_dict(payload["label_buffer"])
    return [buffer.storage[i] for i in range(len(buffer))]


def reference_rewards(batch) -> dict[str, float]:
    rewards, mask = batch[ACTION_REWARDS], batch["action_mask"]
    masked = torch.where(mask, rewards, torch.tensor(-torch.inf))
    return {"random": float(((rewards * mask).sum(-1) / mask.sum(-1)).mean()),
            "best": float(masked.max(-1).values.mean())}


def greedy_reward(learner: Learner, batch) -> float:
    learner.set_training(False)
    with torch.no_grad():
        pick = learner.actor.get_dist(batch).probs.argmax(-1)
    return float(batch[ACTION_REWARDS].gather(1, pick[:, None]).mean())


def train_and_score(hidden: int, train: list, test_batch, steps: int, lr: float, extra: list[str]) -> dict:
    config = load_config(["scene=office", "slam=model", "algo.distill_coef=1.0",
                          "algo.distill_target=expected_reward", f"model.hidden={hidden}", *extra])
    torch.manual_seed(0)
    learner = Learner(config)
    optimizer = torch.optim.Adam(learner.actor.parameters(), lr=lr)
    curve, seconds = [], 0.0
    for step in range(steps + 1):
        if step % max(1, steps // 6) == 0:
            curve.append((step, round(greedy_reward(learner, test_batch), 4)))
            print(f"hidden {hidden:5d} step {step:5d} held-out greedy reward {curve[-1][1]:+.3f}", flush=True)
        if step == steps:
            break
        learner.set_training(True)
        batch = pad_graphs([train[i] for i in torch.randint(len(train), (BATCH,)).tolist()])
        start = time.perf_counter()
        loss = learner.distill_loss(batch)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        seconds += time.perf_counter() - start
    last = [reward for _, reward in curve[-3:]]
    return {"curve": curve, "final_mean_last3": sum(last) / len(last), "ms_step": 1e3 * seconds / max(steps, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train", type=Path)
    parser.add_argument("--test", type=Path)
    parser.add_argument("--hidden", type=int, nargs="*", default=[64, 128, 256])
    parser.add_argument("--steps", type=int, default=600)
    parser.add_argument("--test-size", type=int, default=600)
    parser.add_argument("--lr", type=float, default=3e-4)
    parser.add_argument("--smoke", action="store_true", help="a 5-decision run, 2 sizes, 3 steps")
    args = parser.parse_args()
    torch.set_num_threads(1)
    extra = []
    if args.smoke:
        extra = ["planning.actions.max_frontiers=3", "model.mlp_hidden=16"]
        args.train = args.test = smoke_run(Path(tempfile.mkdtemp()) / "run", extra)
        args.hidden, args.steps = [8, 16], 3
    if args.train is None or args.test is None:
        parser.error("--train and --test run folders are needed (or --smoke)")
    train, test = kept_decisions(args.train), kept_decisions(args.test)[: args.test_size]
    test_batch = pad_graphs(test)
    results = {str(h): train_and_score(h, train, test_batch, args.steps, args.lr, extra) for h in args.hidden}
    emit({"study": "hidden_size", "smoke": args.smoke, "machine": machine(), "train": str(args.train),
          "test": str(args.test), "train_decisions": len(train), "test_decisions": len(test),
          "lr": args.lr, "steps": args.steps, "reference": reference_rewards(test_batch), "results": results})


def smoke_run(run_dir: Path, extra: list[str]) -> Path:
    """A 5-decision training run with the replay buffer on."""
    from explore_rl.trainer.a2c import train

    config = load_config(["scene=office", "slam=model", "train.frames=5", "algo.steps_per_update=5",
                          "train.progress_bar=false", "algo.distill_coef=1.0", "algo.distill_target=expected_reward",
                          "algo.dagger_steps=1", "model.hidden=8", *extra])
    train(config, run_dir)
    return run_dir


if __name__ == "__main__":
    main()
