"""Fixtures of the mlspaces Python tests: the tutorial's library, and libraries written here
with numpy (the files a MolmoSpaces user has)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SOURCE_DIR = Path(os.environ.get("MLSPACES_SOURCE_DIR", Path(__file__).resolve().parents[2]))
EXAMPLE_DIR = SOURCE_DIR / "examples" / "custom_assets"
CLI = os.environ.get("MLSPACES_CLI_PATH", "mlspaces")


def mlspaces(*args: str) -> subprocess.CompletedProcess:
    """The mlspaces command (MLSPACES_CLI_PATH) with `args`, its output captured as text."""
    return subprocess.run([CLI, *args], capture_output=True, text=True)


def obs_scene(traj) -> dict:
    """An h5py trajectory group's obs_scene JSON (NUL-padded bytes or str), read directly."""
    raw = traj["obs_scene"][()]
    if isinstance(raw, bytes):
        raw = raw.rstrip(b"\0").decode()
    return json.loads(raw)


@pytest.fixture
def tutorial_library() -> Path:
    return EXAMPLE_DIR / "asset_library"


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def random_poses(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        out[i, :3, :3] = random_rotation(rng)
        out[i, :3, 3] = rng.uniform(-0.2, 0.2, size=3)
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


def run_datagen_module(project: Path, spec: str, *args: str) -> subprocess.CompletedProcess:
    """`python -m mlspaces.datagen SPEC --output run --seed 0 -q ARGS` in `project`, without
    a configured install dir of built-in data."""
    env = dict(os.environ)
    env.pop("MLSPACES_ASSETS_DIR", None)
    return subprocess.run(
        [sys.executable, "-m", "mlspaces.datagen", spec, "--output", "run", "--seed", "0", "-q",
         *args], cwd=project, env=env, capture_output=True, text=True)


SMALL_CAMERA_SIZE = (96, 64)  # (width, height), multiples of 16: videos hold exactly this size


def small_camera_run(folder: Path, episodes: int) -> Path:
    """The tutorial (a copy of examples/custom_assets in `folder`) run through
    `python -m mlspaces.datagen` with SMALL_CAMERA_SIZE wrist and exo images, no shadows or
    reflections (rendering dominates otherwise), `episodes` successful episodes in house_0;
    returns the run folder."""
    width, height = SMALL_CAMERA_SIZE
    config = f"""
from datagen import FrankaPickDroidDataGenConfig
from mlspaces.configs import FrankaDroidCameraSystem, PickTaskSamplerConfig
from mlspaces.data_generation.config_registry import register_config

_SAMPLER = FrankaPickDroidDataGenConfig.model_fields["task_sampler_config"].default


@register_config("SmallCameraConfig")
class SmallCameraConfig(FrankaPickDroidDataGenConfig):
    camera_config: FrankaDroidCameraSystem = FrankaDroidCameraSystem(
        img_resolution=({width}, {height}), shadows=False, reflections=False)
    task_sampler_config: PickTaskSamplerConfig = _SAMPLER.model_copy(
        update={{"samples_per_house": {episodes}}})
"""
    project = folder / "custom_assets"
    shutil.copytree(EXAMPLE_DIR, project, ignore=shutil.ignore_patterns("experiment_output"))
    (project / "small_camera_config.py").write_text(config)
    out = run_datagen_module(project, "small_camera_config:SmallCameraConfig")
    assert out.returncode == 0, out.stderr
    assert f"Success count: {episodes}, Total count: {episodes}" in out.stdout
    return project / "run"


def jitter_robot_base(env, task_config, noise: float = 0.05) -> None:
    """A sampler hook's first half: the robot base moved by U(-noise, noise) in x and y
    (np.random), kinematics refreshed, robot_base_pose set."""
    import mujoco
    import numpy as np

    from mlspaces.utils.pose import pose_mat_to_7d
    base = env.current_robot.robot_view.base
    pose = base.pose
    pose[:2, 3] += np.random.uniform(-noise, noise, size=2)
    base.pose = pose
    mujoco.mj_fwdPosition(env.current_model, env.current_data)
    task_config.robot_base_pose = pose_mat_to_7d(base.pose).tolist()
