"""Loading and validating the front-end calibration files (``conf/calibration/*.yaml``).

Two files, both written by scripts (never by hand):

* ``scan_matching.yaml`` (``scripts/calibrate_scan_matching.py``): how the icp front end's
  sequential scan matching errs -- how often a keyframe is degenerate given what its
  scan sees, how many weak planar directions a usable match has, the error
  distribution per condition and the covariance the icp front end reports;
* ``loop_closures.yaml`` (``scripts/calibrate_loop_closures.py``): ``r_lc``, the
  acceptance rates of pose and segment matching versus distance and the error of
  accepted closures.

:func:`load_scan_matching` and :func:`load_loop_closures` return plain dataclasses. A
missing file, a missing or unknown key, a wrong type, a non-finite number, a negative
standard deviation or a probability outside [0, 1] raises :class:`CalibrationError`
naming the file and the key path (``conditions.weak1_turned.yaw_deg.core_sigma``).
"""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from explore_rl.slam.config import loop_closures_path, scan_matching_path

SCAN_MATCHING_FILE = scan_matching_path("")
LOOP_CLOSURES_FILE = loop_closures_path("")

WEAK_COUNTS = (0, 1, 2)
MOTIONS = ("straight", "turned")


class CalibrationError(ValueError):
    """A calibration file is missing or malformed (the message names file and key)."""


# ----------------------------------------------------------------------------- data


@dataclass(frozen=True)
class Mixture:
    """Zero-mean scale mixture of two normals: ``N(0, core^2)`` with probability
    ``1 - tail_fraction``, else ``N(0, tail^2)`` (the heavy tail of registration errors)."""

    core_sigma: float
    tail_sigma: float
    tail_fraction: float

    @property
    def std(self) -> float:
        """Total standard deviation."""
        return math.sqrt((1 - self.tail_fraction) * self.core_sigma**2
                         + self.tail_fraction * self.tail_sigma**2)

    def sample(self, rng: np.random.Generator, size=None) -> np.ndarray | float:
        if size is None:  # one draw (the model's hot path: no array temporaries)
            sigma = self.tail_sigma if rng.random() < self.tail_fraction else self.core_sigma
            return sigma * rng.standard_normal()
        tail = rng.random(size) < self.tail_fraction
        return rng.standard_normal(size) * np.where(tail, self.tail_sigma, self.core_sigma)

    def sample_pair(self, rng: np.random.Generator) -> tuple[float, float]:
        """Two draws as floats: the same values as ``sample(rng, 2)`` without arrays."""
        tail_a, tail_b = rng.random() < self.tail_fraction, rng.random() < self.tail_fraction
        a, b = rng.standard_normal(), rng.standard_normal()
        return (a * (self.tail_sigma if tail_a else self.core_sigma),
                b * (self.tail_sigma if tail_b else self.core_sigma))


@dataclass(frozen=True)
class Histogram:
    """A distribution over bins ``[edges[k], edges[k+1])`` (sampled uniformly inside)."""

    edges: tuple[float, ...]
    probabilities: tuple[float, ...]

    def sample(self, rng: np.random.Generator) -> float:
        k = draw_index(self.probabilities, rng)
        return self.edges[k] + (self.edges[k + 1] - self.edges[k]) * rng.random()


def draw_index(probabilities, rng: np.random.Generator) -> int:
    """Index ``k`` with probability ``probabilities[k]`` (one uniform draw)."""
    u, total = rng.random(), 0.0
    for k, p in enumerate(probabilities):
        total += p
        if u < total:
            return k
    return len(probabilities) - 1


def interpolate(x: float, xs: tuple[float, ...], ys: tuple[float, ...]) -> float:
    """``np.interp`` for one point (clamped at the ends); scalar, for the model's hot path."""
    k = bisect.bisect_right(xs, x)
    if k == 0:
        return float(ys[0])
    if k == len(xs):
        return float(ys[-1])
    t = (x - xs[k - 1]) / (xs[k] - xs[k - 1])
    return float(ys[k - 1] + t * (ys[k] - ys[k - 1]))


