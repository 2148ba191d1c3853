"""stop_coverage/reached.py: the buildings where every policy reached the stop coverage are copied, the others
not; the counts per policy. by_coverage.py: the pooled ratios at each coverage over the buildings both reached,
against ratios built into made-up explorations. phases.py: the learned / EM ratios of metres per decision, loop
closures per metre and open frontiers in each coverage band, against ratios built in. line.py: each variant's
distance from the line through two others, by hand. by_kind.py: the per-group geometric means, by hand. divergence.py: the
first decision where two runs part, and the graph size there, on made-up trials. one_step.py: the pooled gap and the
episode index by hand, and an actor scored on a made-up dataset (EM's stored choice closes the whole gap). late_probe.py:
fine-tunes on the arm's rows of that dataset only (late rows repeated on request), held-out layouts never. at_travel.py:
each run's means and ratios at fixed travel distances and at the stop, against values built into made-up trials.
lots_em.py: EM's means and medians over made-up buildings. lot_blind.py: the blind floor of an empty box against
its area by hand, and the garage against sparse lots. Bad arguments refused in one line. dataset_kinds.py: a made-up
collection split by the lot probability it was drawn with. revisit_choice.py: the revisit rates of EM's and the
actor's choices on the made-up dataset, by hand; late_probe.py's ``--revisit-repeat`` rows by hand."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.benchmarks.smoke import json_lines, load_script, run_main

SCRIPT = "benchmarks/results/stop_coverage/reached.py"
BY_COVERAGE = "benchmarks/results/stop_coverage/by_coverage.py"
LINE = "benchmarks/results/stop_coverage/line.py"
BY_KIND = "benchmarks/results/stop_coverage/by_kind.py"


def building(run, seed: int, explored: dict[str, float]):
    """A finished building folder: one trial per policy with its final coverage."""
    folder = run / f"building_{seed}"
    folder.mkdir(parents=True)
    folder.joinpath("trials.jsonl").write_text(
        "".join(json.dumps({"policy": p, "explored": e, "trial": 0}) + "\n" for p, e in explored.items()))
    folder.joinpath("summary.md").write_text("| table |\n")


def test_reached_keeps_the_buildings_every_policy_brought_to_the_target(tmp_path, capsys):
    run = tmp_path / "val"
    building(run, 1010, {"learned": 0.86, "em": 0.851})
    building(run, 1011, {"learned": 0.84, "em": 0.90})  # learned stopped short
    building(run, 1012, {"learned": 0.95, "em": 0.60})  # EM stopped short
    building(run, 1013, {"learned": 0.85, "em": 0.85})  # exactly at the target counts
    (run / "building_1014").mkdir()  # cut before it finished: no trials.jsonl
    code, out, _ = run_main(SCRIPT, [str(run), "--out", str(tmp_path / "kept")], capsys)
    result = json.loads(out.strip().splitlines()[-1])
    assert code == 0 and result["buildings"] == 4 and result["all_reached"] == 2
    assert result["reached"] == {"learned": 3, "em": 3}
    assert sorted(p.name for p in (tmp_path / "kept").iterdir()) == ["building_1010", "building_1013"]
    assert (tmp_path / "kept" / "building_1010" / "summary.md").exists()
    code, out, _ = run_main(SCRIPT, [str(run), "--out", str(tmp_path / "k2"), "--target", "0.9"], capsys)
    assert json.loads(out.strip().splitlines()[-1])["all_reached"] == 0 and not (tmp_path / "k2").exists()


def test_reached_refuses_bad_arguments_in_one_line(tmp_path, capsys):
    code, _, err = run_main(SCRIPT, [str(tmp_path), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and "no building_SEED/trials.jsonl" in err
    building(tmp_path / "val", 1010, {"learned": 0.9, "em": 0.9})
    code, _, err = run_main(SCRIPT, [str(tmp_path / "val"), "--out", str(tmp_path / "o"), "--target", "85"], capsys)
    assert code == 2 and "--target 85.0" in err


def exploration(policy: str, metres_per_step: float, errors: list[float], last: float) -> dict:
    """A trial exploring 10 % per decision up to ``last``, ``metres_per_step`` each, map error ``errors[i]``."""
    steps = int(round(last * 10))
    rows = [{"decision": i, "travel_m": metres_per_step * (i + 1), "explored": 0.1 * (i + 1),
             "map_error_m": errors[i], "loop_closures": 0} for i in range(steps)]
    return {"scene": "b", "policy": policy, "status": "explored", "rows": rows, "ms_decide": 10.0,
            "explored": rows[-1]["explored"]}


def test_by_coverage_pools_the_buildings_that_reached_each_coverage(tmp_path, capsys):
    em_errors = [0.1 * (i + 1) for i in range(10)]
    for seed, em_last in ((1, 1.0), (2, 1.0), (3, 0.6)):  # EM stops at 60 % in building 3
        folder = tmp_path / "val" / f"building_{seed}"
        folder.mkdir(parents=True)
        trials = [exploration("learned", 12.0, [2.0 * e if i < 5 else e for i, e in enumerate(em_errors)], 1.0),
                  exploration("em", 10.0, em_errors, em_last)]
        for trial in trials:
            trial["scene"] = f"building_{seed}"
        folder.joinpath("trials.jsonl").write_text("".join(json.dumps(t) + "\n" for t in trials))
    code, out, _ = run_main(BY_COVERAGE, [str(tmp_path / "val"), "--coverages", "0.5", "0.8", "--resamples", "50"],
                            capsys)
    half, late = [json.loads(line) for line in out.strip().splitlines()]
    # learned drives 1.2x EM's metres per 10 %; its map error is twice EM's up to 50 % explored, EM's after
    assert code == 0 and half["buildings"] == 3 and late["buildings"] == 2
    assert abs(half["travel_ratio"] - 1.2) < 1e-6 and abs(half["error_ratio"] - 2.0) < 1e-6
    assert abs(late["travel_ratio"] - 1.2) < 1e-6 and abs(late["error_ratio"] - 1.0) < 1e-6
    code, _, err = run_main(BY_COVERAGE, [str(tmp_path / "val"), "--coverages", "85"], capsys)
    assert code == 2 and "--coverages 85.0" in err
    code, _, err = run_main(BY_COVERAGE, [str(tmp_path / "nothing")], capsys)
    assert code == 2 and "no building_SEED/trials.jsonl" in err
    alone = tmp_path / "learned_only" / "building_1"  # a learned-only run not joined with EM's trials yet
    alone.mkdir(parents=True)
    alone.joinpath("trials.jsonl").write_text(json.dumps(exploration("learned", 12.0, em_errors, 1.0)) + "\n"
                                              + json.dumps({**exploration("learned", 12.0, em_errors, 1.0),
                                                            "scene": "c"}) + "\n")
    (alone.parent / "building_2").mkdir()
    (alone.parent / "building_2" / "trials.jsonl").write_text((alone / "trials.jsonl").read_text())
    code, out, _ = run_main(BY_COVERAGE, [str(alone.parent), "--coverages", "0.5"], capsys)
    assert code == 0 and "no building with both" in json_lines(out)[0]["note"]


PHASES = "benchmarks/results/stop_coverage/phases.py"


def phased_exploration(policy: str, metres: list[float], closures: list[int], frontiers: list[int]) -> dict:
    """A trial exploring 10 % per decision: decision i drives ``metres[i]``, closes ``closures[i]`` loops and chose
    among ``frontiers[i]`` frontiers."""
    travel = np.cumsum(metres)
    closed = np.cumsum(closures)
    rows = [{"decision": i, "travel_m": float(travel[i]), "explored": 0.1 * (i + 1),
             "loop_closures": int(closed[i]), "candidates": frontiers[i]} for i in range(len(metres))]
    return {"scene": "b", "policy": policy, "rows": rows}


def test_phases_recovers_the_ratios_built_into_each_band(tmp_path, capsys):
    # decision i is taken at 10 i % explored: decisions 0-3 fall in the band [0, 0.35), 4-7 in the last band
    for seed in (1, 2, 3):
        folder = tmp_path / "test" / f"building_{seed}"
        folder.mkdir(parents=True)
        em = phased_exploration("em", [10.0] * 8, [4] * 8, [10] * 8)
        # learned: half the metres per decision and 1.5x the open frontiers before 40 %, then EM's; its closures per
        # metre are EM's in the first band (2 per 5 m) and half EM's after (2 per 10 m)
        learned = phased_exploration("learned", [5.0] * 4 + [10.0] * 4, [2] * 8, [15] * 4 + [10] * 4)
        folder.joinpath("trials.jsonl").write_text("".join(json.dumps(t) + "\n" for t in (learned, em)))
    code, out, _ = run_main(PHASES, [str(tmp_path / "test"), "--bands", "0", "0.35", "--resamples", "50"], capsys)
    early, late = [json.loads(line) for line in out.strip().splitlines()]
    assert code == 0 and early["band"] == [0.0, 0.35] and early["buildings"] == 3
    assert abs(early["metres_per_decision"]["ratio"] - 0.5) < 1e-6
    assert abs(early["open_frontiers"]["ratio"] - 1.5) < 1e-6
    assert abs(early["closures_per_m"]["ratio"] - 1.0) < 1e-6
    assert abs(late["metres_per_decision"]["ratio"] - 1.0) < 1e-6 and abs(late["closures_per_m"]["ratio"] - 0.5) < 1e-6
    assert early["em"]["metres_per_decision"] == 10.0 and early["learned"]["open_frontiers"] == 15.0


def test_phases_refuses_bad_arguments_in_one_line(tmp_path, capsys):
    code, _, err = run_main(PHASES, [str(tmp_path)], capsys)
    assert code == 2 and "no building_SEED/trials.jsonl" in err
    code, _, err = run_main(PHASES, [str(tmp_path), "--bands", "0.5", "0.3"], capsys)
    assert code == 2 and "--bands 0.5 0.3" in err


def targets_json(path, travel: float, error: float, scenes: int = 3) -> str:
    """A study_zero_shot.py targets.json with one per-building entry and the pooled one."""
    pooled = {"scene": f"all {scenes} scenes", "scenes": scenes, "travel_ratio": travel, "error_ratio": error,
              "travel_ratio_ci95": [travel - 0.05, travel + 0.05], "error_ratio_ci95": [error - 0.1, error + 0.1]}
    building = {**pooled, "scene": "building_1", "scenes": 1}
    path.write_text(json.dumps({"targets": {"coverage": 0.85}, "entries": [building, pooled]}))
    return str(path)


def test_line_measures_each_point_against_the_line_through_two(tmp_path, capsys):
    """line.py: the line through (1.0, 1.2) and (1.1, 1.0) has slope -2 and intercept 3.2; a point at (1.05, 1.0)
    lies 0.1 below it; the CSV and the PNG are written."""
    a = targets_json(tmp_path / "a.json", 1.0, 1.2)
    b = targets_json(tmp_path / "b.json", 1.1, 1.0)
    c = targets_json(tmp_path / "c.json", 1.05, 1.0)
    code, out, err = run_main(LINE, ["--out", str(tmp_path / "out"), "--point", f"a={a}", "--point", f"b={b}",
                                     "--point", f"c={c}", "--line", "a", "b"], capsys)
    assert code == 0, err
    lines = json_lines(out)
    assert lines[-1]["slope"] == pytest.approx(-2.0) and lines[-1]["intercept"] == pytest.approx(3.2)
    above = {row["name"]: row["above_line"] for row in lines[:-1]}
    assert above["a"] == pytest.approx(0.0) and above["b"] == pytest.approx(0.0)
    assert above["c"] == pytest.approx(-0.1)
    assert (tmp_path / "out" / "line.png").stat().st_size > 0
    assert len((tmp_path / "out" / "line.csv").read_text().splitlines()) == 4


@pytest.mark.parametrize("args", [["--line", "a", "zz"], ["--line", "a", "a"], ["--point", "nameless"]])
def test_line_refuses_bad_arguments_in_one_line(tmp_path, capsys, args):
    a = targets_json(tmp_path / "a.json", 1.0, 1.2)
    base = ["--out", str(tmp_path), "--point", f"a={a}"]
    if args[0] == "--point":
        argv = [*base, *args, "--line", "a", "a"]
    else:
        argv = [*base, *args]
    code, _, err = run_main(LINE, argv, capsys)
    assert code == 2
    assert len([line for line in err.splitlines() if "error:" in line]) == 1


def test_by_kind_groups_the_per_building_ratios(tmp_path, capsys):
    """by_kind.py: per group, the geometric mean of the buildings' ratios (by hand); every building is in "all" and
    in exactly one of "loops" / "no loops" and one area tercile; the pooled entry is not a building."""
    seeds, ratios = [0, 1, 2, 3, 4, 5], [0.8, 1.25, 1.0, 2.0, 0.5, 1.0]
    entries = [{"scene": f"run/building_{s}", "travel_ratio": 1.0, "error_ratio": r} for s, r in zip(seeds, ratios)]
    entries.append({"scene": "all 6 scenes", "travel_ratio": 9.0, "error_ratio": 9.0})
    path = tmp_path / "targets.json"
    path.write_text(json.dumps({"targets": {}, "entries": entries}))
    code, out, err = run_main(BY_KIND, [f"x={path}"], capsys)
    assert code == 0, err
    rows = {row["group"]: row for row in json_lines(out)}
    assert rows["all"]["buildings"] == 6
    assert rows["all"]["error_ratio"] == pytest.approx(float(np.exp(np.mean(np.log(ratios)))), abs=1e-3)
    assert rows["all"]["travel_ratio"] == pytest.approx(1.0)
    assert rows.get("loops", {"buildings": 0})["buildings"] + rows.get("no loops", {"buildings": 0})["buildings"] == 6
    assert sum(rows[g]["buildings"] for g in rows if g.startswith("area ")) == 6
    assert sum(rows[g]["buildings"] for g in rows if g.startswith("corridor ")) == 6
    code, _, err = run_main(BY_KIND, [f"x={tmp_path / 'missing.json'}"], capsys)
    assert code == 2 and len([line for line in err.splitlines() if "error:" in line]) == 1


def test_rows_on_lots_marks_each_row_by_its_layouts_plan():
    """by_kind.rows_on_lots: a row is on a lot exactly when its layout's plan is a parking lot (repeated layouts,
    and a layout without a plan, which is not)."""
    from explore_rl.scene.building import LOT

    rows_on_lots = load_script(BY_KIND).rows_on_lots
    plans = {3: {"corridor": LOT}, 5: {"corridor": "a corridor kind"}}
    assert rows_on_lots(np.array([3, 5, 3, 7]), plans).tolist() == [True, False, True, False]
    assert rows_on_lots(np.array([5]), plans).dtype == bool


DIVERGENCE = "benchmarks/results/stop_coverage/divergence.py"


def decided(run, seed: int, choices: list[tuple[float, int]], policy: str = "learned"):
    """A finished building whose ``policy`` trial chose ``(x, nodes)`` at each decision (keyframes = nodes - 2)."""
    folder = run / f"building_{seed}"
    folder.mkdir(parents=True)
    rows = [{"chosen_x": x, "chosen_y": 0.0, "keyframes": nodes - 2, "candidates": 2} for x, nodes in choices]
    trials = [{"policy": policy, "rows": rows}, {"policy": "em", "rows": []}]
    folder.joinpath("trials.jsonl").write_text("".join(json.dumps(t) + "\n" for t in trials))


def test_divergence_finds_the_first_decision_where_two_runs_part(tmp_path, capsys):
    variant, reference = tmp_path / "variant", tmp_path / "reference"
    decided(variant, 1, [(1.0, 100), (2.0, 600), (3.0, 700)])
    decided(reference, 1, [(1.0, 100), (2.0, 600), (3.0, 700)])  # identical
    decided(variant, 2, [(1.0, 100), (2.0, 300), (5.0, 800)])
    decided(reference, 2, [(1.0, 100), (2.0, 300), (4.0, 800)])  # parts at decision 2, over 512 nodes
    decided(variant, 3, [(1.0, 100), (9.0, 200)])
    decided(reference, 3, [(1.0, 100), (2.0, 200)])  # parts at decision 1, within 512
    decided(variant, 4, [(1.0, 100)])
    decided(reference, 4, [(1.0, 100), (2.0, 900)])  # the variant stopped first: parts where it ends
    decided(variant, 5, [(1.0, 100)])  # no reference building: not counted
    code, out, _ = run_main(DIVERGENCE, [str(variant), "--reference", str(reference), "--nodes", "512"], capsys)
    lines = json_lines(out)
    assert code == 0
    assert {line["building"]: (line["first_difference"], line["nodes"]) for line in lines[:-1]} == {
        "building_2": (2, 800), "building_3": (1, 200), "building_4": (1, None)}
    assert lines[-1] == {"buildings": 4, "identical": 1, "diverge_over_nodes": 1, "diverge_within_nodes": 2,
                         "nodes": 512}


@pytest.mark.parametrize(("args", "message"), [(["--nodes", "0"], "--nodes 0: give a positive graph size"),
                                               ([], "no building with a 'learned' trial in both")])
def test_divergence_refuses_bad_arguments_in_one_line(tmp_path, capsys, args, message):
    decided(tmp_path / "variant", 1, [(1.0, 100)])
    (tmp_path / "reference").mkdir()  # no building: nothing to pair
    code, _, err = run_main(DIVERGENCE, [str(tmp_path / "variant"), "--reference", str(tmp_path / "reference"),
                                         *args], capsys)
    assert code == 2 and message in err.strip().splitlines()[-1]


ONE_STEP = "benchmarks/results/stop_coverage/one_step.py"


def test_one_step_gap_and_episode_index_by_hand():
    """one_step.py's pooled gap closed and each decision's index within its episode, by hand."""
    one_step = load_script(ONE_STEP)
    assert one_step.gap_closed(np.array([1.0, 3.0]), np.array([1.0, 1.0]), np.array([3.0, 3.0])) == pytest.approx(0.5)
    assert np.isnan(one_step.gap_closed(np.array([1.0]), np.array([1.0]), np.array([1.0])))
    episodes = np.array([[7, 0], [7, 0], [7, 0], [8, 1], [8, 1], [7, 2]])
    assert one_step.decision_index(episodes).tolist() == [0, 1, 2, 0, 1, 0]


def made_up_dataset(path, features: list[str], zeroed: tuple[str, ...] = ()):
    """A dataset of two episodes: layout 4 with 20 decisions, layout 3 (held out) with 5; 3 frontiers each, random
    rewards, EM's stored choice the best of them; the node features ``zeroed`` 0 (else the same dataset)."""
    import torch
    from tensordict import TensorDict

    from explore_rl.trainer.dataset import DatasetSchema, DecisionDataset

    dataset = DecisionDataset(path, DatasetSchema(8, 16, list(features), 64))
    rng = np.random.default_rng(0)

    def decision(layout: int, episode: int) -> TensorDict:
        rewards = torch.tensor([0.0, *rng.normal(size=3).tolist(), 0.0, 0.0])
        mask = torch.tensor([False, True, True, True, False, False])
        edges = torch.tensor([[0, 0, 0, 0, 4], [1, 2, 3, 4, 5]])
        x = rng.normal(size=(6, len(features)))
        x[:, [features.index(name) for name in zeroed]] = 0.0
        return TensorDict({"x": torch.from_numpy(x).float(), "edges": edges,
                           "weights": torch.ones(5), "action_mask": mask, "action_rewards": rewards,
                           "em_action": int(torch.argmax(rewards.masked_fill(~mask, -9.0))),
                           "layout": layout, "episode": episode}, batch_size=[])

    dataset.append([decision(4, 0) for _ in range(20)], scene="building")
    dataset.append([decision(3, 1) for _ in range(5)], scene="building")
    return dataset


