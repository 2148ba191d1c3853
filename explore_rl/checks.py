"""One-line checks of config values: each raises ``ValueError`` naming the key and the allowed range.

Shared by ``explore_rl/config.py:validate`` and the groups' own ``validate()`` methods, so
every bad value fails before anything runs with the same kind of message
(``robot.turn_rate_deg must be positive (finite), got 0.0``). Imports nothing of the
package: the lowest layer.
"""

from __future__ import annotations

import math
from typing import Iterable


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def positive(key: str, value, finite: bool = True) -> None:
    """``value > 0`` (and finite unless ``finite=False``, which allows inf)."""
    number = _number(value)
    if not number > 0 or (finite and not math.isfinite(number)):
        raise ValueError(f"{key} must be positive{' (finite)' if finite else ''}, got {value}")


def non_negative(key: str, value) -> None:
    """``0 <= value < inf``."""
    number = _number(value)
    if not (number >= 0 and math.isfinite(number)):
        raise ValueError(f"{key} must be >= 0 (finite), got {value}")


def at_least(key: str, value, low: int) -> None:
    """An integer ``>= low``."""
    if not _number(value) >= low:
        raise ValueError(f"{key} must be >= {low}, got {value}")


def in_range(key: str, value, low: float, high: float, low_open: bool = False, high_open: bool = False) -> None:
    """``low <(=) value <(=) high``; the message writes the interval as ``(low, high]`` etc."""
    number = _number(value)
    above = number > low if low_open else number >= low
    below = number < high if high_open else number <= high
    if not (above and below):
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        raise ValueError(f"{key} must be in {interval}, got {value}")


def one_of(key: str, value, allowed: Iterable) -> None:
    allowed = list(allowed)
    if value not in allowed:
        raise ValueError(f"{key}={value!r}: choose one of {', '.join(map(str, allowed))}")


def finite_pair(key: str, value, positive_entries: bool = True) -> None:
    """A list of two finite numbers (``> 0`` each if ``positive_entries``)."""
    numbers = [_number(v) for v in value] if isinstance(value, (list, tuple)) else []
    good = len(numbers) == 2 and all(math.isfinite(n) and (n > 0 or not positive_entries) for n in numbers)
    if not good:
        raise ValueError(f"{key} must be two {'positive ' if positive_entries else ''}finite numbers "
                         f"[x, y], got {value}")