@dataclass(frozen=True)
class Condition:
    """Errors of usable matches with ``weak`` weak planar directions and one motion kind.

    ``yaw_deg``: yaw error (deg). ``translation``: error (m) along each *constrained*
    planar translation direction (both axes for weak 0; the one perpendicular to the weak
    translation direction for weak 1 and 2). Along weak directions the icp front end keeps
    the wheel-odometry prior, so the error there is the odometry error (not fitted).
    ``weak_angle_deg``: weak 1: angle between the weak translation direction and the body
    x axis; weak 2: the same for the constrained translation direction (0..90 deg).
    ``reported_sigma_*``: median of the standard deviations the icp front end reported.
    """

    count: int
    yaw_deg: Mixture
    translation: Mixture
    reported_sigma_yaw_deg: float
    reported_sigma_translation: float
    weak_angle_deg: Histogram | None = None
    # Quantiles of the reported sigmas at ``sigma_levels`` and mixtures of the errors
    # divided by them: the model draws sigma (one level for yaw and translation) x z.
    sigma_levels: tuple[float, ...] = ()
    sigma_yaw_deg_quantiles: tuple[float, ...] = ()
    sigma_translation_quantiles: tuple[float, ...] = ()
    yaw_z: Mixture | None = None
    translation_z: Mixture | None = None

    def draw_sigmas(self, rng: np.random.Generator) -> tuple[float, float]:
        """Reported (yaw deg, translation m) sigmas at one random quantile level."""
        if not self.sigma_levels:
            return self.reported_sigma_yaw_deg, self.reported_sigma_translation
        u = rng.random()
        return (interpolate(u, self.sigma_levels, self.sigma_yaw_deg_quantiles),
                interpolate(u, self.sigma_levels, self.sigma_translation_quantiles))


@dataclass(frozen=True)
class ScanMatchingCalibration:
    """Everything the ``model`` front end samples sequential scan matches from."""

    # The scan statistic: number of points between these heights above the floor
    # (sensor frame z + mount_height), i.e. the LiDAR's obstacle band.
    statistic_min_height: float
    statistic_max_height: float
    mount_height: float
    # Binned by the statistic (bin k: [bin_edges[k], bin_edges[k+1]), last bin open).
    bin_edges: tuple[float, ...]
    degenerate_rate: tuple[float, ...]  # after a usable (anchored) keyframe
    degenerate_rate_after_degenerate: tuple[float, ...]  # after a degenerate one
    weak_probabilities: tuple[tuple[float, float, float], ...]  # P(weak = 0, 1, 2 | usable)
    turn_threshold_deg: float  # a keyframe "turned" if |wheel yaw| exceeds this
    max_span: int  # after this many degenerate keyframes the submap restarts
    weak_sigma: float
    off_plane_sigma: float
    conditions: dict[str, Condition] = field(default_factory=dict)
    path: str = ""

    def bin(self, statistic: float) -> int:
        return int(np.clip(np.searchsorted(self.bin_edges, statistic, side="right") - 1,
                           0, len(self.degenerate_rate) - 1))

    def condition(self, weak: int, turned: bool) -> Condition:
        return self.conditions[condition_name(weak, turned)]


def condition_name(weak: int, turned: bool) -> str:
    return f"weak{int(weak)}_{'turned' if turned else 'straight'}"


@dataclass(frozen=True)
class LoopSource:
    """One loop-closure source (pose or segment matching) of ``loop_closures.yaml``."""

    bin_edges: tuple[float, ...]
    rate_per_attempt: tuple[float | None, ...]
    rate_per_revisit: tuple[float | None, ...]
    logistic_intercept: float | None
    logistic_slope: float | None
    rms_translation: float
    rms_rotation_deg: float

    def rate(self, distance: float, per: str = "attempt") -> float:
        """Acceptance probability at ``distance``: the bin's rate, else the logistic fit
        (empty bins), else 0; 0 beyond the last bin."""
        rates = self.rate_per_attempt if per == "attempt" else self.rate_per_revisit
        if distance < self.bin_edges[0] or distance >= self.bin_edges[-1]:
            return 0.0
        k = min(bisect.bisect_right(self.bin_edges, distance) - 1, len(rates) - 1)
        if rates[k] is not None:
            return float(rates[k])
        if self.logistic_intercept is None or self.logistic_slope is None:
            return 0.0
        return float(1.0 / (1.0 + np.exp(-(self.logistic_intercept + self.logistic_slope * distance))))


