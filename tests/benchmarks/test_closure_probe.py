"""closure_probe/: the relative loop uncertainty against a dense inverse, the path's map gain against a
one-landmark hand computation, a one-episode collection, and the ridge probe on made-up decisions where EM's reward
is one group's quantity itself (so only the models that see it reach EM's choice); bad arguments are refused in
one line."""

from __future__ import annotations

import json
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

from tests.benchmarks.smoke import ROOT, json_lines, load_script, script_runner

FOLDER = ROOT / "benchmarks" / "results" / "closure_probe"


def run(script: str, *args: str) -> subprocess.CompletedProcess:
    """collect.py as a user runs it (its spawned workers import it by path)."""
    return subprocess.run([sys.executable, str(FOLDER / script), *args], capture_output=True, text=True, cwd=ROOT)


@pytest.fixture()
def run_here(capsys):
    """A script of closure_probe/ in this process (tests/benchmarks/smoke.py: run_main)."""
    return lambda script, *args: script_runner(f"benchmarks/results/closure_probe/{script}", capsys)(*args)


def test_relative_uncertainty_is_the_trace_of_the_difference_covariance():
    from explore_rl.planning.em_fast import TRANS_X, TRANS_Y

    relative_uncertainty = load_script("benchmarks/results/closure_probe/collect.py").relative_uncertainty
    rng = np.random.default_rng(0)
    k = 5
    jac = sp.random(8 * k, 6 * k, density=0.3, random_state=1).toarray() + np.eye(8 * k, 6 * k)
    information = jac.T @ jac + 0.1 * np.eye(6 * k)  # dense here, sparse to the function
    poses = np.column_stack([rng.normal(size=(k, 2)), rng.uniform(-np.pi, np.pi, k)])
    current = 3
    covariance = np.linalg.inv(information)
    expected = []
    for other in range(k):
        select = np.zeros((2, 6 * k))
        for pose, sign in ((current, 1.0), (other, -1.0)):
            c, s = np.cos(poses[pose, 2]), np.sin(poses[pose, 2])
            select[0, 6 * pose + TRANS_X] += sign * c
            select[0, 6 * pose + TRANS_Y] -= sign * s
            select[1, 6 * pose + TRANS_X] += sign * s
            select[1, 6 * pose + TRANS_Y] += sign * c
        expected.append(np.trace(select @ covariance @ select.T))
    values = relative_uncertainty(sp.csr_matrix(information), poses, current)
    np.testing.assert_allclose(values, expected, rtol=1e-9, atol=1e-12)
    assert values[current] == pytest.approx(0.0, abs=1e-12) and (np.delete(values, current) > 0).all()


