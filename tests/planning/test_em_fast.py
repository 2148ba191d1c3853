"""EM's fast backend against the reference forward simulation (explore_rl/planning/em_fast.py).

Two kinds of evidence:

* exact agreement (to round-off) where both linearise at the same point: the hand-made
  tour of tests/planning/test_em.py has noise-free odometry, so the live estimates are
  the linearisation point and the reference's graph copy never relinearises;
* agreement within the documented tolerance (``UTILITY_RTOL``/``UTILITY_ATOL`` below) and
  the same choice on >= 95 % of decisions on states recorded from real office, street and
  garage episodes (``slam=model``), where the reference's iSAM2 copy relinearises.
"""

from __future__ import annotations

import dataclasses

import gtsam
import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.geometry import se2_to_matrix
from explore_rl.planning.config import EMConfig
from explore_rl.planning.em import EMPlanner, Observations, ssm_covariance
from explore_rl.planning.em_fast import (
    FuseRounds,
    covariances_of,
    distinct,
    fuse_batched,
    intersect,
    lever_terms,
    observed_information,
    planar_adjoint,
    planar_adjoint_inverse,
    step_tangent_covariances,
    world_from_tangent,
)
from explore_rl.planning.policies import PolicyConfig
from explore_rl.planning.virtual_map import covariance_intersection
from explore_rl.runner import Explorer
from explore_rl.slam.pose_graph import odometry_covariance
from tests.planning.test_em import planner, tour_state

# Documented tolerance of the fast backend against the reference on real states: a
# candidate's U' may differ by UTILITY_ATOL + UTILITY_RTOL x its utility drop |U0 - U'|
# (iSAM2 relinearises the reference's graph copy; DESIGN.md: ~1 % on marginals).
UTILITY_RTOL = 0.02
UTILITY_ATOL = 1.0
SAME_CHOICE = 0.95


# ---------------------------------------------------------------------- building blocks


def test_planar_adjoint_matches_gtsam():
    rng = np.random.default_rng(0)
    poses = np.column_stack([rng.uniform(-10, 10, 5), rng.uniform(-10, 10, 5), rng.uniform(-3, 3, 5)])
    expected = np.stack([gtsam.Pose3(se2_to_matrix(p)).AdjointMap() for p in poses])
    np.testing.assert_allclose(planar_adjoint(poses), expected, atol=1e-12)
    np.testing.assert_allclose(planar_adjoint_inverse(poses) @ expected, np.broadcast_to(np.eye(6), (5, 6, 6)),
                               atol=1e-12)


def test_world_from_tangent_matches_the_pose_graph():
    state = tour_state(3.0)
    graph = state.session.graph
    poses = graph.poses_se2()
    tangent = np.stack([graph.marginal_covariance(i) for i in range(graph.num_poses)])
    expected = np.stack([graph.world_xy_yaw_covariance(i) for i in range(graph.num_poses)])
    np.testing.assert_allclose(world_from_tangent(tangent, poses), expected, rtol=1e-12, atol=1e-15)


