"""Scene metadata (``molmo_spaces.utils.scene_metadata_utils``)."""

from __future__ import annotations

from .._registry import get_scene_metadata


class SceneMeta:
    """MolmoSpaces' static alias."""

    get_scene_metadata = staticmethod(get_scene_metadata)


__all__ = ["SceneMeta", "get_scene_metadata"]
