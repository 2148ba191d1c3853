"""Smoke test of benchmarks/study_data.py: a tiny real dataset collected, actors trained offline
for two sizes and both feature sets, each evaluated under the protocol; CSV, PNG, JSON."""

from __future__ import annotations

import csv
import json

from explore_rl.models.actor_file import read_actor_file
from tests.benchmarks.smoke import run_script


def test_study_data_smoke(tmp_path):
    result = run_script("benchmarks/study_data.py", "--smoke", "--out", str(tmp_path / "out"), cwd=tmp_path,
                        timeout=400)
    total = result["decisions"]  # two 3-decision episodes (fewer if one ended or EM failed)
    assert result["smoke"] is True and 2 <= total <= 6 and result["trainable"] + result["held_out"] == total
    sizes = [s for s in (2, 4) if s <= result["trainable"]] or [result["trainable"]]
    assert [(r["features"], r["decisions"]) for r in result["rows"]] == [
        (features, size) for features in ("paper", "extended") for size in sizes]
    for row in result["rows"]:
        assert row["steps"] == 2 and row["train_s"] >= 0 and "gap_closed" in row and "offline_gap_holdout" in row
    out = tmp_path / "out"
    with open(out / "data_curve.csv") as handle:
        assert len(list(csv.DictReader(handle))) == 2 * len(sizes)
    assert (out / "data_curve.png").is_file() and json.loads((out / "summary.json").read_text())["decisions"] == total
    policies = {json.loads(line)["policy"] for line in (out / "episodes.jsonl").read_text().splitlines()}
    assert policies == {"learned", "em", "random", "nearest"}
    # again on the same folder (the smoke dataset is resumed, not re-collected): offline figures only,
    # with a relative feature in the model; no protocol episode is played
    episodes = (out / "episodes.jsonl").read_text()
    again = run_script("benchmarks/study_data.py", "--smoke", "--offline-only", "--out", str(out),
                       "--set", "model.relative_features=[distance]", cwd=tmp_path, timeout=400)
    assert again["decisions"] == total and all(row["gap_closed"] is None for row in again["rows"])
    for row in again["rows"]:  # the saved actors carry the relative feature in their model config
        assert read_actor_file(row["actor"]).model.relative_features == ["distance"]
    assert (out / "episodes.jsonl").read_text() == episodes
