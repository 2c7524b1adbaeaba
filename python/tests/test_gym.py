"""The evaluation env: a real gymnasium.Env from a datagen config (declared spaces, env
checker, vector env, determinism) that replays a recorded episode's actions to the same
states and success."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import gymnasium
import h5py
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import mlspaces
from mlspaces.configs import (CameraSystemConfig, FrankaRobotConfig, PickBaseConfig,
                              PickTaskSamplerConfig)
from mlspaces.configs.camera_configs import CameraConfig
from mlspaces.datagen import register_config, run_config
from mlspaces.env import create_mlspaces_body
from mlspaces.tasks import PickTaskSampler
from mlspaces.tasks.gym_env import GymEnv, env_id_for_config, register_configs
from mlspaces.utils.pose import pose_mat_to_7d

from conftest import EXAMPLE_DIR, jitter_robot_base


class TinySampler(PickTaskSampler):
    """The tutorial's hook (np.random draws, writes through the body views)."""

    def _sample_and_place_robot(self, env) -> None:
        task_cfg = self.config.task_config
        jitter_robot_base(env, task_cfg)
        obj = create_mlspaces_body(env.current_data, task_cfg.pickup_obj_name)
        start = pose_mat_to_7d(obj.pose)
        task_cfg.pickup_obj_start_pose = start.tolist()
        start[2] += 0.05
        task_cfg.pickup_obj_goal_pose = start.tolist()


def _small_cameras(object_image_points: bool = True) -> CameraSystemConfig:
    return CameraSystemConfig(
        img_resolution=(64, 48), shadows=False, reflections=False,
        object_image_points=object_image_points,
        cameras=[CameraConfig(name="wrist_camera", type="mjcf",
                              mjcf_name="gripper/wrist_camera", robot_namespace="robot_0/",
                              fov=56.74)])


@register_config("GymTestConfig", strict=False)
class GymTestConfig(PickBaseConfig):
    robot_config: FrankaRobotConfig = FrankaRobotConfig(base_size=None)
    camera_config: CameraSystemConfig = _small_cameras()
    task_sampler_config: PickTaskSamplerConfig = PickTaskSamplerConfig(
        task_sampler_class=TinySampler, scene_xml_paths=[str(EXAMPLE_DIR / "scene.xml")],
        samples_per_house=1)
    task_horizon: int = 40


@pytest.fixture(scope="module", autouse=True)
def libraries():
    reg = mlspaces.default_registry()
    if "custom_assets" not in reg.user_asset_libraries:
        mlspaces.register_user_asset_library("custom_assets", EXAMPLE_DIR / "asset_library")
        mlspaces.register_user_grasp_library("custom_grasps", EXAMPLE_DIR / "asset_library",
                                             "custom_assets")


def test_registered_env_passes_the_checker_with_declared_spaces():
    assert env_id_for_config("GymTestConfig") == "MolmoSpaces/GymTestConfig-v0"
    assert "MolmoSpaces/GymTestConfig-v0" in register_configs() + list(gymnasium.registry)
    assert register_configs() == []  # idempotent
    # gymnasium's checker compares observations with np.allclose, which holds NaN unequal to
    # itself: object_image_points' NaN padding is checked in the next test.
    env = gymnasium.make("MolmoSpaces/GymTestConfig-v0", render_mode="rgb_array",
                         config_overrides={"camera_config": _small_cameras(False)})
    assert "object_image_points" not in env.observation_space["extra"].spaces
    check_env(env.unwrapped, skip_render_check=False)
    obs, info = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    assert obs["sensor_data"]["wrist_camera"].shape == (48, 64, 3)
    assert obs["sensor_data"]["wrist_camera"].dtype == np.uint8
    assert obs["sensor_data"]["wrist_camera"].std() > 0
    assert info["task"]["pickup_obj_name"] == "red_block" and "success" in info
    frame = env.render()
    assert frame.shape == (48, 64, 3) and frame.dtype == np.uint8
    action = env.action_space.sample()
    obs2, reward, terminated, truncated, info = env.step(action)
    assert env.observation_space.contains(obs2)
    assert isinstance(reward, float) and not terminated and not truncated
    env.close()


def test_observations_carry_object_image_points_as_the_dataset():
    env = GymEnv("GymTestConfig")
    space = env.observation_space["extra"]["object_image_points"]
    assert list(space.spaces) == ["gripper", "pickup_obj"]
    a = env.reset(seed=3)[0]
    points = a["extra"]["object_image_points"]
    assert env.observation_space.contains(a)
    for key in ("gripper", "pickup_obj"):
        entry = points[key]["wrist_camera"]
        assert entry["points"].shape == (10, 2) and entry["points"].dtype == np.float32
        assert entry["num_points"].shape == (1,) and entry["num_points"].dtype == np.int32
        n = int(entry["num_points"][0])
        assert np.all(np.isnan(entry["points"][n:]))
        assert np.all((entry["points"][:n] >= 0) & (entry["points"][:n] <= 1))
    # The wrist camera sees the gripper's fingers from the first frame.
    assert points["gripper"]["wrist_camera"]["num_points"][0] == 10
    # The block's points lie on red pixels of the frame they come with.
    frame = a["sensor_data"]["wrist_camera"].astype(int)
    block = points["pickup_obj"]["wrist_camera"]
    assert block["num_points"][0] == 10
    cols = (block["points"][:, 0] * 64).round().astype(int)
    rows = (block["points"][:, 1] * 48).round().astype(int)
    rgb = frame[rows, cols]
    assert np.all(rgb[:, 0] > rgb[:, 1] + 40), rgb
    # Same seed, same points; render() draws none.
    env.render_mode = "rgb_array"
    env.render()
    b = env.reset(seed=3)[0]
    for key in ("gripper", "pickup_obj"):
        np.testing.assert_array_equal(points[key]["wrist_camera"]["points"],
                                      b["extra"]["object_image_points"][key]["wrist_camera"]["points"])
    c = env.step(env.action_space.sample())[0]
    assert env.observation_space.contains(c)
    env.close()


