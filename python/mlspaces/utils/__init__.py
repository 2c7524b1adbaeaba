"""Mirrors of ``molmo_spaces.utils`` modules."""
