"""``molmo_spaces.tasks.task_sampler``."""

from .pick_task_sampler import BaseMujocoTaskSampler

__all__ = ["BaseMujocoTaskSampler"]
