"""study_fidelity.py: the pooled model / icp ratios against values worked out here (closures counted +1, a zero
error left out and counted); bad arguments are refused in one line before any run."""

from __future__ import annotations

import math
import sys

import pytest

from tests.benchmarks.smoke import load_script

SCRIPT = "benchmarks/study_fidelity.py"


def row(icp: dict, model: dict) -> dict:
    """A building's figures: icp's, and two model variants (the second one twice the first's)."""
    return {"icp": icp, "models": [model, {key: 2.0 * value for key, value in model.items()}]}


def test_pooled_ratios_are_geometric_means_over_buildings() -> None:
    study = load_script(SCRIPT)
    rows = [row({"ate_m": 0.1, "map_error_m": 0.05, "loop_closures": 0, "keyframes": 100},
                {"ate_m": 0.2, "map_error_m": 0.05, "loop_closures": 3.0, "keyframes": 100.0}),
            row({"ate_m": 0.2, "map_error_m": 0.0, "loop_closures": 9, "keyframes": 200},
                {"ate_m": 0.2, "map_error_m": 0.02, "loop_closures": 4.0, "keyframes": 200.0}),
            row({"ate_m": 0.1, "map_error_m": 0.04, "loop_closures": 1, "keyframes": 50},
                {"ate_m": 0.05, "map_error_m": 0.08, "loop_closures": 1.0, "keyframes": 50.0})]
    pooled = study.pooled_ratios(rows)
    assert math.isclose(pooled["ate_m"]["model_over_icp"], round((2.0 * 1.0 * 0.5) ** (1 / 3), 3))
    low, high = pooled["ate_m"]["ci95"]
    assert low < pooled["ate_m"]["model_over_icp"] < high and pooled["ate_m"]["buildings"] == 3
    # the second building's icp map error is 0: left out, counted
    assert pooled["map_error_m"]["buildings"] == 2
    assert math.isclose(pooled["map_error_m"]["model_over_icp"], round(math.sqrt(1.0 * 2.0), 3))
    # closures +1: 4/1, 5/10, 2/2
    assert math.isclose(pooled["loop_closures"]["model_over_icp"], round((4.0 * 0.5 * 1.0) ** (1 / 3), 3))
    assert pooled["keyframes"] == {"model_over_icp": 1.0, "ci95": [1.0, 1.0], "buildings": 3}
    second = study.pooled_ratios(rows, 1)
    assert math.isclose(second["ate_m"]["model_over_icp"], round(2.0 * (2.0 * 1.0 * 0.5) ** (1 / 3), 3))
    assert second["keyframes"]["model_over_icp"] == 2.0


@pytest.mark.parametrize(("args", "message"), [(["--decisions", "0"], "--decisions 0: give at least 1"),
                                               (["--seeds", "x"], "x"),
                                               (["--model-set", "slam.nope=1"], "nope"),
                                               (["--model-set", "--model-set", "slam.nope=1"], "nope")])
def test_bad_arguments_are_refused_before_any_run(monkeypatch, capsys, args, message) -> None:
    study = load_script(SCRIPT)
    monkeypatch.setattr(sys, "argv", [SCRIPT, *args])
    monkeypatch.setattr(study, "spawned_results", lambda *a, **k: pytest.fail("a run started"))
    with pytest.raises(SystemExit) as exit_:
        study.main()
    assert message in str(exit_.value.code) + capsys.readouterr().err
