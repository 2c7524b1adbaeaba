"""``PickTaskSampler`` (``molmo_spaces.tasks.pick_task_sampler``): subclass it and override
``_sample_and_place_robot(self, env)`` to place the robot and the object of each episode.

The engine runs the episode loop in C++ and calls the hook once per episode, after resetting
the scene and choosing ``task_config.pickup_obj_name``. Before the call it seeds Python's
``random``, ``np.random`` (and ``torch`` when imported) and ``self.rng`` (a
``numpy.random.Generator``) from the run seed and the episode, so a hook's draws are the same in
every run with that seed, whatever the worker. The hook must set
``self.config.task_config.robot_base_pose``, ``pickup_obj_start_pose`` and
``pickup_obj_goal_pose`` (7 floats: x, y, z, qw, qx, qy, qz, world frame); raising
``RobotPlacementError`` skips the episode (journaled as a sampler rejection).
"""

from __future__ import annotations

import random
import sys
from typing import Any

import numpy as np

from .. import _validate as _v
from ..env.env import CPUMujocoEnv


class BaseMujocoTaskSampler:
    """Holds the experiment config (``self.config``) and the env of the current scene
    (``self.env``, ``None`` until the engine loads a scene)."""

    def __init__(self, config: Any) -> None:
        if not hasattr(getattr(config, "task_config", None), "model_copy"):
            raise _v.type_error(type(self).__name__, "config",
                                "a datagen config (a PickBaseConfig)", config)
        self.config = config
        self._task_config_preset = config.task_config.model_copy(deep=True)
        self.env: CPUMujocoEnv | None = None
        self._engine_randomize = None
        self._engine_place = None
        seed = getattr(config, "seed", None)
        self.rng = np.random.default_rng(seed)
        if seed is not None:
            self.seed_task_sampling(seed)

    def seed_task_sampling(self, seed: int) -> None:
        """Seeds ``random``, ``np.random``, ``torch`` (when imported) and ``self.rng``."""
        # Any int, as random.seed takes it (np.random gets it mod 2**32).
        seed = _v.integer(seed, "seed", "seed_task_sampling", minimum=0, maximum=None)
        random.seed(seed)
        np.random.seed(seed % 2**32)
        torch = sys.modules.get("torch")
        if torch is not None:
            torch.manual_seed(seed % 2**63)
        self.rng = np.random.default_rng(seed)

    def close(self) -> None:
        self.env = None

    # -- called by the engine -------------------------------------------------------------

    def _attach_env(self, model, data, scene_metadata, model_path, namespace, base_body,
                    robot_name):
        self.env = CPUMujocoEnv(model, data, scene_metadata, model_path, namespace, base_body,
                                robot_name)
        return self.env

    def _begin_episode(self, seed: int, pickup_obj_name: str | None) -> None:
        self.seed_task_sampling(seed)
        task_config = self._task_config_preset.model_copy(deep=True)
        if pickup_obj_name is not None:
            task_config.pickup_obj_name = pickup_obj_name
        self.config.task_config = task_config

    # -- hooks a subclass may override (the engine calls the default ones without Python) -

    def init_scene(self, env: CPUMujocoEnv) -> None:
        """Called once when a scene is loaded, after ``self.env`` is set."""

    def randomize_scene(self, env: CPUMujocoEnv, robot_view: Any) -> None:
        """The engine's per-episode reset: ``mj_resetData``, the robot's home pose with the
        configured joint noise, the objects at their compiled poses. An override that calls
        ``super().randomize_scene(env, robot_view)`` runs it, then adds its own changes."""
        engine = getattr(self, "_engine_randomize", None)
        if engine is None:
            raise RuntimeError("randomize_scene runs inside the engine's episode loop only")
        engine()

    def _on_candidate_selected(self, env: CPUMujocoEnv, reference_obj_name: str,
                               reference_obj_id: int, supporting_geom_id: int) -> bool:
        """Whether to use the chosen pickup object; False (or a ValueError) skips the
        episode (journaled as a sampler rejection). mlspaces' ``UsageError`` (an mlspaces
        function called with a bad argument) is a bug in the hook and stops the run."""
        return True


class PickTaskSampler(BaseMujocoTaskSampler):
    """The pick task sampler. Its default ``_sample_and_place_robot`` is the engine's
    ``block_pickup`` placement: the robot base and then the object move by
    ``task_sampler_config.robot_base_noise`` / ``object_noise`` (uniform x, y, yaw from the
    episode's engine generator), the goal ``goal_offset_z`` above the start, and the three poses
    are set in ``self.config.task_config``. A subclass that does not override the hook runs it
    in C++ without entering Python (the same episodes as ``task_sampler_class="block_pickup"``);
    an override may call ``super()._sample_and_place_robot(env)`` and then adjust."""

    def _sample_and_place_robot(self, env: CPUMujocoEnv) -> None:
        engine = getattr(self, "_engine_place", None)
        if engine is None:
            raise RuntimeError("_sample_and_place_robot runs inside the engine's episode loop "
                               "only")
        task_cfg = self.config.task_config
        (task_cfg.robot_base_pose, task_cfg.pickup_obj_start_pose,
         task_cfg.pickup_obj_goal_pose) = engine()


__all__ = ["BaseMujocoTaskSampler", "PickTaskSampler"]