@dataclass(frozen=True)
class LoopClosureCalibration:
    r_lc: float
    sources: dict[str, LoopSource]
    path: str = ""
    # (metres, degrees) of the keyframes the fit was made with; None if the file does not say
    keyframe_spacing: tuple[float, float] | None = None


# ----------------------------------------------------------------------------- validation


class _Reader:
    """Typed access to a parsed YAML mapping with errors that name file and key."""

    def __init__(self, path: Path, data: Any, prefix: str = ""):
        self.path, self.data, self.prefix = path, data, prefix

    def fail(self, key: str, problem: str) -> CalibrationError:
        where = f"{self.prefix}{key}" if key else self.prefix.rstrip(".") or "<top level>"
        return CalibrationError(f"{self.path}: {where}: {problem}")

    def child(self, key: str) -> "_Reader":
        value = self.get(key)
        if not isinstance(value, dict):
            raise self.fail(key, f"expected a mapping, got {type(value).__name__}")
        return _Reader(self.path, value, f"{self.prefix}{key}.")

    def keys(self) -> list[str]:
        return [str(k) for k in self.data]

    def only(self, allowed: set[str]) -> None:
        unknown = sorted(set(map(str, self.data)) - allowed)
        if unknown:
            raise self.fail(unknown[0], f"unknown key (allowed: {', '.join(sorted(allowed))})")

    def get(self, key: str) -> Any:
        if not isinstance(self.data, dict) or key not in self.data:
            raise self.fail(key, "missing")
        return self.data[key]

    def number(self, key: str, low: float | None = None, high: float | None = None,
               value: Any = None, name: str | None = None) -> float:
        name = key if name is None else name
        value = self.get(key) if value is None else value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(name, f"expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise self.fail(name, f"must be finite, got {value}")
        if low is not None and value < low:
            raise self.fail(name, f"must be >= {low}, got {value}")
        if high is not None and value > high:
            raise self.fail(name, f"must be <= {high}, got {value}")
        return value

    def optional_number(self, key: str, **kw) -> float | None:
        return None if self.get(key) is None else self.number(key, **kw)

    def integer(self, key: str, low: int | None = None) -> int:
        value = self.get(key)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"expected an integer, got {value!r}")
        if low is not None and value < low:
            raise self.fail(key, f"must be >= {low}, got {value}")
        return int(value)

    def numbers(self, key: str, low: float | None = None, high: float | None = None,
                allow_null: bool = False, length: int | None = None) -> tuple:
        values = self.get(key)
        if not isinstance(values, list) or not values:
            raise self.fail(key, f"expected a non-empty list, got {values!r}")
        if length is not None and len(values) != length:
            raise self.fail(key, f"expected {length} entries, got {len(values)}")
        out = []
        for k, v in enumerate(values):
            if v is None and allow_null:
                out.append(None)
            else:
                out.append(self.number(key, low, high, value=v, name=f"{key}[{k}]"))
        return tuple(out)

    def edges(self, key: str) -> tuple[float, ...]:
        edges = self.numbers(key, low=0.0)
        if len(edges) < 2 or any(b <= a for a, b in zip(edges, edges[1:])):
            raise self.fail(key, "expected at least two strictly increasing bin edges")
        return edges


def _load_yaml(path: Path | str) -> tuple[Path, dict]:
    path = Path(path)
    if not path.is_file():
        raise CalibrationError(f"{path}: calibration file not found (run the calibration script "
                               "named in its docs, or pass another path)")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        raise CalibrationError(f"{path}: not valid YAML: {err}") from None
    if not isinstance(data, dict):
        raise CalibrationError(f"{path}: expected a mapping at the top level")
    return path, data


def _mixture(reader: _Reader) -> Mixture:
    reader.only({"core_sigma", "tail_sigma", "tail_fraction"})
    return Mixture(reader.number("core_sigma", low=0.0), reader.number("tail_sigma", low=0.0),
                   reader.number("tail_fraction", low=0.0, high=1.0))


