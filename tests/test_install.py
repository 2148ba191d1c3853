"""A plain (non-editable) install works: conf/ and policies/ ship in the wheel, and the
console scripts run from any folder (issue 20 item 2).

The slow test builds the wheel from a copy of the sources, installs it with ``--no-deps``
into a fresh venv whose dependencies come from this project's .venv (a ``.pth`` file adds
its site-packages *after* the venv's own, so the wheel's explore_rl is the one imported;
``.pth`` files inside that folder, e.g. the editable install's finder, are not run), and
runs ``explore-rl-view`` and a 2-decision ``explore-rl-eval`` of the shipped policy in an
unrelated temporary folder.
"""

from __future__ import annotations

import shutil
import site
import subprocess
import sys
from pathlib import Path

import pytest

from explore_rl import resources

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser, as pip vendors it
    from pip._vendor import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]


def test_pyproject_lists_every_package_and_maps_the_shipped_data():
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = {".".join(p.relative_to(ROOT).parts[:-1]) for p in (ROOT / "explore_rl").rglob("__init__.py")}
    assert set(setuptools["packages"]) == packages | {"explore_rl.conf", "explore_rl.policies"}
    assert setuptools["package-dir"] == {"explore_rl.conf": "conf", "explore_rl.policies": "policies"}
    assert (ROOT / "conf" / "config.yaml").is_file() and (ROOT / "policies" / "buildings_dagger_em_choice" / "actor.pt").is_file()


def test_shipped_data_is_found_inside_the_package_first_then_beside_it(tmp_path, monkeypatch):
    assert resources.conf_dir() == ROOT / "conf"  # the source tree (editable install)
    package = tmp_path / "site-packages" / "explore_rl"
    (package / "conf").mkdir(parents=True)
    (package / "policies" / "buildings_distill").mkdir(parents=True)
    monkeypatch.setattr(resources, "PACKAGE_DIR", package)
    assert resources.conf_dir() == package / "conf"  # a wheel: its package data
    assert resources.shipped_file("policies/buildings_distill/actor.pt") == package / "policies" / "buildings_distill" / "actor.pt"
    shutil.rmtree(package / "conf")
    with pytest.raises(FileNotFoundError, match="conf/ folder is missing"):
        resources.conf_dir()


def run(command: list[str], cwd: Path) -> subprocess.CompletedProcess:
    result = subprocess.run(command, capture_output=True, text=True, cwd=cwd)
    assert result.returncode == 0, f"{command}\n{result.stdout}\n{result.stderr}"
    return result


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """A fresh venv with the wheel installed (--no-deps); returns its bin/ folder."""
    base = tmp_path_factory.mktemp("install")
    source = base / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in ("explore_rl", "conf", "policies"):
        shutil.copytree(ROOT / name, source / name, ignore=ignore)
    run([sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "--no-build-isolation",
         "-w", str(base / "wheel"), "-q"], cwd=base)
    (wheel,) = (base / "wheel").glob("explore_rl-*.whl")
    venv = base / "venv"
    run([sys.executable, "-m", "venv", "--without-pip", str(venv)], cwd=base)
    (site_packages,) = (venv / "lib").glob("python*/site-packages")
    (site_packages / "explore_rl_dependencies.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install", "--no-deps",
         "--no-index", str(wheel), "-q"], cwd=base)
    return venv / "bin"


@pytest.mark.slow
def test_the_wheel_runs_view_and_a_learned_evaluation_from_an_unrelated_folder(installed, tmp_path):
    where = run([str(installed / "python"), "-c",
                 "import explore_rl.config as c; from explore_rl.models.actor_file import resolve; "
                 "print(c.__file__); print(c.CONF_DIR); print(resolve(None))"], cwd=tmp_path).stdout.split()
    venv = installed.parent.resolve()
    assert all(Path(p).resolve().is_relative_to(venv) for p in where), where  # the wheel's code, conf, policy
    assert not any(str(ROOT) in p for p in where)

    run([str(installed / "explore-rl-view"), "out=view.png"], cwd=tmp_path)
    assert (tmp_path / "view.png").stat().st_size > 10_000

    run([str(installed / "explore-rl-eval"), "evaluate.policies=[learned]", "evaluate.trials=1",
         "evaluate.workers=1", "evaluate.progress_bar=false", "explore.max_decisions=2", "slam=model",
         "out=eval"], cwd=tmp_path)
    rows = (tmp_path / "eval" / "decisions.csv").read_text().splitlines()
    assert len(rows) == 3 and ",learned," in rows[1]  # header + 2 decisions of the shipped policy


@pytest.mark.slow
def test_the_wheel_keeps_config_path_and_checkpoint_overrides(installed, tmp_path):
    conf = tmp_path / "myconf"
    shutil.copytree(ROOT / "conf", conf)
    robot = conf / "robot" / "jackal.yaml"
    robot.write_text(robot.read_text().replace("radius: 0.3", "radius: 0.31"))
    printed = run([str(installed / "explore-rl-view"), "--config-path", str(conf), "--cfg", "job"], cwd=tmp_path)
    assert "radius: 0.31" in printed.stdout
    missing = subprocess.run([str(installed / "explore-rl-eval"), "evaluate.policies=[learned]",
                              "policy.checkpoint=elsewhere/actor.pt", "out=eval"],
                             capture_output=True, text=True, cwd=tmp_path)
    assert missing.returncode == 2 and "error: elsewhere/actor.pt: no checkpoint there" in missing.stderr