def lever_observations(rng, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Random gains ``[-I | lever]`` and symmetric positive noises ``(count, 2, 2)``."""
    gain = np.zeros((count, 2, 3))
    gain[:, 0, 0] = gain[:, 1, 1] = -1.0
    gain[:, :, 2] = rng.uniform(-3, 3, (count, 2))
    root = rng.normal(size=(count, 2, 2)) * 1e-2
    return gain, root @ np.swapaxes(root, 1, 2) + 1e-6 * np.eye(2)


def random_covariances(rng, *shape: int) -> np.ndarray:
    a = rng.normal(size=shape + (3, 3)) * 0.1
    return a @ np.swapaxes(a, -1, -2) + 1e-4 * np.eye(3)


def test_observed_information_inverts_noise_plus_gain_covariance_gain():
    rng = np.random.default_rng(1)
    gain, noise = lever_observations(rng, 5000)  # more than one chunk
    covs = random_covariances(rng, 4, 20)  # (C, N, 3, 3)
    pose_idx = rng.integers(0, 20, 5000)
    info = observed_information(lever_terms(gain, noise), covs, pose_idx)  # (4, M, C)
    expected = np.linalg.inv(noise + gain @ covs[:, pose_idx] @ np.swapaxes(gain, 1, 2))  # (C, M, 2, 2)
    np.testing.assert_allclose(info[0].T, expected[..., 0, 0], rtol=1e-9)
    np.testing.assert_allclose(info[1].T, expected[..., 0, 1], rtol=1e-9)
    np.testing.assert_allclose(info[2].T, expected[..., 1, 1], rtol=1e-9)
    np.testing.assert_array_equal(info[3], 2.0 * info[1])


def test_a_round_of_intersection_is_the_covariance_intersection():
    """``intersect`` (in place, endpoint from ``lin + quad``) = ``covariance_intersection``:
    concave and convex quadratics, a dominated observation, an identical one."""
    rng = np.random.default_rng(2)
    a = np.linalg.inv(random_covariances(rng, 400)[:, :2, :2])
    b = np.linalg.inv(random_covariances(rng, 400)[:, :2, :2])
    b[0] = 0.5 * a[0]  # dominated: w = 1
    b[1] = a[1]  # identical: any w
    b[2] = 3.0 * a[2]  # dominates: w = 0
    expected, w = covariance_intersection(np.linalg.inv(a), np.linalg.inv(b))
    assert np.any(w == 0.0) and np.any(w == 1.0) and np.any((w > 0) & (w < 1))
    info = np.stack([a[:, 0, 0], a[:, 0, 1], a[:, 1, 1]])
    observed = np.stack([b[:, 0, 0], b[:, 0, 1], b[:, 1, 1], 2.0 * b[:, 0, 1]])
    with np.errstate(divide="ignore", invalid="ignore"):
        intersect(info, observed)
    fused, reference = np.linalg.inv(covariances_of(info)), np.linalg.inv(expected)
    scale = np.abs(reference).max(axis=(1, 2), keepdims=True)  # round-off relative to each matrix
    np.testing.assert_allclose(fused / scale, reference / scale, rtol=0, atol=1e-12)


def test_batched_fusion_is_the_fusion_in_order_of_each_set():
    """``fuse_batched`` over ``C`` sets of pose covariances = ``fuse_in_order`` per set."""
    rng = np.random.default_rng(3)
    count, poses, landmarks = 3000, 40, 60
    gain, noise = lever_observations(rng, count)
    pose_idx = np.sort(rng.integers(0, poses, count))
    observations = Observations(pose_idx, rng.integers(0, landmarks, count), gain, noise)
    covs = random_covariances(rng, 3, poses)
    prior = np.repeat(0.04 * np.eye(2)[None], landmarks, axis=0)
    rounds = FuseRounds.of(observations)
    fused = fuse_batched(rounds, covs, prior[rounds.landmarks])
    for k in range(len(covs)):
        expected = observations.fuse(prior, covs[k])
        np.testing.assert_allclose(fused[k], expected[rounds.landmarks], rtol=1e-9)


def test_distinct_finds_bitwise_copies():
    rng = np.random.default_rng(4)
    a, b = rng.normal(size=(2, 5, 3, 3))
    near = a.copy()
    near[0, 0, 0] = np.nextafter(near[0, 0, 0], np.inf)  # one ulp away: not a copy
    unique, inverse = distinct(np.stack([a, b, a, near, b]))
    np.testing.assert_array_equal(inverse, [0, 1, 0, 2, 1])
    np.testing.assert_array_equal(unique, np.stack([a, b, near]))


def test_step_noise_is_odometry_and_scan_matching_fused():
    graph = tour_state(1.0).session.graph
    ssm = ssm_covariance(EMConfig())
    steps = np.array([3, 1, 3, 7])
    expected = [np.linalg.inv(np.linalg.inv(odometry_covariance(graph.config, n)) + np.linalg.inv(ssm)) for n in steps]
    np.testing.assert_allclose(step_tangent_covariances(graph, steps, ssm), expected, rtol=1e-12)
    full = ssm + 1e-7  # not diagonal: the general path
    expected = [np.linalg.inv(np.linalg.inv(odometry_covariance(graph.config, n)) + np.linalg.inv(full)) for n in steps]
    np.testing.assert_allclose(step_tangent_covariances(graph, steps, full), expected, rtol=1e-9)


def test_unknown_backend_fails_in_one_line():
    with pytest.raises(ValueError, match="planning.em.backend='isam3': choose fast or reference"):
        EMConfig(backend="isam3").validate()
    with pytest.raises(ValueError, match="planning.em.backend='isam3'"):
        load_config(["planning.em.backend=isam3"])
    assert load_config([]).planning.em.backend == "fast"  # the default once equivalent (this file)


# ---------------------------------------------------------------------- exact agreement


@pytest.mark.parametrize("scale", [0.3, 3.0, 5.0])
@pytest.mark.parametrize("shortcut", [True, False])
def test_fast_equals_reference_at_a_shared_linearisation_point(scale, shortcut):
    """Loops as a low-rank update = the iSAM2 copy, to round-off (no relinearisation)."""
    state = tour_state(scale)
    reference = planner(shortcut_without_loops=shortcut).evaluate(state)
    fast = planner(backend="fast", shortcut_without_loops=shortcut).evaluate(state)
    assert reference.loops.max() >= 1
    assert fast.u0 == pytest.approx(reference.u0, rel=1e-12)
    np.testing.assert_allclose(fast.u_after, reference.u_after, rtol=1e-11, atol=1e-8)
    assert fast.chosen == reference.chosen


def test_planar_only_update_equals_the_full_update(monkeypatch):
    """Planar graphs (no factor joins yaw, x, y to roll, pitch, z): the loops' planar
    components alone give the same utilities as all six."""
    import explore_rl.planning.em_fast as em_fast

    state = tour_state(3.0)
    planar = planner(backend="fast").evaluate(state)
    assert em_fast.FastContext.of(state.session.graph).decoupled
    of = em_fast.FastContext.of.__func__
    monkeypatch.setattr(em_fast.FastContext, "of", classmethod(lambda cls, graph: of(cls, graph, planar=False)))
    full = planner(backend="fast").evaluate(state)
    assert planar.loops.max() >= 1
    np.testing.assert_allclose(planar.u_after, full.u_after, rtol=1e-12, atol=1e-9)


def test_a_coupling_update_on_a_planar_context_uses_the_full_factorisation():
    """A predicted loop whose noise couples yaw with roll: the planar factorisation is not
    enough; the update switches to the 6-dof one and matches a 6-dof context."""
    from explore_rl.planning.em import loop_covariance
    from explore_rl.planning.em_fast import FastContext, loop_update

    state = tour_state(3.0)
    em = planner(backend="fast")
    context = em.decision_context(state)
    predicted = [em.predicted_keyframes(context, a.prediction) for a in em.actions(state)]
    looping = next(p for p in predicted if p.revisits)
    coupled = loop_covariance(em.em)
    coupled[2, 0] = coupled[0, 2] = 0.3 * np.sqrt(coupled[0, 0] * coupled[2, 2])
    planar = FastContext.of(state.session.graph)
    full = FastContext.of(state.session.graph, planar=False)
    assert planar.decoupled and not full.decoupled
    ssm = ssm_covariance(em.em)
    steps = step_tangent_covariances(state.session.graph, looping.steps, ssm)
    got = loop_update(context, planar, looping, steps, coupled)
    expected = loop_update(context, full, looping, steps, coupled)
    assert planar._full is not None  # the switch happened
    np.testing.assert_allclose(got.old, expected.old, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(got.new, expected.new, rtol=1e-10, atol=1e-14)


def test_planar_decoupled_sees_a_coupling_entry():
    import scipy.sparse as sp

    from explore_rl.planning.em_fast import planar_decoupled

    information = np.eye(12)
    assert planar_decoupled(sp.csr_matrix(information))
    information[2, 6] = information[6, 2] = 0.1  # yaw of pose 0 with roll of pose 1
    assert not planar_decoupled(sp.csr_matrix(information))


def test_fast_context_has_the_reference_marginals():
    state = tour_state(3.0)
    reference = planner().decision_context(state)
    fast = planner(backend="fast").decision_context(state)
    assert reference.fast is None and fast.fast is not None
    scale = np.abs(reference.pose_covs).max(axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(fast.pose_covs / scale, reference.pose_covs / scale, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.landmark_covs, reference.landmark_covs, rtol=1e-8)


def test_a_failed_factorisation_falls_back_to_the_reference(monkeypatch, caplog):
    """Degenerate systems are handled and logged: that decision uses the graph copies."""
    import explore_rl.planning.em_fast as em_fast

    def singular(graph):
        raise RuntimeError("Factor is exactly singular")

    monkeypatch.setattr(em_fast.FastContext, "of", staticmethod(singular))
    state = tour_state(3.0)
    with caplog.at_level("WARNING"):
        fast = planner(backend="fast").evaluate(state)
    assert "uses the reference backend" in caplog.text
    reference = planner().evaluate(state)
    np.testing.assert_allclose(fast.u_after, reference.u_after, rtol=1e-12)


# ---------------------------------------------------------------------- recorded episodes


DECISIONS = {"office": 9, "street": 7, "garage": 7}  # per scene; the first 3 (few poses) are skipped
SKIP = 3


def scene_decisions(scene: str) -> list[tuple]:
    """(reference, fast) evaluations at the decisions of one random-frontier episode (both
    planners see every decision: the fast one carries observations over between them)."""
    config = load_config([f"scene={scene}", "slam=model", "seed=0", "policy=random", "explore.progress_bar=false",
                          f"explore.max_decisions={DECISIONS[scene]}"])
    em = {backend: EMPlanner(PolicyConfig(name="em"), dataclasses.replace(
        config.planning, em=dataclasses.replace(config.planning.em, backend=backend)), robot=config.robot)
        for backend in ("reference", "fast")}
    explorer = Explorer(config)
    out = []
    while (state := explorer.next_state()) is not None:
        actions = em["reference"].actions(state)
        evaluations = tuple(em[b].evaluate(state, actions) for b in ("reference", "fast"))
        if len(explorer.result.records) >= SKIP:
            out.append(evaluations)
        explorer.act(state, int(explorer.policy.choose(state)))
    return out


@pytest.fixture(scope="module")
def recorded() -> dict[str, list[tuple]]:
    return {scene: scene_decisions(scene) for scene in DECISIONS}


def test_fast_utilities_within_tolerance_on_recorded_states(recorded):
    loops = 0
    for scene, decisions in recorded.items():
        assert decisions, scene
        for reference, fast in decisions:
            np.testing.assert_array_equal(fast.indices, reference.indices)
            np.testing.assert_array_equal(fast.loops, reference.loops)
            assert fast.u0 == pytest.approx(reference.u0, rel=1e-9)
            bound = UTILITY_ATOL + UTILITY_RTOL * np.abs(reference.u0 - reference.u_after)
            gap = np.abs(fast.u_after - reference.u_after)
            assert np.all(gap <= bound), (scene, gap, bound)
            loops += int(np.sum(reference.loops > 0))
    assert loops >= 10  # the low-rank path was exercised, not only the no-loop shortcut


def test_fast_makes_the_same_choice_on_recorded_states(recorded):
    same = [fast.chosen == reference.chosen for decisions in recorded.values() for reference, fast in decisions]
    assert len(same) >= 12
    assert np.mean(same) >= SAME_CHOICE, same