def test_path_map_counts_the_landmarks_in_range_and_the_gain_of_one_observation():

    path_map = load_script("benchmarks/results/closure_probe/collect.py").path_map
    prediction = SimpleNamespace(poses=np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    landmark_xy = np.array([[3.5, 0.0], [0.0, 2.0], [10.0, 0.0]])  # in range of the 2nd pose, the 1st, neither
    landmark_covs = np.array([np.diag([0.04, 0.01]), 0.02 * np.eye(2), np.eye(2)])
    robot = 0.01 * np.eye(2)
    landmarks, uncertainty, gain = path_map(prediction, landmark_xy, landmark_covs, robot, sensor_range=3.0)
    assert landmarks == 2 and uncertainty == pytest.approx(0.05 + 0.04)
    # scalar fusion per axis: s * r / (s + r), off the trace
    expected = sum(s - s * 0.01 / (s + 0.01) for s in (0.04, 0.01, 0.02, 0.02))
    assert gain == pytest.approx(expected)
    assert path_map(SimpleNamespace(poses=np.zeros((0, 3))), landmark_xy, landmark_covs, robot, 3.0) == (0, 0.0, 0.0)


def test_one_episode_is_collected_and_resumed(tmp_path, run_here):
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    actor, _ = actor_file(tmp_path / "actor", load_config([*TINY_MODEL, "graph.features=loops"]))
    args = ["--out", str(tmp_path / "out"), "--episodes", "1", "--max-decisions", "2", "--workers", "1",
            "--actor", str(actor)]
    result = run("collect.py", *args)
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    rows = [json.loads(line) for line in (tmp_path / "out" / "decisions.jsonl").read_text().splitlines()]
    assert summary["decisions"] == len(rows) >= 1 and summary["episodes"] == 1
    for row in rows:
        frontiers = len(row["rewards"])
        assert np.shape(row["x"]) == (frontiers, 11) and len(row["loop_uncertainty"]) == frontiers
        assert 0 <= row["em_choice"] < frontiers and min(row["loop_uncertainty"]) >= 0
        revisits = np.asarray(row["x"])[:, row["features"].index("revisits")]
        assert all(u == 0 for u, r in zip(row["loop_uncertainty"], revisits) if r == 0)
        landmarks, uncertainty, gain = (np.asarray(row["path_map"][key]) for key in ("landmarks", "uncertainty", "gain"))
        assert len(landmarks) == frontiers and (landmarks >= 1).all()  # a path sees the landmarks around it
        assert (gain > 0).all() and (gain < uncertainty).all()  # an observation takes off part of the uncertainty
    again = run_here("collect.py", *args)  # resumed: the episode is done, nothing is added (no worker starts)
    assert again.returncode == 0 and json.loads(again.stdout.strip().splitlines()[-1])["decisions"] == len(rows)


def made_up_decisions(path, count: int = 160, reward_of: str = "loop_uncertainty", path_map: bool = True) -> None:
    rng = np.random.default_rng(0)
    names = ["uncertainty", "distance", "bearing", "identity", "path_length", "frontier_size", "unknown_nearby",
             "revisits", "revisit_uncertainty", "landmark_uncertainty", "loop_length"]
    with open(path, "w") as handle:
        for index in range(count):
            frontiers = 3 + index % 4
            x = rng.uniform(0, 1, size=(frontiers, len(names)))
            x[:, names.index("identity")] = 1.0
            loop = rng.uniform(0, 0.01, frontiers)
            extra = {"landmarks": rng.integers(0, 50, frontiers).tolist(), "uncertainty": rng.uniform(0, 1, frontiers).tolist(),
                     "gain": rng.uniform(0, 0.5, frontiers).tolist()}
            # EM's reward is the relative uncertainty itself, or the path's map gain
            rewards = 100 * loop if reward_of == "loop_uncertainty" else 2 * np.asarray(extra["gain"])
            row = {"episode": index // 8, "layout": index % 16, "step": index % 8, "features": names, "x": x.tolist(),
                   "loop_uncertainty": loop.tolist(), "rewards": rewards.tolist(), "em_choice": int(np.argmax(rewards)),
                   "poses": 10}
            if path_map:
                row["path_map"] = extra
            handle.write(json.dumps(row) + "\n")


def test_the_probe_finds_the_information_where_it_is(tmp_path, run_here):
    made_up_decisions(tmp_path / "decisions.jsonl")
    result = run_here("probe.py", "--decisions", str(tmp_path / "decisions.jsonl"))
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout)
    models = {line["model"]: line for line in lines[:4]}
    assert models["loops + loop_uncertainty"]["gap_closed"] > 0.95
    assert models["loops + loop_uncertainty, pairwise"]["gap_closed"] > 0.9
    assert abs(models["loops"]["gap_closed"]) < 0.5  # features unrelated to the reward
    summary = lines[4]
    assert summary["held_out_decisions"] == 40 and summary["held_out_layouts"] == 4
    difference = summary["differences"]["loop_uncertainty"]
    assert difference["gap_closed"] == pytest.approx(
        models["loops + loop_uncertainty"]["gap_closed"] - models["loops"]["gap_closed"], abs=2e-4)
    assert difference["gap_closed_ci"][0] > 0


def test_each_group_is_tested_alone_and_together(tmp_path, run_here):
    made_up_decisions(tmp_path / "decisions.jsonl", reward_of="path_map")
    result = run_here("probe.py", "--decisions", str(tmp_path / "decisions.jsonl"), "--extras", "loop_uncertainty",
                 "path_map")
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout)
    models = {line["model"]: line["gap_closed"] for line in lines[:-1]}
    assert len(models) == 8
    assert models["loops + path_map"] > 0.95 and models["loops + loop_uncertainty + path_map"] > 0.95
    assert models["loops + loop_uncertainty"] < 0.5
    differences = lines[-1]["differences"]
    assert set(differences) == {"loop_uncertainty", "path_map", "loop_uncertainty + path_map",
                                "loop_uncertainty, pairwise", "path_map, pairwise",
                                "loop_uncertainty + path_map, pairwise"}
    assert differences["path_map"]["gap_closed_ci"][0] > 0


def test_bad_arguments_are_refused_in_one_line(tmp_path, run_here):
    made_up_decisions(tmp_path / "old.jsonl", path_map=False)
    old = run_here("probe.py", "--decisions", str(tmp_path / "old.jsonl"), "--extras", "path_map")
    assert old.returncode == 1 and "without it" in old.stderr.strip().splitlines()[-1]
    missing = run_here("probe.py", "--decisions", str(tmp_path / "nope.jsonl"))
    assert missing.returncode == 1 and "no such file" in missing.stderr.strip().splitlines()[-1]
    for args, message in ((["--explore", "2"], "--explore 2"), (["--episodes", "0"], "--episodes must be >= 1"),
                          (["--actor", str(tmp_path / "nope.pt")], "no such file")):
        result = run_here("collect.py", "--out", str(tmp_path / "out"), *args)
        assert result.returncode == 2 and message in result.stderr.strip().splitlines()[-1]
