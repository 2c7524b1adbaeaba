"""``molmo_spaces.tasks.task_sampler_errors``."""

from ..errors import HouseInvalidForTask, RobotPlacementError

__all__ = ["HouseInvalidForTask", "RobotPlacementError"]
