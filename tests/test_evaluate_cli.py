"""explore-rl-eval end to end on a tiny budget, in a subprocess as a user runs it."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from explore_rl import comparison
from explore_rl.config import load_config
from explore_rl.viz import plt
from tests.policy_files import actor_file

EVAL = "import sys; from explore_rl.cli import evaluate; sys.argv[0] = 'explore-rl-eval'; evaluate()"
TINY = ["scene=street", "slam=model", "explore.max_decisions=2", "evaluate.trials=2", "evaluate.progress_bar=false",
        "planning.actions.max_frontiers=3"]
COLUMNS = ["policy", "trial", "travel_m", "map_error_m", "explored", "volume_m3", "ms_decide", "loop_closures",
           "contacts", "blocked_decisions", "min_clearance_m", "path_status"]


def run_eval(*overrides: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-c", EVAL, *overrides], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def test_eval_writes_every_decision_a_table_and_the_plots(tmp_path):
    path, _ = actor_file(tmp_path / "policy", load_config(["model.hidden=16", "model.mlp_hidden=16"]))
    out = tmp_path / "eval"
    proc = run_eval(*TINY, "evaluate.policies=[learned,nearest]", "evaluate.workers=2", f"policy.checkpoint={path}",
                    f"out={out}", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-4000:]
    with open(out / "decisions.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert not [c for c in COLUMNS if c not in rows[0]]
    assert len(rows) == 2 * 2 * 2  # policies x trials x decisions
    assert {(r["policy"], r["trial"]) for r in rows} == {(p, t) for p in ("learned", "nearest") for t in ("0", "1")}
    table = (out / "summary.md").read_text()
    assert "| street | learned | 2 |" in table and "| street | nearest | 2 |" in table
    assert "map error m" in table and "decision ms" in table and "contacts" in table
    assert table in proc.stdout  # printed too
    for name in ("street_map_error.png", "street_volume.png"):
        assert (out / name).stat().st_size > 1000

    # the worker processes ran what one process runs: trial 1 of nearest, again, here
    logged = {(r["policy"], r["trial"]): r for r in comparison.read_trials(out / "trials.jsonl")}
    config = load_config([*TINY, "policy=nearest"])
    again = comparison.run_trial(comparison.Trial(comparison.trial_config(config, "nearest", 1), 1))
    timing = ("ms_decide", "ms_drive", "ms_safety")
    strip = [{k: v for k, v in row.items() if k not in timing} for row in again["rows"]]
    assert strip == [{k: v for k, v in row.items() if k not in timing} for row in logged[("nearest", 1)]["rows"]]


def test_eval_with_a_missing_actor_file_fails_at_once_with_one_line(tmp_path):
    missing = tmp_path / "no" / "actor.pt"
    proc = run_eval(*TINY, f"policy.checkpoint={missing}", f"out={tmp_path / 'eval'}", cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and f"{missing}: no checkpoint there" in lines[0]
    assert not (tmp_path / "eval").exists()


def test_eval_rejects_an_unknown_policy(tmp_path):
    proc = run_eval(*TINY, "evaluate.policies=[nearest,greedy]", cwd=tmp_path)
    assert proc.returncode == 2 and "evaluate.policies" in proc.stderr


def synthetic_run(policy: str, trial: int, errors: list[float], status: str = "explored") -> dict:
    rows = [{"travel_m": 2.0 * (k + 1), "map_error_m": e, "volume_m3": 3.0 * k, "ms_decide": 10.0}
            for k, e in enumerate(errors)]
    return {"scene": "street", "policy": policy, "trial": trial, "seed": trial, "status": status, "error": None,
            "rows": rows, "travel_m": rows[-1]["travel_m"] if rows else 0.0, "map_error_m": errors[-1] if errors else 0,
            "volume_m3": 1.0, "explored": 0.8, "explored_per_m": 0.1, "loop_closures": 2, "ms_decide": 10.0,
            "contacts": 0, "blocked_decisions": 1, "min_clearance_m": 0.1, "ate_m": 0.0, "decisions": len(rows),
            "safety_interventions": 0}


def test_summary_means_stds_and_failed_trials():
    runs = [synthetic_run("nearest", 0, [0.1, 0.2]), synthetic_run("nearest", 1, [0.1, 0.4]),
            synthetic_run("em", 0, [0.1]), {**synthetic_run("em", 1, []), "status": "error", "error": "boom"}]
    table = comparison.summarise(runs)
    assert [t["policy"] for t in table] == ["em", "nearest"]  # the paper's order
    nearest = table[1]
    assert nearest["map_error_m"] == pytest.approx(0.3) and nearest["map_error_m_std"] == pytest.approx(0.1)
    assert table[0]["trials"] == 1 and table[0]["errors"] == 1
    text = comparison.markdown_table(table)
    assert "| street | em | 1 (1 failed) |" in text and "0.300 ± 0.100" in text
    json.dumps(table)


def test_mean_curve_holds_each_trials_last_value_up_to_the_median_end():
    runs = [synthetic_run("nearest", 0, [0.0, 1.0]), synthetic_run("nearest", 1, [0.0, 1.0, 1.0, 3.0]),
            synthetic_run("nearest", 2, [0.0, 1.0, 2.0])]
    travel, mean, low, high = comparison.mean_curve(runs, "map_error_m", points=5)
    assert travel[0] == 2.0 and travel[-1] == 6.0  # median of the ends 4, 8, 6
    assert mean[-1] == pytest.approx((1.0 + 1.0 + 2.0) / 3)  # trial 0 holds its last value
    # the band: the interquartile range of (1, 1, 2), numpy's linear percentiles by hand
    assert (low[-1], high[-1]) == pytest.approx((1.0, 1.5))


def test_the_spread_band_is_interquartile_and_stays_within_the_trials_values():
    """A positive metric with a skewed spread: mean - std would go below zero, the band does not."""
    runs = [synthetic_run("em", t, values) for t, values in
            enumerate([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 3.0]])]
    travel, mean, low, high = comparison.mean_curve(runs, "map_error_m", points=3)
    finals = np.array([0.0, 0.0, 0.0, 3.0])
    assert mean[-1] == pytest.approx(0.75) and mean[-1] - finals.std() < 0
    assert (low[-1], high[-1]) == pytest.approx((0.0, 0.75))  # sorted 0, 0, 0, 3: quartiles at 0 and 0.75
    assert np.all(low >= 0.0) and np.all(low <= mean + 1e-12) and np.all(high <= 3.0)
    fig, ax = plt.subplots()
    comparison.plot_metric(ax, runs, "map_error_m", "map error [m]")
    assert ax.get_legend().get_title().get_text() == comparison.BAND_LABEL
    assert "interquartile" in comparison.BAND_LABEL
    (band,) = ax.collections
    assert band.get_paths()[0].vertices[:, 1].min() >= 0.0
    plt.close(fig)


def test_travel_and_map_error_where_each_trial_first_reached_the_coverage_target():
    runs = [synthetic_run("em", 0, [0.1, 0.2, 0.3]), synthetic_run("em", 1, [0.1, 0.5]),
            synthetic_run("nearest", 0, [0.4, 0.6])]
    for run, explored in zip(runs, ([0.5, 0.86, 0.9], [0.85, 0.9], [0.2, 0.3])):
        for row, value in zip(run["rows"], explored):
            row["explored"] = value
    em, nearest = comparison.coverage_reached(runs, target=0.85)
    assert (em["policy"], em["reached"], em["trials"]) == ("em", 2, 2)
    assert em["travel_m"] == pytest.approx((4.0 + 2.0) / 2) and em["map_error_m"] == pytest.approx((0.2 + 0.1) / 2)
    assert nearest["reached"] == 0 and np.isnan(nearest["travel_m"]) and nearest["ms_decide"] == 10.0
    text = comparison.coverage_markdown([em, nearest])
    assert "| street | em | 2/2 | 3.0 ± 1.0 | 0.150 ± 0.050 | 10 |" in text and "85 % explored" in text


def test_matched_travel_compares_policies_after_the_reference_policys_mean_travel():
    # em ends at 4 and 8 m (mean 6 m); nearest's trial ends at 4 m and holds its last value
    runs = [synthetic_run("em", 0, [0.1, 0.2]), synthetic_run("em", 1, [0.1, 0.2, 0.3, 0.4]),
            synthetic_run("nearest", 0, [0.5, 0.7]), synthetic_run("learned", 0, [0.0, 0.2, 0.4, 0.6])]
    (entry,) = comparison.matched_travel(runs)
    assert entry["travel_m"] == pytest.approx(6.0)
    assert entry["em"] == pytest.approx((0.2 + 0.3) / 2) and entry["em_std"] == pytest.approx(0.05)
    assert entry["nearest"] == pytest.approx(0.7) and entry["learned"] == pytest.approx(0.4)
    text = comparison.matched_travel_markdown([entry])
    assert "| scene | travel m | learned | em | nearest |" in text and "| street | 6.0 | 0.400 ± 0.000 |" in text
    assert comparison.matched_travel([r for r in runs if r["policy"] != "em"]) == []


def test_trials_run_in_this_process_use_evaluate_threads_torch_threads(monkeypatch):
    """With one worker the trials run in-process: torch uses ``evaluate.threads`` during them (as the spawned workers'
    initialiser sets it), and the caller's count is back afterwards."""
    import torch

    seen = []
    monkeypatch.setattr(comparison, "run_trial", lambda trial: seen.append(torch.get_num_threads()) or {
        "scene": "s", "policy": "p", "trial": trial, "status": "explored"})
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        results = comparison.run_trials([0, 1], workers=1, threads=1, progress=False)
        assert seen == [1, 1] and [r["trial"] for r in results] == [0, 1]
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)