def _histogram(reader: _Reader) -> Histogram:
    reader.only({"edges", "probabilities"})
    edges = reader.edges("edges")
    probabilities = reader.numbers("probabilities", 0.0, 1.0, length=len(edges) - 1)
    if not math.isclose(sum(probabilities), 1.0, abs_tol=1e-3):
        raise reader.fail("probabilities", f"must sum to 1, got {sum(probabilities):.4f}")
    return Histogram(edges, probabilities)


def load_scan_matching(path: Path | str = SCAN_MATCHING_FILE) -> ScanMatchingCalibration:
    """Read and validate ``scan_matching.yaml`` (see its header for the format)."""
    path, data = _load_yaml(path)
    top = _Reader(path, data)
    top.only({"version", "statistic", "degenerate", "weak_probabilities", "turn_threshold_deg",
              "max_span", "weak_sigma", "off_plane_sigma", "conditions", "fit", "provenance"})
    if top.get("version") != 1:
        raise top.fail("version", f"unsupported version {top.get('version')!r} (expected 1)")
    stat = top.child("statistic")
    stat.only({"name", "min_height", "max_height", "mount_height"})
    if stat.get("name") != "obstacle_points":
        raise stat.fail("name", f"unknown statistic {stat.get('name')!r} (expected obstacle_points)")
    degenerate = top.child("degenerate")
    degenerate.only({"bin_edges", "rate", "rate_after_degenerate", "count", "count_after_degenerate"})
    edges = degenerate.edges("bin_edges")
    n_bins = len(edges) - 1
    weak = top.get("weak_probabilities")
    if not isinstance(weak, list) or len(weak) != n_bins:
        raise top.fail("weak_probabilities", f"expected a list of {n_bins} [p0, p1, p2] rows")
    weak_rows = []
    for k, row in enumerate(weak):
        name = f"weak_probabilities[{k}]"
        if not isinstance(row, list) or len(row) != 3:
            raise top.fail(name, "expected [p0, p1, p2]")
        values = tuple(top.number(name, 0.0, 1.0, value=v, name=f"{name}[{i}]") for i, v in enumerate(row))
        if not math.isclose(sum(values), 1.0, abs_tol=1e-3):
            raise top.fail(name, f"must sum to 1, got {sum(values):.4f}")
        weak_rows.append(values)
    conditions_reader = top.child("conditions")
    expected = {f"weak{w}_{m}" for w in WEAK_COUNTS for m in MOTIONS}
    conditions_reader.only(expected)
    conditions = {}
    for name in sorted(expected):
        c = conditions_reader.child(name)
        c.only({"count", "yaw_deg", "translation", "reported_sigma_yaw_deg",
                "reported_sigma_translation", "weak_angle_deg", "error_std",
                "reported_sigma_quantiles", "yaw_z", "translation_z"})
        angle = None
        if not name.startswith("weak0"):
            angle = _histogram(c.child("weak_angle_deg"))
        levels, q_yaw, q_t, yaw_z, translation_z = (), (), (), None, None
        if "reported_sigma_quantiles" in c.data:
            q = c.child("reported_sigma_quantiles")
            q.only({"levels", "yaw_deg", "translation"})
            levels = q.numbers("levels", 0.0, 1.0)
            q_yaw = q.numbers("yaw_deg", low=0.0, length=len(levels))
            q_t = q.numbers("translation", low=0.0, length=len(levels))
            for key, values in (("levels", levels), ("yaw_deg", q_yaw), ("translation", q_t)):
                if any(b < a for a, b in zip(values, values[1:])):
                    raise q.fail(key, "must be non-decreasing")
            yaw_z, translation_z = _mixture(c.child("yaw_z")), _mixture(c.child("translation_z"))
        conditions[name] = Condition(
            count=c.integer("count", low=0),
            yaw_deg=_mixture(c.child("yaw_deg")),
            translation=_mixture(c.child("translation")),
            reported_sigma_yaw_deg=c.number("reported_sigma_yaw_deg", low=0.0),
            reported_sigma_translation=c.number("reported_sigma_translation", low=0.0),
            weak_angle_deg=angle,
            sigma_levels=levels,
            sigma_yaw_deg_quantiles=q_yaw,
            sigma_translation_quantiles=q_t,
            yaw_z=yaw_z,
            translation_z=translation_z,
        )
    return ScanMatchingCalibration(
        statistic_min_height=stat.number("min_height"),
        statistic_max_height=stat.number("max_height"),
        mount_height=stat.number("mount_height", low=0.0),
        bin_edges=edges,
        degenerate_rate=degenerate.numbers("rate", 0.0, 1.0, length=n_bins),
        degenerate_rate_after_degenerate=degenerate.numbers("rate_after_degenerate", 0.0, 1.0,
                                                             length=n_bins),
        weak_probabilities=tuple(weak_rows),
        turn_threshold_deg=top.number("turn_threshold_deg", low=0.0),
        max_span=top.integer("max_span", low=1),
        weak_sigma=top.number("weak_sigma", low=0.0),
        off_plane_sigma=top.number("off_plane_sigma", low=0.0),
        conditions=conditions,
        path=str(path),
    )


