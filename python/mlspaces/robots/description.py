"""Robots as data (docs/robots.md): the bundled robots and their ``robot.yaml`` descriptions.

A robot is a folder holding ``robot.yaml`` and its MJCF. A robot is named by its registered
(bundled) name, e.g. ``"franka_droid"``, or by the path of its ``robot.yaml`` or folder; a
relative path resolves against the current directory.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from .. import _core
from .. import _validate as _v


def list_robots() -> list[str]:
    """The names of the bundled robots (folders of ``robots_dir()`` holding a robot.yaml),
    sorted."""
    return list(_core.bundled_robots())


def robots_dir() -> Path:
    """Where the bundled robots live: ``$MLSPACES_ROBOTS_DIR`` when set, else the package's
    own copy."""
    return Path(_core.robots_dir())


def find_robot(name_or_path: str | os.PathLike[str], func: str = "find_robot",
               arg: str = "name_or_path") -> Path:
    """The ``robot.yaml`` that `name_or_path` means: a bundled robot's name, or a path (a
    ``PathLike``, or a ``str`` holding ``/`` or ending in ``.yaml``) of a robot.yaml or its
    folder. :class:`~mlspaces.errors.MlspacesKeyError` for an unknown name (with the bundled
    names and a "did you mean"), :class:`~mlspaces.errors.MlspacesFileError` for a path that
    holds no robot.yaml, :class:`~mlspaces.errors.MlspacesTypeError` for another type."""
    if isinstance(name_or_path, os.PathLike):
        text, is_path = _v.path(name_or_path, arg, func), True
    else:
        text = _v.string(name_or_path, arg, func, empty=False)
        is_path = "/" in text or text.endswith((".yaml", ".yml"))
    if is_path:
        path = Path(text).absolute()
        yaml = path / "robot.yaml" if path.is_dir() else path
        if not yaml.is_file():
            raise _v.file_error(yaml, "no robot description (robot.yaml) here")
        return yaml
    return Path(_core.find_robot(text, os.getcwd(), arg))


def load_robot_description(name_or_path: str | os.PathLike[str]) -> dict[str, Any]:
    """The robot's description as the engine loads it (strictly: unknown keys, wrong types or
    lengths, NaN, names missing from the MJCF are errors): robot.yaml's keys with their
    defaults filled in and ``mjcf`` an absolute path, plus ``file`` (the robot.yaml, absolute)
    and ``hash`` (16 hex digits over robot.yaml and the MJCF's files: the
    ``description_hash`` every episode's provenance records). A bad description raises
    :class:`~mlspaces.errors.MlspacesError` naming the file and the field
    (``"<robot.yaml>: <field>: <problem>"``, also in ``.path`` / ``.field``); an unknown
    robot or a missing file as :func:`find_robot`."""
    yaml = find_robot(name_or_path, "load_robot_description")
    text, file, digest = _core.load_robot_description(yaml)
    out: dict[str, Any] = _core.config_yaml_to_dict(text)
    out["file"] = str(file)
    out["hash"] = str(digest)
    return out


def check_robot_description(path: str | os.PathLike[str]) -> list[str]:
    """Every problem of a robot description, one line each (``"<robot.yaml>: <field>:
    <problem>"``), instead of raising for the first; an empty list when it loads. `path` is a
    robot.yaml, its folder, or a bundled robot's name; an unknown name or a missing file raise
    as :func:`find_robot`."""
    yaml = find_robot(path, "check_robot_description", "path")
    return list(_core.check_robot_description(yaml))


__all__ = ["check_robot_description", "find_robot", "list_robots", "load_robot_description",
           "robots_dir"]