def test_finished_trials_read_back_what_log_trial_wrote_and_skip_a_cut_last_line(tmp_path, caplog):
    path = tmp_path / comparison.PARTIAL
    assert comparison.finished_trials(path) == {}
    first, second = synthetic_run("em", 0, [0.1, 0.2]), synthetic_run("nearest", 3, [0.4])
    comparison.log_trial(path, first)
    comparison.log_trial(path, second)
    assert comparison.finished_trials(path) == {("em", 0, 0): first, ("nearest", 3, 3): second}
    with open(path, "a") as handle:  # a crash while writing the third record
        handle.write(json.dumps(synthetic_run("em", 1, [0.3]))[:40])
    assert list(comparison.finished_trials(path)) == [("em", 0, 0), ("nearest", 3, 3)]
    assert "cut short" in caplog.text
    comparison.restart_log(path, comparison.finished_trials(path).values())  # what a resumed run does first
    comparison.log_trial(path, synthetic_run("em", 1, [0.3]))
    assert list(comparison.finished_trials(path)) == [("em", 0, 0), ("nearest", 3, 3), ("em", 1, 1)]
    path.write_text("not json\n" + json.dumps(first) + "\n")  # damage before the end is not a crash's
    with pytest.raises(ValueError, match="line 1 is not a trial record"):
        comparison.finished_trials(path)