@pytest.fixture(scope="module")
def scored_data(tmp_path_factory):
    """The made-up dataset and a tiny extended actor file."""
    from explore_rl.config import load_config
    from explore_rl.graph.features import feature_names
    from tests.policy_files import TINY_MODEL, actor_file

    root = tmp_path_factory.mktemp("one_step")
    actor_path, _ = actor_file(root / "actor", load_config(["graph.features=extended", *TINY_MODEL]))
    made_up_dataset(root / "data", list(feature_names("extended")))
    return root, actor_path


def test_one_step_scores_an_actor_on_a_dataset(scored_data, capsys):
    """On the made-up dataset: EM's stored choice closes exactly the whole gap in every group, the bands and area
    groups partition the decisions, every interval holds its point, ``--held-out`` keeps layout 3's 5 decisions and
    ``--training`` layout 4's 20 (not both at once); a
    folder that is no dataset, bad bands or frontier groups and a missing actor file are refused in one line."""
    root, actor_path = scored_data
    code, out, err = run_main(ONE_STEP, [str(root / "data"), "--actor", str(actor_path)], capsys)
    assert code == 0, err
    rows = {row["group"]: row for row in json_lines(out)}
    assert rows["all"]["decisions"] == 25 and rows["all"]["episodes"] == 2
    assert rows["decisions 0-14"]["decisions"] == 20 and rows["decisions 15-29"]["decisions"] == 5
    assert "decisions 30-" not in rows  # empty
    assert sum(rows[g]["decisions"] for g in rows if g.startswith("area ")) == 25
    assert rows["frontiers 1-7"]["decisions"] == 25 and "frontiers 8-9" not in rows  # 3 frontiers each
    for row in rows.values():
        assert row["em"] == pytest.approx(1.0)
        for column in ("greedy", "expected"):
            low, high = row[f"{column}_ci95"]
            assert low - 1e-9 <= row[column] <= high + 1e-9 and -10 < row[column] <= 1.0 + 1e-9
    code, out, err = run_main(ONE_STEP, [str(root / "data"), "--actor", str(actor_path), "--gate", "0.2", "1"], capsys)
    assert code == 0, err
    gates = {row["gate"]: row for row in json_lines(out) if "gate" in row}
    assert gates[0.2]["handed_to_em"] == 5 and gates[1.0]["handed_to_em"] == 25
    assert 0 < gates[0.2]["confidence_cut"] <= 1 and gates[1.0]["confidence_cut"] == 1.0
    assert gates[1.0]["gated"] == pytest.approx(1.0) and gates[1.0]["random_gated"] == pytest.approx(1.0)
    for column in ("gated", "random_gated"):  # EM's stored choice is the best frontier: handing it over never loses
        assert gates[0.2][column] >= rows["all"]["greedy"] - 1e-9
    code, _, err = run_main(ONE_STEP, [str(root / "data"), "--gate", "0"], capsys)
    assert code == 2 and "--gate 0.0" in err.strip().splitlines()[-1]
    code, out, err = run_main(ONE_STEP, [str(root / "data"), "--actor", str(actor_path), "--held-out"], capsys)
    held = {row["group"]: row for row in json_lines(out)}
    assert code == 0 and held["all"]["decisions"] == held["decisions 0-14"]["decisions"] == 5
    assert held["all"]["episodes"] == 1 and "decisions 15-29" not in held
    code, out, err = run_main(ONE_STEP, [str(root / "data"), "--actor", str(actor_path), "--training"], capsys)
    trained = {row["group"]: row for row in json_lines(out)}
    assert code == 0 and trained["all"]["decisions"] == 20 and trained["all"]["episodes"] == 1
    code, _, err = run_main(ONE_STEP, [str(root / "data"), "--held-out", "--training"], capsys)
    assert code == 2 and "not allowed with" in err.strip().splitlines()[-1]
    code, _, err = run_main(ONE_STEP, [str(root)], capsys)
    assert code == 2 and "no dataset.json" in err.strip().splitlines()[-1]
    code, _, err = run_main(ONE_STEP, [str(root / "data"), "--versus", str(root / "missing.pt")], capsys)
    assert code == 2 and "--versus" in err.strip().splitlines()[-1]
    code, _, err = run_main(ONE_STEP, [str(root / "data"), "--bands", "5", "3"], capsys)
    assert code == 2 and "--bands 5 3" in err.strip().splitlines()[-1]
    code, _, err = run_main(ONE_STEP, [str(root / "data"), "--frontiers", "0", "3"], capsys)
    assert code == 2 and "--frontiers 0 3" in err.strip().splitlines()[-1]
    code, _, err = run_main(ONE_STEP, [str(root / "data"), "--actor", str(root / "missing.pt")], capsys)
    assert code == 2 and "--actor" in err.strip().splitlines()[-1] and "missing.pt" in err.strip().splitlines()[-1]


