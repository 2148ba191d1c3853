"""Training curves through a TorchRL logger, plus a progress bar with the current figures.

Every scalar is logged against the number of decisions collected so far. Per update:
``reward`` (Algorithm 1 reward per decision), ``em_agreement``, the losses, ``grad_norm``,
``frames_per_s``, ``ms_update``, ``skipped_updates``, ``wall_s``, ``updates``. Per finished episode:
``episode/reward``, ``episode/explored``, ``episode/map_error``, ``episode/length``,
``episode/em_agreement``, ``episode/travel``, ``episode/failed``.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from tensordict import TensorDictBase
from tqdm import tqdm

from explore_rl.envs.keys import EM_ACTION, POLICY_LAG
from explore_rl.trainer.episodes import EpisodeSummary

EXPERIMENT = "a2c"


def make_torchrl_logger(kind: str, log_dir: Path):
    """TorchRL's CSV or TensorBoard logger writing under ``log_dir``."""
    if kind == "csv":
        from torchrl.record.loggers import CSVLogger

        return CSVLogger(exp_name=EXPERIMENT, log_dir=str(log_dir))
    if kind == "tensorboard":
        from torchrl.record.loggers import TensorboardLogger

        return TensorboardLogger(exp_name=EXPERIMENT, log_dir=str(log_dir))
    raise ValueError(f"logger.kind={kind!r}: choose csv or tensorboard")


def trim_csv_logs(scalars_dir: Path, last_step: int) -> None:
    """Drop rows logged after ``last_step`` (a killed run's tail past its last
    checkpoint), so a resumed run does not log them twice."""
    for path in Path(scalars_dir).glob("**/*.csv"):
        rows = path.read_text().splitlines()
        kept = [row for row in rows if row and float(row.split(",")[0]) <= last_step]
        path.write_text("".join(f"{row}\n" for row in kept))


class RunLogger:
    """Scalars to the TorchRL logger and a tqdm bar over decisions."""

    def __init__(self, log_dir: Path, kind: str, resume_at: int = 0, progress_total: int | None = None,
                 progress_start: int = 0):
        if kind == "csv" and resume_at > 0:
            trim_csv_logs(Path(log_dir) / EXPERIMENT / "scalars", resume_at)
        self.logger = make_torchrl_logger(kind, Path(log_dir))
        self.bar = None
        if progress_total is not None:
            self.bar = tqdm(total=progress_total, initial=progress_start, unit="decision", dynamic_ncols=True)

    def scalars(self, step: int, values: dict) -> None:
        for name, value in values.items():
            if value is not None and not (isinstance(value, float) and math.isnan(value)):
                self.logger.log_scalar(name, float(value), step=step)

    def update(self, frames: int, batch: TensorDictBase, stats, finished: list[EpisodeSummary],
               ms_update: float, state) -> None:
        labels, actions = batch[EM_ACTION], batch["action"]
        labelled = labels >= 0
        agreement = float((actions[labelled] == labels[labelled]).float().mean()) if labelled.any() else None
        reward = float(batch["next", "reward"].mean())
        values = {"reward": reward, "em_agreement": agreement, "ms_update": ms_update,
                  "frames_per_s": frames / max(state.wall_s, 1e-9), "skipped_updates": state.skipped_updates,
                  "wall_s": state.wall_s, "updates": state.updates}
        if POLICY_LAG in batch.keys(include_nested=True):  # async collection
            values["policy_lag"] = int(batch[POLICY_LAG].max())
        if stats is not None:
            values.update(dataclasses.asdict(stats))
        self.scalars(frames, values)
        for episode in finished:
            self.scalars(frames, {
                "episode/reward": episode.mean_reward, "episode/explored": episode.explored,
                "episode/map_error": episode.map_error, "episode/length": episode.decisions,
                "episode/em_agreement": episode.em_agreement, "episode/travel": episode.travel,
                "episode/failed": float(episode.failed)})
        if self.bar is not None:
            self.bar.update(batch.numel())
            postfix = {"upd": state.updates, "reward": f"{reward:+.2f}"}
            if agreement is not None:
                postfix["em"] = f"{agreement:.2f}"
            if finished:
                postfix["explored"] = f"{finished[-1].explored:.2f}"
            self.bar.set_postfix(postfix)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
