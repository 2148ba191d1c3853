"""Configuration of the virtual map, revisit prediction and reward (plain dataclasses).

These become Hydra structured configs (``conf/planning/default.yaml`` holds the same
defaults); keep every field a plain type.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional


@dataclass
class VirtualMapConfig:
    """Virtual landmarks of the EM utility (Wang et al.); values from the paper, Sec. IV."""

    cell_size: float = 0.5  # m; an integer multiple of the occupancy grid's resolution
    prior_std: float = 0.2  # m; every landmark starts at prior_std^2 * I
    sigma_range: float = 0.02  # m; range noise of the virtual range-bearing sensor
    sigma_bearing_deg: float = 0.2  # deg; bearing noise of the virtual sensor
    sensor_range: float = 3.0  # m; landmarks farther than this are not observed
    min_range: float = 0.25  # m; the range is clamped below at this value
    los_step_fraction: float = 0.5  # line-of-sight sample step, in fine grid cells
    max_batch_samples: int = 2_000_000  # line-of-sight samples evaluated per numpy batch


@dataclass
class RevisitConfig:
    """When a predicted pose closes a loop with an older keyframe."""

    r_lc: float = 2.0  # m; fitted from the icp loop-closure statistics (conf/calibration/loop_closures.yaml)
    min_travel_gap: float = 3.0  # m; travel between keyframe and pose must exceed this
    merge_keyframe_gap: int = 4  # revisited keyframes this close in index form one revisit
    keyframe_spacing: float = 0.5  # m; spacing of predicted poses along a path
    los_step_fraction: float = 0.5  # line-of-sight sample step, in fine grid cells


@dataclass
class RewardConfig:
    """Raw reward U0 - U' - alpha * path_length and its normalisation (paper Alg. 1)."""

    alpha: float = 10.0  # utility per metre of travel; see benchmarks/RESULTS.md (EM alpha sweep)
    tie_tolerance: float = 1e-9  # relative spread below which all raw rewards count equal


EM_BACKENDS = ("fast", "reference")


@dataclass
class EMConfig:
    """EM-specific settings: the predicted measurements' noise and how U' is computed."""

    # Predicted sequential scan matching (SSM), planar axes; defaults near the measured
    # kiss-icp step accuracy (~1 cm, ~0.15 deg; DESIGN.md) = the scan matcher's
    # covariance floors (slam.scan_matcher.min_sigma_*).
    ssm_sigma_translation: float = 0.01
    ssm_sigma_rotation_deg: float = 0.15
    # Predicted loop closures (pose matching against an old keyframe up to r_lc away).
    loop_sigma_translation: float = 0.05
    loop_sigma_rotation_deg: float = 0.5
    # z / roll / pitch sigma of predicted SSM and loop factors (left to odometry, like
    # the real front end's off-plane sigma).
    off_plane_sigma: float = 1.0
    # Factor kind of predicted loops on the graph copy (never on the live graph).
    loop_kind: str = "predicted_loop"
    # Skip the graph copy for candidates without a predicted loop (exact up to
    # linearisation); false forces the copy for every candidate (slower; for checks).
    shortcut_without_loops: bool = True
    # How the pose marginals and U' are computed: fast = one sparse factorisation of the
    # live graph per decision, every candidate's marginals as a low-rank update of it
    # (explore_rl/planning/em_fast.py; same utilities within the tolerance documented in
    # tests/planning/test_em_fast.py); reference = a copy of the live iSAM2 per loop
    # candidate and one marginal query per pose (the baseline of tests and benchmarks).
    backend: str = "fast"

    def validate(self) -> None:
        """One-line errors for values no run can use."""
        if self.backend not in EM_BACKENDS:
            raise ValueError(f"planning.em.backend={self.backend!r}: choose {' or '.join(EM_BACKENDS)}")


@dataclass
class ActionSetConfig:
    """Which frontiers a decision offers (explore_rl/planning/actions.py): one set for the
    exploration graph, the EM planner and the Algorithm 1 reward."""

    # graph: the paper's set, the nearest frontier + every frontier whose path closes a loop;
    # nearest: the max_frontiers shortest-path frontiers alone
    kind: str = "graph"
    # also offer this many shortest-path frontiers (studies; 0 = the paper's set)
    extra_nearest: int = 0
    # at most this many frontiers, nearest first then by path length (bounds EM's cost)
    max_frontiers: int = 10


@dataclass
class PlanningConfig:
    """The ``planning`` config group."""

    actions: ActionSetConfig = field(default_factory=ActionSetConfig)
    virtual_map: VirtualMapConfig = field(default_factory=VirtualMapConfig)
    revisits: RevisitConfig = field(default_factory=RevisitConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)
    em: EMConfig = field(default_factory=EMConfig)


@dataclass
class PolicyConfig:
    """The ``policy`` config group. ``name``: nearest, random, em or learned.

    EM evaluates the decision's action set, ``planning.actions`` (one set for the
    exploration graph, EM and the reward). ``learned`` reads its actor from ``checkpoint``:
    an actor file (``explore-rl-export``) or a training checkpoint; the default is the
    shipped policy (explore_rl/planning/learned.py).

    ``revisit_bias`` (learned only): added to each frontier's logit per keyframe its path
    revisits (the predicted loop closures) before the greedy choice -- a decision-time prior
    towards closing loops, not learned; 0 is the actor alone.

    ``loop_bias`` (learned only): added to each frontier's logit per metre of its
    ``loop_length`` (the pose-graph distance from the current keyframe to the farthest
    keyframe its path revisits) -- a decision-time prior towards closing long loops, not
    learned, whatever node features the actor reads; 0 is the actor alone.

    ``loop_bias_until_m`` (learned only): if > 0, ``loop_bias`` applies only while the robot has
    travelled less than this many metres (its own odometry) -- the prior in the opening phase of
    an exploration, without its detours later; 0: at every decision.

    ``loop_bias_from_m`` (learned only): if > 0, ``loop_bias`` applies only once the robot has
    travelled this many metres or more (its own odometry) -- the prior in the late phase, where
    the closures that set the map error at the stop are made, without its detours while the
    building is opened; 0: from the start. With ``loop_bias_until_m`` it must lie below it.

    ``closure_bias`` (learned only): added to each frontier's logit per metre of relative
    position uncertainty a loop closure on its path would remove (the current keyframe
    against each keyframe it revisits, the largest; ``explore_rl.planning.learned.closure_gains``)
    -- a decision-time prior towards closures that pay, not learned; 0 is the actor alone.

    ``em_top_k`` (learned only): if > 0, the EM planner picks among the actor's ``k`` most
    probable frontiers (after the priors) by its utility -- a hybrid, not the learned
    policy alone, that costs about what EM costs (EM's decision context dominates); a
    diagnostic of the actor's ranking; 0 is the actor alone.

    ``em_below_confidence`` (learned only): if > 0, EM decides over the whole action set
    whenever the actor's top probability (after the priors) is below it -- a hybrid that pays
    EM only where the actor is unsure; 0 is the actor alone, 1 nearly always EM."""

    name: str = "nearest"
    checkpoint: Optional[str] = "policies/buildings_dagger_em_choice/actor.pt"
    revisit_bias: float = 0.0
    loop_bias: float = 0.0
    loop_bias_until_m: float = 0.0
    loop_bias_from_m: float = 0.0
    closure_bias: float = 0.0
    em_top_k: int = 0
    em_below_confidence: float = 0.0
