"""``BaseRobotConfig`` and ``FrankaRobotConfig`` (``molmo_spaces.configs.robot_configs``).

A robot config names the robot and its per-run settings. The robot itself is data: a folder
holding ``robot.yaml`` and its MJCF (docs/robots.md), named by ``name`` (a bundled robot, or the
path of a robot.yaml or its folder) or by ``robot_dir``. A MolmoSpaces robot config subclass
(the add-robot tutorial's ``XArm7RobotConfig(BaseRobotConfig)``) works as written:

- ``init_qpos`` / ``init_qpos_noise_range`` are dicts per move group (``"arm"``, ``"gripper"``,
  ``"base"``); empty lists mean the robot's own home pose / home noise (robot.yaml
  ``arm.home``, ``gripper.home``, ``arm.home_noise``); ``init_qpos_noise_range=None`` means no
  noise, as in MolmoSpaces. mlspaces robots have no base joints in the home pose, so ``"base"``
  must be empty; the gripper gets no noise.
- ``command_mode`` is a dict per move group (``"arm"``: ``"joint_position"`` or
  ``"joint_rel_position"``, ``"gripper"``: ``"joint_position"``; other groups ``None``).
- a relative ``robot_xml_path`` is a file of the robot's folder (``robot_dir``, else the named
  robot's); ``None`` = robot.yaml's ``mjcf``.
- ``robot_cls``, ``robot_factory`` and ``robot_view_factory`` are accepted for source
  compatibility and not used: the robot's behaviour comes from its robot.yaml.
- ``K_stiffness``, ``K_damping`` and ``force_limit`` must stay ``None`` (set the actuators'
  gains in the robot's MJCF).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import Field

from .. import _validate as _v
from ._base import Config, default
from ._fields import engine_model

_GROUPS = ("arm", "gripper")


class _RobotConfig(Config):
    """The conversion of a robot config to the engine's ``robot_config`` (to_native)."""

    def _engine_fields(self) -> dict[str, Any]:
        """The engine's robot_config of this config (paths absolute, per-group dicts checked)."""
        func = type(self).__name__
        out = {name: getattr(self, name) for name in type(self).model_fields}
        for key in ("K_stiffness", "K_damping", "force_limit"):
            if out.get(key) is not None:
                raise _v.value_error(func, key, "not supported: set the actuators' gains and "
                                                "force ranges in the robot's MJCF")
        name = out.get("name")
        out["name"] = os.fspath(name) if isinstance(name, os.PathLike) else name
        robot_dir = out.get("robot_dir")
        if robot_dir is not None:
            robot_dir = Path(_v.path(robot_dir, "robot_dir", func)).absolute()
            out["robot_dir"] = str(robot_dir)
        xml = out.get("robot_xml_path")
        if xml is not None:
            xml = Path(_v.path(xml, "robot_xml_path", func))
            if not xml.is_absolute():
                xml = self._robot_folder(func) / xml
            out["robot_xml_path"] = str(xml)
        if out.get("base_size") is not None:
            out["base_size"] = _floats(out["base_size"], "base_size", func)
        if "init_qpos" in out:
            out["init_qpos"] = _per_group(out["init_qpos"], "init_qpos", func, ("arm", "gripper"))
        if "init_qpos_noise_range" in out:
            noise = out["init_qpos_noise_range"]
            if noise is None:  # MolmoSpaces: no noise
                n = len(self._description(func)["arm"]["joints"])
                out["init_qpos_noise_range"] = {"arm": [0.0] * n}
            else:
                out["init_qpos_noise_range"] = _per_group(noise, "init_qpos_noise_range", func,
                                                          ("arm",))
        if "command_mode" in out:
            out["command_mode"] = _command_mode(out["command_mode"], func)
        return out

    def _robot_yaml(self, func: str) -> Path:
        from ..robots.description import find_robot
        if getattr(self, "robot_dir", None) is not None:
            return find_robot(Path(_v.path(self.robot_dir, "robot_dir", func)), func,
                              "robot_dir")
        return find_robot(self.name, func, "name")

    def _robot_folder(self, func: str) -> Path:
        return self._robot_yaml(func).parent

    def _description(self, func: str) -> dict[str, Any]:
        from ..robots.description import load_robot_description
        return load_robot_description(self._robot_yaml(func))


