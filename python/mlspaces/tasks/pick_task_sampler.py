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

from ..env.data_views import create_mlspaces_body
from ..env.env import CPUMujocoEnv
from ..utils.pose import pose_mat_to_7d


def _planar(rng: np.random.Generator, noise: dict[str, float]) -> np.ndarray:
    x = rng.uniform(-noise["x"], noise["x"])
    y = rng.uniform(-noise["y"], noise["y"])
    yaw = np.deg2rad(rng.uniform(-noise["yaw_deg"], noise["yaw_deg"]))
    out = np.eye(4)
    out[:2, 3] = (x, y)
    out[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    return out


class BaseMujocoTaskSampler:
    """Holds the experiment config (``self.config``) and the env of the current scene
    (``self.env``, ``None`` until the engine loads a scene)."""

    def __init__(self, config: Any) -> None:
        self.config = config
        self._task_config_preset = config.task_config.model_copy(deep=True)
        self.env: CPUMujocoEnv | None = None
        self._engine_randomize = None
        seed = getattr(config, "seed", None)
        self.rng = np.random.default_rng(seed)
        if seed is not None:
            self.seed_task_sampling(seed)

    def seed_task_sampling(self, seed: int) -> None:
        """Seeds ``random``, ``np.random``, ``torch`` (when imported) and ``self.rng``."""
        random.seed(seed)
        np.random.seed(seed % 2**32)
        torch = sys.modules.get("torch")
        if torch is not None:
            torch.manual_seed(seed % 2**63)
        self.rng = np.random.default_rng(seed)

    def close(self) -> None:
        self.env = None

    # -- called by the engine -------------------------------------------------------------

    def _attach_env(self, model, data, scene_metadata, model_path, namespace, base_body):
        self.env = CPUMujocoEnv(model, data, scene_metadata, model_path, namespace, base_body)
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
        episode (journaled as a sampler rejection)."""
        return True


class PickTaskSampler(BaseMujocoTaskSampler):
    """The pick task sampler. Its default ``_sample_and_place_robot`` moves the robot base and
    the object by ``task_sampler_config.robot_base_noise`` / ``object_noise`` (uniform x, y,
    yaw, drawn from ``self.rng``) and sets the goal ``goal_offset_z`` above the start."""

    def _sample_and_place_robot(self, env: CPUMujocoEnv) -> None:
        import mujoco
        cfg = self.config.task_sampler_config
        task_cfg = self.config.task_config
        base = env.current_robot.robot_view.base
        base.pose = base.pose @ _planar(self.rng, cfg.robot_base_noise)
        mujoco.mj_fwdPosition(env.current_model, env.current_data)
        task_cfg.robot_base_pose = pose_mat_to_7d(base.pose).tolist()
        obj = create_mlspaces_body(env.current_data, task_cfg.pickup_obj_name)
        obj.pose = obj.pose @ _planar(self.rng, cfg.object_noise)
        mujoco.mj_fwdPosition(env.current_model, env.current_data)
        start = pose_mat_to_7d(obj.pose)
        task_cfg.pickup_obj_start_pose = start.tolist()
        start[2] += cfg.goal_offset_z
        task_cfg.pickup_obj_goal_pose = start.tolist()


__all__ = ["BaseMujocoTaskSampler", "PickTaskSampler"]
