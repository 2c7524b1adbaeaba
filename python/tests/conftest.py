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

from library_files import random_poses, write_library  # noqa: F401 (the tests import them here)

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
