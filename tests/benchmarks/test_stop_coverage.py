"""stop_coverage/reached.py: the buildings where every policy reached the stop coverage are copied, the others
not; the counts per policy; bad arguments refused in one line."""

from __future__ import annotations

import json

from tests.benchmarks.smoke import run_main

SCRIPT = "benchmarks/results/stop_coverage/reached.py"


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
