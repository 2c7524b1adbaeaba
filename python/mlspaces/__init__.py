"""mlspaces: MolmoSpaces' asset and grasp libraries and data engine, on a C++ engine.

A MolmoSpaces user changes ``molmo_spaces`` to ``mlspaces`` in import lines and nothing else:
the modules under ``mlspaces`` mirror the original's paths (``mlspaces.molmo_spaces_constants``,
``mlspaces.utils.grasps``, ``mlspaces.utils.object_metadata``, ...). The flat names here are the
canonical ones.

``import mujoco`` stays the user's own import, and both share one MuJoCo: this package imports
``mujoco`` first, and its extension links the ``libmujoco`` of that same ``mujoco`` package.
"""

from __future__ import annotations

import os as _os
from pathlib import Path as _Path

import mujoco as _mujoco  # first: the extension links the libmujoco this package ships

from . import _core
from .errors import (HouseInvalidForTask, MlspacesError, MlspacesFileError, MlspacesKeyError,
                     MlspacesTypeError, RobotPlacementError, UsageError)

if _core.mujoco_runtime_version() != _mujoco.__version__:  # pragma: no cover - broken installs
    raise ImportError(
        f"mlspaces was built against MuJoCo {_core.MUJOCO_BUILD_VERSION} but the process runs "
        f"libmujoco {_core.mujoco_runtime_version()} while the mujoco package is "
        f"{_mujoco.__version__}: install the mujoco version mlspaces pins")

__version__: str = _core.__version__

# An installed wheel carries the bundled robot models beside the package (in the folder of the
# mlspaces.robots modules).
if (_Path(__file__).parent / "robots" / "franka_droid").is_dir():
    _os.environ.setdefault("MLSPACES_ROBOTS_DIR", str(_Path(__file__).parent / "robots"))

from ._registry import (Registry, default_registry, get_grasp_libraries_for_object,  # noqa: E402
                        get_joint_grasp_path, get_pickup_grasp_path, get_scene_metadata,
                        has_joint_grasp_path, has_pickup_grasp_path, has_valid_joint_grasps,
                        has_valid_pickup_grasps, install_uid, load_joint_grasps,
                        load_pickup_grasps, locate_uid_package, register_user_asset_library,
                        register_user_grasp_library)
from .reader import read_dataset  # noqa: E402
from .utils.grasps import flip_grasps  # noqa: E402
from .utils.object_metadata import ObjectMeta  # noqa: E402
from .utils.pose import pos_quat_to_pose_mat, pose_mat_to_7d, pose_mat_to_pos_quat  # noqa: E402

__all__ = [
    "HouseInvalidForTask", "MlspacesError", "MlspacesFileError", "MlspacesKeyError",
    "MlspacesTypeError", "ObjectMeta", "Registry",
    "RobotPlacementError", "UsageError", "default_registry", "flip_grasps",
    "get_grasp_libraries_for_object", "get_joint_grasp_path", "get_pickup_grasp_path",
    "get_scene_metadata", "has_joint_grasp_path", "has_pickup_grasp_path",
    "has_valid_joint_grasps", "has_valid_pickup_grasps", "install_uid", "load_joint_grasps",
    "load_pickup_grasps", "locate_uid_package", "pos_quat_to_pose_mat", "pose_mat_to_7d",
    "pose_mat_to_pos_quat", "read_dataset", "register_user_asset_library",
    "register_user_grasp_library",
]
