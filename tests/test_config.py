"""Config validation (explore_rl/config.py:validate and the groups' validate()): every bad
value of issue 20 item 4 fails before anything runs, in one line naming the key and the
allowed range; the shipped conf/ files repeat the dataclass defaults."""

import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import pytest
import yaml

from explore_rl.config import load_config
from explore_rl.robot import RobotConfig
from explore_rl.sensors.lidar import LidarConfig
from explore_rl.tour import TourConfig

CONF = Path(__file__).resolve().parents[1] / "conf"


@pytest.mark.parametrize("override,message", [
    ("mapping.frontiers.neighbourhood=6", "mapping.frontiers.neighbourhood=6: choose one of 4, 8"),
    ("planning.virtual_map.cell_size=0", "planning.virtual_map.cell_size must be positive"),
    ("planning.virtual_map.cell_size=-1", "planning.virtual_map.cell_size must be positive"),
    ("planning.virtual_map.cell_size=0.25", "cell_size=0.25 must be a whole multiple .* of scene.grid_resolution=0.1"),
    ("planning.virtual_map.cell_size=0.05", "cell_size=0.05 must be a whole multiple"),
    ("robot.noise_xy=-0.01", r"robot.noise_xy must be >= 0 \(finite\), got -0.01"),
    ("robot.noise_xy=nan", "robot.noise_xy must be >= 0"),
    ("robot.noise_yaw_deg=-1", "robot.noise_yaw_deg must be >= 0"),
    ("robot.heading_tolerance_deg=0", r"robot.heading_tolerance_deg must be in \(0, 180\]"),
    ("robot.heading_tolerance_deg=270", r"robot.heading_tolerance_deg must be in \(0, 180\]"),
    ("robot.turn_rate_deg=0", "robot.turn_rate_deg must be positive"),
    ("robot.step_angle_deg=0", r"robot.step_angle_deg must be in \[0.1, 180\]"),
    ("robot.waypoint_tolerance=0", "robot.waypoint_tolerance must be positive"),
    ("robot.waypoint_tolerance=-0.1", "robot.waypoint_tolerance must be positive"),
    ("robot.safety.headings=2", "robot.safety.headings=2"),
    ("slam.keyframe_distance=0", "slam.keyframe_distance must be positive"),
    ("slam.keyframe_distance=-1", "slam.keyframe_distance must be positive"),
    ("slam.keyframe_distance=nan", "slam.keyframe_distance must be positive"),
    ("slam.keyframe_angle_deg=0", r"slam.keyframe_angle_deg must be in \(0, 180\]"),
    ("planning.reward.alpha=nan", "planning.reward.alpha must be >= 0"),
    ("planning.reward.alpha=-1", "planning.reward.alpha must be >= 0"),
    ("mapping.occupancy.max_range=0", "mapping.occupancy.max_range must be positive"),
    ("lidar.min_range=3", r"lidar.min_range must be in \[0, 3\), got 3"),
    ("lidar.min_range=5", r"lidar.min_range must be in \[0, 3\)"),
    ("lidar.min_elevation_deg=20", "lidar.min_elevation_deg=20.0 must not exceed lidar.max_elevation_deg=15.0"),
    ("lidar.max_elevation_deg=120", r"lidar.max_elevation_deg must be in \[-90, 90\]"),
    ("lidar.range_noise=-0.01", "lidar.range_noise must be >= 0"),
    ("lidar.azimuth_resolution_deg=0", r"lidar.azimuth_resolution_deg must be in \(0, 360\]"),
    ("lidar.azimuth_resolution_deg=400", r"lidar.azimuth_resolution_deg must be in \(0, 360\]"),
    ("lidar.channels=0", "lidar.channels must be >= 1"),
    ("lidar.tile_size=-1", "lidar.tile_size must be >= 0"),
    ("explore.travel_budget=0", "explore.travel_budget must be positive"),
    ("explore.travel_budget=-5", "explore.travel_budget must be positive"),
    ("explore.max_decisions=0", "explore.max_decisions must be >= 1"),
    ("scene.size=[5,5]", r"scene.size=\[5.0, 5.0\] is too small for scene=office: at least \[20, 20\]"),
    ("scene.size=[20,-1]", "scene.size must be two positive finite numbers"),
    ("seed=-1", "seed must be >= 0, got -1"),
    ("scene.seed=-3", "scene.seed must be >= 0"),
    ("compare.policies=[]", r"compare.policies=\[\]: give one or more of"),
    ("compare.policies=[nearest,bogus]", r"compare.policies=\['nearest', 'bogus'\]"),
    ("tour.goals=[[1.0,2.0,3.0]]", r"tour.goals\[0\] must be two finite numbers"),
])
def test_bad_value_fails_in_one_line_naming_the_key_and_the_range(override, message):
    with pytest.raises(ValueError, match=message) as error:
        load_config([override])
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("override,message", [
    ("scene.building.nope=1", r"Could not override 'scene.building.nope'.* use \+scene.building.nope=1"),
    ("scene=nowhere", "Could not find 'scene/nowhere'"),
])
def test_unknown_key_or_option_fails_in_one_line_naming_it(override, message):
    """What Hydra refuses to compose (scripts calling load_config catch ValueError for one line)."""
    with pytest.raises(ValueError, match=message) as error:
        load_config([override])
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("overrides", [
    [], ["scene=street"], ["scene=garage"], ["planning.virtual_map.cell_size=0.3"], ["explore.travel_budget=inf"],
    ["policy=em", "compare.policies=[em,learned,random]"], ["lidar.channels=1", "lidar.min_elevation_deg=0",
                                                             "lidar.max_elevation_deg=0"],
])
def test_good_values_pass(overrides):
    load_config(overrides)


