"""``mlspaces.robots.inspect_robot``: ``mlspaces inspect-robot --json`` as a dict
(docs/robots.md, "inspect-robot")."""

from __future__ import annotations

import os
from typing import Any

from .. import _core
from .. import _validate as _v
from .description import find_robot

_FUNC = "inspect_robot"


def _range(value: Any, name: str) -> tuple[float, float]:
    a = _v.array(value, name, _FUNC, (2,))
    if a[0] > a[1]:
        raise _v.value_error(_FUNC, name, f"expected (min, max) with min <= max, got "
                                          f"({a[0]}, {a[1]})")
    return float(a[0]), float(a[1])


def inspect_robot(name_or_path: str | os.PathLike[str], *, settle_time: float = 1.0,
                  finger_tolerance: float = 0.002, tcp_tolerance_deg: float = 10.0,
                  grid_x: tuple[float, float] = (0.3, 0.8),
                  grid_y: tuple[float, float] = (-0.4, 0.4),
                  grid_z: tuple[float, float] = (0.05, 0.6), grid_step: float = 0.1,
                  reachability: bool = True) -> dict[str, Any]:
    """Checks a robot description and measures the robot in simulation, as ``mlspaces
    inspect-robot --json``: a dict with ``problems`` (one line each, ``"<robot.yaml>: <field>:
    <problem>"``; ``[]`` when none), ``loaded`` (``False``: the description does not load, and
    ``problems`` is all there is), ``chain``, ``actuators``, ``dof``, ``home``, ``tcp``,
    ``gripper_travel`` (gaps measured after `settle_time` seconds open, then closed, gravity
    compensation on) and ``reachability`` (IK from home over the `grid_x` x `grid_y` x `grid_z`
    grid, `grid_step` apart, TCP pointing down; ``reachability=False`` skips it) and
    ``grasp_generation`` (whether :func:`mlspaces.grasp_generation.generate_grasps` can use it:
    ``ready``, and ``problem`` when not, naming the robot.yaml and its field).
    `name_or_path` is resolved as :func:`find_robot` does (and raises as it does); a bad option
    raises :class:`~mlspaces.errors.UsageError` or
    :class:`~mlspaces.errors.MlspacesTypeError`."""
    yaml = find_robot(name_or_path, _FUNC)
    return _core.inspect_robot(
        yaml,
        settle_time=_v.number(settle_time, "settle_time", _FUNC, minimum=1e-3, maximum=60.0),
        finger_tolerance=_v.number(finger_tolerance, "finger_tolerance", _FUNC, minimum=0.0),
        tcp_tolerance_deg=_v.number(tcp_tolerance_deg, "tcp_tolerance_deg", _FUNC, minimum=0.0,
                                    maximum=180.0),
        grid_x=_range(grid_x, "grid_x"), grid_y=_range(grid_y, "grid_y"),
        grid_z=_range(grid_z, "grid_z"),
        grid_step=_v.number(grid_step, "grid_step", _FUNC, minimum=1e-4),
        reachability=_v.boolean(reachability, "reachability", _FUNC))


__all__ = ["inspect_robot"]
