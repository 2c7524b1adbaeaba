"""The library API: registration, UID lookup, grasps and scene metadata.

Every module-level function works on one process-default :class:`Registry`
(:func:`default_registry`); build your own :class:`Registry` to keep libraries apart.
Names, arguments and return types are MolmoSpaces' (``molmo_spaces.molmo_spaces_constants``,
``molmo_spaces.utils.lazy_loading_utils``, ``molmo_spaces.utils.grasps``,
``molmo_spaces.utils.scene_metadata_utils``). Where the original misbehaves, this does better
(docs/python.md, "Differences"):

- library paths may be ``str`` as well as ``Path``; they are resolved against the current
  directory when registered (the original resolves them again at every use), and the index
  is parsed then, so a bad index fails at registration;
- a grasp library's robots register in sorted order, all or none;
- every cache is cleared by a registration, so a lookup is never stale;
- nothing is downloaded to look up a user UID: built-in data answers only when an install
  dir is configured (``MLSPACES_ASSETS_DIR``, or the default dir when it exists);
- ``annotation`` returns a new dict on every call (the original shares one, so a caller's edit
  leaks into later calls);
- grasp arrays are always float64.
"""

from __future__ import annotations

import logging
import os
import random
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from . import _core
from . import _validate as _v
from .errors import MlspacesError

_log = logging.getLogger("mlspaces")

#: Built-in asset sources (MolmoSpaces' DATA_TYPE_TO_SOURCE_TO_VERSION["objects"] keys).
BUILTIN_OBJECT_SOURCES = ("objathor_metadata", "objaverse", "thor")
#: Built-in grasp libraries of each built-in asset source.
BUILTIN_OBJECT_TO_GRASP_LIBRARIES = {"thor": ["droid"], "objaverse": ["droid_objaverse"]}


def _getrandbits():
    """The getrandbits the engine draws grasp rows with: the global `random`'s, which
    random.sample uses (the engine reproduces random.sample's algorithm of CPython 3.10-3.14
    exactly; tests/test_library.py checks it against random.sample)."""
    return random.getrandbits


_MISSING = object()
_copy_tree = _core.copy_tree


def _uid(uid: Any, func: str) -> str:
    return uid if type(uid) is str else _v.string(uid, "uid", func)


def _joint(joint_name: Any, func: str) -> str:
    # "" is no joint (it read as the pickup grasps).
    if type(joint_name) is str and joint_name:
        return joint_name
    return _v.string(joint_name, "joint_name", func, empty=False)


def _libraries_arg(grasp_libraries: Any, func: str) -> list[str] | None:
    return _v.libraries(grasp_libraries, "grasp_libraries", func)