LATE_PROBE = "benchmarks/results/stop_coverage/late_probe.py"


@pytest.mark.parametrize(("arm", "decisions"), [("all", 20), ("late", 10)])
def test_late_probe_fine_tunes_on_the_arms_rows_only(scored_data, capsys, arm, decisions):
    """late_probe.py trains on layout 4's decisions only (layout 3 is held out): all 20, or the 10 from decision 10
    on; the written actor file loads and reads the same features; bad arguments are refused in one line."""
    from explore_rl.models.actor_file import read_actor_file

    root, actor_path = scored_data
    out = root / f"{arm}.pt"
    code, stdout, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", arm, "--actor", str(actor_path),
                                              "--late-from", "10", "--steps", "2", "--out", str(out)], capsys)
    assert code == 0, err
    result = json_lines(stdout)[-1]
    assert result["arm"] == arm and result["decisions"] == decisions and result["steps"] == 2
    assert result["drawn_rows"] == decisions and result["late_repeat"] == 1
    assert read_actor_file(out).feature_set == "extended"
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "late", "--actor", str(actor_path),
                                         "--late-from", "99", "--out", str(out)], capsys)
    assert code == 2 and "no decision for arm late" in err.strip().splitlines()[-1]
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", arm, "--steps", "0", "--out", str(out)], capsys)
    assert code == 2 and "--steps 0" in err.strip().splitlines()[-1]


