"""``molmo_spaces.robots.robot_views.abstract``: ``RobotView`` (the view of an env's robot:
``name`` and ``base``), the base views ``MocapRobotBaseGroup`` and
``HoloJointsRobotBaseGroup``, and the ``RobotViewFactory`` type.

In mlspaces the robot's move groups come from its robot.yaml (docs/robots.md), so a
``BaseRobotConfig.robot_view_factory`` is accepted and not called."""

from __future__ import annotations

from typing import Callable

import mujoco

from ...env.env import HoloJointsRobotBaseGroup, MocapRobotBaseGroup, RobotView

#: ``(MjData, namespace) -> RobotView``, as MolmoSpaces types a robot view factory.
RobotViewFactory = Callable[[mujoco.MjData, str], RobotView]

__all__ = ["HoloJointsRobotBaseGroup", "MocapRobotBaseGroup", "RobotView", "RobotViewFactory"]
