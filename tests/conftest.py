"""Shared fixtures: small configs and built scenes (built once per test session)."""

from __future__ import annotations

import numpy as np
import pytest

from explore_rl.robot import RobotConfig
from explore_rl.scene.build import Scene, make_scene
from explore_rl.scene.config import SceneConfig
from explore_rl.sensors.lidar import LidarConfig

SCENE_CONFIGS = {
    "office": SceneConfig(name="office", size=[20.0, 20.0], num_objects=8),
    "street": SceneConfig(name="street", size=[20.0, 20.0], num_objects=5),
    "garage": SceneConfig(name="garage", size=[30.0, 30.0], num_objects=15),
}


def scene_config(kind: str, **overrides) -> SceneConfig:
    base = SCENE_CONFIGS[kind]
    return SceneConfig(**{**base.__dict__, **overrides})


@pytest.fixture(scope="session", params=sorted(SCENE_CONFIGS))
def any_scene(request) -> Scene:
    return make_scene(scene_config(request.param), RobotConfig(), LidarConfig())


@pytest.fixture(scope="session")
def office() -> Scene:
    return make_scene(scene_config("office"), RobotConfig(), LidarConfig())


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)
