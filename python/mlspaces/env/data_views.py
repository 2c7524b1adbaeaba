"""Body views (``molmo_spaces.env.data_views``): read and write a body's pose in an ``MjData``.

Getters return fresh arrays; setters write the state (``mocap_pos``/``mocap_quat`` or the free
joint's ``qpos``) and never run kinematics: call ``mujoco.mj_fwdPosition`` (or
``mj_forward``) before reading derived quantities, as with MolmoSpaces.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .. import _validate as _v
from ..errors import MlspacesError, MlspacesKeyError
from ..utils.pose import _as_matrix, _quat_from_rotation, _rotation_from_quat


def _vector(value, n: int, name: str, owner: object) -> np.ndarray:
    """``n`` finite numbers (any array-like holding exactly ``n``) for a body's setter."""
    func = f"{type(owner).__name__}.{name}"
    v = _v.array(value, name, func)
    if v.size != n:
        raise _v.value_error(func, name, f"expected {n} values, got shape {v.shape}")
    return v.reshape(n)


def _pose_from(pos, quat) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = _rotation_from_quat(quat)
    out[:3, 3] = pos
    return out


class MlSpacesBody:
    """A body of an ``MjData``: ``name``, ``body_id``, ``mj_model``, ``mj_data``, and its pose
    (``pose`` 4x4, ``position`` (3,), ``quat`` (4,) wxyz)."""

    def __init__(self, data: mujoco.MjData, body_name_or_id: str | int) -> None:
        func = type(self).__name__
        if not isinstance(data, mujoco.MjData):
            raise _v.type_error(func, "data", "a mujoco.MjData", data)
        if not isinstance(body_name_or_id, str):
            body_name_or_id = _v.integer(body_name_or_id, "body_name_or_id", func)
        self.mj_data = data
        self.mj_model = data.model
        if isinstance(body_name_or_id, str):
            body_id = mujoco.mj_name2id(self.mj_model, mujoco.mjtObj.mjOBJ_BODY, body_name_or_id)
            if body_id < 0:
                raise MlspacesKeyError(f"no body named {body_name_or_id!r} in the model",
                                       field=body_name_or_id)
        else:
            body_id = int(body_name_or_id)
            if not 0 <= body_id < self.mj_model.nbody:
                raise IndexError(f"body id {body_id} out of range (the model has "
                                 f"{self.mj_model.nbody} bodies)")
        self.body_id = body_id
        self.name = mujoco.mj_id2name(self.mj_model, mujoco.mjtObj.mjOBJ_BODY, body_id) or ""

    @property
    def position(self) -> np.ndarray:
        return np.array(self.mj_data.xpos[self.body_id])

    @property
    def quat(self) -> np.ndarray:
        return np.array(self.mj_data.xquat[self.body_id])

    @property
    def pose(self) -> np.ndarray:
        return _pose_from(self.position, self.quat)

    @pose.setter
    def pose(self, value) -> None:
        m = _as_matrix(value, "pose", f"{type(self).__name__}.pose")
        self.position = m[:3, 3]
        self.quat = _quat_from_rotation(m[:3, :3])

    def _not_movable(self, *_):
        raise MlspacesError(f"body {self.name!r} is not movable (neither a mocap body nor a "
                            "free-joint body)")


class MlSpacesMocapBody(MlSpacesBody):
    """A mocap body: its pose is ``mocap_pos`` / ``mocap_quat``."""

    @property
    def _mocap(self) -> int:
        return int(self.mj_model.body_mocapid[self.body_id])

    @property
    def position(self) -> np.ndarray:
        return np.array(self.mj_data.mocap_pos[self._mocap])

    @position.setter
    def position(self, value) -> None:
        self.mj_data.mocap_pos[self._mocap] = _vector(value, 3, "position", self)

    @property
    def quat(self) -> np.ndarray:
        return np.array(self.mj_data.mocap_quat[self._mocap])

    @quat.setter
    def quat(self, value) -> None:
        self.mj_data.mocap_quat[self._mocap] = _vector(value, 4, "quat", self)

    pose = MlSpacesBody.pose


