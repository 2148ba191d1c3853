"""The reward of paper Algorithm 1: EM's raw reward, min-max normalised per decision."""

from __future__ import annotations

import numpy as np

from explore_rl.planning.config import RewardConfig


def raw_reward(
    u_before: float | np.ndarray,
    u_after: float | np.ndarray,
    path_length: float | np.ndarray,
    alpha: float,
) -> float | np.ndarray:
    """``U0 - U' - alpha * path_length`` (utility drop minus travel cost; vectorises)."""
    return u_before - u_after - alpha * path_length


def normalize_rewards(
    raw_rewards: np.ndarray, nearest: int, config: RewardConfig | None = None
) -> np.ndarray:
    """Algorithm 1 applied to every candidate: ``(C,)`` rewards.

    Min-max normalise to ``r in [0, 1]`` (every ``r = 1`` when the raw rewards are equal
    up to ``tie_tolerance`` relative to their magnitude); if the best raw reward belongs to
    the ``nearest`` frontier return ``r - 1`` (in ``[-1, 0]``), else ``2 r - 1``
    (in ``[-1, 1]``).
    """
    config = config or RewardConfig()
    raw = np.asarray(raw_rewards, dtype=float).ravel()
    if raw.size == 0:
        raise ValueError("normalize_rewards needs at least one candidate")
    low, high = raw.min(), raw.max()
    scale = max(1.0, float(np.max(np.abs(raw))))
    if high - low <= config.tie_tolerance * scale:
        r = np.ones_like(raw)
        nearest_is_best = True
    else:
        r = (raw - low) / (high - low)
        nearest_is_best = bool(raw[nearest] == high)
    return r - 1.0 if nearest_is_best else 2.0 * r - 1.0


def normalized_reward(
    raw_rewards: np.ndarray, chosen: int, nearest: int, config: RewardConfig | None = None
) -> float:
    """Reward of the ``chosen`` candidate given every candidate's raw reward (Alg. 1)."""
    return float(normalize_rewards(raw_rewards, nearest, config)[chosen])