class Registry:
    """Asset and grasp libraries, and every lookup by UID.

    ``assets_dir`` is the install dir of built-in and packaged data (``None``: user libraries
    only). The dicts ``user_asset_libraries``, ``user_grasp_libraries`` and
    ``object_library_to_grasp_libraries`` mirror MolmoSpaces' module globals of the same names
    (upper case there); read them, do not write them.
    """

    def __init__(self, assets_dir: str | os.PathLike[str] | None = None) -> None:
        assets_dir = _v.optional_path(assets_dir, "assets_dir", "Registry")
        self._r = _core.Registry(assets_dir)
        self.assets_dir: Path | None = None if assets_dir is None else Path(assets_dir)
        self.user_asset_libraries: dict[str, Path] = {}
        self.user_grasp_libraries: dict[str, Path] = {}
        self.object_library_to_grasp_libraries: dict[str, list[str]] = {
            k: list(v) for k, v in BUILTIN_OBJECT_TO_GRASP_LIBRARIES.items()}
        self._locate: dict[str, tuple[Any, Any, Any]] = {}
        self._annotations: dict[str, Any] = {}
        self._objathor_checked = False
        #: (root_name, path, object_library) of each grasp library registration, in order.
        self.grasp_library_roots: list[tuple[str, Path, str]] = []

    # -- registration ---------------------------------------------------------------------

    def register_user_asset_library(self, name: str, path: str | os.PathLike[str]) -> None:
        """Registers ``path`` (a folder holding ``assets_index.json``) as asset library
        ``name``. Raises ``ValueError`` (:class:`MlspacesError`) for a name with ``/``, a name
        taken or built-in, or a missing or bad index."""
        func = "register_user_asset_library"
        name = _v.string(name, "name", func, empty=False)
        path = _v.path(path, "path", func)
        self._r.register_asset_library(name, path)
        self.user_asset_libraries[name] = Path(path).absolute()
        self._locate.clear()
        self._annotations.clear()

    def register_user_grasp_library(self, root_name: str, path: str | os.PathLike[str],
                                    object_library: str) -> None:
        """Registers ``path`` (a folder holding ``grasps_index.json``) as grasp libraries
        ``"<root_name>/<robot>"``, one per robot, in front of ``object_library``'s list."""
        func = "register_user_grasp_library"
        root_name = _v.string(root_name, "root_name", func, empty=False)
        path = _v.path(path, "path", func)
        object_library = _v.string(object_library, "object_library", func, empty=False)
        names = self._r.register_grasp_library(root_name, path, object_library)
        absolute = Path(path).absolute()
        for name in names:
            self.user_grasp_libraries[name] = absolute
        self.grasp_library_roots.append((root_name, absolute, object_library))
        self.object_library_to_grasp_libraries[object_library] = self._r.grasp_libraries_of(
            object_library)
        self._locate.clear()

    def library_config(self) -> dict[str, Any]:
        """The registrations as the engine's ``libraries`` config section."""
        return {
            "assets_dir": None if self.assets_dir is None else str(self.assets_dir),
            "asset_libraries": [{"name": n, "path": str(p)}
                                for n, p in self.user_asset_libraries.items()],
            "grasp_libraries": [{"name": n, "path": str(p), "asset_library": a}
                                for n, p, a in self.grasp_library_roots],
        }

    # -- assets ---------------------------------------------------------------------------

    def locate_uid_package(self, uid: str, extension: str = "xml"
                           ) -> tuple[str, str | None, Path] | tuple[None, None, None]:
        """``(source, package, mjcf_path)`` of a UID, or ``(None, None, None)``.

        ``package`` is the archive of a packaged library, else ``None``. ``extension`` is
        accepted for compatibility (every library holds MJCF ``.xml`` files)."""
        if type(extension) is not str:
            _v.string(extension, "extension", "locate_uid_package")
        try:
            return self._locate[uid]
        except (KeyError, TypeError):  # a miss, or an unhashable uid: checked below
            pass
        uid = _uid(uid, "locate_uid_package")
        found = self._r.locate(uid)
        result = (None, None, None) if found is None else found[:3]
        self._locate[uid] = result
        return result

    def install_uid(self, uid: str, grasp_source: str = "droid_objaverse") -> Path:
        """The MJCF path of a UID, installing its archive first when it is not installed yet
        (for a MolmoSpaces-format source, with the archives of ``grasp_source`` matching the
        tokens of the MJCF stem, as the original). Raises ``ValueError`` for an unknown UID."""
        uid = _uid(uid, "install_uid")
        grasp_source = _v.string(grasp_source, "grasp_source", "install_uid", empty=False)
        found = self._r.locate(uid)
        if found is None:
            # Not indexed here yet: with built-in data configured (a remote named, or sources
            # installed), the install sets the sources up and indexes them, and raises for a UID
            # no source has. Without, no network is touched for a user UID.
            assets = Path(_core.resolve_assets_dir(None)[0])
            if os.environ.get("MLSPACES_REMOTE_URL") or (
                    assets / "mjthor_data_type_to_source_to_versions.json").is_file():
                return Path(_core.install_uid(uid, grasp_source))
            raise MlspacesError(f"{uid} not found in asset libraries {self._r.asset_libraries()}",
                                uid=uid)
        if not found[3]:
            _core.install_uid(uid, grasp_source)
        return found[2]

    def annotation(self, uid: str) -> dict[str, Any] | None:
        """The metadata of a UID as a new dict (NPZ arrays inserted as numpy arrays of their
        stored dtype and shape, shared between calls and read-only), or ``None`` for an
        unknown UID."""
        try:
            template = self._annotations.get(uid, _MISSING)
        except TypeError:  # unhashable: refused below
            template = _MISSING
        if template is _MISSING:
            uid = _uid(uid, "annotation")
            self._ensure_objathor()
            # Cached, handed out only as copies; its arrays are read-only views of the store's.
            template = self._r.annotation(uid, template=True)
            self._annotations[uid] = template
        return None if template is None else _copy_tree(template)

    def all_uids(self) -> list[str]:
        """Every UID ``annotation`` answers, each once, in the union's order: the objathor
        metadata's, packed libraries', then the user libraries' (registration order, each
        library sorted)."""
        self._ensure_objathor()
        return self._r.annotated_uids()

    def _ensure_objathor(self) -> None:
        """The first annotation lookup converts the installed objathor metadata into our store
        when that was not done yet (as the original builds its LMDB on first use)."""
        if not self._objathor_checked and self.assets_dir is not None:
            self._r.ensure_objathor(os.fspath(self.assets_dir))
            self._annotations.clear()
        self._objathor_checked = True

    # -- grasps ---------------------------------------------------------------------------

    def get_grasp_libraries_for_object(self, uid: str) -> list[str]:
        """Grasp libraries serving the UID's asset library, highest priority first."""
        return self._r.grasp_libraries_for(_uid(uid, "get_grasp_libraries_for_object"), None)

    def get_pickup_grasp_path(self, uid: str, grasp_libraries: Sequence[str] | None = None
                              ) -> Path | None:
        func = "get_pickup_grasp_path"
        found = self._r.grasp_path(_uid(uid, func), "", _libraries_arg(grasp_libraries, func))
        return None if found is None else Path(found)

    def get_joint_grasp_path(self, uid: str, joint_name: str,
                             grasp_libraries: Sequence[str] | None = None) -> Path | None:
        func = "get_joint_grasp_path"
        found = self._r.grasp_path(_uid(uid, func), _joint(joint_name, func),
                                   _libraries_arg(grasp_libraries, func))
        return None if found is None else Path(found)

    def has_pickup_grasp_path(self, uid: str, grasp_libraries: Sequence[str] | None = None
                              ) -> bool:
        func = "has_pickup_grasp_path"
        return self._r.grasp_path(_uid(uid, func), "",
                                  _libraries_arg(grasp_libraries, func)) is not None

    def has_joint_grasp_path(self, uid: str, joint_name: str,
                             grasp_libraries: Sequence[str] | None = None) -> bool:
        func = "has_joint_grasp_path"
        return self._r.grasp_path(_uid(uid, func), _joint(joint_name, func),
                                  _libraries_arg(grasp_libraries, func)) is not None

    def has_valid_pickup_grasps(self, uid: str, num_grasps: int = 1,
                                grasp_libraries: Sequence[str] | None = None) -> bool:
        func = "has_valid_pickup_grasps"
        return self._r.has_valid_grasps(_uid(uid, func), "",
                                        _v.count(num_grasps, "num_grasps", func),
                                        _libraries_arg(grasp_libraries, func))

    def has_valid_joint_grasps(self, uid: str, joint_name: str, num_grasps: int = 1,
                               grasp_libraries: Sequence[str] | None = None) -> bool:
        func = "has_valid_joint_grasps"
        return self._r.has_valid_grasps(_uid(uid, func), _joint(joint_name, func),
                                        _v.count(num_grasps, "num_grasps", func),
                                        _libraries_arg(grasp_libraries, func))

    def load_pickup_grasps(self, uid: str, grasp_libraries: Sequence[str] | None = None,
                           num_grasps: int = 50) -> Any:
        """Grasps of a UID in its body frame: a fresh float64 ``(N, 4, 4)`` array. All of them
        when the file holds at most ``num_grasps``, else ``num_grasps`` rows drawn with
        Python's ``random.sample`` (as MolmoSpaces draws them). Raises ``ValueError`` when
        there is no grasp file."""
        func = "load_pickup_grasps"
        return self._r.load_grasps(_uid(uid, func), "", _libraries_arg(grasp_libraries, func),
                                   _v.count(num_grasps, "num_grasps", func), _getrandbits())

    def load_joint_grasps(self, uid: str, joint_name: str,
                          grasp_libraries: Sequence[str] | None = None,
                          num_grasps: int = 50) -> Any:
        """As :meth:`load_pickup_grasps`, for the grasps of one joint (in the frame of the
        joint's body)."""
        func = "load_joint_grasps"
        return self._r.load_grasps(_uid(uid, func), _joint(joint_name, func),
                                   _libraries_arg(grasp_libraries, func),
                                   _v.count(num_grasps, "num_grasps", func), _getrandbits())


