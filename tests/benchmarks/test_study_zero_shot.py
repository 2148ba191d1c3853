"""study_zero_shot.py's pairing of separate runs (``--reference``) and its pool over reports
(``--pool``), on small synthetic reports whose ratios are known by construction."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from tests.benchmarks.smoke import ROOT, run_script, script_runner

SCRIPT = "benchmarks/study_zero_shot.py"


def trial(scene: str, policy: str, travel_per_step: float, error: float, ms: float) -> dict:
    """A trial exploring 10 % per decision over 10 decisions, ``travel_per_step`` metres each,
    with a constant map error ``error``."""
    rows = [{"decision": i, "travel_m": travel_per_step * (i + 1), "explored": 0.1 * (i + 1), "map_error_m": error,
             "volume_m3": 5.0 * (i + 1)} for i in range(10)]
    return {"scene": scene, "policy": policy, "trial": 0, "seed": 0, "status": "explored", "rows": rows,
            "ms_decide": ms}


def write_report(folder: Path, scenes: dict[str, list[dict]]) -> Path:
    """A sweep folder: one ``N_scene/trials.jsonl`` per scene."""
    for i, (scene, runs) in enumerate(scenes.items()):
        sub = folder / f"{i}_{scene}"
        sub.mkdir(parents=True)
        (sub / "trials.jsonl").write_text("".join(json.dumps(run) + "\n" for run in runs))
    return folder


@pytest.fixture()
def runs(tmp_path: Path) -> dict[str, Path]:
    """Two sweeps over the same scene names (as two scene options over the same seeds), each
    with the learned policy alone and EM in a separate run: learned travels 1.2x (first) and
    0.8x (second) EM's, its map error 1.5x and 1.0x, and decides 4x faster."""
    folders = {}
    for name, travel, error in (("first", 1.2, 1.5), ("second", 0.8, 1.0)):
        folders[f"{name}_learned"] = write_report(tmp_path / f"{name}_learned", {
            scene: [trial(scene, "learned", 10.0 * travel, 0.1 * error, 10.0)] for scene in ("b_1", "b_2")})
        folders[f"{name}_em"] = write_report(tmp_path / f"{name}_em", {
            scene: [trial(scene, "em", 10.0, 0.1, 40.0)] for scene in ("b_1", "b_2")})
    return folders


def test_reference_pairs_separate_runs_and_pool_keeps_same_named_scenes_apart(runs: dict[str, Path],
                                                                              tmp_path: Path) -> None:
    result = run_script(SCRIPT, str(runs["first_learned"]), str(runs["second_learned"]), "--reference",
                        str(runs["first_em"]), str(runs["second_em"]), "--pool", "both", "--out",
                        str(tmp_path / "targets"), "--smoke", cwd=tmp_path)
    first = result["reports"]["first_learned"]["b_1"]
    assert math.isclose(first["travel_ratio"], 1.2, rel_tol=1e-9)
    assert math.isclose(first["error_ratio"], 1.5, rel_tol=1e-9)
    assert math.isclose(first["speedup"], 4.0, rel_tol=1e-9)
    assert math.isclose(result["reports"]["second_learned"]["b_2"]["travel_ratio"], 0.8, rel_tol=1e-9)
    pool = result["pool"]
    assert list(pool) == ["all 4 scenes"]  # its scenes are the reports' above
    entries = json.loads((tmp_path / "targets/both/targets.json").read_text())["entries"]
    scenes = sorted(e["scene"] for e in entries if not e["scene"].startswith("all "))
    assert scenes == ["first_learned/b_1", "first_learned/b_2", "second_learned/b_1", "second_learned/b_2"]
    assert math.isclose(pool["all 4 scenes"]["travel_ratio"], math.sqrt(1.2 * 0.8), rel_tol=1e-9)  # geometric mean
    assert math.isclose(pool["all 4 scenes"]["error_ratio"], math.sqrt(1.5 * 1.0), rel_tol=1e-9)
    assert (tmp_path / "targets/both/targets.md").is_file()
    assert (tmp_path / "targets/first_learned/targets.json").is_file()


