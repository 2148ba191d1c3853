"""Smoke tests: every benchmark, study and calibration script runs end to end in its
``--smoke`` size (a few seconds) and prints its key figures as a JSON last line.

They check that the scripts run, not their figures. Outputs go to ``tmp_path``.
"""

from __future__ import annotations

import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.benchmarks.smoke import ROOT, load_script, run_script

# script, extra arguments ({tmp} = the test's tmp dir), keys the JSON last line must hold
SCRIPTS = [
    ("benchmarks/bench_building.py", [], ["ms_plan", "ms_compile", "ms_plan_compile", "office_ms_plan_compile",
                                          "plan_compile_ratio_vs_office", "ngeom_median", "lidar_ms_scan_building",
                                          "lidar_ms_scan_office"]),
    ("benchmarks/bench_decision.py", [], ["ms_em", "ms_nearest", "poses", "candidates", "growth", "ms_learned",
                                          "ms_learned_graph", "ms_learned_forward", "learned_actor",
                                          "ms_learned_reference", "em_over_learned", "same_choice"]),
    ("benchmarks/bench_env.py", [], ["decisions_per_s", "decisions_per_s_reference", "speedup", "same_em_choice",
                                     "reward_ms", "reward_ms_reference", "ms_context", "ms_graph", "ms_reward",
                                     "ms_drive", "ms_reward_reference", "ms_drive_reference", "max_nodes_seen",
                                     "speedup_bound_em_free",
                                     "decisions_per_s_runner_em"]),
    ("benchmarks/bench_env.py", ["--profile"], ["fast", "reference"]),
    ("benchmarks/bench_explore.py", [], ["ms_per_decision", "ms_decide", "ms_drive", "keyframes_per_s",
                                         "explored", "baseline_random", "ms_metrics", "ms_metrics_reference",
                                         "map_error_rel_diff", "metrics_speedup", "ms_paths",
                                         "ms_paths_reference", "same_distance_field", "paths_speedup"]),
    ("benchmarks/bench_frontends.py", [], ["ms_slam_stage_icp", "ms_slam_stage_model", "slam_stage_ratio",
                                           "ate_m_icp", "ate_m_model", "fidelity_ok", "lidar_stage_ms"]),
    ("benchmarks/bench_lidar.py", [], ["results", "all_meet_4_mrays_per_s"]),
    ("benchmarks/bench_import.py", [], ["s_import_config", "s_import_runtime", "speedup", "heavy_modules_config"]),
    ("benchmarks/bench_slam.py", [], ["keyframes_per_s", "ate_m", "ate_m_no_loops", "ate_m_odometry",
                                      "map_error_m", "loop_closures", "false_loop_closures", "attempts"]),
    ("benchmarks/study_buildings.py", ["--out", "{tmp}/buildings"], ["loop_fraction", "tree_fraction", "fractions",
                                                                     "medians", "contact_sheet",
                                                                     "ordering_buildings"]),
    ("benchmarks/study_inflation.py", [], ["baseline", "per_variant", "table"]),
    ("benchmarks/study_ordering.py", ["--out", "{tmp}/ordering"], ["table", "checks", "plots"]),
    ("benchmarks/sweep_alpha.py", [], ["nearest_travel_m", "nearest_map_error_m", "rows", "chosen_alpha"]),
    ("benchmarks/bench_drive.py", ["--profile", "{tmp}/drive_profile.txt", "--fast-set", "slam=model_45deg"],
     ["drive_ms_per_decision", "drive_ms_per_decision_reference", "speedup", "max_abs_logodds_diff", "same_voxels",
      "same_explored", "profile", "fast_overrides"]),
    ("benchmarks/study_keyframes.py", ["--spacings", "1:45", "--model-set",
                                       "slam.loop_closure.model_step_sigma_translation=0.012"], ["table", "model_set"]),
    ("benchmarks/study_fidelity.py", ["--model-set", "--model-set", "slam.loop_closure.model_step_sigma_translation=0.008"],
     ["pooled", "buildings", "model_sets"]),
    ("benchmarks/study_zero_shot.py", [str(ROOT / "benchmarks/results/zero_shot_v3_10"), "--out", "{tmp}/targets"],
     ["reports"]),
    ("benchmarks/collect_decisions.py", ["--out", "{tmp}/decisions", "--set", "train.dataset_capacity=16"],
     ["decisions", "layouts", "tasks_done", "wall_s", "decisions_per_s", "decisions_per_s_per_worker"]),
    ("scripts/calibrate_scan_matching.py", ["--out", "{tmp}/scan_matching.yaml"],
     ["matches", "degenerate_fraction", "mahalanobis_d2_per_dof", "fraction_above_chi2_99"]),
]

# files the smoke run must have written into the tmp dir
OUTPUTS = {
    "benchmarks/collect_decisions.py": ["decisions/dataset.json", "decisions/collect.jsonl",
                                        "decisions/storage/storage_metadata.json"],
    "benchmarks/study_buildings.py": ["buildings/contact_sheet.png", "buildings/buildings.csv",
                                      "buildings/summary.json", "buildings/table.md", "buildings/eval/ordering.md",
                                      "buildings/eval/ordering.json"],
    "benchmarks/study_ordering.py": ["ordering/ordering_table.md", "ordering/ordering_runs.jsonl",
                                     "ordering/ordering_street.png"],
    "benchmarks/study_zero_shot.py": ["targets/zero_shot_v3_10/targets.md", "targets/zero_shot_v3_10/targets.json"],
    "scripts/calibrate_scan_matching.py": ["scan_matching.yaml"],
}


