"""``molmo_spaces.data_generation``."""