class MlSpacesFreeJointBody(MlSpacesBody):
    """A body whose first joint is a free joint: its pose is ``qpos[adr:adr+7]``."""

    @property
    def _adr(self) -> int:
        return int(self.mj_model.jnt_qposadr[self.mj_model.body_jntadr[self.body_id]])

    @property
    def position(self) -> np.ndarray:
        return np.array(self.mj_data.qpos[self._adr:self._adr + 3])

    @position.setter
    def position(self, value) -> None:
        self.mj_data.qpos[self._adr:self._adr + 3] = _vector(value, 3, "position", self)

    @property
    def quat(self) -> np.ndarray:
        return np.array(self.mj_data.qpos[self._adr + 3:self._adr + 7])

    @quat.setter
    def quat(self, value) -> None:
        self.mj_data.qpos[self._adr + 3:self._adr + 7] = _vector(value, 4, "quat", self)

    pose = MlSpacesBody.pose


class MlSpacesImmovableBody(MlSpacesBody):
    """Any other body: its pose is ``xpos`` / ``xquat`` of the last kinematics; read only."""

    position = property(MlSpacesBody.position.fget, MlSpacesBody._not_movable)
    quat = property(MlSpacesBody.quat.fget, MlSpacesBody._not_movable)
    pose = property(MlSpacesBody.pose.fget, MlSpacesBody._not_movable)


def create_mlspaces_body(data: mujoco.MjData, body_name_or_id: str | int) -> MlSpacesBody:
    """The view of a body that fits it: mocap, free joint, or immovable. ``KeyError`` for an
    unknown name, ``IndexError`` for a bad id."""
    if not isinstance(data, mujoco.MjData):
        raise _v.type_error("create_mlspaces_body", "data", "a mujoco.MjData", data)
    if not isinstance(body_name_or_id, str):
        body_name_or_id = _v.integer(body_name_or_id, "body_name_or_id", "create_mlspaces_body")
    probe = MlSpacesBody(data, body_name_or_id)
    model = probe.mj_model
    if model.body_mocapid[probe.body_id] >= 0:
        return MlSpacesMocapBody(data, probe.body_id)
    if (model.body_jntnum[probe.body_id] > 0 and
            model.jnt_type[model.body_jntadr[probe.body_id]] == mujoco.mjtJoint.mjJNT_FREE):
        return MlSpacesFreeJointBody(data, probe.body_id)
    return MlSpacesImmovableBody(data, probe.body_id)


class MlSpacesObject:
    """An object of a scene by its root body (``molmo_spaces.env.data_views.MlSpacesObject``):
    ``name``, ``object_id`` (the root body's id), ``pose`` / ``position`` / ``quat`` as
    ``create_mlspaces_body`` reads and writes them, and the hinge and slide joints of the
    body's subtree (``joint_names``, ``joint_ids``, ``njoints``, ``get_joint_position``)."""

    def __init__(self, object_name: str | int, data: mujoco.MjData) -> None:
        self._body = create_mlspaces_body(data, object_name)
        self.mj_data, self.mj_model = data, self._body.mj_model
        self.name, self.object_id = self._body.name, self._body.body_id
        model, root = self.mj_model, self.object_id
        in_subtree = [b for b in range(model.nbody)
                      if b == root or _is_descendant(model, b, root)]
        self.joint_ids = [j for b in in_subtree
                          for j in range(model.body_jntadr[b],
                                         model.body_jntadr[b] + model.body_jntnum[b])
                          if model.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE,
                                                   mujoco.mjtJoint.mjJNT_SLIDE)]
        self.joint_names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or ""
                            for j in self.joint_ids]

    @property
    def njoints(self) -> int:
        return len(self.joint_ids)

    def get_joint_position(self, joint_idx: int) -> float:
        """The position (qpos) of the object's ``joint_idx``-th joint."""
        joint_idx = _v.integer(joint_idx, "joint_idx", f"{type(self).__name__}.get_joint_position")
        return float(self.mj_data.qpos[self.mj_model.jnt_qposadr[self.joint_ids[joint_idx]]])

    pose = property(lambda self: self._body.pose,
                    lambda self, value: setattr(self._body, "pose", value))
    position = property(lambda self: self._body.position,
                        lambda self, value: setattr(self._body, "position", value))
    quat = property(lambda self: self._body.quat,
                    lambda self, value: setattr(self._body, "quat", value))


class MlSpacesArticulationObject(MlSpacesObject):
    """An object with joints (``molmo_spaces.env.data_views.MlSpacesArticulationObject``)."""


def _is_descendant(model: mujoco.MjModel, body: int, root: int) -> bool:
    while body > 0:
        body = int(model.body_parentid[body])
        if body == root:
            return True
    return False


__all__ = ["MlSpacesArticulationObject", "MlSpacesBody", "MlSpacesFreeJointBody",
           "MlSpacesImmovableBody", "MlSpacesMocapBody", "MlSpacesObject",
           "create_mlspaces_body"]