@pytest.mark.parametrize(("script", "args", "keys"), SCRIPTS, ids=[Path(s).stem for s, _, _ in SCRIPTS])
def test_script_smoke(script: str, args: list[str], keys: list[str], tmp_path: Path) -> None:
    result = run_script(script, "--smoke", *(a.format(tmp=tmp_path) for a in args), cwd=tmp_path)
    assert result.get("smoke") is True, f"{script} did not report a smoke run: {sorted(result)}"
    missing = [k for k in keys if k not in result]
    assert not missing, f"{script}: JSON last line lacks {missing} (has {sorted(result)})"
    for name in OUTPUTS.get(script, []):
        assert (tmp_path / name).is_file(), f"{script} --smoke did not write {name} into the tmp dir"


def test_every_script_has_a_smoke_test() -> None:
    """A new script in benchmarks/ or scripts/ needs a smoke test: a row above or a test
    module in this directory that names it."""
    here = Path(__file__).resolve().parent
    root = here.parents[1]
    scripts = {p.stem for d in ("benchmarks", "scripts") for p in (root / d).glob("*.py")
               if "__main__" in p.read_text()}
    tests = " ".join(p.read_text() for p in here.glob("test_*.py"))
    missing = sorted(name for name in scripts if not re.search(rf"\b{name}\b", tests))
    assert not missing, f"scripts without a smoke test in tests/benchmarks/: {missing}"


def test_every_script_prints_its_help(capsys, monkeypatch) -> None:
    """``--help`` of every benchmark and study script that parses arguments prints its usage and exits 0: argparse
    formats each help string with ``%``, so a bare ``%`` in one (``layout % 4``) crashes ``--help`` only."""
    root = Path(__file__).resolve().parents[2]
    scripts = sorted(p for d in ("benchmarks", "scripts") for p in (root / d).rglob("*.py")
                     if "__main__" in (text := p.read_text()) and "def main(" in text
                     and ("argparse" in text or "parse_args(" in text))
    assert len(scripts) > 40, f"expected the benchmark and study scripts, found {len(scripts)}"
    broken = {}
    for path in scripts:
        name = str(path.relative_to(root))
        module = load_script(name)
        monkeypatch.setattr(sys, "argv", [name, "--help"])  # the benchmarks' common.parse_args reads sys.argv
        try:
            module.main(["--help"]) if inspect.signature(module.main).parameters else module.main()
            broken[name] = "returned instead of exiting"
        except SystemExit as exit_:
            out = capsys.readouterr().out
            if exit_.code not in (0, None) or "usage:" not in out:
                broken[name] = f"exit {exit_.code}, usage printed: {'usage:' in out}"
        except Exception as error:  # noqa: BLE001 - the failure to report is whatever --help raised
            broken[name] = repr(error)
    assert not broken, f"scripts whose --help fails: {broken}"


def test_every_shell_driver_parses() -> None:
    """The study drivers (``benchmarks/**/*.sh``, ``scripts/**/*.sh``) run for hours in the background: ``bash -n``
    finds a syntax error before a run does, hours in."""
    root = Path(__file__).resolve().parents[2]
    drivers = sorted(root.glob("benchmarks/**/*.sh")) + sorted(root.glob("scripts/**/*.sh"))
    assert len(drivers) > 10, f"expected the study drivers under benchmarks/, found {len(drivers)}"
    broken = {}
    for driver in drivers:
        result = subprocess.run(["bash", "-n", str(driver)], capture_output=True, text=True)
        if result.returncode:
            broken[str(driver.relative_to(root))] = result.stderr.strip()
    assert not broken, f"shell drivers that do not parse: {broken}"


def test_calibrate_loop_closures_writes_a_fit_the_model_loads_with_its_spacing(tmp_path: Path) -> None:
    """The loop-closure script at another keyframe spacing (``--set``): its file loads (a source
    that closed nothing included) and says which spacing it holds for."""
    from explore_rl.slam.calibration import load_loop_closures

    out = tmp_path / "loop_closures.yaml"
    result = run_script("scripts/calibrate_loop_closures.py", "--smoke", "--set", "slam.keyframe_angle_deg=45",
                        "--out", str(out), "--csv", str(tmp_path / "attempts.csv"), cwd=tmp_path)
    for key in ("r_lc", "attempts", "revisits_pose_matching", "accepted_revisits_pose_matching", "false_closures"):
        assert key in result, f"JSON last line lacks {key}"
    calibration = load_loop_closures(out)
    assert calibration.keyframe_spacing == (0.5, 45.0) and calibration.r_lc == result["r_lc"]
    assert (tmp_path / "attempts.csv").is_file()


def test_calibrate_loop_closures_refuses_another_config_without_out(monkeypatch, capsys) -> None:
    """A fit for another config (--set) must not overwrite the default file the model reads."""
    from tests.benchmarks.smoke import load_script

    monkeypatch.setattr("sys.argv", ["calibrate_loop_closures.py", "--set", "slam.keyframe_angle_deg=45"])
    with pytest.raises(SystemExit) as exit_:
        load_script("scripts/calibrate_loop_closures.py").main()
    assert exit_.value.code == 2 and "--set fits another config: give --out" in capsys.readouterr().err