def test_eval_resumes_the_trials_it_lacks_and_refuses_another_configs_log(tmp_path):
    """A study stopped after one of its trials: the same command runs only the other one (the logged trial is
    kept as logged, not run again), writes the whole report and drops the log; a log of another config is
    refused in one line before anything runs."""
    out = tmp_path / "eval"
    command = [*TINY, "evaluate.policies=[nearest]", "evaluate.workers=1", f"out={out}"]
    assert run_eval(*command, cwd=tmp_path).returncode == 0
    first = {run["trial"]: run for run in comparison.read_trials(out / "trials.jsonl")}
    marked = {**first[0], "ms_decide": -1.0}  # what only the logged record holds
    (out / "trials.jsonl").unlink()
    comparison.log_trial(out / comparison.PARTIAL, marked)

    proc = run_eval(*command, "evaluate.workers=2", "evaluate.progress_bar=true", cwd=tmp_path)  # run-only keys
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert "resuming: 1 of 2 trials were finished before" in proc.stdout + proc.stderr
    again = {run["trial"]: run for run in comparison.read_trials(out / "trials.jsonl")}
    assert again[0] == marked and again[1]["ms_decide"] > 0
    assert again[1]["rows"] and again[1]["travel_m"] == pytest.approx(first[1]["travel_m"], rel=1e-9)
    assert not (out / comparison.PARTIAL).exists()

    comparison.log_trial(out / comparison.PARTIAL, marked)
    proc = run_eval(*[c for c in command if not c.startswith("explore.max_decisions")], "explore.max_decisions=3",
                    cwd=tmp_path)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "finished trials of another config" in lines[0] and f"out={out}" in lines[0]
    assert (out / comparison.PARTIAL).exists()  # nothing ran, nothing was removed


def test_first_trial_gives_more_trials_of_the_same_study_where_another_seed_would_change_the_scene():
    config = load_config(["scene=street"])
    ten = comparison.make_trials(config, ["em", "nearest"], 10)
    more = comparison.make_trials(config, ["em", "nearest"], 3, first=8)
    assert [(t.policy, t.trial) for t in more] == [(p, t) for t in (8, 9, 10) for p in ("em", "nearest")]
    assert more[0].config == ten[16].config and more[3].config == ten[19].config  # trials 8 and 9 as in the study
    assert [t.config.seed for t in more[::2]] == [8, 9, 10] and {t.config.scene.seed for t in more} == {0}
    # the trap first_trial avoids: seed=8 seeds the trials 8, 9, ... but also draws the scene from seed 8
    shifted = comparison.make_trials(load_config(["scene=street", "seed=8"]), ["em"], 1)[0].config
    assert shifted.seed == 8 and shifted.scene.seed == 8 != more[0].config.scene.seed
    with pytest.raises(ValueError, match="evaluate.first_trial must be >= 0"):
        load_config(["evaluate.first_trial=-1"])
