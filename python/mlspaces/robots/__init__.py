"""Robots (``molmo_spaces.robots``): the robot of an env and its view."""
