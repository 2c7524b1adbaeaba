"""Open / close tasks through the `mlspaces` command (docs/tasks.md): the example configs
(examples/open_close) generate episodes that succeed, record the chosen joint and describe the
close task as closing; validate-dataset passes; a bad task field is one line naming the file
and the field."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from conftest import SOURCE_DIR, mlspaces, obs_scene

EXAMPLE = SOURCE_DIR / "examples" / "open_close"


@pytest.mark.parametrize("task,verb,start", [("open", "Open", 0.0), ("close", "Close", 0.5)])
def test_episodes_succeed_record_the_joint_and_validate(tmp_path: Path, task, verb, start):
    out = tmp_path / task
    r = mlspaces("datagen", str(EXAMPLE / f"datagen_{task}.yaml"), "--episodes", "2",
                 "--seed", "2", "--output", str(out), "-q",
                 "--set", "task_config.enable_rendering=false")
    assert r.returncode == 0, r.stderr
    assert mlspaces("validate-dataset", str(out)).returncode == 0
    with h5py.File(out / "house_0" / "trajectories_batch_1_of_1.h5") as f:
        assert sorted(f) == ["traj_0", "traj_1"]
        for k in f:
            t = f[k]
            scene = obs_scene(t)
            joint = scene["joint"]
            assert scene["task_type"] == task
            assert scene["task_description"].startswith(verb + " the ")
            assert joint["joint_name"] in ("drawer_slide", "door_hinge")
            assert scene["frozen_config"]["joint_name"] == joint["joint_name"]
            lo, hi = joint["joint_range"]
            assert joint["joint_start_position"] == pytest.approx(start * (hi - lo) + lo)
            np.testing.assert_allclose(t["obs/extra/joint_range"][:], [[lo, hi]] * len(t["success"]),
                                       rtol=1e-6)
            frac = t["obs/extra/joint_opened_fraction"][:]
            assert frac[0] == pytest.approx(start, abs=1e-6)
            assert bool(t["success"][-1])
            assert t["rewards"][-1] >= joint["task_success_threshold"]
            info = json.loads(bytes(t["obs/extra/task_info"][-1]).rstrip(b"\0"))
            assert set(info) >= {"joint_position", "success", "episode_step"}


def test_a_bad_task_field_is_one_line_naming_file_and_field(tmp_path: Path):
    text = (EXAMPLE / "datagen_close.yaml").read_text()
    text = text.replace("[scene.xml]", f"[{EXAMPLE / 'scene.xml'}]")
    text = text.replace("path: ../objects", f"path: {EXAMPLE.parent / 'objects'}")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("task_success_threshold: 0.85", "task_success_threshold: 2"))
    r = mlspaces("datagen", str(bad), "--output", str(tmp_path / "run"))
    assert r.returncode == 1
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert str(bad) in lines[0] and "task_config.task_success_threshold" in lines[0]


def test_cameras_record_videos_that_validate(tmp_path: Path):
    out = tmp_path / "cams"
    r = mlspaces("datagen", str(EXAMPLE / "datagen_close.yaml"), "--episodes", "1", "--seed", "2",
                 "--output", str(out), "-q", "--set", "camera_config.img_resolution=[64, 48]",
                 "--set", "camera_config.shadows=false", "--set", "camera_config.reflections=false")
    assert r.returncode == 0, r.stderr
    assert len(list((out / "house_0").glob("*.mp4"))) == 2  # wrist and exo cameras
    v = mlspaces("validate-dataset", str(out))
    assert v.returncode == 0 and "2 videos: ok" in v.stdout, v.stdout + v.stderr


def _python_close_config():
    """datagen_close.yaml as a Python config, with the Python OpenTaskSampler."""
    import mlspaces
    from mlspaces.configs import (CameraSystemConfig, FrankaRobotConfig, PickBaseConfig,
                                  PickTaskSamplerConfig)
    from mlspaces.configs.camera_configs import CameraConfig
    from mlspaces.tasks import OpenTaskSampler

    objects = SOURCE_DIR / "examples" / "objects"
    if "example_objects" not in mlspaces.default_registry().user_asset_libraries:
        mlspaces.register_user_asset_library("example_objects", objects)
        mlspaces.register_user_grasp_library("example_objects_grasps", objects, "example_objects")

    class FrankaCloseConfig(PickBaseConfig):
        task_type: str = "close"
        task_horizon: int = 300
        robot_config: FrankaRobotConfig = FrankaRobotConfig(base_size=None)
        camera_config: CameraSystemConfig = CameraSystemConfig(
            img_resolution=(64, 48), shadows=False, reflections=False,
            cameras=[CameraConfig(name="wrist_camera", type="mjcf",
                                  mjcf_name="gripper/wrist_camera", robot_namespace="robot_0/",
                                  fov=56.74)])
        task_sampler_config: PickTaskSamplerConfig = PickTaskSamplerConfig(
            task_sampler_class=OpenTaskSampler, scene_xml_paths=[str(EXAMPLE / "scene.xml")],
            samples_per_house=2, robot_base_noise={"x": 0.05, "y": 0.05, "yaw_deg": 10})
        seed: int = 1

        def model_post_init(self, ctx) -> None:
            super().model_post_init(ctx)
            self.task_config.enable_rendering = False
            self.policy_config.grasp_horizontal_cost_weight = 10.0
            self.policy_config.grasp_cost_weights = {"pos": 1.0, "rot": 0.05, "vertical": 0.0,
                                                     "com_dist": 0.0}

    return FrankaCloseConfig


def test_the_python_open_task_sampler_runs_the_engines(tmp_path: Path, monkeypatch):
    from mlspaces.datagen import run_config

    config_class = _python_close_config()
    monkeypatch.chdir(tmp_path)
    report = run_config(config_class(), output_dir="out", progress=False)
    assert report["episodes_kept"] == 2
    with h5py.File(tmp_path / "out" / "house_0" / "trajectories_batch_1_of_1.h5") as f:
        for k in f:
            assert obs_scene(f[k])["task_description"].startswith("Close the ")



def test_a_python_subclass_of_open_task_sampler_runs_its_hooks(tmp_path: Path, monkeypatch):
    """The hooks a subclass overrides run in Python, the others (and super()) in the engine:
    the joint is still chosen and the close task still described; the override's changes
    show in the episodes."""
    from mlspaces.datagen import run_config
    from mlspaces.tasks import OpenTaskSampler

    calls: list[str] = []

    class Hooked(OpenTaskSampler):
        def _on_candidate_selected(self, env, name, body_id, geom_id) -> bool:
            calls.append(name)
            return True

        def _sample_and_place_robot(self, env) -> None:
            super()._sample_and_place_robot(env)
            self.config.task_config.pickup_obj_goal_pose[2] += 0.01

    config = _python_close_config()()
    config.task_sampler_config.task_sampler_class = Hooked
    monkeypatch.chdir(tmp_path)
    report = run_config(config, output_dir="out", progress=False)
    assert report["episodes_kept"] == 2
    with h5py.File(tmp_path / "out" / "house_0" / "trajectories_batch_1_of_1.h5") as f:
        assert len(f) == 2
        for k in f:
            scene = obs_scene(f[k])
            assert scene["task_description"].startswith("Close the ")
            assert scene["joint"]["joint_name"] in ("drawer_slide", "door_hinge")
            start, end = f[k]["obs/extra/obj_start"][0], f[k]["obs/extra/obj_end"][0]
            assert end[2] - start[2] == pytest.approx(0.01, abs=1e-6)
            assert calls.count(scene["object_name"]) >= 1
    assert len(calls) == 2

    class Declines(OpenTaskSampler):
        def _on_candidate_selected(self, env, name, body_id, geom_id) -> bool:
            return False

    config = _python_close_config()()
    config.task_sampler_config.task_sampler_class = Declines
    config.task_sampler_config.samples_per_house = 1
    report = run_config(config, output_dir="declined", progress=False)
    assert report["episodes_kept"] == 0
    journal = (tmp_path / "declined" / "journal.jsonl").read_text()
    assert "sampler_reject" in journal and "Declines._on_candidate_selected" in journal


def test_the_gym_env_rewards_the_joints_closed_fraction():
    pytest.importorskip("gymnasium")
    from mlspaces.tasks.gym_env import GymEnv

    env = GymEnv(exp_config=_python_close_config()())
    obs, info = env.reset(seed=3)
    assert info["success"] is False  # half open: reward 1 - 0.5 < 0.85
    hold = {"arm": np.asarray(obs["agent"]["qpos"]["arm"], dtype=np.float64),
            "gripper": np.zeros(1)}
    _, reward, terminated, truncated, info = env.step(hold)
    assert reward == pytest.approx(0.5, abs=0.02)
    assert info["success"] is False
    env.close()
