"""explore_rl.deploy: plain arrays in, the chosen frontier out -- the same choice as the
environment's actor on the same state, through the exported program too, and without
the simulator or SLAM libraries."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from explore_rl.config import load_config
from explore_rl.deploy import load_policy, main
from explore_rl.graph.exploration_graph import factor_edges
from explore_rl.planning.em import world_covariances
from explore_rl.models.checkpoint import CheckpointError
from explore_rl.planning.learned import LearnedPolicy
from explore_rl.planning.policies import PolicyConfig
from tests.policy_files import TINY_MODEL, actor_file, env_decisions

FAST = ["scene=office", "slam=model", "planning.actions.max_frontiers=4", *TINY_MODEL]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    directory = tmp_path_factory.mktemp("deploy")
    config = load_config(FAST)
    path, learner = actor_file(directory, config)
    main([str(path), str(directory / "copy.pt"), "--program", str(directory / "actor.pt2")])
    return config, learner, path, directory / "actor.pt2"


def arrays_of(decision) -> dict:
    """What a robot with its own SLAM would hand over, read from the env's decision."""
    state, graph = decision.state, decision.graph
    poses = state.session.graph.poses_se2()
    frontiers = graph.frontier_nodes
    return dict(pose_xy=poses[:, :2], pose_cov=world_covariances(state.session.graph, poses),
                pose_edges=factor_edges(state.session.graph.edges), frontier_xy=graph.xy[frontiers],
                frontier_uncertainty=graph.features[frontiers, 0],
                frontier_revisits=[[r.keyframe_index for r in a.prediction.revisits] for a in decision.actions])


def test_deploy_chooses_what_the_environments_actor_chooses(files):
    config, learner, path, program_path = files
    policy = load_policy(path, max_nodes=config.graph.max_nodes)
    program = load_policy(program_path)
    assert program.max_nodes == config.graph.max_nodes  # kept from training
    checked = 0
    for decision, env_choice in env_decisions(config, learner, steps=6):
        arrays = arrays_of(decision)
        made = policy.decide(**arrays)
        assert decision.actions[made.frontier].candidate == env_choice
        np.testing.assert_allclose(made.graph.features, decision.graph.features, rtol=1e-12, atol=1e-15)
        assert made.probabilities.sum() == pytest.approx(1.0)
        exported = program.decide(**arrays)
        np.testing.assert_allclose(exported.probabilities, made.probabilities, atol=1e-5)
        if np.ptp(np.sort(made.probabilities)[-2:]) > 1e-4:  # not a tie: the same frontier
            assert exported.frontier == made.frontier
        # the caller's frontier order does not matter, only which one is nearest
        order = np.random.default_rng(checked).permutation(len(arrays["frontier_xy"]))
        shuffled = dict(arrays, frontier_xy=arrays["frontier_xy"][order],
                        frontier_uncertainty=arrays["frontier_uncertainty"][order],
                        frontier_revisits=[arrays["frontier_revisits"][i] for i in order])
        nearest = int(np.flatnonzero(order == 0)[0])
        assert order[policy.choose(**shuffled, nearest=nearest)] == made.frontier
        checked += 1
    assert checked >= 4


SCRIPT = """
import json, sys
import numpy as np
from explore_rl.deploy import load_policy
policy = load_policy(sys.argv[1])
k = policy.choose(pose_xy=np.c_[np.arange(6.0) * 0.5, np.zeros(6)], pose_uncertainty=np.linspace(0, 0.01, 6),
                  pose_edges=[[i, i + 1] for i in range(5)], frontier_xy=[[3.5, 0.2], [0.0, 1.0]],
                  frontier_uncertainty=[0.08, 0.05], frontier_revisits=[[], [0, 1]])
print(json.dumps({"choice": k, "loaded": sorted(m for m in ("mujoco", "gtsam", "kiss_icp", "torchrl", "hydra")
                                                 if m in sys.modules),
                  "trainer": sorted(m for m in sys.modules if m.startswith("explore_rl.trainer"))}))
"""


def test_deploy_imports_no_simulator_slam_or_torchrl(files):
    _, _, path, _ = files
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(path)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["choice"] in (0, 1)
    assert result["loaded"] == []
    assert result["trainer"] == []  # checkpoint I/O lives in explore_rl.models: no upward import


def test_bad_arrays_are_named(files):
    _, _, path, _ = files
    policy = load_policy(path)
    good = dict(pose_xy=[[0, 0], [0.5, 0]], pose_uncertainty=[0, 0.001], pose_edges=[[0, 1]],
                frontier_xy=[[1, 0]], frontier_uncertainty=[0.08], frontier_revisits=[[]])
    assert policy.choose(**good) == 0
    with pytest.raises(ValueError, match=r"frontier_revisits\[0\] names keyframes \[7\]"):
        policy.choose(**dict(good, frontier_revisits=[[7]]))
    with pytest.raises(ValueError, match="exactly one of pose_cov and pose_uncertainty"):
        policy.choose(**dict(good, pose_cov=np.zeros((2, 2, 2))))
    with pytest.raises(ValueError, match="pose_edges must index keyframes 0..1"):
        policy.choose(**dict(good, pose_edges=[[0, 2]]))