def test_late_probe_repeats_the_late_rows(scored_data, capsys):
    """``--late-repeat 3``: layout 4's 20 decisions, its 10 late ones twice more (40 rows drawn from); arm late
    repeats only late rows; a repeat below 1 is refused in one line."""
    training_rows = load_script(LATE_PROBE).training_rows
    layouts = np.array([3] * 4 + [4] * 6)
    episodes = np.stack([layouts, np.zeros(10, dtype=int)], axis=1)  # decisions 0..3 of layout 3, 0..5 of layout 4
    assert sorted(training_rows(layouts, episodes, "all", 3, 2)) == [4, 5, 6, 7, 7, 8, 8, 9, 9]
    assert sorted(training_rows(layouts, episodes, "late", 3, 2)) == [7, 7, 8, 8, 9, 9]
    root, actor_path = scored_data
    code, stdout, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--actor", str(actor_path),
                                              "--late-from", "10", "--late-repeat", "3", "--steps", "2",
                                              "--out", str(root / "repeat.pt")], capsys)
    assert code == 0, err
    result = json_lines(stdout)[-1]
    assert result["decisions"] == 20 and result["drawn_rows"] == 40 and result["late_repeat"] == 3
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--late-repeat", "0",
                                         "--out", str(root / "repeat.pt")], capsys)
    assert code == 2 and "--late-repeat 0" in err.strip().splitlines()[-1]
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--fraction", "1.5",
                                         "--out", str(root / "repeat.pt")], capsys)
    assert code == 2 and "--fraction 1.5" in err.strip().splitlines()[-1]


def test_late_probe_repeats_the_rows_where_em_revisits(scored_data, capsys):
    """``em_revisits`` reads the ``revisits`` feature of EM's chosen node; ``repeated`` draws those rows N times in all
    and no others; ``--revisit-repeat 3`` trains on layout 4's 20 decisions plus twice its EM-revisit ones, with
    ``--revisit-kind lot`` only on lot plans; 0 and a bad override are refused in one line."""
    import torch
    from tensordict import TensorDict

    late_probe = load_script(LATE_PROBE)
    x = torch.zeros(3, 2, 4)
    x[0, 1, 2] = 2.0  # row 0: EM picks node 1, which revisits
    x[1, 0, 2] = 1.0  # row 1: EM picks node 1; node 0 revisits, node 1 does not
    rows = TensorDict({"x": x, "em_action": torch.tensor([1, 1, 0])}, batch_size=[3])
    assert late_probe.em_revisits(rows, 2).tolist() == [True, False, False]
    chosen = np.array([True, False, True, False])
    assert sorted(late_probe.repeated(np.array([0, 1, 2]), chosen, 3)) == [0, 0, 0, 1, 2, 2, 2]
    root, actor_path = scored_data
    from explore_rl.trainer.dataset import DecisionDataset

    dataset = DecisionDataset(root / "data")
    stored = dataset.rows()
    revisiting = late_probe.em_revisits(stored, dataset.columns_for(["revisits"])[0])
    expected = 20 + 2 * int(revisiting[stored["layout"].numpy() == 4].sum())
    code, stdout, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--actor", str(actor_path),
                                              "--revisit-repeat", "3", "--steps", "2",
                                              "--out", str(root / "revisit.pt")], capsys)
    assert code == 0, err
    result = json_lines(stdout)[-1]
    assert result["decisions"] == 20 and result["drawn_rows"] == expected > 20 and result["revisit_repeat"] == 3
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--revisit-repeat", "0",
                                         "--out", str(root / "revisit.pt")], capsys)
    assert code == 2 and "--revisit-repeat 0" in err.strip().splitlines()[-1]
    # --revisit-kind lot: with every plan a lot the same rows as all kinds; the default family has no lot, so none
    for overrides, drawn in ((["--set", "scene.building.lot_probability=1"], expected), ([], 20)):
        code, stdout, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--actor", str(actor_path),
                                                  "--revisit-repeat", "3", "--revisit-kind", "lot", *overrides,
                                                  "--steps", "1", "--out", str(root / "lot.pt")], capsys)
        assert code == 0, err
        assert json_lines(stdout)[-1]["drawn_rows"] == drawn and json_lines(stdout)[-1]["revisit_kind"] == "lot"
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--actor", str(actor_path),
                                         "--revisit-repeat", "3", "--revisit-kind", "lot", "--set",
                                         "scene.building.nope=1", "--out", str(root / "lot.pt")], capsys)
    assert code == 2 and "scene.building.nope" in err.strip().splitlines()[-1]
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--set", "scene.building.lot_probability=1",
                                         "--out", str(root / "lot.pt")], capsys)
    assert code == 2 and "only --revisit-kind lot" in err.strip().splitlines()[-1]


