"""benchmarks/collect_decisions.py: which tasks a resumed collection skips (per scene)."""

from __future__ import annotations

from tests.benchmarks.smoke import load_script


def test_each_scene_has_its_own_tasks_and_old_rows_count_as_office():
    tasks_done_for = load_script("benchmarks/collect_decisions.py").tasks_done_for
    rows = [{"task": 0, "layout": 3}, {"task": 1, "layout": 4, "scene": "office"},
            {"task": 0, "layout": 7, "scene": "building"}, {"session_s": 10.0}]
    assert tasks_done_for(rows, "office") == {0, 1}
    assert tasks_done_for(rows, "building") == {0}
    assert tasks_done_for(rows, "street") == set()