def load_loop_closures(path: Path | str = LOOP_CLOSURES_FILE) -> LoopClosureCalibration:
    """Read and validate ``loop_closures.yaml`` (format: its header)."""
    path, data = _load_yaml(path)
    top = _Reader(path, data)
    # Only the keys read here are checked: the loop-closure script may add others.
    r_lc = top.number("r_lc", low=0.0)
    if top.get("version") != 1:
        raise top.fail("version", f"unsupported version {top.get('version')!r} (expected 1)")
    sources_reader = top.child("sources")
    sources = {}
    for name in sources_reader.keys():
        s = sources_reader.child(name)
        logistic = s.child("acceptance_logistic")
        per_revisit, per_attempt = s.child("per_revisit"), s.child("per_attempt")
        edges = per_attempt.edges("bin_edges_m")
        revisit_edges = per_revisit.edges("bin_edges_m")
        if revisit_edges != edges:
            raise per_revisit.fail("bin_edges_m", "must equal per_attempt.bin_edges_m")
        error = s.child("accepted_error")
        rate_per_attempt = per_attempt.numbers("rate", 0.0, 1.0, allow_null=True, length=len(edges) - 1)
        rate_per_revisit = per_revisit.numbers("rate", 0.0, 1.0, allow_null=True, length=len(edges) - 1)
        intercept, slope = logistic.optional_number("intercept"), logistic.optional_number("slope")
        # A source that never closed a loop (at that keyframe spacing, say) has no error to
        # sample: its errors may be null, and then it must never accept.
        never_closed = error.integer("count", low=0) == 0
        if never_closed and (any(rate_per_attempt + rate_per_revisit) or intercept is not None):
            raise error.fail("count", "is 0 (no closure to fit errors on), yet an acceptance rate is above 0")
        rms = error.optional_number if never_closed else error.number
        sources[name] = LoopSource(
            bin_edges=edges,
            rate_per_attempt=rate_per_attempt,
            rate_per_revisit=rate_per_revisit,
            logistic_intercept=intercept,
            logistic_slope=slope,
            rms_translation=rms("rms_translation_m", low=0.0) or 0.0,
            rms_rotation_deg=rms("rms_rotation_deg", low=0.0) or 0.0,
        )
    if not sources:
        raise top.fail("sources", "no loop-closure source")
    spacing = None
    if top.get("keyframe_spacing") is not None:
        fitted = top.child("keyframe_spacing")
        spacing = (fitted.number("distance_m", low=0.0), fitted.number("angle_deg", low=0.0))
    return LoopClosureCalibration(r_lc=r_lc, sources=sources, path=str(path), keyframe_spacing=spacing)


@functools.lru_cache(maxsize=4)
def cached_scan_matching(path: str = str(SCAN_MATCHING_FILE)) -> ScanMatchingCalibration:
    """:func:`load_scan_matching`, parsed once per process (sessions are made per episode)."""
    return load_scan_matching(path)


@functools.lru_cache(maxsize=4)
def cached_loop_closures(path: str = str(LOOP_CLOSURES_FILE)) -> LoopClosureCalibration:
    """:func:`load_loop_closures`, parsed once per process."""
    return load_loop_closures(path)
