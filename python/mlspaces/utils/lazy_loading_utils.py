"""UID lookup and installing (``molmo_spaces.utils.lazy_loading_utils``), on the
process-default registry and the environment's resource settings (MLSPACES_CACHE_DIR,
MLSPACES_ASSETS_DIR, MLSPACES_REMOTE_URL, MLSPACES_PINNED_ASSETS_FILE)."""

from __future__ import annotations

import functools
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

from pydantic import TypeAdapter

from .. import _core
from .. import _validate as _v
from .._registry import install_uid, locate_uid_package


@dataclass(frozen=True)
class UserAssetLibraryIndexEntry:
    """One entry of a user library's ``assets_index.json`` (paths relative to the library)."""
    uid: str
    object_path: Path
    metadata_path: Path
    metadata_npz_path: Path | None = None


#: The schema of a whole ``assets_index.json`` (uid -> entry), as the original's pydantic
#: ``TypeAdapter``: ``UserAssetLibraryIndex.validate_json(text)``, ``.dump_json(index)``.
UserAssetLibraryIndex = TypeAdapter(dict[str, UserAssetLibraryIndexEntry])


@dataclass(frozen=True)
class UserGraspLibraryIndex:
    """A user grasp library's ``grasps_index.json`` (paths relative to the library)."""
    articulated_grasp_paths: dict[str, dict[str, dict[str, Path]]] = field(default_factory=dict)
    grasp_paths: dict[str, dict[str, Path]] = field(default_factory=dict)


def _index_error(file: Path, key: str, what: str) -> ValueError:
    return ValueError(f"{file}: {key}: {what}")


def _paths(file: Path, key: str, value, depth: int):
    """A nest of dicts ``depth`` deep whose leaves are path strings, as Paths."""
    if depth == 0:
        if not isinstance(value, str):
            raise _index_error(file, key, "expected a path string")
        return Path(value)
    if not isinstance(value, dict):
        raise _index_error(file, key, "expected an object")
    return {k: _paths(file, f"{key}/{k}", v, depth - 1) for k, v in value.items()}


def _cached_per_path(func):
    """``func(path)`` cached per path (``functools.cache``, as the original's, with its
    ``cache_clear``), the argument checked first (a path, named in the error)."""
    cached = functools.cache(func)

    @functools.wraps(func)
    def checked(path):
        return cached(Path(_v.path(path, "path", func.__name__)))
    checked.cache_clear = cached.cache_clear
    checked.cache_info = cached.cache_info
    return checked


def _read_json(file: Path):
    with _v.reading(file, "not a JSON file"):  # a missing file: FileNotFoundError naming it
        return json.loads(file.read_text())


@_cached_per_path
def get_user_library_index(path: Path) -> dict[str, UserAssetLibraryIndexEntry]:
    """The parsed ``assets_index.json`` of a user library dir (cached per path, as the
    original). Raises ``OSError`` when unreadable, ``ValueError`` naming the field when
    malformed."""
    file = Path(path) / "assets_index.json"
    doc = _read_json(file)
    if not isinstance(doc, dict):
        raise _index_error(file, "", "expected an object")
    out = {}
    for key, entry in doc.items():
        if not isinstance(entry, dict):
            raise _index_error(file, key, "expected an object")
        for name in ("uid", "object_path", "metadata_path"):
            if not isinstance(entry.get(name), str):
                raise _index_error(file, f"{key}/{name}", "expected a string")
        npz = entry.get("metadata_npz_path")
        if npz is not None and not isinstance(npz, str):
            raise _index_error(file, f"{key}/metadata_npz_path", "expected a string or null")
        out[key] = UserAssetLibraryIndexEntry(entry["uid"], Path(entry["object_path"]),
                                              Path(entry["metadata_path"]),
                                              None if npz is None else Path(npz))
    return out


