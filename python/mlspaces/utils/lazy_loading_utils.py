"""UID lookup and installing (``molmo_spaces.utils.lazy_loading_utils``), on the
process-default registry and the environment's resource settings (MLSPACES_CACHE_DIR,
MLSPACES_ASSETS_DIR, MLSPACES_REMOTE_URL, MLSPACES_PINNED_ASSETS_FILE)."""

from __future__ import annotations

import os
from pathlib import Path

from .. import _core
from .._registry import install_uid, locate_uid_package


def install_scene_with_objects_and_grasps_from_path(
    xml_path: str | os.PathLike | dict,
    grasp_sources: tuple[str, ...] | list[str] = ("droid_objaverse",),
    exclude_thor: bool = True,
) -> dict[str, dict[str, list[str]]]:
    """Installs a scene archive (``xml_path`` a path inside a scene source or under
    ``<assets>/scenes``, a scene number, or ``{"base": path}``), then the objects and grasps
    its MJCFs reference through ``../objects/...``. Returns ``{"scenes": {source: [archives]},
    "objects": {...}, "grasps": {...}}``: every archive asked for, installed now or before."""
    if isinstance(xml_path, dict):
        xml_path = xml_path["base"]
    return _core.install_scene_with_objects_and_grasps_from_path(
        os.fspath(xml_path), list(grasp_sources), exclude_thor)


def install_objects_for_scene(xml_path: str | os.PathLike, exclude_thor: bool = True
                              ) -> dict[str, list[str]]:
    """Installs the object archives an installed scene MJCF (under ``<assets>/scenes/<source>/``)
    references; returns ``{source: [archives]}``, ``{}`` unless objaverse is configured."""
    return _core.install_objects_for_scene(Path(xml_path), exclude_thor)


def install_grasps_for_scene(xml_path: str | os.PathLike, grasp_source: str = "droid_objaverse",
                             exclude_thor: bool = True) -> dict[str, list[str]]:
    """Installs the archives of ``grasp_source`` matching the name tokens of each file the scene
    MJCF references; returns ``{grasp_source: [archives]}``, or ``{}`` for THOR's grasp sources
    (droid, rum) when THOR is excluded or when ``grasp_source`` is not configured."""
    return _core.install_grasps_for_scene(Path(xml_path), grasp_source, exclude_thor)


def find_object_paths(scene_xml: str | os.PathLike, exclude_thor: bool = True):
    """Yields ``(source, path relative to the source)`` for each ``../objects/...`` file the
    scene MJCF references (mesh, texture, material, hfield, skin under ``<asset>``)."""
    yield from (tuple(p) for p in _core.find_object_paths(Path(scene_xml), exclude_thor))


__all__ = [
    "find_object_paths",
    "install_grasps_for_scene",
    "install_objects_for_scene",
    "install_scene_with_objects_and_grasps_from_path",
    "install_uid",
    "locate_uid_package",
]