def test_late_probe_keeps_whole_episodes_for_a_fraction():
    """``episode_fraction``: half of four episodes keeps two of them whole, the same two for the same seed; a tiny
    fraction still keeps one episode."""
    episode_fraction = load_script(LATE_PROBE).episode_fraction
    episodes = np.repeat(np.array([[4, 0], [4, 1], [8, 0], [8, 1]]), 3, axis=0)  # 4 episodes of 3 decisions
    rows = np.arange(12)
    half = episode_fraction(rows, episodes, 0.5, seed=0)
    kept = {tuple(key) for key in episodes[half]}
    assert len(half) == 6 and len(kept) == 2
    assert all(len(half[(episodes[half] == key).all(axis=1)]) == 3 for key in kept)  # whole episodes
    assert half.tolist() == episode_fraction(rows, episodes, 0.5, seed=0).tolist()  # row indices (integers)
    assert len(episode_fraction(rows, episodes, 0.01, seed=1)) == 3


def test_one_step_pairs_two_actors_on_the_same_decisions(scored_data, tmp_path, capsys):
    """``--versus``: an actor against itself differs by exactly 0; against another, the difference is the two
    actors' own gaps from separate runs, and its paired interval holds it."""
    from explore_rl.config import load_config
    from tests.policy_files import TINY_MODEL, actor_file

    root, first = scored_data
    second, _ = actor_file(tmp_path / "second", load_config(["graph.features=extended", *TINY_MODEL]), seed=1)
    data = str(root / "data")

    def groups(*args: str) -> dict:
        code, out, err = run_main(ONE_STEP, [data, *args], capsys)
        assert code == 0, err
        return {row["group"]: row for row in json_lines(out)}

    same = groups("--actor", str(first), "--versus", str(first))["all"]
    assert same["greedy_minus_versus"] == 0.0 and same["greedy_minus_versus_ci95"] == [0.0, 0.0]
    alone_first, alone_second = groups("--actor", str(first))["all"], groups("--actor", str(second))["all"]
    paired = groups("--actor", str(first), "--versus", str(second))["all"]
    for column in ("greedy", "expected"):
        difference = paired[f"{column}_minus_versus"]
        assert difference == pytest.approx(alone_first[column] - alone_second[column], abs=2e-4)
        low, high = paired[f"{column}_minus_versus_ci95"]
        assert low - 1e-9 <= difference <= high + 1e-9
    assert "em_minus_versus" not in paired


def test_blind_columns_read_as_zero_and_leave_the_dataset_alone(scored_data):
    """``BlindColumns``: the named node-feature columns of every row read as 0, the other columns as stored, and the
    stored dataset keeps its values; a name the dataset lacks is refused naming it."""
    from explore_rl.trainer.dataset import DecisionDataset

    late_probe = load_script(LATE_PROBE)
    root, _ = scored_data
    dataset = DecisionDataset(root / "data")
    view = late_probe.blinded(dataset, ["uncertainty", "landmark_uncertainty"])
    blind = dataset.columns_for(["uncertainty", "landmark_uncertainty"])
    seen = view.rows()["x"].numpy()
    stored = dataset.rows()["x"].numpy()
    others = [c for c in range(stored.shape[-1]) if c not in blind]
    assert len(view) == len(dataset) == 25
    assert np.abs(seen[..., blind]).max() == 0.0 and np.abs(stored[..., blind]).max() > 0.1
    assert np.abs(seen[..., others] - stored[..., others]).max() < 1e-12
    assert late_probe.blinded(dataset, []) is dataset
    with pytest.raises(ValueError, match="no node feature 'loop_length'"):
        late_probe.blinded(dataset, ["loop_length"])


def test_a_blind_actor_trains_without_its_blind_columns_and_ignores_them(scored_data, tmp_path, capsys):
    """``late_probe.py --blind``: the file records the blind columns and its input weights on them are 0 while the
    others trained, so ``one_step.py`` scores it the same whatever those columns hold (the made-up dataset, and a
    copy with them zeroed); an unknown name is refused in one line."""
    from explore_rl.models.actor_critic import INPUT_WEIGHT
    from explore_rl.models.actor_file import read_actor_file
    from explore_rl.trainer.dataset import DecisionDataset

    root, actor_path = scored_data
    names = ["uncertainty", "revisit_uncertainty", "landmark_uncertainty"]
    out = tmp_path / "blind.pt"
    code, stdout, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--actor", str(actor_path),
                                              "--steps", "3", "--blind", *names, "--out", str(out)], capsys)
    assert code == 0, err
    assert json_lines(stdout)[-1]["blind"] == names
    before, after = read_actor_file(actor_path), read_actor_file(out)
    assert after.meta["blind"] == names
    columns = [after.features.index(name) for name in names]
    assert after.weights[INPUT_WEIGHT][:, columns].abs().max() == 0.0
    assert before.weights[INPUT_WEIGHT][:, columns].abs().max() > 0.0
    others = [c for c in range(len(after.features)) if c not in columns]
    assert (after.weights[INPUT_WEIGHT] - before.weights[INPUT_WEIGHT])[:, others].abs().max() > 0.0  # trained
    made_up_dataset(tmp_path / "zeroed", list(after.features), zeroed=tuple(names))
    zeroed_x, stored_x = (DecisionDataset(path).rows()["x"].numpy() for path in (tmp_path / "zeroed", root / "data"))
    assert np.abs(zeroed_x[..., others] - stored_x[..., others]).max() < 1e-12  # the same dataset otherwise

    def scores(data) -> dict:
        code, stdout, err = run_main(ONE_STEP, [str(data), "--actor", str(out)], capsys)
        assert code == 0, err
        return {row["group"]: row for row in json_lines(stdout)}

    as_stored, as_zeroed = scores(root / "data"), scores(tmp_path / "zeroed")
    assert as_stored.keys() == as_zeroed.keys()
    for group, row in as_stored.items():
        for key in ("greedy", "expected"):
            assert row[key] == pytest.approx(as_zeroed[group][key], abs=1e-9)
    code, _, err = run_main(LATE_PROBE, [str(root / "data"), "--arm", "all", "--blind", "loop_length",
                                         "--out", str(tmp_path / "x.pt")], capsys)
    assert code == 2 and "--blind loop_length" in err.strip().splitlines()[-1]


