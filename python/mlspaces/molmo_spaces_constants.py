"""Library registration and global state (``molmo_spaces.molmo_spaces_constants``).

The dicts below are the process-default registry's own: a registration shows in them at once,
wherever they were imported. Read them; register through the functions.

``python -m mlspaces.molmo_spaces_constants`` sets the built-in data up as the original's does
(every pinned source's manifest, tries and install link, its EAGER archives, and post_setup's
scene archives), from the environment's settings (MLSPACES_CACHE_DIR, MLSPACES_ASSETS_DIR,
MLSPACES_REMOTE_URL, MLSPACES_PINNED_ASSETS_FILE; docs/resources.md). An error is one
``mlspaces: error: ...`` line and exit code 1.
"""

from __future__ import annotations

import os
from pathlib import Path

from . import _core
from ._registry import (BUILTIN_OBJECT_SOURCES, default_registry, register_user_asset_library,
                        register_user_grasp_library)

#: The install dir of built-in data (MLSPACES_ASSETS_DIR, else the default).
ASSETS_DIR: Path = Path(_core.resolve_assets_dir(None)[0])
#: The download cache (MLSPACES_CACHE_DIR, else ~/.cache/molmo-spaces-resources).
DATA_CACHE_DIR: Path = Path(os.environ.get("MLSPACES_CACHE_DIR") or
                            Path.home() / ".cache" / "molmo-spaces-resources")

USER_ASSET_LIBRARIES: dict[str, Path] = default_registry().user_asset_libraries
USER_GRASP_LIBRARIES: dict[str, Path] = default_registry().user_grasp_libraries
OBJECT_LIBRARY_TO_GRASP_LIBRARIES: dict[str, list[str]] = (
    default_registry().object_library_to_grasp_libraries)
#: Built-in sources (the versions are the installer's pins; see `mlspaces install`).
DATA_TYPE_TO_SOURCE_TO_VERSION: dict[str, dict[str, str]] = {
    "objects": {name: "" for name in BUILTIN_OBJECT_SOURCES},
    "grasps": {"droid": "", "droid_objaverse": ""},
}


def print_license_info(data_type, data_source, asset_or_tar_id=None):
    """Prints the licence of an item (``mlspaces.utils.license_utils.print_license_info``)."""
    from .utils.license_utils import print_license_info as _print
    _print(data_type, data_source, asset_or_tar_id)


def _set_up_builtin_data() -> int:
    import json
    import sys

    from .errors import MlspacesError
    try:
        _core.install_uids([])  # no UID: the set-up (and post_setup) alone
        manifest = ASSETS_DIR / "mjthor_data_type_to_source_to_versions.json"
        installed = json.loads(manifest.read_text()) if manifest.is_file() else {}
    except (MlspacesError, OSError, ValueError) as e:
        sys.stderr.write(f"mlspaces: error: {e}\n")
        return 1
    if not any(installed.values()):
        remote = os.environ.get("MLSPACES_REMOTE_URL") or "the default remote"
        sys.stderr.write(f"mlspaces: error: {manifest}: no built-in source is set up (none of "
                         f"the pinned sources was found on {remote}; MLSPACES_REMOTE_URL)\n")
        return 1
    sources = sorted(f"{t}/{s}" for t, srcs in installed.items() for s in srcs)
    print(f"Set up {len(sources)} sources in {ASSETS_DIR}: {', '.join(sources)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(_set_up_builtin_data())

__all__ = ["ASSETS_DIR", "DATA_CACHE_DIR", "DATA_TYPE_TO_SOURCE_TO_VERSION",
           "OBJECT_LIBRARY_TO_GRASP_LIBRARIES", "USER_ASSET_LIBRARIES", "USER_GRASP_LIBRARIES",
           "print_license_info", "register_user_asset_library", "register_user_grasp_library"]
