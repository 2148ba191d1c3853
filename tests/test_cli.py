"""Console scripts as a user runs them, and config validation."""

import subprocess
import sys
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.errors import ConfigCompositionException
from omegaconf import OmegaConf

from explore_rl.cli import CONF_DIR
from explore_rl.config import validate

ROOT = Path(__file__).resolve().parents[1]
VIEW = [sys.executable, "-c", "from explore_rl.cli import view; view()"]


def compose_config(*overrides):
    with initialize_config_dir(CONF_DIR, version_base="1.3"):
        return OmegaConf.to_object(compose("config", overrides=list(overrides)))


@pytest.mark.parametrize("group,options", [
    ("scene", ["office", "street", "garage"]),
    ("policy", ["nearest", "random", "em"]),
])
def test_every_group_option_composes_and_validates(group, options):
    for option in options:
        config = compose_config(f"{group}={option}")
        validate(config)
        assert getattr(config, group).name == option


def test_unknown_key_fails_at_composition():
    with pytest.raises(ConfigCompositionException):
        compose_config("scene.bogus=1")


@pytest.mark.parametrize("override,message", [
    ("robot.radius=-1", "robot.radius must be positive"),
    ("slam.frontend=lidar", "slam.frontend='lidar'"),
    ("explore.target_explored=1.5", "explore.target_explored"),
    ("mapping.paths.clearance_weight=-2", "mapping.paths.clearance_weight must be >= 0"),
    ("tour.clearance_scale=0", "tour.clearance_scale must be positive"),
])
def test_validate_names_the_key(override, message):
    with pytest.raises(ValueError, match=message):
        validate(compose_config(override))


