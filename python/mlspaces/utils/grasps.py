"""Grasps (``molmo_spaces.utils.grasps``), on the process-default registry.

``load_*`` return poses in the object body frame (pickup) or the joint's body frame;
``get_*_grasps`` return them in the world frame of an env. Arrays are fresh float64
``(N, 4, 4)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _core
from .. import _validate as _v
from .._registry import (get_grasp_libraries_for_object, get_joint_grasp_path,
                         get_pickup_grasp_path, has_joint_grasp_path, has_pickup_grasp_path,
                         has_valid_joint_grasps, has_valid_pickup_grasps, load_joint_grasps,
                         load_pickup_grasps)
from ..errors import MlspacesError


def flip_grasps(grasps) -> np.ndarray:
    """``grasps @ Rz(180 deg)``: each grasp turned half a turn about its approach (z) axis
    (the jaw-symmetric twin). Takes ``(4, 4)`` or ``(N, 4, 4)``."""
    g = _v.array(grasps, "grasps", "flip_grasps")
    if g.shape == (4, 4):
        return _core.flip_grasps(g[None])[0]
    if g.ndim != 3 or g.shape[1:] != (4, 4):
        raise _v.value_error("flip_grasps", "grasps",
                             f"expected shape (N, 4, 4) or (4, 4), got {g.shape}")
    return _core.flip_grasps(g)


def _env_and_obj(env: Any, obj: Any, func: str) -> None:
    if not hasattr(env, "current_scene_metadata"):
        raise _v.type_error(func, "env", "an env (CPUMujocoEnv)", env)
    if not isinstance(getattr(obj, "name", None), str) or not hasattr(obj, "pose"):
        raise _v.type_error(func, "obj", "a scene object (with .name and .pose)", obj)


def _asset_id(env: Any, obj_name: str) -> str:
    meta = env.current_scene_metadata
    if meta is None:
        raise MlspacesError(f"Could not load grasps for object {obj_name}: No scene metadata "
                            "found!")
    objects = meta.get("objects", {})
    if obj_name not in objects:
        raise MlspacesError(f"Could not load grasps for object {obj_name}: Object not found in "
                            "scene metadata!")
    return objects[obj_name]["asset_id"]  # KeyError when the entry has none, as the original


def get_pickup_grasps(env: Any, obj: Any, include_flipped: bool = True,
                      grasp_libraries: Sequence[str] | None = None) -> np.ndarray:
    """Every pickup grasp of a scene object in the world frame: ``obj.pose @ G`` for each
    grasp ``G`` of its asset, followed by their flipped twins when ``include_flipped``
    (``(2N, 4, 4)``). Raises ``ValueError`` when the scene has no metadata for the object, or
    the asset has no grasps."""
    func = "get_pickup_grasps"
    _env_and_obj(env, obj, func)
    include_flipped = _v.boolean(include_flipped, "include_flipped", func)
    grasp_libraries = _v.libraries(grasp_libraries, "grasp_libraries", func)
    uid = _asset_id(env, obj.name)
    grasps = load_pickup_grasps(uid, grasp_libraries, num_grasps=10**6)
    if len(grasps) == 0:
        raise MlspacesError(f"Could not load grasps for object {obj.name}: 0 grasps", uid=uid)
    return _core.grasps_in_world(obj.pose, grasps, include_flipped)


def get_joint_grasps(env: Any, obj: Any, joint_idx: int, include_flipped: bool = True,
                     grasp_libraries: Sequence[str] | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The grasps of one joint of an articulated scene object in the world frame, and the
    world pose of the joint's body (from the data's current kinematics)."""
    func = "get_joint_grasps"
    _env_and_obj(env, obj, func)
    joint_idx = _v.integer(joint_idx, "joint_idx", func)
    include_flipped = _v.boolean(include_flipped, "include_flipped", func)
    grasp_libraries = _v.libraries(grasp_libraries, "grasp_libraries", func)
    uid = _asset_id(env, obj.name)
    entry = env.current_scene_metadata["objects"][obj.name]
    joint_name = obj.joint_names[joint_idx]  # IndexError when out of range, as the original
    asset_joint = entry["name_map"]["joints"][joint_name]
    grasps = load_joint_grasps(uid, asset_joint, grasp_libraries, num_grasps=10**6)
    if len(grasps) == 0:
        raise MlspacesError(f"Could not load grasps for joint {joint_name} of {obj.name}: "
                            "0 grasps", uid=uid)
    model, data = env.current_model, env.current_data
    body = model.jnt_bodyid[model.joint(joint_name).id]
    body_pose = np.eye(4)
    body_pose[:3, :3] = np.asarray(data.xmat[body]).reshape(3, 3)
    body_pose[:3, 3] = data.xpos[body]
    return _core.grasps_in_world(body_pose, grasps, include_flipped), body_pose


__all__ = ["flip_grasps", "get_grasp_libraries_for_object", "get_joint_grasp_path",
           "get_joint_grasps", "get_pickup_grasp_path", "get_pickup_grasps",
           "has_joint_grasp_path", "has_pickup_grasp_path", "has_valid_joint_grasps",
           "has_valid_pickup_grasps", "load_joint_grasps", "load_pickup_grasps"]
