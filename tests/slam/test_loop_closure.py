"""Loop closures through the loop closer: gate, verification, factors, statistics.

Synthetic sessions: keyframes driven around a rectangle in the test room of
``test_frontend`` (walls and three boxes; scans sampled from its surfaces at the true
poses), a pose graph fed noisy odometry only (so the uncertainty grows until the loop
closes), and the loop closer run after every keyframe, as ``SlamSession`` does.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import yaml

from explore_rl.geometry import se2_between, se2_compose, se2_to_matrix
from explore_rl.slam import loop_closure as lc
from explore_rl.slam.config import LoopClosureConfig, PoseGraphConfig, SlamConfig
from explore_rl.slam.loop_closure import IcpLoopCloser, read_attempts_csv, write_attempts_csv
from explore_rl.slam.pose_graph import PoseGraph
from explore_rl.slam.session import NoLoopClosures, make_loop_closer

from .test_frontend import SENSOR_HEIGHT, room_points, scan

STEPS_PER_KEYFRAME = 4  # motion steps per keyframe (odometry sigma x 2)


@dataclass
class FakeKeyframe:
    index: int
    true_pose: np.ndarray
    travel: float
    cloud: np.ndarray


class FakeSession:
    """What the loop closer reads from a ``SlamSession``."""

    def __init__(self, graph: PoseGraph):
        self.graph = graph
        self.keyframes: list[FakeKeyframe] = []


def rectangle(loops: float = 1.5, step: float = 0.5) -> np.ndarray:
    """True poses every ``step`` m around the 2 m x 1 m rectangle (2, 2)-(4, 3) of the
    test room, heading along it (a 90 deg turn at each corner)."""
    corners = np.array([[2.0, 2.0], [4.0, 2.0], [4.0, 3.0], [2.0, 3.0]])
    poses = []
    for k in range(int(round(loops * 6.0 / step)) + 1):
        s = (k * step) % 6.0
        lengths = [2.0, 1.0, 2.0, 1.0]
        side = 0
        while s >= lengths[side] - 1e-9:
            s -= lengths[side]
            side = (side + 1) % 4
        a, b = corners[side], corners[(side + 1) % 4]
        heading = np.arctan2(*(b - a)[::-1])
        poses.append([*(a + s * (b - a) / lengths[side]), heading])
    return np.array(poses)


def drive(truth: np.ndarray, closer, config: PoseGraphConfig | None = None, odom_bias=None,
          seed: int = 0, on_keyframe=None) -> FakeSession:
    """Feed keyframes at ``truth`` with noisy (optionally biased) odometry; run the loop
    closer after each one. ``on_keyframe(session, j, added)`` is called after it. The
    odometry noise follows the default odometry sigmas, whatever the graph assumes."""
    config = config or PoseGraphConfig()
    rng = np.random.default_rng(seed)
    noise = PoseGraphConfig()
    sigma = np.sqrt(STEPS_PER_KEYFRAME) * np.array(
        [noise.odom_sigma_xy_per_step, noise.odom_sigma_xy_per_step,
         np.deg2rad(noise.odom_sigma_yaw_deg_per_step)])
    session = FakeSession(PoseGraph(config, truth[0]))
    travel = 0.0
    for j, pose in enumerate(truth):
        if j:
            delta = se2_between(truth[j - 1], pose) + rng.normal(0.0, sigma)
            if odom_bias is not None:
                delta = delta + odom_bias(j)
            session.graph.add_keyframe(delta, STEPS_PER_KEYFRAME)
            travel += float(np.hypot(*(pose[:2] - truth[j - 1][:2])))
        session.keyframes.append(FakeKeyframe(j, pose.copy(), travel, scan(room_points(rng), pose, rng)))
        added = closer.process(session)
        if on_keyframe is not None:
            on_keyframe(session, j, added)
    return session


def make_closer(**overrides) -> IcpLoopCloser:
    config = dataclasses.replace(LoopClosureConfig(), line_of_sight=False, segments_enabled=False,
                                 **overrides)
    return IcpLoopCloser(config, mount_height=SENSOR_HEIGHT)


def true_relative_error(session: FakeSession, i: int, j: int, relative: np.ndarray) -> tuple[float, float]:
    truth = se2_between(session.keyframes[i].true_pose, session.keyframes[j].true_pose)
    return lc.planar_error(relative, truth)


# ------------------------------------------------------------------ pose matching


def test_accepted_loop_closure_shrinks_current_pose_covariance_and_is_true():
    closer = make_closer()
    traces = []

    def measure(session, j, added):
        traces.append((j, added, np.trace(session.graph.world_xy_covariance(j))))

    # Record the covariance just before each keyframe's closures too.
    before = {}
    original = closer._process

    def process(session):
        j = len(session.keyframes) - 1
        before[j] = np.trace(session.graph.world_xy_covariance(j))
        return original(session)

    closer._process = process
    session = drive(rectangle(), closer, on_keyframe=measure)
    accepted = [a for a in closer.attempts if a.accepted]
    assert accepted, [(a.query, a.candidate, a.reason) for a in closer.attempts]
    assert closer.closures["pose_matching"] == len(accepted)
    assert session.graph.factor_counts["pose_matching"] == len(accepted)
    first = accepted[0]
    j = first.query
    after = next(t for k, n, t in traces if k == j)
    assert after < 0.5 * before[j], (before[j], after)
    # Every accepted closure is true (logged error against ground truth).
    for a in accepted:
        assert a.error_translation < 0.05 and a.error_rotation_deg < 1.0, a
        assert a.registered and a.source == "pose_matching" and a.ms > 0
        assert a.travel_gap >= closer.config.min_travel_gap
        assert a.query - a.candidate >= closer.config.min_index_gap


def test_loop_closures_halve_the_error_at_the_end_of_the_loop():
    closer = make_closer()
    no_loops = drive(rectangle(), NoLoopClosures())
    session = drive(rectangle(), closer)
    truth = np.array([k.true_pose for k in session.keyframes])
    err_loops = np.linalg.norm(session.graph.poses_se2()[:, :2] - truth[:, :2], axis=1)
    err_none = np.linalg.norm(no_loops.graph.poses_se2()[:, :2] - truth[:, :2], axis=1)
    assert closer.closures["pose_matching"] > 0
    assert err_loops[-1] < 0.5 * err_none[-1], (err_loops[-1], err_none[-1])


@pytest.mark.parametrize("odom_sigma, attempted", [(1e-4, False), (0.1, True)])
def test_a_wrong_initial_guess_far_outside_the_gate_is_never_attempted(odom_sigma, attempted, monkeypatch):
    """On keyframe 12 (back at the start) the odometry claims a 1.8 m side step that
    never happened, so the second lap is estimated 1.8 m south of where it truly is:
    every revisited keyframe is a candidate (within search_radius) whose guess lies
    outside overlap_radius. With near-perfect odometry sigmas the joint marginal is
    tiny and the gate rejects all of them without registering; with honest (large)
    sigmas the same guesses are inside the gate and registered."""
    calls = []
    original = lc.Verifier.register

    def counting(self, source, target, starts):
        calls.append(len(starts))
        return original(self, source, target, starts)

    monkeypatch.setattr(lc.Verifier, "register", counting)
    config = dataclasses.replace(PoseGraphConfig(), odom_sigma_xy_per_step=odom_sigma,
                                 odom_sigma_yaw_deg_per_step=np.rad2deg(odom_sigma))
    closer = make_closer(min_sigma_translation=0.0, min_sigma_rotation_deg=0.0,
                         max_sigma_translation=10.0, max_sigma_rotation_deg=180.0)
    # Keyframe 11 heads south (-y): a forward step of 1.8 m in its frame moves south.
    side_step = lambda j: np.array([1.8, 0.0, 0.0]) if j == 12 else np.zeros(3)  # noqa: E731
    # Keyframes 12-16 retrace the southern side (2, 2)-(4, 2).
    calls_before = {}
    session = drive(rectangle(loops=16 / 12), closer, config=config, odom_bias=side_step,
                    on_keyframe=lambda session, j, added: calls_before.setdefault(j + 1, len(calls)))
    calls_on_revisits = len(calls) - calls_before[12]
    revisits = [a for a in closer.attempts if a.query >= 12]
    assert revisits, "no candidate reached the gate"
    first = revisits[0]
    assert first.query == 12 and first.distance > closer.config.overlap_radius, first
    assert first.true_distance < 0.3  # truly the same place
    if attempted:
        assert first.registered and calls_on_revisits > 0
    else:
        assert all(a.distance > closer.config.overlap_radius for a in revisits), revisits
        assert all(not a.registered and a.reason == "gate_far" for a in revisits), revisits
        assert all(a.gate_d2 > 100 for a in revisits)
        assert calls_on_revisits == 0
        assert not [e for e in session.graph.edges if e[2] == "pose_matching" and e[1] >= 12]


def test_wrong_registration_is_rejected_as_inconsistent_or_absorbed(monkeypatch):
    """Force every registration to report a perfect fit 1 m (and 10 deg) away from the
    truth: the chi-square consistency check rejects it; with the check disabled the
    factors are added and the Cauchy kernel bounds the damage."""
    original = lc.Verifier.register

    def wrong(self, source, target, starts):
        solutions = original(self, source, target, starts)
        for s in solutions[:1]:
            s.relative = se2_compose(s.relative, [1.0, 0.0, np.deg2rad(10.0)])
        return solutions

    clean_closer = make_closer()
    clean = drive(rectangle(), clean_closer)
    assert clean_closer.closures["pose_matching"] > 0
    monkeypatch.setattr(lc.Verifier, "register", wrong)

    checked = make_closer()
    drive(rectangle(), checked)
    registered = [a for a in checked.attempts if a.registered]
    assert registered and not any(a.accepted for a in registered)
    assert {a.reason for a in registered} <= {"inconsistent", "inlier_fraction", "residual",
                                               "weakly_constrained", "weak_and_uncertain", "no_overlap"}
    assert any(a.reason == "inconsistent" for a in registered)

    unchecked = make_closer(consistency_probability=1.0 - 1e-15, max_closures_per_keyframe=1)
    # With the consistency check off the quality test alone passes some wrong fits
    # (their refined systems are measured at the true alignment).
    monkeypatch.setattr(lc.IcpLoopCloser, "_consistent", lambda *args: True)
    damaged = drive(rectangle(), unchecked)
    wrong_added = [a for a in unchecked.attempts if a.accepted]
    assert wrong_added and all(a.error_translation > 0.9 for a in wrong_added)
    truth = np.array([k.true_pose for k in damaged.keyframes])
    shift = np.linalg.norm(damaged.graph.poses_se2()[:, :2] - clean.graph.poses_se2()[:, :2], axis=1)
    # The wrong closures (1 m off) move the trajectory by less than a fifth of their error.
    assert shift.max() < 0.2, shift.max()
    assert np.linalg.norm(damaged.graph.poses_se2()[:, :2] - truth[:, :2], axis=1).max() < 0.3
    # Without the robust kernel the same closures drag it much further.
    plain_closer = make_closer(consistency_probability=1.0 - 1e-15)
    plain = drive(rectangle(), plain_closer, config=PoseGraphConfig(loop_robust_kernel="none"))
    assert any(a.accepted for a in plain_closer.attempts)
    plain_shift = np.linalg.norm(plain.graph.poses_se2()[:, :2] - clean.graph.poses_se2()[:, :2], axis=1)
    assert plain_shift.max() > 2 * shift.max() and plain_shift.max() > 0.2, (plain_shift.max(), shift.max())


def test_empty_and_floor_only_clouds_never_raise():
    closer = make_closer(min_sigma_translation=0.0, min_sigma_rotation_deg=0.0)
    session = FakeSession(PoseGraph(PoseGraphConfig(), [2.0, 2.0, 0.0]))
    truth = rectangle()
    for j, pose in enumerate(truth):
        if j:
            session.graph.add_keyframe(se2_between(truth[j - 1], pose), STEPS_PER_KEYFRAME)
        cloud = np.zeros((0, 3)) if j % 2 else np.array([[1.0, 0.0, -SENSOR_HEIGHT]] * 50)
        session.keyframes.append(FakeKeyframe(j, pose, 0.5 * j, cloud))
        assert closer.process(session) == 0
    assert all(not a.accepted for a in closer.attempts)
    assert closer.failures == 0
    # A session without the attributes the closer needs is logged and skipped, not raised.
    assert closer.process(object()) == 0
    assert closer.failures == 1


# ------------------------------------------------------------------ records, wiring


def test_attempts_round_trip_through_csv(tmp_path):
    closer = make_closer()
    drive(rectangle(), closer)
    assert closer.attempts
    path = write_attempts_csv(closer.attempts, tmp_path / "attempts.csv")
    back = read_attempts_csv(path)
    assert len(back) == len(closer.attempts)
    for a, b in zip(closer.attempts, back):
        for f in dataclasses.fields(a):
            x, y = getattr(a, f.name), getattr(b, f.name)
            if isinstance(x, float) and np.isnan(x):
                assert np.isnan(y)
            else:
                assert x == pytest.approx(y) if isinstance(x, float) else x == y, f.name


def test_loop_closer_pickles_with_its_logs():
    import pickle

    closer = make_closer()
    drive(rectangle(), closer)
    clone = pickle.loads(pickle.dumps(closer))
    np.testing.assert_equal([dataclasses.asdict(a) for a in clone.attempts],
                            [dataclasses.asdict(a) for a in closer.attempts])
    assert clone.closures == closer.closures
    assert clone.config == closer.config and clone.verifier is not closer.verifier


def test_make_loop_closer_follows_the_config():
    assert isinstance(make_loop_closer(SlamConfig()), IcpLoopCloser)
    off = SlamConfig(loop_closure=LoopClosureConfig(enabled=False))
    assert isinstance(make_loop_closer(off), NoLoopClosures)
    from explore_rl.slam.frontend_model import ModelLoopCloser

    assert isinstance(make_loop_closer(SlamConfig(frontend="model")), ModelLoopCloser)


def test_conf_yaml_mirrors_loop_closure_defaults():
    path = Path(__file__).resolve().parents[2] / "conf" / "slam" / "icp.yaml"
    conf = yaml.safe_load(path.read_text())
    assert conf["loop_closure"] == dataclasses.asdict(LoopClosureConfig())


def test_relative_covariance_matches_sampling():
    """``relative_covariance`` against Monte Carlo on Pose3 right perturbations."""
    import gtsam

    rng = np.random.default_rng(3)
    Ti, Tj = se2_to_matrix([1.0, 2.0, 0.4]), se2_to_matrix([2.5, 1.0, 1.3])
    A = rng.normal(size=(12, 12)) * 0.02
    joint = A @ A.T
    rel = np.linalg.inv(Ti) @ Tj
    samples = []
    for xi in rng.multivariate_normal(np.zeros(12), joint, size=8000):
        Pi = Ti @ gtsam.Pose3.Expmap(xi[:6]).matrix()
        Pj = Tj @ gtsam.Pose3.Expmap(xi[6:]).matrix()
        samples.append(gtsam.Pose3.Logmap(gtsam.Pose3(np.linalg.inv(rel) @ np.linalg.inv(Pi) @ Pj)))
    empirical = np.cov(np.array(samples).T)
    predicted = lc.relative_covariance(joint, rel)
    assert np.abs(empirical - predicted).max() < 0.05 * np.abs(predicted).max()


def test_closest_separated_matches_the_pairwise_rule():
    """One candidate per run of neighbouring keyframes, closest first: the same picks as
    checking every pick so far (the rule both loop closers use)."""
    from explore_rl.slam.loop_closure import closest_separated

    rng = np.random.default_rng(3)
    for _ in range(50):
        indices = np.sort(rng.choice(200, size=rng.integers(0, 60), replace=False))
        distance = rng.uniform(0, 3, len(indices)).round(1)  # ties: stable order decides
        separation = int(rng.integers(1, 12))
        expected: list[int] = []
        for i in indices[np.argsort(distance, kind="stable")].tolist():
            if all(abs(i - p) >= separation for p in expected):
                expected.append(i)
        assert closest_separated(indices, distance, separation) == expected
        assert closest_separated(indices, distance, separation, limit=3) == expected[:3]
