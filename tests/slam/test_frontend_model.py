"""The `model` front end: fitted statistics reproduced, same graph structure as icp, clear
errors for bad calibration files."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from explore_rl.geometry import matrix_to_se2, se2_between, se2_compose, se2_to_matrix
from explore_rl.slam.calibration import (
    SCAN_MATCHING_FILE,
    CalibrationError,
    load_loop_closures,
    load_scan_matching,
)
from explore_rl.slam.config import SlamConfig
from explore_rl.slam.frontend_model import ModelFrontend, obstacle_points

CAL = load_scan_matching()


def cloud_in_bin(k: int, rng: np.random.Generator) -> np.ndarray:
    """A sensor-frame cloud whose obstacle-band count falls in calibration bin ``k``."""
    lo, hi = CAL.bin_edges[k], min(CAL.bin_edges[k + 1], CAL.bin_edges[k] + 3000)
    n = int((lo + hi) / 2)
    z = rng.uniform(CAL.statistic_min_height, CAL.statistic_max_height, n) - CAL.mount_height
    floor = np.column_stack([rng.uniform(-2, 2, (200, 2)), np.full(200, -CAL.mount_height)])
    points = np.vstack([np.column_stack([rng.uniform(-3, 3, (n, 2)), z]), floor])
    assert CAL.bin(obstacle_points(points, CAL.mount_height)) == k
    return points


def abs_quantile(mixture, q: float) -> float:
    """The q-quantile of |x| under a zero-mean two-normal scale mixture."""
    from scipy.optimize import brentq
    from scipy.stats import norm

    def cdf(x):
        return ((1 - mixture.tail_fraction) * (2 * norm.cdf(x / mixture.core_sigma) - 1)
                + mixture.tail_fraction * (2 * norm.cdf(x / mixture.tail_sigma) - 1))

    return brentq(lambda x: cdf(x) - q, 0.0, 20 * mixture.tail_sigma)


def condition_error_std(weak: int, turn: bool) -> float:
    document = yaml.safe_load(SCAN_MATCHING_FILE.read_text())
    name = f"weak{weak}_{'turned' if turn else 'straight'}"
    return document["conditions"][name]["error_std"]["yaw_deg"]


def drive(frontend: ModelFrontend, points: np.ndarray, n: int, rng: np.random.Generator,
          turn: bool = False, wheel_noise: float = 0.0):
    """``n`` keyframes of 0.5 m (or 15 deg turns); returns [(match, true span motion)]."""
    true_delta = np.array([0.0, 0.0, np.deg2rad(15.0)]) if turn else np.array([0.5, 0.0, 0.0])
    true_poses, out = [np.zeros(3)], []
    frontend.register(points, np.eye(4), np.eye(4))
    for _ in range(n):
        wheel = true_delta + rng.normal(0.0, wheel_noise, 3)
        true_poses.append(se2_compose(true_poses[-1], true_delta))
        match = frontend.register(points, se2_to_matrix(wheel), se2_to_matrix(true_delta))
        span_truth = se2_between(true_poses[-1 - match.span], true_poses[-1])
        out.append((match, span_truth))
    return out


def test_degenerate_and_weak_rates_match_the_fit():
    rng = np.random.default_rng(0)
    for k in (2, 5):
        frontend = ModelFrontend(SlamConfig(), CAL, np.random.default_rng(k))
        results = drive(frontend, cloud_in_bin(k, rng), 3000, rng)
        degenerate = np.array([m.degenerate for m, _ in results])
        after_usable = np.r_[True, ~degenerate[:-1]]  # the first follows the (anchoring) start
        rate = degenerate[after_usable].mean()
        n = after_usable.sum()
        expected = CAL.degenerate_rate[k]
        assert abs(rate - expected) < 4 * np.sqrt(expected * (1 - expected) / n) + 0.01, (k, rate, expected)
        weak = np.array([m.weak_directions for m, _ in results if not m.degenerate])
        frequencies = np.bincount(weak, minlength=3)[:3] / len(weak)
        assert np.allclose(frequencies, CAL.weak_probabilities[k], atol=0.04), (k, frequencies)
        # With max_span 1 a drawn degenerate keyframe is always followed by a forced
        # restart (degenerate too, no factor): runs of degenerate keyframes are even.
        if CAL.max_span == 1:
            edges = np.flatnonzero(np.diff(np.r_[0, degenerate.astype(int), 0]))
            starts, ends = edges[::2], edges[1::2]
            complete = ends < len(degenerate)  # the last run may be cut by the end of the drive
            assert np.all((ends - starts)[complete] % 2 == 0)


@pytest.mark.parametrize("turn", [False, True])
def test_sampled_errors_reproduce_the_fitted_mixtures(turn):
    rng = np.random.default_rng(1)
    k = len(CAL.degenerate_rate) - 1  # many obstacle points: few degenerate keyframes
    frontend = ModelFrontend(SlamConfig(), CAL, np.random.default_rng(2))
    results = drive(frontend, cloud_in_bin(k, rng), 6000, rng, turn=turn)  # exact wheel odometry
    for weak in (0, 1):
        condition = CAL.condition(weak, turn)
        chosen = [(m, t) for m, t in results if not m.degenerate and m.weak_directions == weak]
        errors = np.array([se2_between(t, matrix_to_se2(m.span_relative)) for m, t in chosen])
        yaw = np.rad2deg(errors[:, 2])
        assert len(chosen) > 300
        assert yaw.std() == pytest.approx(condition.yaw_deg.std, rel=0.2), (weak, yaw.std())
        for q in (0.5, 0.9):
            assert np.quantile(np.abs(yaw), q) == pytest.approx(abs_quantile(condition.yaw_deg, q), rel=0.2)
        # ... and so the statistics of the icp errors the mixtures were fitted to.
        assert yaw.std() == pytest.approx(condition_error_std(weak, turn), rel=0.25)
        # The constrained translation error; along the weak axis the (exact) wheel prior is kept.
        translation = np.linalg.norm(errors[:, :2], axis=1)
        expected = condition.translation.std * np.sqrt(2.0 if weak == 0 else 1.0)
        assert np.sqrt(np.mean(translation**2)) == pytest.approx(expected, rel=0.2), weak
        # Reported covariance: sigmas drawn from the fitted quantiles of icp's (median
        # preserved) along constrained directions, weak_sigma along weak ones; the errors
        # divided by them follow the fitted standardised mixture.
        planar = np.array([m.covariance[np.ix_([2, 3, 4], [2, 3, 4])] for m, _ in chosen])
        sigma_yaw = np.rad2deg(np.sqrt(planar[:, 0, 0]))
        values = np.linalg.eigvalsh(planar[:, 1:, 1:])
        assert np.median(sigma_yaw) == pytest.approx(condition.reported_sigma_yaw_deg, rel=0.1)
        assert np.median(np.sqrt(values[:, 0])) == pytest.approx(condition.reported_sigma_translation, rel=0.1)
        assert sigma_yaw.min() >= condition.sigma_yaw_deg_quantiles[0] - 1e-9
        assert sigma_yaw.max() <= condition.sigma_yaw_deg_quantiles[-1] + 1e-9
        if weak:
            assert np.allclose(np.sqrt(values[:, -1]), CAL.weak_sigma)
        if weak == 0:
            assert (yaw / sigma_yaw).std() == pytest.approx(condition.yaw_z.std, rel=0.2)


def test_weak_axis_keeps_the_wheel_prior_and_spans_follow_degenerate_keyframes():
    rng = np.random.default_rng(3)
    cal = replace(CAL, weak_probabilities=tuple((0.0, 1.0, 0.0) for _ in CAL.weak_probabilities))
    frontend = ModelFrontend(SlamConfig(), cal, np.random.default_rng(4))
    results = drive(frontend, cloud_in_bin(3, rng), 500, rng, wheel_noise=0.02)
    for match, truth in results:
        if match.degenerate:
            assert match.weak_directions == 3 and not match.usable
            continue
        assert match.weak_directions == 1 and match.span >= 1
        planar = match.covariance[np.ix_([3, 4], [3, 4])]
        values, vectors = np.linalg.eigh(planar)
        assert np.sqrt(values[-1]) == pytest.approx(cal.weak_sigma)
    spans = [m.span for m, _ in results if not m.degenerate]
    assert max(spans) <= cal.max_span + 1


def test_model_is_reproducible_and_cheap():
    rng = np.random.default_rng(5)
    points = cloud_in_bin(4, rng)
    a = drive(ModelFrontend(SlamConfig(), CAL), points, 50, np.random.default_rng(6))
    b = drive(ModelFrontend(SlamConfig(), CAL), points, 50, np.random.default_rng(6))
    assert all(np.allclose(x.span_relative, y.span_relative) for (x, _), (y, _) in zip(a, b))
    assert np.median([m.ms for m, _ in a]) < 1.0


# ---------------------------------------------------------------- same graph structure


def _replay(config, overrides, steps, scene):
    from explore_rl.sensors.lidar import Lidar
    from explore_rl.slam.session import SlamSession

    slam = replace(config.slam, frontend=overrides)
    slam = replace(slam, loop_closure=replace(slam.loop_closure, enabled=False))
    lidar = Lidar(scene, config.lidar, np.random.default_rng([config.seed, 1]))
    session = SlamSession(slam, config.mapping, scene, lidar, scene.start_pose,
                          np.random.default_rng([config.seed, 3]))
    for step in steps:
        session.observe(step)
    return session


def test_icp_and_model_build_graphs_of_the_same_structure():
    """The same motion steps (same keyframes, same scans) into an icp and a model session:
    one odometry factor per keyframe from its predecessor, at most one scan-matching
    factor per keyframe from its last anchored keyframe, similar shares of both."""
    from explore_rl.config import load_config
    from explore_rl.robot import Robot
    from explore_rl.scene.build import make_scene

    config = load_config(["seed=0"])
    config.scene.start_index = config.tour.start_index
    scene = make_scene(config.scene, config.robot, config.lidar)
    robot = Robot(config.robot, scene.start_pose, scene.is_free, np.random.default_rng(0))
    steps = list(robot.follow(np.array([[10.0, 4.5], [7.0, 4.5], [7.0, 3.0]])))
    assert len(steps) > 40
    sessions = {name: _replay(config, name, steps, scene) for name in ("icp", "model")}
    icp, model = sessions["icp"], sessions["model"]
    assert len(icp.keyframes) == len(model.keyframes) > 10
    assert np.allclose(icp.true_poses(), model.true_poses())
    for session in (icp, model):
        edges = session.graph.edges
        kinds = {kind for _, _, kind in edges}
        assert kinds <= {"odometry", "scan_matching"} and "scan_matching" in kinds
        odometry = [(i, j) for i, j, kind in edges if kind == "odometry"]
        assert odometry == [(j - 1, j) for j in range(1, len(session.keyframes))]
        ssm = [(i, j) for i, j, kind in edges if kind == "scan_matching"]
        assert len({j for _, j in ssm}) == len(ssm)  # at most one per keyframe
        for i, j in ssm:
            match = session.keyframes[j].match
            assert match.usable and i == j - match.span
    ssm_fraction = {name: s.graph.factor_counts["scan_matching"] / (len(s.keyframes) - 1)
                    for name, s in sessions.items()}
    assert abs(ssm_fraction["icp"] - ssm_fraction["model"]) < 0.3, ssm_fraction


# ---------------------------------------------------------------- bad calibration files


def _write(tmp_path: Path, document: dict) -> Path:
    path = tmp_path / "scan_matching.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


@pytest.mark.parametrize("change, key", [
    (lambda d: d["degenerate"].pop("rate"), "degenerate.rate"),
    (lambda d: d["degenerate"]["rate"].__setitem__(0, 1.5), "degenerate.rate[0]"),
    (lambda d: d["conditions"]["weak1_turned"]["yaw_deg"].__setitem__("core_sigma", "0.1"),
     "conditions.weak1_turned.yaw_deg.core_sigma"),
    (lambda d: d["conditions"]["weak0_straight"]["translation"].__setitem__("tail_sigma", float("nan")),
     "conditions.weak0_straight.translation.tail_sigma"),
    (lambda d: d["weak_probabilities"][1].__setitem__(0, 0.9), "weak_probabilities[1]"),
    (lambda d: d.__setitem__("surprise", 1), "surprise"),
    (lambda d: d["conditions"].pop("weak2_straight"), "conditions.weak2_straight"),
])
def test_bad_scan_matching_file_names_file_and_key(tmp_path, change, key):
    document = yaml.safe_load(SCAN_MATCHING_FILE.read_text())
    change(document)
    path = _write(tmp_path, document)
    with pytest.raises(CalibrationError) as error:
        load_scan_matching(path)
    assert str(path) in str(error.value) and key in str(error.value), str(error.value)


def test_missing_or_broken_calibration_files(tmp_path):
    with pytest.raises(CalibrationError, match="not found"):
        load_scan_matching(tmp_path / "nope.yaml")
    (tmp_path / "broken.yaml").write_text("version: [1\n")
    with pytest.raises(CalibrationError, match="not valid YAML"):
        load_loop_closures(tmp_path / "broken.yaml")
    (tmp_path / "loops.yaml").write_text(yaml.safe_dump({"version": 1, "r_lc": -1.0, "sources": {}}))
    with pytest.raises(CalibrationError, match="r_lc"):
        load_loop_closures(tmp_path / "loops.yaml")


def _never_closing(document: dict, source: str) -> dict:
    """``document`` with ``source`` as a refit gives a source that closed nothing: zero
    rates, no logistic, null errors."""
    fit = document["sources"][source]
    for table in ("per_attempt", "per_revisit"):
        fit[table]["rate"] = [None if r is None else 0.0 for r in fit[table]["rate"]]
    fit["acceptance_logistic"] = {"intercept": None, "slope": None}
    fit["accepted_error"] = {**fit["accepted_error"], "count": 0, "rms_translation_m": None, "rms_rotation_deg": None}
    return document


def test_a_source_that_never_closed_loads_and_never_accepts_but_not_with_a_rate(tmp_path):
    from explore_rl.slam.calibration import LOOP_CLOSURES_FILE

    document = _never_closing(yaml.safe_load(LOOP_CLOSURES_FILE.read_text()), "segment_matching")
    path = tmp_path / "loops.yaml"
    path.write_text(yaml.safe_dump(document))
    source = load_loop_closures(path).sources["segment_matching"]
    assert source.rms_translation == 0.0 and all(source.rate(d, per) == 0.0 for d in np.linspace(0, 9, 37)
                                                  for per in ("attempt", "revisit"))
    document["sources"]["segment_matching"]["per_attempt"]["rate"][3] = 0.5
    path.write_text(yaml.safe_dump(document))
    with pytest.raises(CalibrationError, match="segment_matching.accepted_error.count"):
        load_loop_closures(path)


def test_the_model_reads_the_calibration_file_the_config_names(tmp_path):
    from explore_rl.config import load_config
    from explore_rl.slam.calibration import LOOP_CLOSURES_FILE
    from explore_rl.slam.config import LoopClosureConfig, loop_closures_path
    from explore_rl.slam.frontend_model import ModelLoopCloser

    document = _never_closing(yaml.safe_load(LOOP_CLOSURES_FILE.read_text()), "pose_matching")
    path = tmp_path / "refit.yaml"
    path.write_text(yaml.safe_dump(document))
    closer = ModelLoopCloser(LoopClosureConfig(calibration_file=str(path)))
    assert closer.calibration.path == str(path) and closer.calibration.sources["pose_matching"].rate(0.1) == 0.0
    assert ModelLoopCloser(LoopClosureConfig()).calibration.path == str(LOOP_CLOSURES_FILE)
    assert loop_closures_path("loop_closures.yaml") == LOOP_CLOSURES_FILE  # a bare name: conf/calibration/
    assert load_config(["slam=model", f"slam.loop_closure.calibration_file={path}"]).slam.loop_closure.calibration_file
    with pytest.raises(ValueError, match="slam.loop_closure.calibration_file='nope.yaml': no such file"):
        load_config(["slam=model", "slam.loop_closure.calibration_file=nope.yaml"])


def test_a_fit_made_at_another_keyframe_spacing_is_logged_and_the_45_deg_preset_has_its_own(caplog, monkeypatch):
    from explore_rl.config import load_config
    from explore_rl.slam import session
    from explore_rl.slam.session import make_loop_closer

    monkeypatch.setattr(session, "_SPACING_WARNED", set())  # whatever ran before in this process

    def warned(overrides: list[str]) -> bool:
        caplog.clear()
        make_loop_closer(load_config(["slam=model", *overrides]).slam)
        return any("was fitted at 0.5 m / 15 deg" in r.getMessage() for r in caplog.records)

    with caplog.at_level("WARNING", logger="explore_rl.slam.session"):
        assert not warned([])
        assert warned(["slam.keyframe_angle_deg=45"])
        assert not warned(["slam.keyframe_angle_deg=45"])  # once per file and spacing
        assert not warned(["slam=model_45deg"])
    preset = make_loop_closer(load_config(["slam=model_45deg"]).slam)
    assert preset.calibration.keyframe_spacing == (0.5, 45.0)
    assert preset.config.model_step_sigma_translation > load_config(["slam=model"]).slam.loop_closure.model_step_sigma_translation


# ---------------------------------------------------------------- model loop closures


class _FakeSession:
    """Just what ModelLoopCloser reads: keyframes, graph, occupancy, scene grid, map poses
    (none yet: the closer then asks the graph for its estimates)."""

    def __init__(self, start):
        from types import SimpleNamespace

        from explore_rl.grid import GridSpec
        from explore_rl.mapping.occupancy import OccupancyGrid
        from explore_rl.slam.config import PoseGraphConfig
        from explore_rl.slam.pose_graph import PoseGraph

        self.graph = PoseGraph(PoseGraphConfig(), start)
        grid = GridSpec((-2.0, -2.0), 0.1, (80, 80))
        self.scene = SimpleNamespace(grid=grid)
        self.occupancy = OccupancyGrid(grid)  # nothing known: no wall blocks a candidate
        self.keyframes = [SimpleNamespace(true_pose=np.asarray(start, float), travel=0.0,
                                          error_points=np.zeros((4, 3)))]
        self.map_poses = np.zeros((0, 3))


def test_model_loop_closer_closes_revisits_with_the_fitted_error():
    from explore_rl.slam.config import LoopClosureConfig
    from explore_rl.slam.frontend_model import ModelLoopCloser

    calibration = load_loop_closures()
    rng = np.random.default_rng(7)
    # Two laps of a 3 m square, 0.5 m keyframes, odometry with a small yaw bias.
    closures, errors = 0, []
    for trial in range(8):
        session = _FakeSession(np.zeros(3))
        add = session.graph.add_loop_closure

        def recording_add(i, j, relative, covariance, kind, session=session, add=add):
            truth = se2_between(session.keyframes[i].true_pose, session.keyframes[j].true_pose)
            errors.append(se2_between(truth, matrix_to_se2(relative)))
            add(i, j, relative, covariance, kind)

        session.graph.add_loop_closure = recording_add
        closer = ModelLoopCloser(LoopClosureConfig(segments_enabled=False), calibration,
                                 np.random.default_rng(trial))
        true = np.zeros(3)
        for k in range(1, 49):
            step = np.array([0.5, 0.0, np.pi / 2 if k % 6 == 0 else 0.0])
            true = se2_compose(true, step)
            odom_step = step + [0.0, 0.0, 0.004] + rng.normal(0, [0.01, 0.01, 0.001])
            session.graph.add_keyframe(se2_to_matrix(odom_step), 3)
            session.keyframes.append(type(session.keyframes[0])(
                true_pose=true.copy(), travel=0.5 * k, error_points=np.zeros((4, 3))))
            closures += closer.process(session)
        for i, j, kind in session.graph.edges:
            if kind == "pose_matching":
                assert j - i >= closer.config.min_index_gap
    assert closures >= 10
    errors = np.array(errors)
    source = calibration.sources["pose_matching"]
    rms_t = np.sqrt(np.mean(np.sum(errors[:, :2] ** 2, axis=1)))
    rms_r = np.rad2deg(np.sqrt(np.mean(errors[:, 2] ** 2)))
    assert rms_t == pytest.approx(source.rms_translation, rel=0.5)
    assert rms_r == pytest.approx(source.rms_rotation_deg, rel=0.5)
    assert closer.closures["pose_matching"] == len(closer.accepted)
    # No two accepted closures of one run are "worth"-close to each other.
    for (a, b), (c, d) in zip(closer.accepted, closer.accepted[1:]):
        assert abs(a - c) + abs(b - d) >= 1


def test_steps_via_closures_follow_the_closure_links():
    """One closure (a, b): the path from i to j over it is |i - a| + |b - j| or the other way
    round. Several: the vectorised minimum equals the definition's double loop over the
    closure endpoints p, q: |i - p| + through[p, q] + |q - j|."""
    from explore_rl.slam.config import LoopClosureConfig
    from explore_rl.slam.frontend_model import ModelLoopCloser

    rng = np.random.default_rng(4)
    indices = np.arange(60)
    single = ModelLoopCloser(LoopClosureConfig(), load_loop_closures(), rng)
    assert np.all(np.isinf(single.steps_via_closures(indices, 10)))
    single._link(12, 47)
    for j in (0, 12, 30, 47, 59):
        expected = np.minimum(np.abs(indices - 12) + abs(47 - j), np.abs(indices - 47) + abs(12 - j))
        np.testing.assert_array_equal(single.steps_via_closures(indices, j), expected)

    closer = ModelLoopCloser(LoopClosureConfig(), load_loop_closures(), rng)
    for _ in range(7):
        a, b = sorted(rng.choice(60, 2, replace=False))
        closer._link(int(a), int(b))
    nodes = closer._nodes
    for j in rng.choice(60, 8, replace=False):
        expected = [min(abs(i - p) + closer._through[u, v] + abs(q - j)
                        for u, p in enumerate(nodes) for v, q in enumerate(nodes)) for i in indices]
        np.testing.assert_array_equal(closer.steps_via_closures(indices, int(j)), expected)
    # From at or past every endpoint (the loop closer's newest keyframe: the O(n) path).
    for j in range(max(nodes), 70):
        expected = [min(abs(i - p) + closer._through[u, v] + abs(q - j)
                        for u, p in enumerate(nodes) for v, q in enumerate(nodes)) for i in indices]
        np.testing.assert_array_equal(closer.steps_via_closures(indices, j), expected)


def test_segments_clear_matches_the_grid_line_of_sight():
    from explore_rl.grid import GridSpec
    from explore_rl.mapping.occupancy import OccupancyGrid
    from explore_rl.mapping.visibility import line_of_sight
    from explore_rl.slam.frontend_model import segments_clear

    rng = np.random.default_rng(5)
    grid = GridSpec((-2.0, -1.0), 0.1, (40, 50))
    occupancy = OccupancyGrid(grid)
    occupancy.log_odds[rng.random(grid.shape) < 0.04] = 3.0  # scattered walls
    occupancy.log_odds[10:30, 25] = 3.0
    start = np.array([0.3, 1.1])
    ends = rng.uniform([-3.0, -2.0], [4.0, 4.0], size=(200, 2))  # some end outside the grid
    got = segments_clear(start, ends, occupancy)
    expected = line_of_sight(np.tile(start, (len(ends), 1)), ends, occupancy.known_occupied, grid, 0.5)
    np.testing.assert_array_equal(got, expected)
    assert 20 < got.sum() < 180  # both outcomes occur


def reallocating_link(tables: dict, a: int, b: int) -> None:
    """The tables' update as the session-30 code made it (new arrays for every endpoint
    and closure): the reference the in-place ``ModelLoopCloser._link`` must equal."""
    nodes = tables["nodes"]
    for x in (a, b):
        if x in nodes:
            continue
        n = len(nodes)
        chain = np.abs(np.asarray(nodes, dtype=float) - x)
        distance, through = np.full((n + 1, n + 1), np.inf), np.full((n + 1, n + 1), np.inf)
        distance[:n, :n], through[:n, :n] = tables["distance"], tables["through"]
        if n:
            distance[n, :n] = distance[:n, n] = np.min(chain[:, None] + tables["distance"], axis=0)
            through[n, :n] = through[:n, n] = np.min(chain[:, None] + tables["through"], axis=0)
        distance[n, n] = 0.0
        tables["distance"], tables["through"] = distance, through
        nodes.append(x)
    ia, ib = nodes.index(a), nodes.index(b)
    D = tables["distance"]
    via = np.minimum(D[:, ia][:, None] + D[ib][None, :], D[:, ib][:, None] + D[ia][None, :])
    tables["through"], tables["distance"] = np.minimum(tables["through"], via), np.minimum(D, via)


def test_closure_endpoint_tables_grown_in_place_equal_the_reallocating_update():
    """After every accepted closure the tables ``_link`` keeps in growing buffers equal the
    reallocating update's, and ``_distance`` is the all-pairs shortest path over the
    endpoints (chain links of their index distance, closures of length ~0)."""
    from scipy.sparse.csgraph import shortest_path

    from explore_rl.slam.config import LoopClosureConfig
    from explore_rl.slam.frontend_model import ModelLoopCloser

    rng = np.random.default_rng(7)
    closer = ModelLoopCloser(LoopClosureConfig(), load_loop_closures(), rng)
    reference = {"nodes": [], "distance": np.zeros((0, 0)), "through": np.zeros((0, 0))}
    closures = []
    for _ in range(40):  # past the first buffer growths (16, 32, 64 endpoints)
        a, b = (int(v) for v in sorted(rng.choice(300, 2, replace=False)))
        closer._link(a, b)
        reallocating_link(reference, a, b)
        closures.append((a, b))
        assert closer._nodes == reference["nodes"]
        np.testing.assert_array_equal(closer._distance, reference["distance"])
        np.testing.assert_array_equal(closer._through, reference["through"])
        nodes = np.asarray(closer._nodes)
        expected = np.min(reference["through"] - nodes[None, :].astype(float), axis=1)
        np.testing.assert_array_equal(closer._through_minus_node, expected)
        index = {p: k for k, p in enumerate(nodes)}
        weights = np.abs(nodes[:, None] - nodes[None, :]).astype(float)
        for p, q in closures:
            weights[index[p], index[q]] = weights[index[q], index[p]] = 1e-3  # ~0 (rounded off), still an edge
        np.testing.assert_array_equal(closer._distance, np.round(shortest_path(weights, method="FW", directed=False)))


def test_the_model_reads_the_scan_matching_file_the_config_names(tmp_path):
    from explore_rl.config import load_config
    from explore_rl.slam.calibration import SCAN_MATCHING_FILE
    from explore_rl.slam.config import SlamConfig, scan_matching_path
    from explore_rl.slam.frontend_model import ModelFrontend

    document = yaml.safe_load(SCAN_MATCHING_FILE.read_text())
    document["degenerate"]["rate"] = [1.0] * len(document["degenerate"]["rate"])  # every scan degenerate
    path = tmp_path / "refit.yaml"
    path.write_text(yaml.safe_dump(document))
    config = load_config(["slam=model", f"slam.scan_matcher.calibration_file={path}"]).slam
    frontend = ModelFrontend(config)
    assert frontend.calibration.path == str(path) and set(frontend.calibration.degenerate_rate) == {1.0}
    default = ModelFrontend(SlamConfig(frontend="model"))
    assert default.calibration.path == str(SCAN_MATCHING_FILE) and min(default.calibration.degenerate_rate) < 0.1
    assert scan_matching_path("scan_matching.yaml") == SCAN_MATCHING_FILE  # a bare name: conf/calibration/
    with pytest.raises(ValueError, match="slam.scan_matcher.calibration_file='nope.yaml': no such file"):
        load_config(["slam=model", "slam.scan_matcher.calibration_file=nope.yaml"])


def test_the_buildings_preset_reads_its_own_fits_at_the_default_spacing(caplog, monkeypatch):
    from explore_rl.config import load_config
    from explore_rl.slam import session
    from explore_rl.slam.calibration import SCAN_MATCHING_FILE
    from explore_rl.slam.config import loop_closures_path, scan_matching_path
    from explore_rl.slam.frontend_model import ModelFrontend
    from explore_rl.slam.session import make_loop_closer

    monkeypatch.setattr(session, "_SPACING_WARNED", set())
    preset, default = load_config(["slam=model_buildings"]).slam, load_config(["slam=model"]).slam
    with caplog.at_level("WARNING", logger="explore_rl.slam.session"):
        closer = make_loop_closer(preset)
    assert not [r for r in caplog.records if "was fitted at" in r.getMessage()]
    assert closer.calibration.path == str(loop_closures_path("loop_closures_buildings.yaml"))
    assert closer.calibration.keyframe_spacing == (preset.keyframe_distance, preset.keyframe_angle_deg)
    frontend = ModelFrontend(preset)
    assert frontend.calibration.path == str(scan_matching_path("scan_matching_buildings.yaml")) != str(SCAN_MATCHING_FILE)
    assert preset.loop_closure.model_step_sigma_translation < default.loop_closure.model_step_sigma_translation
    # everything else is slam=model's: the same graph, keyframes and candidate rules
    assert (preset.keyframe_distance, preset.keyframe_angle_deg, preset.pose_graph) == (
        default.keyframe_distance, default.keyframe_angle_deg, default.pose_graph)
    assert preset.loop_closure.search_radius == default.loop_closure.search_radius
