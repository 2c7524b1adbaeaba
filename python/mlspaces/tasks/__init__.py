"""Task samplers (``molmo_spaces.tasks``)."""

from ..errors import HouseInvalidForTask, RobotPlacementError
from .pick_task_sampler import BaseMujocoTaskSampler, PickTaskSampler

__all__ = ["BaseMujocoTaskSampler", "HouseInvalidForTask", "PickTaskSampler",
           "RobotPlacementError"]