AT_TRAVEL = "benchmarks/results/stop_coverage/at_travel.py"


def travelled_trial(policy: str, seed: int, error: float, metres: float, closures_per_m: float = 0.5) -> dict:
    """A trial of decisions every 10 m up to ``metres``: map error ``error`` and ATE ``2 error`` throughout, explored
    1 % per metre's tenth (10 m: 0.1), ``closures_per_m`` loop closures per metre."""
    travel = np.arange(10.0, metres + 1e-9, 10.0)
    rows = [{"travel_m": float(t), "map_error_m": error, "ate_m": 2 * error, "explored": t / 100.0,
             "loop_closures": int(round(closures_per_m * t))} for t in travel]
    return {"policy": policy, "seed": seed, "rows": rows, "map_error_m": error, "ate_m": 2 * error,
            "explored": float(travel[-1]) / 100.0, "travel_m": float(travel[-1]),
            "loop_closures": rows[-1]["loop_closures"]}


def test_at_travel_recovers_the_ratios_built_into_the_trials(tmp_path, capsys):
    # EM: map error 0.1 on seeds 0-3 (all 80 m); the other run 0.2 on seeds 0-2 (80 m) and seed 3 stopped at 40 m
    trials = [travelled_trial("em", seed, 0.1, 80.0) for seed in range(4)]
    trials += [travelled_trial("learned", seed, 0.2, 80.0, closures_per_m=0.25) for seed in range(3)]
    trials.append(travelled_trial("learned", 3, 0.2, 40.0, closures_per_m=0.25))
    path = tmp_path / "trials.jsonl"
    path.write_text("".join(json.dumps(t) + "\n" for t in trials))
    code, out, _ = run_main(AT_TRAVEL, [f"em={path}:em", f"mine={path}", "--travel", "25", "60", "--resamples", "50"],
                            capsys)
    early, late, stop = [json.loads(line) for line in out.strip().splitlines()]
    assert code == 0 and early["travel_m"] == 25.0 and late["travel_m"] == 60.0 and stop["travel_m"] == "stop"
    assert early["mine"]["trials"] == 4 and late["mine"]["trials"] == 3 and late["em"]["trials"] == 4
    assert early["em"]["map_error_m"] == pytest.approx(0.1) and early["mine"]["ate_m"] == pytest.approx(0.4)
    assert early["mine"]["explored"] == pytest.approx(0.25)
    for entry in (early, late, stop):
        assert entry["mine"]["map_error_m_ratio"]["ratio"] == pytest.approx(2.0)
        assert entry["mine"]["ate_m_ratio"]["ci95"] == pytest.approx([2.0, 2.0])
    assert late["mine"]["map_error_m_ratio"]["seeds"] == 3 and stop["mine"]["map_error_m_ratio"]["seeds"] == 4
    assert late["mine"]["closures_per_m_ratio"]["ratio"] == pytest.approx(0.5, abs=0.02)
    assert stop["mine"]["explored_ratio"]["ratio"] == pytest.approx((3 * 0.8 + 0.4) / 4 / 0.8)


def test_at_travel_refuses_bad_arguments_in_one_line(tmp_path, capsys):
    path = tmp_path / "trials.jsonl"
    path.write_text("".join(json.dumps(travelled_trial("em", s, 0.1, 30.0)) + "\n" for s in range(2)))
    for args, message in (([f"em={path}:em"], "at least two runs"),
                          ([f"em={path}:em", str(path)], "give NAME=FILE[:POLICY]"),
                          ([f"em={path}:em", f"x={tmp_path / 'none.jsonl'}"], "is no file"),
                          ([f"em={path}:em", f"x={path}"], "holds 0 trials of policy 'learned'"),
                          ([f"em={path}:em", f"x={path}:em", "--travel", "50", "20"], "positive, increasing"),
                          ([f"em={path}:em", f"em={path}:em"], "share a NAME")):
        code, _, err = run_main(AT_TRAVEL, args, capsys)
        errors = [line for line in err.splitlines() if "error:" in line]  # after argparse's usage lines
        assert code == 2 and len(errors) == 1 and message in errors[0], (args, err)


LOTS_EM = "benchmarks/results/stop_coverage/lots_em.py"


def test_lots_em_summarises_ems_trial_of_each_building(tmp_path, capsys):
    for seed, error in ((1, 0.1), (2, 0.3), (3, 0.8)):
        folder = tmp_path / f"building_{seed}"
        folder.mkdir()
        trials = [{"policy": policy, "map_error_m": value, "ate_m": 2 * value, "travel_m": 100.0, "explored": 0.85,
                   "loop_closures": seed} for policy, value in (("em", error), ("learned", 9.0))]
        folder.joinpath("trials.jsonl").write_text("".join(json.dumps(t) + "\n" for t in trials))
    code, out, _ = run_main(LOTS_EM, [str(tmp_path)], capsys)
    summary = json.loads(out)
    assert code == 0 and summary["buildings"] == 3
    assert summary["map_error_m"] == {"mean": 0.4, "median": 0.3} and summary["ate_m"]["median"] == 0.6
    assert summary["per_building"]["building_3"]["loop_closures"] == 3.0
    code, _, err = run_main(LOTS_EM, [str(tmp_path / "none")], capsys)
    assert code == 2 and "no building_SEED/trials.jsonl with a 'em' trial" in err



LOT_BLIND = "benchmarks/results/stop_coverage/lot_blind.py"


def test_lot_blind_floor_of_an_empty_box_is_its_inner_square():
    from explore_rl.scene.layout import Layout

    script = load_script(LOT_BLIND)
    stats = script.floor_stats(Layout("box", (10.0, 10.0)), robot_radius=0.3, blind=2.5)
    # floor: cells farther than 0.3 m from the walls (a 9.4 m square); blind: farther than 2.5 m (a 5 m square)
    assert stats["cars"] == 0 and abs(stats["blind"] - 5.0 ** 2 / 9.4 ** 2) < 0.03


def test_lot_blind_ranks_the_garage_below_sparse_lots(capsys):
    sparse = "sparse=size_min=28 size_max=30 lot_lane_width=[6.5,7.0] lot_car_pitch=[6.0,6.5] lot_gap_probability=0.5"
    code, out, _ = run_main(LOT_BLIND, ["--seeds", "1050", "1050", "--lots", sparse], capsys)
    rows = {row["scene"]: row for row in json_lines(out)}
    assert code == 0 and rows["garage"]["cars"] == 15 and rows["sparse"]["layouts"] == 1
    assert 0 < rows["garage"]["blind"] < rows["sparse"]["blind"] < 1
    for args, message in ((["--seeds", "5", "4"], "FIRST must be <= LAST"), (["--lots", "x"], "give NAME=key=value"),
                          (["--garage-seeds", "0"], "give at least 1")):
        code, _, err = run_main(LOT_BLIND, args, capsys)
        assert code != 0 and message in err, (args, err)


