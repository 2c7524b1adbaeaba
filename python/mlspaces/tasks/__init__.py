"""Task samplers (``molmo_spaces.tasks``)."""

from ..errors import HouseInvalidForTask, RobotPlacementError
from .opening_task_samplers import OpenTaskSampler
from .pick_and_place_task_sampler import (PickAndPlaceColorTaskSampler,
                                          PickAndPlaceNextToTaskSampler,
                                          PickAndPlaceReceptacleTaskSampler,
                                          PickAndPlaceTaskSampler)
from .pick_task_sampler import BaseMujocoTaskSampler, PickTaskSampler

__all__ = ["BaseMujocoTaskSampler", "HouseInvalidForTask", "OpenTaskSampler",
           "PickAndPlaceColorTaskSampler", "PickAndPlaceNextToTaskSampler",
           "PickAndPlaceReceptacleTaskSampler", "PickAndPlaceTaskSampler", "PickTaskSampler",
           "RobotPlacementError"]
