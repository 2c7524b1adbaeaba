"""``CPUMujocoEnv`` (``molmo_spaces.env.env``): the scene a task sampler works in.

``current_model`` and ``current_data`` are real ``mujoco.MjModel`` / ``mujoco.MjData`` objects,
shared with the C++ engine: what user code writes (``data.qpos``, a body pose, a mocap pose)
is what the engine simulates, and ``mujoco.mj_forward(model, data)`` works on them as on any.
"""

from __future__ import annotations

from typing import Any

import mujoco

from .. import _validate as _v
from .data_views import MlSpacesMocapBody


class MocapRobotBaseGroup(MlSpacesMocapBody):
    """A robot base that is a mocap body (``pose`` get/set as for any mocap body)."""


class FrankaDroidRobotView:
    """The Franka DROID robot's view: ``name`` and ``base``."""

    def __init__(self, data: mujoco.MjData, namespace: str, base_body: str) -> None:
        self.name = f"{namespace}franka_droid"
        self.base = MocapRobotBaseGroup(data, base_body)


class FrankaRobot:
    """The robot of an env: ``namespace`` and ``robot_view``."""

    def __init__(self, data: mujoco.MjData, namespace: str, base_body: str) -> None:
        self.namespace = namespace
        self.robot_view = FrankaDroidRobotView(data, namespace, base_body)


class CPUMujocoEnv:
    """One scene with its robot (one batch element: ``n_batch`` is 1)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 scene_metadata: dict[str, Any] | None, model_path: str, namespace: str,
                 base_body: str) -> None:
        self.mj_model = model
        self.mj_datas = [data]
        self.robots = [FrankaRobot(data, namespace, base_body)]
        self._scene_metadata = scene_metadata
        self.current_model_path = model_path
        self.n_batch = 1
        self._batch_index = 0

    @property
    def current_batch_index(self) -> int:
        return self._batch_index

    @current_batch_index.setter
    def current_batch_index(self, value: int) -> None:
        value = _v.integer(value, "current_batch_index", "CPUMujocoEnv")
        if not 0 <= value < self.n_batch:
            raise _v.value_error("CPUMujocoEnv", "current_batch_index",
                                 f"expected an int in [0, {self.n_batch}), got {value}")
        self._batch_index = value

    @property
    def current_model(self) -> mujoco.MjModel:
        return self.mj_model

    @property
    def current_data(self) -> mujoco.MjData:
        return self.mj_datas[self._batch_index]

    @property
    def current_robot(self) -> FrankaRobot:
        return self.robots[self._batch_index]

    @property
    def current_scene_metadata(self) -> dict[str, Any] | None:
        """The live scene metadata (objects inserted at run time included)."""
        return self._scene_metadata


__all__ = ["CPUMujocoEnv", "FrankaDroidRobotView", "FrankaRobot", "MocapRobotBaseGroup"]
