"""User libraries written with numpy as a MolmoSpaces user has them (an MJCF, a metadata JSON
and np.savez grasps per UID, MolmoSpaces' index files): for the Python tests (conftest.py)
and bench/python_api_bench.py, whose workers also run in the original's venv. numpy only."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def _rotations(q: np.ndarray) -> np.ndarray:
    """The rotation matrices of quaternions `q` (N x 4, w x y z; normalised here)."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def random_poses(n: int, seed: int) -> np.ndarray:
    """`n` 4x4 poses: uniformly random rotations, positions in [-0.2, 0.2] m."""
    rng = np.random.default_rng(seed)
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, :3] = _rotations(rng.normal(size=(n, 4)))
    out[:, :3, 3] = rng.uniform(-0.2, 0.2, size=(n, 3))
    return out


MINIMAL_MJCF = """<mujoco model="{uid}">
  <worldbody><body name="{uid}"><freejoint/><geom type="box" size="0.02 0.02 0.02"/></body>
  </worldbody>
</mujoco>
"""


def write_library(root: Path, uids: dict[str, int], robots=("droid",), npz_meta: bool = False,
                  joints: dict[str, list[str]] | None = None) -> Path:
    """A user asset + grasp library under `root`: for each uid, an MJCF, a metadata JSON and
    `n` grasps per robot (np.savez), indexes as MolmoSpaces writes them."""
    root.mkdir(parents=True, exist_ok=True)
    assets, grasp_paths, joint_paths = {}, {}, {}
    for k, (uid, n) in enumerate(sorted(uids.items())):
        d = root / uid
        d.mkdir(exist_ok=True)
        (d / f"{uid}.xml").write_text(MINIMAL_MJCF.format(uid=uid))
        meta = {"uid": uid, "category": "block", "description": f"a {uid}",
                "description_long": f"a long {uid}",
                "description_short": {"one_word": "block", "two_words": f"{uid} block",
                                      "three_words": f"small {uid} block"},
                "mass": 0.05 + k, "boundingBox": {"x": 0.04, "y": 0.04, "z": 0.04}}
        (d / f"{uid}.json").write_text(json.dumps(meta, indent=2))
        entry = {"uid": uid, "object_path": f"{uid}/{uid}.xml",
                 "metadata_path": f"{uid}/{uid}.json", "metadata_npz_path": None}
        if npz_meta:
            np.savez(d / f"{uid}_meta.npz",
                     **{"clip_img_features": np.arange(12, dtype=np.float32).reshape(3, 4) + k,
                        "extra/ids": np.array([1, 2, 3], dtype=np.int64)})
            entry["metadata_npz_path"] = f"{uid}/{uid}_meta.npz"
        assets[uid] = entry
        for r_i, robot in enumerate(robots):
            (d / robot).mkdir(exist_ok=True)
            np.savez(d / robot / "grasps.npz", transforms=random_poses(n, 100 * k + r_i))
            grasp_paths.setdefault(robot, {})[uid] = f"{uid}/{robot}/grasps.npz"
            for joint in (joints or {}).get(uid, []):
                np.savez(d / robot / f"joint_grasps_{joint}.npz",
                         transforms=random_poses(n + 1, 7 + k))
                joint_paths.setdefault(robot, {}).setdefault(uid, {})[joint] = (
                    f"{uid}/{robot}/joint_grasps_{joint}.npz")
    (root / "assets_index.json").write_text(json.dumps(assets, indent=4, sort_keys=True))
    (root / "grasps_index.json").write_text(json.dumps(
        {"articulated_grasp_paths": joint_paths, "grasp_paths": grasp_paths}, indent=4))
    return root
