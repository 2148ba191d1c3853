"""benchmarks/collect_decisions.py: which tasks a resumed collection skips (per scene)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "collect_decisions.py"


def load_script():
    spec = importlib.util.spec_from_file_location("collect_decisions", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_each_scene_has_its_own_tasks_and_old_rows_count_as_office():
    tasks_done_for = load_script().tasks_done_for
    rows = [{"task": 0, "layout": 3}, {"task": 1, "layout": 4, "scene": "office"},
            {"task": 0, "layout": 7, "scene": "building"}, {"session_s": 10.0}]
    assert tasks_done_for(rows, "office") == {0, 1}
    assert tasks_done_for(rows, "building") == {0}
    assert tasks_done_for(rows, "street") == set()