@_cached_per_path
def get_user_grasp_library_index(path: Path) -> UserGraspLibraryIndex:
    """The parsed ``grasps_index.json`` of a user grasp library dir (cached per path).
    Raises ``OSError`` when unreadable, ``ValueError`` naming the field when malformed."""
    file = Path(path) / "grasps_index.json"
    doc = _read_json(file)
    if not isinstance(doc, dict):
        raise _index_error(file, "", "expected an object")
    return UserGraspLibraryIndex(
        _paths(file, "articulated_grasp_paths", doc.get("articulated_grasp_paths", {}), 3),
        _paths(file, "grasp_paths", doc.get("grasp_paths", {}), 2))


def install_scene_with_objects_and_grasps_from_path(
    xml_path: str | os.PathLike | dict,
    grasp_sources: tuple[str, ...] | list[str] = ("droid_objaverse",),
    exclude_thor: bool = True,
) -> dict[str, dict[str, list[str]]]:
    """Installs a scene archive (``xml_path`` a path inside a scene source or under
    ``<assets>/scenes``, a scene number, or ``{"base": path}``), then the objects and grasps
    its MJCFs reference through ``../objects/...``. Returns ``{"scenes": {source: [archives]},
    "objects": {...}, "grasps": {...}}``: every archive asked for, installed now or before."""
    func = "install_scene_with_objects_and_grasps_from_path"
    if isinstance(xml_path, dict):
        if "base" not in xml_path:
            raise _v.value_error(func, "xml_path", f"a dict needs the key 'base', got keys "
                                                   f"{sorted(map(str, xml_path))}")
        xml_path = xml_path["base"]
    if isinstance(xml_path, int) and not isinstance(xml_path, bool):
        scene = str(_v.integer(xml_path, "xml_path", func, minimum=0))
    else:
        scene = _v.path(xml_path, "xml_path", func)
    return _core.install_scene_with_objects_and_grasps_from_path(
        scene, _v.strings(grasp_sources, "grasp_sources", func),
        _v.boolean(exclude_thor, "exclude_thor", func))


def install_objects_for_scene(xml_path: str | os.PathLike, exclude_thor: bool = True
                              ) -> dict[str, list[str]]:
    """Installs the object archives an installed scene MJCF (under ``<assets>/scenes/<source>/``)
    references; returns ``{source: [archives]}``, ``{}`` unless objaverse is configured."""
    func = "install_objects_for_scene"
    return _core.install_objects_for_scene(Path(_v.path(xml_path, "xml_path", func)),
                                           _v.boolean(exclude_thor, "exclude_thor", func))


def install_grasps_for_scene(xml_path: str | os.PathLike, grasp_source: str = "droid_objaverse",
                             exclude_thor: bool = True) -> dict[str, list[str]]:
    """Installs the archives of ``grasp_source`` matching the name tokens of each file the scene
    MJCF references; returns ``{grasp_source: [archives]}``, or ``{}`` for THOR's grasp sources
    (droid, rum) when THOR is excluded or when ``grasp_source`` is not configured."""
    func = "install_grasps_for_scene"
    return _core.install_grasps_for_scene(
        Path(_v.path(xml_path, "xml_path", func)),
        _v.string(grasp_source, "grasp_source", func, empty=False),
        _v.boolean(exclude_thor, "exclude_thor", func))


def find_object_paths(scene_xml: str | os.PathLike, exclude_thor: bool = True):
    """Yields ``(source, path relative to the source)`` for each ``../objects/...`` file the
    scene MJCF references (mesh, texture, material, hfield, skin under ``<asset>``)."""
    func = "find_object_paths"
    found = _core.find_object_paths(Path(_v.path(scene_xml, "scene_xml", func)),
                                    _v.boolean(exclude_thor, "exclude_thor", func))
    return (tuple(p) for p in found)


__all__ = [
    "UserAssetLibraryIndex",
    "UserAssetLibraryIndexEntry",
    "UserGraspLibraryIndex",
    "get_user_grasp_library_index",
    "get_user_library_index",
    "find_object_paths",
    "install_grasps_for_scene",
    "install_objects_for_scene",
    "install_scene_with_objects_and_grasps_from_path",
    "install_uid",
    "locate_uid_package",
]