def _floats(value: Any, name: str, func: str) -> list[float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise _v.type_error(func, name, "a list of numbers", value)
    out = []
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) and not hasattr(v, "__float__"):
            raise _v.type_error(func, f"{name}[{i}]", "a number", v)
        f = float(v)
        if not math.isfinite(f):
            raise _v.value_error(func, f"{name}[{i}]", f"expected a finite number, got {f}")
        out.append(f)
    return out


def _per_group(value: Any, name: str, func: str, groups: tuple[str, ...]) -> dict[str, Any]:
    """{"arm": [...], "gripper": [...]} of a MolmoSpaces per-move-group dict: `groups` are
    kept, any other group must be empty (or all zeros)."""
    if not isinstance(value, Mapping):
        raise _v.type_error(func, name, "a dict of move group -> list of numbers", value)
    out: dict[str, Any] = {}
    for group, values in value.items():
        field = f"{name}[{group!r}]"
        numbers = [] if values is None else _floats(values, field, func)
        if group in groups:
            out[group] = numbers
        elif any(numbers):
            raise _v.value_error(func, field, f"mlspaces robots take {' and '.join(groups)} "
                                              f"values here, got {len(numbers)} for {group!r}")
    return out


def _command_mode(value: Any, func: str) -> dict[str, Any]:
    if not isinstance(value, Mapping):
        raise _v.type_error(func, "command_mode", "a dict of move group -> mode", value)
    out: dict[str, Any] = {}
    for group, mode in value.items():
        if group in _GROUPS:
            if mode is not None:
                out[group] = mode
        elif mode is not None:
            raise _v.value_error(func, f"command_mode[{group!r}]",
                                 f"mlspaces robots command the arm and the gripper only, "
                                 f"got {mode!r} for {group!r}")
    return out


BaseRobotConfig = engine_model(
    "BaseRobotConfig", __name__, ("robot_config",),
    "A robot config (MolmoSpaces' BaseRobotConfig): name (a bundled robot or a robot.yaml "
    "path), robot_dir, robot_xml_path, robot_namespace, init_qpos, init_qpos_noise_range, "
    "command_mode, gravcomp, base_size (pedestal x, y, z in metres; None = on the floor), "
    "action_noise_config; robot_cls / robot_factory / robot_view_factory are not used.",
    base=_RobotConfig,
    robot_cls=(Any, None),
    robot_factory=(Any, None),
    robot_view_factory=(Any, None),
    robot_dir=(Any, None),
    robot_xml_path=(Any, None),
    base_size=(Any, None),
    gravcomp=(bool, False),
    init_qpos=(Any, Field(default_factory=lambda: {"base": [], "arm": [], "gripper": []})),
    init_qpos_noise_range=(Any, Field(default_factory=lambda: {"arm": []})),
    command_mode=(Any, Field(default_factory=lambda: dict(default("robot_config",
                                                                  "command_mode")))),
    K_stiffness=(Any, None),
    K_damping=(Any, None),
    force_limit=(Any, None),
)

FrankaRobotConfig = engine_model(
    "FrankaRobotConfig", __name__, ("robot_config",),
    "The Franka DROID robot (franka_droid): base_size (pedestal x, y, z in metres; None = on "
    "the floor), robot_namespace, init_qpos, init_qpos_noise_range, command_mode, gravcomp, ...",
    base=BaseRobotConfig,
    base_size=(Any, default("robot_config", "base_size")),
    robot_dir=(Any, None),
    robot_xml_path=(Any, None),
)

__all__ = ["BaseRobotConfig", "FrankaRobotConfig"]
