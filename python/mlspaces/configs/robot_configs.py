"""``FrankaRobotConfig`` (``molmo_spaces.configs.robot_configs``)."""

from __future__ import annotations

from typing import Any

from ._base import default
from ._fields import engine_model

FrankaRobotConfig = engine_model(
    "FrankaRobotConfig", __name__, ("robot_config",),
    "The Franka DROID robot: base_size (pedestal x, y, z in metres; None = on the floor), "
    "robot_namespace, init_qpos, init_qpos_noise_range, command_mode, gravcomp, ...",
    base_size=(Any, default("robot_config", "base_size")),
    robot_xml_path=(Any, None),
)

__all__ = ["FrankaRobotConfig"]