_default: Registry | None = None
_default_lock = threading.Lock()


def default_registry() -> Registry:
    """The process-default registry the module functions use. Its install dir is
    ``MLSPACES_ASSETS_DIR`` when set, else the default install dir when it exists, else none
    (user libraries only: nothing is downloaded for a user UID)."""
    global _default
    if _default is None:
        with _default_lock:
            if _default is None:
                path, origin = _core.resolve_assets_dir(None)
                use = path if origin != "default" or Path(path).is_dir() else None
                _default = Registry(use)
    return _default


def register_user_asset_library(name: str, path: str | os.PathLike[str]) -> None:
    default_registry().register_user_asset_library(name, path)


def register_user_grasp_library(root_name: str, path: str | os.PathLike[str],
                                object_library: str) -> None:
    default_registry().register_user_grasp_library(root_name, path, object_library)


def locate_uid_package(uid: str, extension: str = "xml"):
    return default_registry().locate_uid_package(uid, extension)


def install_uid(uid: str, grasp_source: str = "droid_objaverse") -> Path:
    return default_registry().install_uid(uid, grasp_source)


def get_grasp_libraries_for_object(uid: str) -> list[str]:
    return default_registry().get_grasp_libraries_for_object(uid)


def get_pickup_grasp_path(uid: str, grasp_libraries: Sequence[str] | None = None) -> Path | None:
    return default_registry().get_pickup_grasp_path(uid, grasp_libraries)


