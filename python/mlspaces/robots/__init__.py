"""Robots (``molmo_spaces.robots``): the robots as data (robot.yaml, docs/robots.md) and the
robot of an env and its view (``mlspaces.robots.franka``, ``mlspaces.robots.abstract``)."""

from .description import (check_robot_description, find_robot, list_robots,
                          load_robot_description, robots_dir)
from ._inspect import inspect_robot  # noqa: F401  (`mlspaces inspect-robot`; docs/robots.md)

__all__ = ["check_robot_description", "find_robot", "list_robots", "load_robot_description",
           "robots_dir"]