def test_garage_rows_must_fit_the_garage():
    with pytest.raises(ValueError, match=r"scene.car_rows_y=.* outside the garage's scene.size\[1\]=20"):
        load_config(["scene=garage", "scene.size=[30,20]"])


@pytest.mark.parametrize("path,config", [
    ("robot/jackal.yaml", RobotConfig()), ("lidar/vlp16.yaml", LidarConfig()),
])
def test_conf_files_repeat_the_dataclass_defaults(path, config):
    assert yaml.safe_load((CONF / path).read_text()) == asdict(config)


def test_tour_config_defaults_validate():
    TourConfig().validate()
    with pytest.raises(ValueError, match="tour.clearance_scale must be positive"):
        TourConfig(clearance_scale=0).validate()


def test_importing_the_config_loads_no_runtime_code():
    """A fresh process: ``import explore_rl.config`` pulls in none of the simulator, SLAM,
    scipy or torch, and only config modules of the package (no import circle through
    runtime modules)."""
    code = ("import sys, explore_rl.config\n"
            "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('mujoco', 'gtsam', 'kiss_icp', 'scipy', 'torch', 'torchrl'))))\n"
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('explore_rl'))))\n")
    heavy, ours = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                 check=True).stdout.split("\n")[:2]
    assert heavy == ""
    runtime = [m for m in ours.split() if m.rsplit(".", 1)[-1] not in (
        "explore_rl", "config", "checks", "resources", "robot_config", "run_config",
        "envs", "graph", "mapping", "models", "planning", "scene", "sensors", "slam", "trainer")]
    assert runtime == [], runtime


@pytest.mark.parametrize("module, higher", [
    ("explore_rl.graph.exploration_graph", ("explore_rl.planning", "explore_rl.models", "explore_rl.envs",
                                            "explore_rl.trainer")),
    ("explore_rl.models.actor_file", ("explore_rl.planning", "explore_rl.envs", "explore_rl.trainer")),
])
def test_lower_layers_import_no_higher_ones(module, higher):
    """A fresh process: the graph layer needs nothing from planning at run time, and actor
    files (models) nothing from the trainer (checkpoint I/O lives in explore_rl.models)."""
    code = f"import sys, {module}\nprint(' '.join(sorted(m for m in sys.modules if m.startswith({higher!r}))))\n"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert loaded == [], loaded