DATASET_KINDS = "benchmarks/results/stop_coverage/dataset_kinds.py"


def test_dataset_kinds_counts_lots_by_the_collections_overrides(tmp_path, capsys):
    rows = [{"task": 0, "layout": 5, "stored": 7, "seconds": 2.0}, {"task": 1, "layout": 7, "stored": 3, "seconds": 1.0},
            {"task": 2, "layout": 5, "stored": 2, "seconds": 1.0}, {"session_s": 1.0, "stored": 12}]
    tmp_path.joinpath("collect.jsonl").write_text("".join(json.dumps(row) + "\n" for row in rows))
    code, out, _ = run_main(DATASET_KINDS, [str(tmp_path), "--set", "scene.building.lot_probability=1"], capsys)
    (all_lots,) = json_lines(out)
    # layout 7 % 4 == 3 is held out: only layout 5's 9 decisions are on the training split
    assert code == 0 and all_lots["decisions"] == {"lot": 12} and all_lots["training_decisions"] == {"lot": 9}
    assert all_lots["episodes"] == {"lot": 3} and all_lots["layouts"] == {"lot": 2, "building": 0}
    assert all_lots["decisions_per_s"] == {"lot": 3.0}  # 12 decisions in 4 s of episodes
    code, out, _ = run_main(DATASET_KINDS, [str(tmp_path)], capsys)  # the family's default draws no lot
    assert code == 0 and json_lines(out)[0]["decisions"] == {"building": 12}
    code, _, err = run_main(DATASET_KINDS, [str(tmp_path / "missing")], capsys)
    assert code != 0 and "no collect.jsonl" in err
    code, _, err = run_main(DATASET_KINDS, [str(tmp_path), "--set", "scene.building.nope=1"], capsys)
    assert code == 2 and "scene.building.nope" in err.strip().splitlines()[-1]


def test_one_step_groups_by_kind_with_the_collections_overrides(scored_data, capsys):
    """``--set`` draws the layouts' plans as the collection did: with every plan a lot, ``kind lot`` holds all 25
    decisions and scores as ``all``; without it (the default family, no lots) there is no kind group; a bad override is
    refused in one line."""
    root, actor_path = scored_data
    code, out, err = run_main(ONE_STEP, [str(root / "data"), "--actor", str(actor_path), "--set",
                                         "scene.building.lot_probability=1"], capsys)
    rows = {row["group"]: row for row in json_lines(out)}
    assert code == 0, err
    assert rows["kind lot"]["decisions"] == 25 and "kind building" not in rows
    assert rows["kind lot"]["greedy"] == pytest.approx(rows["all"]["greedy"])
    code, out, _ = run_main(ONE_STEP, [str(root / "data"), "--actor", str(actor_path)], capsys)
    assert code == 0 and not any(row["group"].startswith("kind") for row in json_lines(out))
    code, _, err = run_main(ONE_STEP, [str(root / "data"), "--actor", str(actor_path), "--set",
                                       "scene.building.lot_probability=2"], capsys)
    assert code == 2 and "lot_probability" in err.strip().splitlines()[-1]


REVISIT_CHOICE = "benchmarks/results/stop_coverage/revisit_choice.py"


def test_revisit_choice_rates_by_hand(scored_data, capsys):
    """On the made-up dataset, every plan a lot: EM's revisit rate over the decisions offering a revisit equals the
    count by hand from the stored features, every rate lies in [0, 1] inside its interval, held out and in sample
    split the 25 decisions by layout, and a rate's parts agree (EM revisits or explores: the actor agrees on both
    sides at most as often as it can); a folder that is no dataset and a bad override are refused in one line."""
    import torch

    from explore_rl.trainer.dataset import DecisionDataset

    root, actor_path = scored_data
    stored = DecisionDataset(root / "data").rows()
    column = DecisionDataset(root / "data").columns_for(["revisits"])[0]
    mask = stored["action_mask"]
    revisits = stored["x"][:, :mask.shape[1], column] > 0
    offered = (revisits & mask).any(-1).numpy()
    em = revisits[torch.arange(len(stored)), stored["em_action"].long()].numpy()
    lot = ["--set", "scene.building.lot_probability=1"]
    counts = {}
    for split, layout in (([], 3), (["--training"], 4)):
        code, out, err = run_main(REVISIT_CHOICE, [str(root / "data"), "--actor", str(actor_path), *lot, *split],
                                  capsys)
        assert code == 0, err
        (line,) = json_lines(out)
        kept = offered & (stored["layout"].numpy() == layout)
        assert line["kind"] == "lot" and line["decisions"] == int(kept.sum())
        assert line["em_revisits"] == pytest.approx(em[kept].mean(), abs=1e-4)
        for key in ("em_revisits", "actor_revisits", "agree_when_em_revisits"):
            low, high = line[f"{key}_ci95"]
            assert 0 <= low - 1e-9 <= line[key] <= high + 1e-9 <= 1 + 2e-9
        counts[layout] = line["decisions"]
    assert counts[3] <= 5 and counts[4] <= 20 and counts[3] + counts[4] == int(offered.sum())
    code, out, _ = run_main(REVISIT_CHOICE, [str(root / "data"), "--actor", str(actor_path)], capsys)
    assert code == 0 and json_lines(out)[0]["kind"] == "building"  # the default family draws no lot
    code, _, err = run_main(REVISIT_CHOICE, [str(root / "missing")], capsys)
    assert code == 2 and "no dataset.json" in err.strip().splitlines()[-1]
    code, _, err = run_main(REVISIT_CHOICE, [str(root / "data"), "--actor", str(actor_path), "--set",
                                             "scene.building.nope=1"], capsys)
    assert code == 2 and "scene.building.nope" in err.strip().splitlines()[-1]


NOISE_PARTS = "benchmarks/results/stop_coverage/noise_parts.py"


def timed_trial(policy: str, seed: int, error: float, metres: float) -> dict:
    """:func:`travelled_trial` with a decision time, as explore-rl-eval records it."""
    return {**travelled_trial(policy, seed, error, metres), "ms_decide": 1.0}


def write_building(folder, seed: int, trials: list[dict]) -> None:
    path = folder / f"building_{seed}"
    path.mkdir(parents=True)
    path.joinpath("trials.jsonl").write_text("".join(json.dumps(t) + "\n" for t in trials))


