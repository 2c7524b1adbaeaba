"""``molmo_spaces.robots.abstract``: ``Robot``, the class of ``env.current_robot`` for every
robot (``namespace``, ``name``, ``robot_view``).

MolmoSpaces users subclass ``Robot`` to add a robot in Python; in mlspaces a robot is data (a
robot.yaml, docs/robots.md) and the engine drives it, so ``Robot`` is the class such code
imports and annotates with, and ``BaseRobotConfig.robot_cls`` is not called."""

from ..env.env import Robot

__all__ = ["Robot"]
