"""frontend_shift/shift.py: the paired ratio of two front ends' per-building ratios, against values worked out
here; pooled rows and unpaired buildings are left out; a missing file and too few buildings are refused."""

from __future__ import annotations

import json
import math

from tests.benchmarks.smoke import run_main

SCRIPT = "benchmarks/results/frontend_shift/shift.py"


def targets(path, report: str, ratios: dict[int, float]):
    """A targets.json with one entry per building (every ratio the same value) and a pooled row."""
    entry = {key: 0.0 for key in ("error_ratio", "equal_travel_error_ratio", "travel_ratio", "closures_ratio")}
    entries = [{"scene": f"{report}/building_{seed}", "scenes": 1, **{k: r for k in entry}}
               for seed, r in ratios.items()]
    entries.append({"scene": "all scenes", "scenes": len(ratios), **{k: 99.0 for k in entry}})
    path.write_text(json.dumps({"targets": {}, "entries": entries}))
    return str(path)


def test_shift_is_the_geometric_mean_of_the_paired_ratios(tmp_path, capsys):
    a = targets(tmp_path / "a.json", "icp", {1010: 1.0, 1011: 2.0, 1012: 1.5, 1013: 1.0})
    b = targets(tmp_path / "b.json", "model", {1010: 2.0, 1011: 1.0, 1012: 1.5, 1099: 5.0})
    code, out, _ = run_main(SCRIPT, [a, b, "--resamples", "2000"], capsys)
    result = json.loads(out.strip().splitlines()[-1])
    # paired: 1010 x2, 1011 x0.5, 1012 x1 -> geometric mean 1; 1013 and 1099 unpaired, the pooled row ignored
    assert code == 0 and result["buildings"] == 3
    assert math.isclose(result["error_ratio_b_over_a"], 1.0, abs_tol=1e-4)
    low, high = result["error_ratio_b_over_a_ci95"]
    assert low < 1.0 < high and low >= 0.5 - 1e-9 and high <= 2.0 + 1e-9
    b2 = targets(tmp_path / "b2.json", "model", {1010: 0.5, 1011: 1.0, 1012: 0.75})
    code, out, _ = run_main(SCRIPT, [a, b2, "--resamples", "2000"], capsys)
    result = json.loads(out.strip().splitlines()[-1])
    assert math.isclose(result["travel_ratio_b_over_a"], 0.5, abs_tol=1e-4)
    assert result["travel_ratio_b_over_a_ci95"] == [0.5, 0.5]  # every building halves


def test_shift_refuses_a_missing_file_and_too_few_buildings(tmp_path, capsys):
    a = targets(tmp_path / "a.json", "icp", {1010: 1.0, 1011: 2.0})
    code, _, err = run_main(SCRIPT, [a, str(tmp_path / "nope.json")], capsys)
    assert code == 1 and "nope.json: no such targets.json" in err
    b = targets(tmp_path / "b.json", "model", {1010: 1.0, 1012: 2.0})
    code, _, err = run_main(SCRIPT, [a, b], capsys)
    assert code == 1 and "1 building(s) in both files" in err
