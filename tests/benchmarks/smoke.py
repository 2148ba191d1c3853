"""Run a benchmark or study script as a user would and read its JSON last line.

Shared by the smoke tests of ``benchmarks/`` and ``scripts/``: the script runs in a
subprocess with this interpreter, one BLAS/OpenMP thread (the suite runs ``-n 2`` on two
cores) and the working directory ``cwd`` (a tmp dir, so nothing lands in the checkout).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))
from common import module_at  # noqa: E402


def load_script(script: str):
    """Import ``ROOT/script`` as a module (its functions, without running its main), under a name of its own."""
    path = ROOT / script
    return module_at(path, "script_" + "_".join(path.relative_to(ROOT).with_suffix("").parts[-2:]))  # several probe.py


def json_lines(text: str) -> list[dict]:
    """The JSON lines of a script's output, in order. Other lines are left out: torchrl logs the first
    storage it builds in a process to stdout, so whether that line shows depends on what ran before."""
    return [json.loads(line) for line in text.splitlines() if line.startswith("{")]


def run_main(script: str, args: list[str], capsys) -> tuple[int, str, str]:
    """``ROOT/script``'s ``main(args)`` in this process (no interpreter start and imports per call, for the
    small research scripts): its exit code, stdout and stderr as a user would see them (``sys.exit("message")``:
    code 1 and the message on stderr)."""
    code, message = 0, ""
    try:
        load_script(script).main(list(args))
    except SystemExit as exit_:
        if isinstance(exit_.code, str):
            code, message = 1, exit_.code + "\n"
        else:
            code = int(exit_.code or 0)
    out, err = capsys.readouterr()
    return code, out, err + message


def script_runner(script: str, capsys):
    """``call(*args)``: :func:`run_main` of ``script`` as ``SimpleNamespace(returncode, stdout, stderr)``,
    the shape of a finished subprocess, for a test fixture."""
    from types import SimpleNamespace

    def call(*args: str) -> SimpleNamespace:
        code, out, err = run_main(script, list(args), capsys)
        return SimpleNamespace(returncode=code, stdout=out, stderr=err)

    return call


def run_script(script: str, *args: str, cwd: Path, timeout: float = 120.0) -> dict:
    """Run ``ROOT/script args``; fail unless it exits 0 with a JSON object as its last
    stdout line, and return that object."""
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "MPLBACKEND": "Agg", "PYTHONUNBUFFERED": "1"}
    command = [sys.executable, str(ROOT / script), *args]
    proc = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    shown = f"$ {' '.join(command)}\n--- stdout (tail) ---\n{proc.stdout[-2000:]}\n--- stderr (tail) ---\n" \
            f"{proc.stderr[-4000:]}"
    if proc.returncode != 0:
        pytest.fail(f"{script} exited with {proc.returncode}\n{shown}", pytrace=False)
    lines = proc.stdout.strip().splitlines()
    try:
        result = json.loads(lines[-1]) if lines else None
    except json.JSONDecodeError as error:
        pytest.fail(f"{script}: the last stdout line is not JSON ({error})\n{shown}", pytrace=False)
    if not isinstance(result, dict):
        pytest.fail(f"{script}: the last stdout line is not a JSON object\n{shown}", pytrace=False)
    return result