def test_view_draws_a_scene_file(tmp_path):
    out = tmp_path / "lab.png"
    result = subprocess.run(VIEW + ["scene=file", f"scene.path={ROOT / 'examples/scenes/lab.yaml'}", f"out={out}"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert out.stat().st_size > 10_000


def test_view_rejects_a_bad_scene_file_in_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nname: x\nsize: [5.0, 5.0]\nwalls:\n  - {from: [1.0, 1.0], to: [3.0, 1.0], thickness: -0.1}\n"
                   "starts:\n  - [2.5, 2.5, 0.0]\n")
    result = subprocess.run(VIEW + ["scene=file", f"scene.path={bad}", f"out={tmp_path / 'x.png'}"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 2
    assert "bad.yaml" in result.stderr and "walls[0].thickness" in result.stderr
    assert "Traceback" not in result.stderr


def test_explore_writes_csv_figure_and_animation(tmp_path):
    scene = tmp_path / "closet.yaml"
    scene.write_text("version: 1\nname: closet\nsize: [6.0, 3.0]\n"
                     "walls:\n  - {from: [3.0, 0.0], to: [3.0, 1.8]}\nstarts:\n  - [1.0, 1.0, 0.0]\n")
    explore = [sys.executable, "-c", "from explore_rl.cli import explore; explore()"]
    result = subprocess.run(explore + ["scene=file", f"scene.path={scene}", f"out={tmp_path}",
                                       "explore.animation=true", "explore.max_decisions=3"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    stem = "closet_nearest_seed0"
    rows = (tmp_path / f"{stem}.csv").read_text().splitlines()
    assert rows[0].startswith("decision,travel_m,explored") and len(rows) >= 2
    assert (tmp_path / f"{stem}.png").stat().st_size > 10_000
    assert (tmp_path / f"{stem}.gif").stat().st_size > 10_000


def test_load_config_composes_validates_and_names_bad_values():
    from explore_rl.config import load_config

    config = load_config(["scene=street", "slam=model", "seed=3"])
    assert (config.scene.name, config.slam.frontend, config.seed) == ("street", "model", 3)
    with pytest.raises(ValueError, match="lidar.tile_size"):
        load_config(["lidar.tile_size=-1"])


# ---------------------------------------------------------------- issue 20 items 4 and 5

CLOSET = ("version: 1\nname: closet\nsize: [6.0, 3.0]\n"
          "walls:\n  - {from: [3.0, 0.0], to: [3.0, 1.8]}\nstarts:\n  - [1.0, 1.0, 0.0]\n")


def command(name: str, *args: str, cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    """Run the console command ``name`` (a function of explore_rl.cli) as a user would."""
    return subprocess.run([sys.executable, "-c", f"from explore_rl.cli import {name}; {name}()", *args],
                          capture_output=True, text=True, cwd=cwd, env=env)


def error_line(result: subprocess.CompletedProcess) -> str:
    """The one ``error:`` line of a failed command (and no traceback)."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = [line for line in result.stderr.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, result.stderr
    return lines[0]


@pytest.mark.parametrize("name,override,message", [
    ("tour", "robot.waypoint_tolerance=0", "robot.waypoint_tolerance must be positive"),
    ("explore", "robot.step_angle_deg=0", "robot.step_angle_deg must be in"),
    ("view", "seed=-1", "seed must be >= 0"),
    ("compare", "compare.policies=[nearest,bogus]", "compare.policies=['nearest', 'bogus']"),
    ("evaluate", "lidar.range_noise=-1", "lidar.range_noise must be >= 0"),
    ("train", "mapping.frontiers.neighbourhood=6", "mapping.frontiers.neighbourhood=6"),
])
def test_every_command_rejects_a_bad_value_in_one_line_before_running(name, override, message, tmp_path):
    out = tmp_path / "out"
    assert message in error_line(command(name, override, f"out={out}", cwd=tmp_path))
    assert not out.exists()


@pytest.mark.parametrize("name", ["evaluate", "train"])
def test_a_missing_scene_file_fails_in_one_line_before_any_trial_or_worker(name, tmp_path):
    """Trials and collector workers each build their scene: without a check up front every one of them failed on
    its own (explore-rl-eval wrote a report of 40 failed trials)."""
    out = tmp_path / "out"
    line = error_line(command(name, "scene=file", f"scene.path={tmp_path / 'nope.yaml'}", f"out={out}", cwd=tmp_path))
    assert "nope.yaml: file not found" in line
    assert not out.exists()


def test_a_value_error_raised_inside_a_run_reaches_the_user_as_one_line(tmp_path):
    """Not from validation: raised while exploring (here by a patched Explorer.run)."""
    script = ("import explore_rl.runner as runner\n"
              "def run(self, *args, **kwargs):\n"
              "    raise ValueError('frontier 3 has no path\\nsecond line')\n"
              "runner.Explorer.run = run\n"
              "from explore_rl.cli import explore; explore()\n")
    (tmp_path / "closet.yaml").write_text(CLOSET)
    result = subprocess.run([sys.executable, "-c", script, "scene=file", "scene.path=closet.yaml", f"out={tmp_path}"],
                            capture_output=True, text=True, cwd=tmp_path)
    assert error_line(result) == "error: frontier 3 has no path"


def test_compare_without_any_decision_reports_it_instead_of_crashing(tmp_path):
    """The first scan already covers the target (explore.target_explored tiny): no records."""
    (tmp_path / "closet.yaml").write_text(CLOSET)
    result = command("compare", "scene=file", "scene.path=closet.yaml", "explore.target_explored=0.001",
                     "compare.policies=[nearest]", f"out={tmp_path / 'out'}", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "nearest  explored" in result.stdout and "no decisions" in result.stdout
    assert (tmp_path / "out" / "file_comparison.png").exists()


@pytest.mark.parametrize("override,module,install", [
    ("collector=ray", "ray", 'pip install "explore_rl[ray]"'),
    ("logger=tensorboard", "tensorboard", "pip install tensorboard"),
])
def test_train_names_a_missing_optional_dependency_with_its_install_command_first(override, module, install,
                                                                                   tmp_path):
    """The package is made invisible (installed or not) the way the check and TorchRL look for it."""
    script = ("import importlib.util\n"
              "real = importlib.util.find_spec\n"
              f"importlib.util.find_spec = lambda name, *a: None if name.split('.')[0] == {module!r} else real(name, *a)\n"
              "from explore_rl.cli import train; train()\n")
    out = tmp_path / "run"
    result = subprocess.run([sys.executable, "-c", script, override, f"out={out}"], capture_output=True, text=True,
                            cwd=tmp_path)
    line = error_line(result)
    assert f"needs the package '{module}', which is not installed: {install}" in line
    assert not out.exists()


def test_train_refuses_a_non_empty_folder_that_is_not_a_run(tmp_path):
    out = tmp_path / "notes"
    out.mkdir()
    (out / "config.yaml").write_text("mine: true\n")
    line = error_line(command("train", f"out={out}", cwd=tmp_path))
    assert line == f"error: out={out} is not empty and holds no training run: choose a new or empty folder " \
                   "(nothing was written)"
    assert (out / "config.yaml").read_text() == "mine: true\n" and sorted(p.name for p in out.iterdir()) == [
        "config.yaml"]


def test_a_failed_resume_writes_nothing(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    line = error_line(command("train", f"out={out}", "resume=true", cwd=tmp_path))
    assert "checkpoints/last.pt: no checkpoint there" in line
    assert list(out.iterdir()) == []  # no config_resumed.yaml
