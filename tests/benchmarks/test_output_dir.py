"""benchmarks/common.py: output_dir keeps --quick and --smoke runs out of the committed results."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

from common import output_dir  # noqa: E402


def test_a_trial_run_writes_to_a_new_temporary_folder_unless_told(tmp_path):
    committed = ROOT / "benchmarks" / "results" / "safety"
    first, second = output_dir(None, committed, True, "safety"), output_dir(None, committed, True, "safety")
    assert first != second and first.is_dir() and committed not in first.parents and first != committed
    assert output_dir(None, committed, False, "safety") == committed
    assert output_dir(tmp_path / "mine", committed, True, "safety") == tmp_path / "mine"
