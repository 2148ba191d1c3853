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