def test_missing_files_fail_with_one_line(tmp_path, capsys):
    with pytest.raises(CheckpointError, match="actor.pt2: no exported actor there"):
        load_policy(tmp_path / "actor.pt2")
    with pytest.raises(SystemExit) as exit_info:
        main([str(tmp_path / "nothing.pt"), str(tmp_path / "out.pt")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and "nothing.pt: no checkpoint there" in err and "\n" not in err


@pytest.mark.parametrize("features", ["extended", "loops"])
def test_an_extended_feature_policy_takes_frontier_extra_and_matches_the_env(tmp_path, features):
    """``graph.features=extended``: the caller passes the 6 extra frontier columns; deploy
    builds the env's graph and makes the env actor's choice; missing or unwanted extras
    are named. ``loops``: the same 6, and deploy computes ``loop_length`` from the arrays."""
    config = load_config([*FAST, f"graph.features={features}"])
    path, learner = actor_file(tmp_path, config)
    policy = load_policy(path, max_nodes=config.graph.max_nodes)
    for decision, env_choice in env_decisions(config, learner, steps=3):
        arrays = arrays_of(decision)
        extra = decision.graph.features[decision.graph.frontier_nodes, 4:10]
        made = policy.decide(**arrays, frontier_extra=extra)
        np.testing.assert_allclose(made.graph.features, decision.graph.features, rtol=1e-12, atol=1e-15)
        assert decision.actions[made.frontier].candidate == env_choice
        with pytest.raises(ValueError, match=f"reads graph.features={features}: pass frontier_extra"):
            policy.decide(**arrays)
        with pytest.raises(ValueError, match=r"frontier_extra must be finite, shape"):
            policy.decide(**arrays, frontier_extra=extra[:, :3])


def test_the_loop_prior_makes_the_env_policys_choice(tmp_path):
    """``decide(loop_bias=B)``: on the env's states, deploy makes the choice of the env's
    ``LearnedPolicy`` with ``policy.loop_bias=B`` (its prior computed from the env's pose graph,
    deploy's from the arrays), at a weight where the prior dominates and at the shipped option's;
    the prior changes the choice on some states; a negative or non-finite weight is refused."""
    config = load_config([*FAST, "graph.features=extended"])
    path, learner = actor_file(tmp_path, config)
    policy = load_policy(path, max_nodes=config.graph.max_nodes)
    informative = 0  # states where the dominant prior changes the choice
    for decision, _ in env_decisions(config, learner, steps=6):
        arrays = arrays_of(decision)
        arrays["frontier_extra"] = decision.graph.features[decision.graph.frontier_nodes, 4:10]
        for bias in (0.04, 1e6):
            env_policy = LearnedPolicy(PolicyConfig("learned", checkpoint=str(path), loop_bias=bias),
                                       config.planning, graph=config.graph)
            made = policy.decide(**arrays, loop_bias=bias)
            assert decision.actions[made.frontier].candidate == env_policy.choose(decision.state)
            assert made.probabilities.sum() == pytest.approx(1.0)
        informative += made.frontier != policy.choose(**arrays)
        for bad in (-0.5, float("nan")):
            with pytest.raises(ValueError, match="loop_bias=.* must be finite and >= 0"):
                policy.decide(**arrays, loop_bias=bad)
    assert informative > 0


def test_a_paper_feature_policy_refuses_frontier_extra(files):
    config, learner, path, _ = files
    policy = load_policy(path)
    decision, _ = next(env_decisions(config, learner, steps=1))
    arrays = arrays_of(decision)
    with pytest.raises(ValueError, match="do not pass frontier_extra"):
        policy.decide(**arrays, frontier_extra=np.zeros((len(arrays["frontier_xy"]), 6)))


def test_a_no_covariance_policy_takes_no_uncertainty_and_four_extra_columns(tmp_path):
    """``graph.features=no_covariance``: the caller passes no covariance or trace and the 4 extra columns without
    covariance; deploy builds the env's graph and makes the env actor's choice; an uncertainty passed anyway, or
    the 6 extended columns, are refused naming what to pass."""
    config = load_config([*FAST, "graph.features=no_covariance"])
    path, learner = actor_file(tmp_path, config)
    policy = load_policy(path, max_nodes=config.graph.max_nodes)
    for decision, env_choice in env_decisions(config, learner, steps=3):
        arrays = arrays_of(decision)
        arrays.pop("pose_cov"), arrays.pop("frontier_uncertainty")
        extra = decision.graph.features[decision.graph.frontier_nodes, 3:7]
        made = policy.decide(**arrays, frontier_extra=extra)
        np.testing.assert_allclose(made.graph.features, decision.graph.features, rtol=1e-12, atol=1e-15)
        assert decision.actions[made.frontier].candidate == env_choice
        with pytest.raises(ValueError, match="no covariance: do not pass pose_cov"):
            policy.decide(**arrays, frontier_extra=extra, pose_uncertainty=np.zeros(len(arrays["pose_xy"])))
        with pytest.raises(ValueError, match="columns path_length, frontier_size, unknown_nearby, revisits"):
            policy.decide(**arrays, frontier_extra=np.zeros((len(extra), 6)))
