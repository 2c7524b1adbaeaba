"""``molmo_spaces.robots.franka``: the Franka DROID robot of an env (``env.current_robot``)."""

from ..env.env import FrankaDroidRobotView, FrankaRobot

__all__ = ["FrankaDroidRobotView", "FrankaRobot"]
