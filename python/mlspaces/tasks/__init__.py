"""Task samplers (``molmo_spaces.tasks``)."""

from ..errors import HouseInvalidForTask, RobotPlacementError
from .opening_task_samplers import OpenTaskSampler
from .pick_task_sampler import BaseMujocoTaskSampler, PickTaskSampler

__all__ = ["BaseMujocoTaskSampler", "HouseInvalidForTask", "OpenTaskSampler", "PickTaskSampler",
           "RobotPlacementError"]
