"""Pick-and-place tasks through the `mlspaces` command and Python (docs/tasks.md): the example
configs (examples/pick_and_place) generate episodes that record the place target and the
original's descriptions; validate-dataset passes; a bad task field is one line naming the
file and the field; the Python sampler classes run the engine's; the gym env's reward is the
task's."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from conftest import SOURCE_DIR, mlspaces, obs_scene

EXAMPLE = SOURCE_DIR / "examples" / "pick_and_place"


@pytest.mark.parametrize("yaml,task,phrase", [
    ("datagen.yaml", "pick_and_place", "and place it in or on the "),
    ("datagen_next_to.yaml", "pick_and_place_next_to", "and place it next to the bowl"),
    ("datagen_color.yaml", "pick_and_place_color", "and place it in or on the "),
])
def test_episodes_record_the_target_and_validate(tmp_path: Path, yaml, task, phrase):
    out = tmp_path / task
    r = mlspaces("datagen", str(EXAMPLE / yaml), "--episodes", "1", "--seed", "1",
                 "--output", str(out), "-q", "--set", "task_config.enable_rendering=false",
                 "--set", "filter_for_successful_trajectories=false")
    assert r.returncode == 0, r.stderr
    v = mlspaces("validate-dataset", str(out))
    assert v.returncode == 0, v.stdout + v.stderr
    with h5py.File(out / "house_0" / "trajectories_batch_1_of_1.h5") as f:
        for k in f:
            t = f[k]
            scene = obs_scene(t)
            assert scene["task_type"] == task
            assert scene["task_description"].startswith("Pick up the block ")
            assert phrase in scene["task_description"]
            assert scene["place_receptacle_name"] == scene["frozen_config"]["place_receptacle_name"]
            assert "place_name" in scene["referral_expressions"]
            info = json.loads(bytes(t["obs/extra/task_info"][-1]).rstrip(b"\0"))
            assert {"success", "episode_step", "receptacle_pos_displacement"} <= set(info)
            phases = set(np.asarray(t["obs/extra/policy_phase"][:]).tolist())
            assert {2, 3, 4, 5, 6, 7, 8, 9} <= phases  # pregrasp .. go_home
            if task == "pick_and_place_color":
                color = scene["frozen_config"]["target_color"]
                assert color in scene["task_description"].replace(" ", "_")


def test_a_bad_task_field_is_one_line_naming_file_and_field(tmp_path: Path):
    text = (EXAMPLE / "datagen.yaml").read_text()
    text = text.replace("[scene.xml]", f"[{EXAMPLE / 'scene.xml'}]")
    text = text.replace("path: ../objects", f"path: {EXAMPLE.parent / 'objects'}")
    text = text.replace("path: ../custom_assets", f"path: {EXAMPLE.parent / 'custom_assets'}")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("receptacle_supported_weight_frac: 0.5",
                                "receptacle_supported_weight_frac: 2"))
    r = mlspaces("datagen", str(bad), "--output", str(tmp_path / "run"))
    assert r.returncode == 1
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert str(bad) in lines[0] and "task_config.receptacle_supported_weight_frac" in lines[0]


def _python_config():
    """datagen.yaml as a Python config, with the Python PickAndPlaceTaskSampler."""
    import mlspaces
    from mlspaces.configs import FrankaRobotConfig, PickBaseConfig, PickTaskSamplerConfig
    from mlspaces.tasks import PickAndPlaceTaskSampler

    reg = mlspaces.default_registry()
    objects = SOURCE_DIR / "examples" / "objects"
    if "example_objects" not in reg.user_asset_libraries:  # as test_open_close registers it
        mlspaces.register_user_asset_library("example_objects", objects)
        mlspaces.register_user_grasp_library("example_objects_grasps", objects, "example_objects")
    if "custom_assets" not in reg.user_asset_libraries:
        lib = SOURCE_DIR / "examples" / "custom_assets" / "asset_library"
        mlspaces.register_user_asset_library("custom_assets", lib)
        mlspaces.register_user_grasp_library("custom_grasps", lib, "custom_assets")

    class FrankaPickAndPlaceConfig(PickBaseConfig):
        task_type: str = "pick_and_place"
        robot_config: FrankaRobotConfig = FrankaRobotConfig(base_size=None)
        task_sampler_config: PickTaskSamplerConfig = PickTaskSamplerConfig(
            task_sampler_class=PickAndPlaceTaskSampler,
            scene_xml_paths=[str(EXAMPLE / "scene.xml")], samples_per_house=1,
            robot_base_noise={"x": 0.05, "y": 0.05, "yaw_deg": 10})
        seed: int = 1

        def model_post_init(self, ctx) -> None:
            super().model_post_init(ctx)
            self.task_config.enable_rendering = False
            self.task_sampler_config.max_robot_to_place_receptacle_dist = 0.65
            self.policy_config.move_settle_time = 0.5

    return FrankaPickAndPlaceConfig


def test_the_python_sampler_classes_run_the_engines(tmp_path: Path, monkeypatch):
    from mlspaces.datagen import run_config
    from mlspaces.tasks import (PickAndPlaceColorTaskSampler, PickAndPlaceNextToTaskSampler,
                                PickAndPlaceReceptacleTaskSampler, PickAndPlaceTaskSampler)
    from mlspaces.tasks.opening_task_samplers import engine_sampler_name

    assert PickAndPlaceReceptacleTaskSampler is PickAndPlaceTaskSampler
    assert engine_sampler_name(PickAndPlaceNextToTaskSampler) == "PickAndPlaceNextToTaskSampler"
    assert engine_sampler_name(PickAndPlaceColorTaskSampler) == "PickAndPlaceColorTaskSampler"
    config_class = _python_config()
    monkeypatch.chdir(tmp_path)
    report = run_config(config_class(), output_dir="out", progress=False)
    assert report["episodes_kept"] == 1



def test_a_python_subclass_of_a_pick_and_place_sampler_runs_its_hooks(tmp_path: Path,
                                                                      monkeypatch):
    """The hooks a subclass overrides run in Python, the others (and super()) in the engine:
    the receptacles are still added and placed; the override's changes show in the
    episodes."""
    from mlspaces.datagen import run_config
    from mlspaces.tasks import PickAndPlaceColorTaskSampler

    names: list[str] = []

    class Hooked(PickAndPlaceColorTaskSampler):
        def randomize_scene(self, env, robot_view) -> None:
            super().randomize_scene(env, robot_view)
            names.append("randomize")

        def _sample_and_place_robot(self, env) -> None:
            super()._sample_and_place_robot(env)
            self.config.task_config.pickup_obj_goal_pose[2] += 0.01

    config = _python_config()()
    config.task_type = "pick_and_place_color"
    config.task_sampler_config.task_sampler_class = Hooked
    monkeypatch.chdir(tmp_path)
    report = run_config(config, output_dir="out", progress=False)
    assert report["episodes_kept"] == 1
    assert names == ["randomize"]
    with h5py.File(tmp_path / "out" / "house_0" / "trajectories_batch_1_of_1.h5") as f:
        (traj,) = f.values()
        scene = obs_scene(traj)
        assert scene["place_receptacle_name"].startswith("place_receptacle/")
        assert " the " in scene["task_description"] and "in or on the" in \
            scene["task_description"]
        start, end = traj["obs/extra/obj_start"][0], traj["obs/extra/obj_end"][0]
        assert end[2] - start[2] == pytest.approx(0.06, abs=1e-6)  # +0.05 (engine) +0.01


def test_the_gym_env_rewards_the_distance_to_the_receptacle():
    pytest.importorskip("gymnasium")
    from mlspaces.tasks.gym_env import GymEnv

    env = GymEnv(exp_config=_python_config()())
    obs, info = env.reset(seed=3)
    assert info["success"] is False  # the block is on the floor, not in the receptacle
    hold = {"arm": np.asarray(obs["agent"]["qpos"]["arm"], dtype=np.float64),
            "gripper": np.zeros(1)}
    _, reward, terminated, truncated, info = env.step(hold)
    assert 0.5 < reward < 1.0  # exp(-distance), the receptacle 0.15-0.5 m away
    assert info["success"] is False
    env.close()


def test_cameras_record_videos_that_validate(tmp_path: Path):
    out = tmp_path / "cams"
    r = mlspaces("datagen", str(EXAMPLE / "datagen.yaml"), "--episodes", "1", "--seed", "1",
                 "--output", str(out), "-q", "--set", "camera_config.img_resolution=[64, 48]",
                 "--set", "camera_config.shadows=false", "--set", "camera_config.reflections=false",
                 "--set", "filter_for_successful_trajectories=false")
    assert r.returncode == 0, r.stderr
    assert len(list((out / "house_0").glob("*.mp4"))) == 2  # wrist and exo cameras
    v = mlspaces("validate-dataset", str(out))
    assert v.returncode == 0 and "2 videos: ok" in v.stdout, v.stdout + v.stderr