def test_seeded_resets_are_deterministic_and_bad_actions_are_value_errors():
    env = GymEnv("GymTestConfig")
    a = env.reset(seed=11)[0]
    b = env.reset(seed=11)[0]
    c = env.reset(seed=12)[0]
    np.testing.assert_array_equal(a["extra"]["robot_base_pose"], b["extra"]["robot_base_pose"])
    assert not np.array_equal(a["extra"]["robot_base_pose"], c["extra"]["robot_base_pose"])
    for bad in ({"arm": np.zeros(6), "gripper": [0.0]}, {"arm": None, "gripper": [0.0]},
                {"arm": [np.nan] * 7, "gripper": [0.0]}, {"gripper": [0.0]}, [1, 2]):
        with pytest.raises(ValueError):
            env.step(bad)
    with pytest.raises(ValueError):
        GymEnv("GymTestConfig", config_overrides={"no_such_field": 1})
    with pytest.raises(ValueError):
        GymEnv("NoSuchConfig")


def test_async_vector_env(tmp_path):
    """AsyncVectorEnv with its default (fork) context, in a fresh process: the parent builds
    the vector env before any rendering, each worker renders on its own."""
    code = f"""
import sys
sys.path.insert(0, {str(Path(__file__).parent)!r})
import gymnasium
import test_gym
from mlspaces.tasks.gym_env import GymEnv
envs = gymnasium.vector.AsyncVectorEnv([lambda: GymEnv("GymTestConfig") for _ in range(2)])
obs, info = envs.reset(seed=[1, 2])
assert obs["sensor_data"]["wrist_camera"].shape == (2, 48, 64, 3), obs["sensor_data"]
obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
assert reward.shape == (2,)
envs.close()
print("ok")
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=600, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr


def test_rendering_in_a_child_forked_after_rendering_is_a_clear_error():
    env = GymEnv("GymTestConfig", render_mode="rgb_array")
    env.reset(seed=1)
    env.render()  # this process has rendered
    pid = os.fork()
    if pid == 0:
        code = 3
        try:
            GymEnv("GymTestConfig").reset(seed=1)
            code = 1
        except ValueError as e:
            code = 0 if "fork" in str(e) else 2
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


def test_replaying_a_recorded_episode_reaches_the_same_states_and_success(tmp_path,
                                                                         monkeypatch):
    # Record one episode (float64 actions, so the replayed targets are exact).
    cfg = GymTestConfig(task_horizon=500)
    cfg.task_config.action_dtype = "float64"
    monkeypatch.chdir(tmp_path)
    report = run_config(cfg, output_dir=tmp_path / "run", seed=5, progress=False)
    assert report["episodes_kept"] == 1
    with h5py.File(tmp_path / "run" / "house_0" / "trajectories_batch_1_of_1.h5", "r") as f:
        traj = f["traj_0"]

        def rows(name):
            data = traj[name][()]
            return [json.loads(bytes(r).rstrip(b"\0")) for r in data]
        commanded = rows("actions/commanded_action")
        qpos = rows("obs/agent/qpos")
        success = traj["success"][()]
        recorded_points = {k: traj[f"obs/extra/object_image_points/{k}/wrist_camera/points"][()]
                           for k in ("gripper", "pickup_obj")}
    env = GymEnv(exp_config=cfg)
    obs, info = env.reset(seed=5, options={"episode": 0})
    # The dataset stores joint states rounded to float32.
    np.testing.assert_allclose(obs["agent"]["qpos"]["arm"], qpos[0]["arm"], rtol=0, atol=2e-6)

    def same_points(obs, t):
        # The replay's observations carry the dataset's object_image_points: the same pixels,
        # drawn from the episode's own stream.
        for key, rec in recorded_points.items():
            got = obs["extra"]["object_image_points"][key]["wrist_camera"]["points"]
            np.testing.assert_array_equal(got, rec[t], err_msg=f"{key} at step {t}")
    same_points(obs, 0)
    seen = 0
    last = None
    for t in range(1, len(commanded)):
        act = commanded[t]
        if not act.get("arm"):
            break  # the `done` row
        obs, reward, terminated, truncated, info = env.step(
            {"arm": act["arm"], "gripper": act["gripper"]})
        np.testing.assert_allclose(obs["agent"]["qpos"]["arm"], qpos[t]["arm"], rtol=0,
                                   atol=2e-6, err_msg=f"step {t}")
        np.testing.assert_allclose(obs["agent"]["qpos"]["gripper"], qpos[t]["gripper"],
                                   rtol=0, atol=2e-6, err_msg=f"step {t}")
        same_points(obs, t)
        seen += int(obs["extra"]["object_image_points"]["pickup_obj"]["wrist_camera"]
                    ["num_points"][0] > 0)
        last = info["success"]
    assert last == bool(success[-1]) == True  # noqa: E712
    assert seen > 0  # the block was in the wrist camera's view at some steps
