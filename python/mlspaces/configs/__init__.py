"""Datagen configs (``molmo_spaces.configs``): pydantic models with MolmoSpaces' names,
fields and defaults (the defaults are the engine's own)."""

from .base_pick_config import MlSpacesExpConfig, PickBaseConfig, to_native
from .camera_configs import (CameraConfig, CameraSystemConfig, FrankaDroidCameraSystem,
                             RobotCameraSystem)
from .policy_configs import PickPlannerPolicyConfig
from .robot_configs import BaseRobotConfig, FrankaRobotConfig
from .task_configs import PickTaskConfig
from .task_sampler_configs import PickTaskSamplerConfig

__all__ = ["BaseRobotConfig", "CameraConfig", "CameraSystemConfig", "FrankaDroidCameraSystem",
           "FrankaRobotConfig", "MlSpacesExpConfig", "PickBaseConfig", "PickPlannerPolicyConfig",
           "PickTaskConfig", "PickTaskSamplerConfig", "RobotCameraSystem", "to_native"]
