"""Robot views (``molmo_spaces.robots.robot_views``)."""
