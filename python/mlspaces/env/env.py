"""``CPUMujocoEnv`` (``molmo_spaces.env.env``): the scene a task sampler works in.

``current_model`` and ``current_data`` are real ``mujoco.MjModel`` / ``mujoco.MjData`` objects,
shared with the C++ engine: what user code writes (``data.qpos``, a body pose, a mocap pose)
is what the engine simulates, and ``mujoco.mj_forward(model, data)`` works on them as on any.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from .. import _validate as _v
from ..errors import MlspacesError
from .data_views import MlSpacesBody, MlSpacesMocapBody, _vector, create_mlspaces_body


class MocapRobotBaseGroup(MlSpacesMocapBody):
    """A robot base that is a mocap body (``pose`` get/set as for any mocap body)."""


class HoloJointsRobotBaseGroup(MlSpacesBody):
    """A holonomic base (robot.yaml ``base.kind: holonomic``): the base body on the joints
    ``<namespace>base_x``, ``base_y``, ``base_yaw`` with position servos of the same names.
    ``pose`` / ``position`` / ``quat`` read those joints (the height is the body's); setting
    them writes the joints, their servo targets and zero joint velocities, as the engine does.
    The base moves in x, y and yaw only: another height, roll or pitch is a ``UsageError``."""

    _JOINTS = ("base_x", "base_y", "base_yaw")

    def __init__(self, data: mujoco.MjData, base_body: str, namespace: str) -> None:
        super().__init__(data, base_body)
        m = self.mj_model
        self._adr: list[tuple[int, int, int]] = []  # (qpos, dof, actuator) of x, y, yaw
        for joint in self._JOINTS:
            name = namespace + joint
            j = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)
            a = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, name)
            if j < 0 or a < 0 or m.jnt_bodyid[j] != self.body_id:
                raise MlspacesError(f"holonomic base joint or servo {name!r} is not in the model")
            self._adr.append((int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]), a))

    def _write(self, index: int, value: float) -> None:
        qpos, dof, act = self._adr[index]
        self.mj_data.qpos[qpos] = value
        self.mj_data.qvel[dof] = 0.0
        self.mj_data.ctrl[act] = value

    @property
    def position(self) -> np.ndarray:
        q = self.mj_data.qpos
        return np.array([q[self._adr[0][0]], q[self._adr[1][0]],
                         self.mj_model.body_pos[self.body_id][2]])

    @position.setter
    def position(self, value) -> None:
        v = _vector(value, 3, "position", self)
        height = self.mj_model.body_pos[self.body_id][2]
        if abs(v[2] - height) > 1e-9:
            raise _v.value_error(f"{type(self).__name__}.position", "position",
                                 f"the holonomic base moves in x and y only: height "
                                 f"{v[2]:.6g} differs from the base's {height:.6g}")
        self._write(0, float(v[0]))
        self._write(1, float(v[1]))

    @property
    def quat(self) -> np.ndarray:
        yaw = self.mj_data.qpos[self._adr[2][0]]
        return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])

    @quat.setter
    def quat(self, value) -> None:
        q = _vector(value, 4, "quat", self)
        q = q / np.linalg.norm(q)
        if abs(q[1]) > 1e-9 or abs(q[2]) > 1e-9:
            raise _v.value_error(f"{type(self).__name__}.quat", "quat",
                                 "the holonomic base turns about z only (roll and pitch 0)")
        self._write(2, float(2 * np.arctan2(q[3], q[0])))

    pose = MlSpacesBody.pose


class RobotView:
    """The view of an env's robot: ``name`` (``"<namespace><robot name>"``, e.g.
    ``"robot_0/franka_droid"``) and ``base``. Any robot (robot.yaml, docs/robots.md) has this
    view; ``FrankaDroidRobotView`` is its MolmoSpaces name."""

    def __init__(self, data: mujoco.MjData, namespace: str, base_body: str,
                 robot_name: str = "franka_droid") -> None:
        self.name = f"{namespace}{robot_name}"
        self.base = _base_view(data, namespace, base_body)


def _base_view(data: mujoco.MjData, namespace: str, base_body: str) -> MlSpacesBody:
    """The view of a robot's base: mocap (robot.yaml base.kind mocap), holonomic (x, y, yaw
    joints) or, for a fixed base, the body's read-only view."""
    base = create_mlspaces_body(data, base_body)
    if isinstance(base, MlSpacesMocapBody):
        return MocapRobotBaseGroup(data, base_body)
    m = data.model
    x = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, namespace + "base_x")
    if x >= 0 and m.jnt_bodyid[x] == base.body_id:
        return HoloJointsRobotBaseGroup(data, base_body, namespace)
    return base


class Robot:
    """The robot of an env: ``namespace``, ``name`` (the robot's name, robot.yaml ``name``)
    and ``robot_view``. ``FrankaRobot`` is its MolmoSpaces name (the class of
    ``env.current_robot`` whichever robot the config names)."""

    def __init__(self, data: mujoco.MjData, namespace: str, base_body: str,
                 robot_name: str = "franka_droid") -> None:
        self.namespace = namespace
        self.name = robot_name
        self.robot_view = RobotView(data, namespace, base_body, robot_name)


#: MolmoSpaces' names of the robot and its view (every robot has the same two classes here).
FrankaDroidRobotView = RobotView
FrankaRobot = Robot


class CPUMujocoEnv:
    """One scene with its robot (one batch element: ``n_batch`` is 1)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 scene_metadata: dict[str, Any] | None, model_path: str, namespace: str,
                 base_body: str, robot_name: str = "franka_droid") -> None:
        self.mj_model = model
        self.mj_datas = [data]
        self.robots = [Robot(data, namespace, base_body, robot_name)]
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
    def current_robot(self) -> Robot:
        return self.robots[self._batch_index]

    @property
    def current_scene_metadata(self) -> dict[str, Any] | None:
        """The live scene metadata (objects inserted at run time included)."""
        return self._scene_metadata


__all__ = ["CPUMujocoEnv", "FrankaDroidRobotView", "FrankaRobot", "HoloJointsRobotBaseGroup",
           "MocapRobotBaseGroup", "Robot", "RobotView"]
