"""The analysis scripts of benchmarks/results/selection_v6 on their committed inputs:
reinterval.py on the per-episode rewards of two held-out tests (session 33's default, session
35's), each point estimate checked against gap_closed computed here from the same numbers; the
validation curve of session 35's run from its logs."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
from tensordict import TensorDict
import pytest

from tests.benchmarks.smoke import script_runner

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "benchmarks" / "results" / "selection_v6"
SCRIPT = FOLDER / "reinterval.py"
NEW, OLD = FOLDER / "test35_episode_rewards.json", FOLDER / "test33_episode_rewards.json"
LINE = re.compile(r"^(\w+): (\d+) episodes, gap_closed (?:difference )?([+-][\d.]+) \[([+-][\d.]+), ([+-][\d.]+)\]")


def run(*args: object) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, cwd=ROOT)


def parsed(stdout: str) -> dict[str, tuple[int, float, float, float]]:
    rows = {}
    for line in stdout.splitlines():
        match = LINE.match(line)
        assert match, line
        name, episodes, point, low, high = match.groups()
        rows[name] = (int(episodes), float(point), float(low), float(high))
    return rows


def gap(columns: dict[str, list[float]], learned: str = "learned") -> float:
    means = {name: float(np.mean(values)) for name, values in columns.items()}
    return (means[learned] - means["random"]) / (means["em"] - means["random"])


def test_intervals_give_the_gap_closed_of_the_episodes_with_an_interval_around_it():
    result = run("intervals", NEW)
    assert result.returncode == 0, result.stderr
    rows, sets = parsed(result.stdout), json.loads(NEW.read_text())
    assert set(rows) == {"office", "building"}
    for name, (episodes, point, low, high) in rows.items():
        assert episodes == len(sets[name]["learned"])
        assert point == pytest.approx(gap(sets[name]), abs=1e-3)
        assert low < point < high


def test_compare_gives_the_paired_difference_and_refuses_other_baselines(tmp_path):
    result = run("compare", NEW, OLD)
    assert result.returncode == 0, result.stderr
    new, old = json.loads(NEW.read_text()), json.loads(OLD.read_text())
    for name, (_, point, low, high) in parsed(result.stdout).items():
        assert point == pytest.approx(gap(new[name]) - gap(old[name]), abs=1e-3)
        assert low < point < high
    other = json.loads(OLD.read_text())
    other["office"]["em"][0] += 1.0  # not the same episodes any more
    tampered = tmp_path / "other.json"
    tampered.write_text(json.dumps(other))
    refused = run("compare", NEW, tampered)
    assert refused.returncode != 0 and "office: em differs" in refused.stderr


def test_the_curve_script_reads_the_committed_validation_logs(tmp_path):
    """curve_em_choice_long.py: update 0 is the previous default's validation, every row's mean
    is the mean of its four sets, wall-clock grows with the update."""
    import csv

    result = subprocess.run([sys.executable, str(FOLDER / "curve_em_choice_long.py"), str(tmp_path)],
                            capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader((tmp_path / "curve_em_choice_long.csv").open()))
    kinds = ("office", "building", "lots", "sparse")
    first = rows[0]
    for kind in kinds:
        protocol = json.loads((ROOT / "benchmarks/results/selection_v4" / kind / "dagger_sparse_last/protocol.json")
                              .read_text())
        assert float(first[kind]) == pytest.approx(protocol["gap_closed"], abs=1e-3)
    for row in rows:
        assert float(row["mean"]) == pytest.approx(np.mean([float(row[k]) for k in kinds]), abs=2e-3)
    minutes = [float(row["stage_minutes"]) for row in rows]
    assert int(rows[0]["update"]) == 0 and int(rows[-1]["update"]) == 825 and minutes == sorted(minutes)
    assert (tmp_path / "curve_em_choice_long.png").stat().st_size > 1000


def test_keep_actors_strips_to_a_loadable_actor_with_the_same_weights(tmp_path, capsys):
    """keep_actors.py on a training checkpoint (tiny model, made here): the kept file has only the actor's parts,
    loads as a policy with bitwise the same weights, and a file that is no training checkpoint is refused."""
    import torch

    from explore_rl.models.actor_file import read_actor_file
    from explore_rl.models.checkpoint import FORMAT
    from tests.policy_files import training_checkpoint

    checkpoints = tmp_path / "checkpoints"
    checkpoints.mkdir()
    training_checkpoint(checkpoints / "last.pt")
    assert {"critic", "optimizer"} <= set(torch.load(checkpoints / "last.pt", map_location="cpu", weights_only=False))
    keep = script_runner("benchmarks/results/selection_v6/keep_actors.py", capsys)
    done = keep(str(checkpoints), str(tmp_path / "kept"))
    assert done.returncode == 0, done.stderr
    kept = torch.load(tmp_path / "kept" / "last.pt", map_location="cpu", weights_only=False)
    assert set(kept) == {"format", "model", "config", "actor", "state"}
    a, b = read_actor_file(tmp_path / "kept" / "last.pt"), read_actor_file(checkpoints / "last.pt")
    assert a.features == b.features and a.weights.keys() == b.weights.keys()
    assert all(torch.equal(a.weights[key], b.weights[key]) for key in a.weights)

    torch.save({"format": FORMAT}, checkpoints / "last.pt")
    refused = keep(str(checkpoints), str(tmp_path / "k2"))
    assert refused.returncode != 0 and "not a training checkpoint" in refused.stderr


def test_the_scratch_curve_places_each_snapshot_after_its_stage(tmp_path):
    """scratch_curve.py on a validation log made here (the form validate_10 writes): a stage-2 snapshot's minutes and
    decisions come after all of stage 1's, the last snapshots are the stages' last updates, a snapshot missing a set
    is left out, and each row's mean is the mean of its four sets."""
    import csv

    kinds = ("office", "building", "lots", "sparse")
    gaps = {"scratch_s38_office_update_00080": 0.1, "scratch_s38_office_last": 0.2,
            "scratch_s38_sparse_update_00240": 0.3, "scratch_s38": 0.4}
    lines = []
    for name, gap in gaps.items():
        for offset, kind in enumerate(kinds):
            lines += [f"== {name} {kind}", "== some/actor.pt on office (held out): layouts [1000]",
                      json.dumps({"gap_closed": gap + offset / 100})]
    lines += ["== scratch_s38_sparse_update_00400 office", json.dumps({"gap_closed": 0.9})]  # incomplete
    log = tmp_path / "validation.log"
    log.write_text("\n".join(lines) + "\n")
    result = subprocess.run([sys.executable, str(FOLDER / "scratch_curve.py"), str(tmp_path), str(log)],
                            capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    rows = list(csv.DictReader((tmp_path / "scratch_curve.csv").open()))
    assert [(row["stage"], int(row["update"])) for row in rows] == [("office", 80), ("office", 174),
                                                                   ("sparse", 240), ("sparse", 499)]
    run = FOLDER / "scratch_run"
    stage1 = np.loadtxt(run / "office" / "wall_s.csv", delimiter=",", ndmin=2)
    stage2 = np.loadtxt(run / "sparse" / "wall_s.csv", delimiter=",", ndmin=2)
    assert float(rows[1]["total_minutes"]) == pytest.approx(stage1[-1, 1] / 60, abs=0.05)
    assert float(rows[3]["total_minutes"]) == pytest.approx((stage1[-1, 1] + stage2[-1, 1]) / 60, abs=0.05)
    assert int(rows[3]["decisions"]) == int(stage1[-1, 0] + stage2[-1, 0])
    assert int(rows[2]["decisions"]) == int(stage1[-1, 0]) + 240 * 20
    for row, gap in zip(rows, gaps.values()):
        assert float(row["office"]) == pytest.approx(gap) and float(row["sparse"]) == pytest.approx(gap + 0.03)
        assert float(row["mean"]) == pytest.approx(np.mean([float(row[k]) for k in kinds]), abs=2e-3)
    assert (tmp_path / "scratch_curve.png").stat().st_size > 1000
    missing = subprocess.run([sys.executable, str(FOLDER / "scratch_curve.py"), str(tmp_path), str(tmp_path / "no.log")],
                             capture_output=True, text=True, cwd=ROOT)
    assert missing.returncode != 0 and missing.stderr.strip() == (
        f"scratch_curve.py: no validation log at {tmp_path / 'no.log'}: give the log scratch_curve.sh wrote")


def revisit_dataset(path, count: int = 24, features: str = "extended"):
    """A small DecisionDataset of made-up decisions with the extended node features (or ``features``; chain
    graphs, random features and rewards, frontier rows masked in, layouts 0-7 in turn), for revisit_probe.py;
    returns it and EM's best rows."""
    import torch

    from explore_rl.config import load_config
    from explore_rl.graph.features import feature_names
    from explore_rl.trainer.dataset import DecisionDataset
    from tests.trainer.test_dataset import schema_for

    torch.manual_seed(0)
    names = feature_names(features)
    decisions, best = [], []
    for index in range(count):
        n = 6 + index % 5
        mask = torch.zeros(n, dtype=torch.bool)
        mask[n // 2:] = True
        rewards = torch.where(mask, torch.randn(n), torch.zeros(n))
        edges = torch.stack([torch.arange(n - 1), torch.arange(1, n)]).to(torch.int32)
        x = torch.rand(n, len(names))
        x[:, names.index("revisits")] = torch.randint(0, 4, (n,)).float()
        em_action = rewards.masked_fill(~mask, -torch.inf).argmax()
        decisions.append(TensorDict({"x": x, "edges": edges, "weights": torch.ones(n - 1), "action_mask": mask,
                                     "action_rewards": rewards, "em_action": em_action,
                                     "layout": torch.tensor(index % 8)}, batch_size=[]))
        best.append(int(em_action))
    dataset = DecisionDataset(path, schema_for(load_config([f"graph.features={features}"]), capacity=count))
    dataset.append(decisions, scene="building")
    return decisions, best


def test_the_revisit_probe_reads_each_actor_with_its_own_model(tmp_path, capsys):
    """revisit_probe.py on a dataset and a tiny actor made here: EM's side equals the revisits and path lengths
    of the best-rewarded frontier computed here, one actor under two names gives the same figures, shares lie in
    [0, 1]; an actor of the paper's features, a malformed --actor, a missing actor file and a folder without a
    dataset are refused in one line."""
    from explore_rl.config import load_config
    from explore_rl.graph.features import feature_names
    from tests.policy_files import TINY_MODEL, actor_file

    decisions, best = revisit_dataset(tmp_path / "data")
    actor, _ = actor_file(tmp_path / "tiny", load_config([*TINY_MODEL, "graph.features=extended"]))
    probe = script_runner("benchmarks/results/selection_v6/revisit_probe.py", capsys)
    script = ["--dataset", str(tmp_path / "data")]
    result = probe(*script, "--actor", f"a={actor}", "--actor", f"b={actor}")
    assert result.returncode == 0, result.stderr
    figures = json.loads(result.stdout.strip().splitlines()[-1])
    assert figures["a"] == figures["b"] and figures["a"]["decisions"] == len(decisions)
    names = list(feature_names("extended"))
    revisits = [float(d["x"][row, names.index("revisits")]) for d, row in zip(decisions, best)]
    lengths = [float(d["x"][row, names.index("path_length")]) for d, row in zip(decisions, best)]
    assert figures["a"]["em_revisits"] == pytest.approx(np.mean(revisits), abs=1e-3)
    assert figures["a"]["em_path_m"] == pytest.approx(np.mean(lengths), abs=1e-3)
    assert figures["a"]["em_any_revisit"] == pytest.approx(np.mean(np.array(revisits) > 0), abs=1e-3)
    for key in ("policy_any_revisit", "same_choice"):
        assert 0.0 <= figures["a"][key] <= 1.0
    paper, _ = actor_file(tmp_path / "paper", load_config([*TINY_MODEL, "graph.features=paper"]))
    refused = probe(*script, "--actor", f"p={paper}")
    assert refused.returncode != 0 and "graph.features=extended" in refused.stderr.strip().splitlines()[-1]
    malformed = probe(*script, "--actor", str(actor))
    assert malformed.returncode != 0 and "NAME=PATH" in malformed.stderr
    for bad in (["--actor", f"a={tmp_path / 'missing.pt'}"], ["--actor", f"a={actor}", "--dataset", str(tmp_path)]):
        refused = probe(*script, *bad)
        last = refused.stderr.strip().splitlines()[-1]
        assert refused.returncode != 0 and "Traceback" not in refused.stderr and str(tmp_path) in last