def get_joint_grasp_path(uid: str, joint_name: str,
                         grasp_libraries: Sequence[str] | None = None) -> Path | None:
    return default_registry().get_joint_grasp_path(uid, joint_name, grasp_libraries)


def has_pickup_grasp_path(uid: str, grasp_libraries: Sequence[str] | None = None) -> bool:
    return default_registry().has_pickup_grasp_path(uid, grasp_libraries)


def has_joint_grasp_path(uid: str, joint_name: str,
                         grasp_libraries: Sequence[str] | None = None) -> bool:
    return default_registry().has_joint_grasp_path(uid, joint_name, grasp_libraries)


def has_valid_pickup_grasps(uid: str, num_grasps: int = 1,
                            grasp_libraries: Sequence[str] | None = None) -> bool:
    return default_registry().has_valid_pickup_grasps(uid, num_grasps, grasp_libraries)


def has_valid_joint_grasps(uid: str, joint_name: str, num_grasps: int = 1,
                           grasp_libraries: Sequence[str] | None = None) -> bool:
    return default_registry().has_valid_joint_grasps(uid, joint_name, num_grasps,
                                                     grasp_libraries)


def load_pickup_grasps(uid: str, grasp_libraries: Sequence[str] | None = None,
                       num_grasps: int = 50):
    return default_registry().load_pickup_grasps(uid, grasp_libraries, num_grasps)


def load_joint_grasps(uid: str, joint_name: str, grasp_libraries: Sequence[str] | None = None,
                      num_grasps: int = 50):
    return default_registry().load_joint_grasps(uid, joint_name, grasp_libraries, num_grasps)


def get_scene_metadata(mj_base_scene_path: str | os.PathLike[str]) -> dict[str, Any] | None:
    """The scene metadata beside a scene XML (``<scene>_metadata.json``, else the file of the
    longest ``_``-prefix of its stem) as a new dict, or ``None`` when there is none. Raises
    ``ValueError`` for a path that is not ``*.xml`` or a bad metadata file."""
    meta = _core.load_scene_metadata(
        _v.path(mj_base_scene_path, "mj_base_scene_path", "get_scene_metadata"))
    if meta is None:
        _log.warning("no scene metadata found for %s", mj_base_scene_path)
    return meta