def test_reference_policy_learned_compares_two_candidates_directly(runs: dict[str, Path], tmp_path: Path) -> None:
    """The first candidate against the second, scene by scene: travel 1.2 / 0.8, error 1.5 / 1.0."""
    result = run_script(SCRIPT, str(runs["first_learned"]), "--reference", str(runs["second_learned"]),
                        "--reference-policy", "learned", "--out", str(tmp_path / "direct"), "--smoke", cwd=tmp_path)
    pooled = result["reports"]["first_learned"]["all 2 scenes"]
    assert math.isclose(pooled["travel_ratio"], 1.5, rel_tol=1e-9)
    assert math.isclose(pooled["error_ratio"], 1.5, rel_tol=1e-9)
    assert math.isclose(pooled["speedup"], 1.0, rel_tol=1e-9)
    assert "learned against learned_reference" in (tmp_path / "direct/first_learned/targets.md").read_text()


def test_plots_draw_the_policy_and_the_paired_reference_per_scene(runs: dict[str, Path], tmp_path: Path) -> None:
    from PIL import Image

    run_script(SCRIPT, str(runs["first_learned"]), "--reference", str(runs["first_em"]), "--plots",
               "--out", str(tmp_path / "plots"), "--smoke", cwd=tmp_path)
    drawn = sorted(path.name for path in (tmp_path / "plots/first_learned").glob("*.png"))
    assert drawn == ["b_1_map_error.png", "b_1_volume.png", "b_2_map_error.png", "b_2_volume.png"]
    assert Image.open(tmp_path / "plots/first_learned/b_1_map_error.png").size[0] > 100
    run_script(SCRIPT, str(runs["second_learned"]), "--reference", str(runs["second_em"]),
               "--out", str(tmp_path / "none"), "--smoke", cwd=tmp_path)
    assert not list((tmp_path / "none/second_learned").glob("*.png"))  # only with --plots
    refused = subprocess.run([sys.executable, str(ROOT / SCRIPT), str(runs["first_learned"]), "--reference",
                              str(runs["first_em"]), "--plots", "--smoke"], capture_output=True, text=True)
    assert refused.returncode != 0 and "--plots: pass --out DIR" in refused.stderr
    assert not list(runs["first_learned"].rglob("*.png"))  # the report's folder untouched


def test_policy_em_against_another_em_run(runs: dict[str, Path], tmp_path: Path) -> None:
    """EM against another EM run of the same scenes (the noise floor): identical runs give 1."""
    result = run_script(SCRIPT, str(runs["first_em"]), "--reference", str(runs["second_em"]), "--policy", "em",
                        "--reference-policy", "em", "--out", str(tmp_path / "floor"), "--smoke", cwd=tmp_path)
    pooled = result["reports"]["first_em"]["all 2 scenes"]
    assert all(math.isclose(pooled[key], 1.0, rel_tol=1e-9) for key in ("travel_ratio", "error_ratio", "speedup"))
    assert "em against em_reference" in (tmp_path / "floor/first_em/targets.md").read_text()


@pytest.fixture()
def run_failing(capsys):
    """``call(*args)``: the script's main in this process, which must refuse; its last stderr line."""
    study = script_runner(SCRIPT, capsys)

    def call(*args: str) -> str:
        proc = study(*args)
        assert proc.returncode != 0, proc.stdout
        return proc.stderr.strip().splitlines()[-1]

    return call


def test_reference_count_and_missing_scenes_fail_in_one_line(runs: dict[str, Path], tmp_path: Path,
                                                            run_failing) -> None:
    message = run_failing(str(runs["first_learned"]), "--reference", str(runs["first_em"]), str(runs["second_em"]))
    assert "--reference: 2 folder(s) for 1 report(s)" in message
    partial = write_report(tmp_path / "partial_em", {"b_1": [trial("b_1", "em", 10.0, 0.1, 40.0)]})
    message = run_failing(str(runs["first_learned"]), "--reference", str(partial))
    assert "no em trial of scene(s) b_2" in message
    message = run_failing(str(runs["first_learned"]), "--reference", str(tmp_path / "nope"))
    assert message.startswith("--reference ") and "no trials.jsonl" in message
    message = run_failing(str(runs["first_learned"]), "--reference-policy", "learned")
    assert "pass --reference FOLDER" in message
    message = run_failing(str(runs["first_em"]), "--policy", "em", "--reference-policy", "em")
    assert "pass --reference FOLDER" in message


def test_reference_refuses_a_report_with_its_own_reference_trials(runs: dict[str, Path], tmp_path: Path,
                                                                 run_failing) -> None:
    message = run_failing(str(runs["first_em"]), "--reference", str(runs["second_em"]))
    assert "has em trials of its own" in message
