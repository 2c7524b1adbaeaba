"""``molmo_spaces.robots.franka``: ``FrankaRobot`` and ``FrankaDroidRobotView``, MolmoSpaces'
names of the robot of an env (``env.current_robot``) and its view; in mlspaces every robot
(franka_droid or any robot.yaml) has these classes (``mlspaces.robots.abstract.Robot``)."""

from ..env.env import FrankaDroidRobotView, FrankaRobot

__all__ = ["FrankaDroidRobotView", "FrankaRobot"]