def test_noise_parts_splits_the_spread_into_trial_noise_and_the_rest(tmp_path, capsys):
    # EM's two trials of building b: map errors 0.1 e^{+d_b} and 0.1 e^{-d_b} (one trial's log variance: 2 var(d));
    # the variant 0.1 e^{0.2} everywhere (a log ratio of 0.2 with no spread); building 9 lacks the variant
    offsets = [0.1, -0.3, 0.25, 0.0, 0.4]
    for seed, d in enumerate(offsets):
        write_building(tmp_path / "first", seed, [timed_trial("em", seed, 0.1 * np.exp(d), 80.0)])
        write_building(tmp_path / "second", seed, [timed_trial("em", seed, 0.1 * np.exp(-d), 80.0)])
        write_building(tmp_path / "mine", seed, [timed_trial("learned", seed, 0.1 * np.exp(0.2), 80.0),
                                                 timed_trial("em", seed, 9.0, 80.0)])
    write_building(tmp_path / "first", 9, [timed_trial("em", 9, 0.1, 80.0)])
    write_building(tmp_path / "second", 9, [timed_trial("em", 9, 0.1, 80.0)])
    scene, more = tmp_path / "scene.jsonl", tmp_path / "more.jsonl"  # one scene's trials in two files
    scene.write_text("".join(json.dumps(timed_trial("em", s, e, 80.0)) + "\n" for s, e in enumerate((1, 2))))
    more.write_text(json.dumps(timed_trial("em", 2, 3, 80.0)) + "\n")
    code, out, _ = run_main(NOISE_PARTS, ["--em-first", str(tmp_path / "first"), "--em-second",
                                          str(tmp_path / "second"), "--variant", f"mine={tmp_path / 'mine'}",
                                          "--scene", f"s={scene}+{more}"], capsys)
    pool, variant, scene_line, plan = json_lines(out)
    noise = 2 * np.var(offsets, ddof=1)
    assert code == 0 and pool["buildings"] == 5 and variant["buildings"] == 5
    assert pool["em_one_trial_log_error_sd"] == pytest.approx(np.sqrt(noise), abs=1e-4)
    assert pool["em_one_trial_log_travel_sd"] == 0.0
    assert variant["error_ratio_geomean"] == pytest.approx(np.exp(0.2), abs=1e-4)
    assert variant["log_error_ratio_sd"] == pytest.approx(0.0, abs=1e-4)
    assert variant["excess_variance"] == pytest.approx(-1.5 * noise, abs=1e-4)
    assert scene_line["map_error_cv"] == 0.5 and scene_line["travel_cv"] == 0.0 and scene_line["trials"] == 3
    assert plan["buildings"]["1.00"]["one_em_trial"] > plan["buildings"]["1.00"]["two_em_trials"]
    assert plan["buildings"]["1.05"]["one_em_trial"] > plan["buildings"]["1.00"]["one_em_trial"]
    # CV 0.5: 3 EM trials alone exceed the allowed variance (log 1.1 / 1.96)^2 = 0.002365; against 200 it leaves
    # 0.002365 - 0.25 / 200 = 0.001115, so 0.25 / 0.001115 = 224.2 trials
    assert plan["scenes"]["s"]["1.00"] == {"vs_3_em": None, "vs_200_em": 225}
    # travel has no noise here: the screen and the rule are steps at the true ratio
    assert plan["screen"]["travel"]["1.00"] == {"passes_screen": 1.0, "passes_test": 1.0, "both": 1.0}
    assert plan["screen"]["travel"]["1.05"] == {"passes_screen": 0.0, "passes_test": 1.0, "both": 0.0}
    error = plan["screen"]["map_error"]
    assert error["1.00"]["passes_screen"] > error["1.05"]["passes_screen"] > error["1.10"]["passes_screen"] > 0
    assert plan["screen"]["s_map_error"]["1.00"] > plan["screen"]["s_map_error"]["1.05"]
    assert plan["screen"]["map_error_every_part"]["1.00"] == pytest.approx(
        error["1.00"]["both"] * plan["screen"]["s_map_error"]["1.00"], abs=1e-3)


def test_noise_parts_planning_figures_by_hand():
    module = load_script(NOISE_PARTS)
    # (1.96 * 0.3 * sqrt(2) / log 1.1)^2 = 76.1 buildings
    assert module.units_needed(0.3, 1.0, 1.0) == 77
    assert module.units_needed(0.3, 1.0, 0.5) == 58
    # CV 0.2 against 200 EM trials: (log 1.1 / 1.96)^2 = 0.002365, minus 0.04 / 200 leaves 0.002165: 18.5 trials
    assert module.trials_needed(0.2, 1.0, 200) == 19
    assert module.trials_needed(0.2, 1.0, 10) is None  # the reference alone is too noisy
    # sd 0.36, 90 buildings: the pooled log ratio's sd is 0.36 sqrt(2 / 90) = 0.05367; a true ratio of 1.00 lies
    # below log 1.03 = 0.02956 with P(Z <= 0.5508) = 0.709; on 200 buildings (sd 0.036) the upper bound 1.96 sd
    # above the pooled ratio lies below log 1.1 = 0.09531 when it is at most 0.02475: P(Z <= 0.6875) = 0.754
    chances = module.pass_probabilities(0.36, 1.0, 1.03, 90, 200)
    assert chances["passes_screen"] == pytest.approx(0.709, abs=1e-3)
    assert chances["passes_test"] == pytest.approx(0.754, abs=1e-3)
    assert chances["both"] == pytest.approx(0.709 * 0.754, abs=2e-3)
    # CV 0.4, 120 trials against 200: sd 0.4 sqrt(1/120 + 1/200) = 0.04619; the upper bound passes when the pooled
    # log ratio is at most 0.09531 - 1.96 x 0.04619 = 0.004779: P(Z <= 0.1035) = 0.541
    assert module.scene_pass_probability(0.4, 1.0, 120, 200) == pytest.approx(0.541, abs=1e-3)
    # two trials per held-out building and policy: sd 0.36 / sqrt(200) = 0.02546, the pooled ratio may be at most
    # 0.09531 - 1.96 x 0.02546 = 0.04542: P(Z <= 1.784) = 0.963; the screen is unchanged
    twice = module.pass_probabilities(0.36, 1.0, 1.03, 90, 200, test_trials=2)
    assert twice["passes_test"] == pytest.approx(0.963, abs=1e-3) and twice["passes_screen"] == chances["passes_screen"]
    # two trials per validation building: sd 0.36 / sqrt(90) = 0.03795, P(Z <= 0.7789) = 0.782
    screened = module.pass_probabilities(0.36, 1.0, 1.03, 90, 200, validation_trials=2)
    assert screened["passes_screen"] == pytest.approx(0.782, abs=1e-3) and screened["passes_test"] == chances["passes_test"]


def test_noise_parts_refuses_bad_arguments_in_one_line(tmp_path, capsys):
    for seed in range(2):
        write_building(tmp_path / "first", seed, [timed_trial("em", seed, 0.1, 80.0)])
        write_building(tmp_path / "second", seed, [timed_trial("em", seed, 0.1, 80.0)])
    base = ["--em-first", str(tmp_path / "first"), "--em-second", str(tmp_path / "second")]
    for args, message in ((["--em-first", str(tmp_path / "none"), "--em-second", str(tmp_path)], "not a folder"),
                          (base + ["--variant", "mine"], "give NAME=PATH"),
                          (base + ["--variant", f"a={tmp_path}", "--variant", f"a={tmp_path}"], "share a NAME"),
                          (base + ["--scene", f"s={tmp_path / 'none.jsonl'}"], "is no file"),
                          (base + ["--scene", f"s={base[1]}/building_0/trials.jsonl+{tmp_path / 'none.jsonl'}"],
                           "is no file"),
                          (base + ["--screen", "0"], "give a positive ratio"),
                          (base + ["--test-buildings", "0"], "at least 1 building"),
                          (base + ["--scene-trials", "0"], "at least 1 building or trial"),
                          (base + ["--test-trials", "0"], "at least 1 building or trial"),
                          (base + ["--validation-trials", "0"], "at least 1 building or trial"),
                          (base, "2 building(s)")):
        code, _, err = run_main(NOISE_PARTS, args, capsys)
        errors = [line for line in err.splitlines() if "error:" in line]
        assert code == 2 and len(errors) == 1 and message in errors[0], (args, err)
