"""Robots as data from Python: a robot config subclassed as MolmoSpaces' add-robot tutorial
does (``XArm7RobotConfig(BaseRobotConfig)``), pointing at a user robot folder (a copy of
franka_droid renamed, made here), run through the Python datagen entry point and the gym env;
the robot's name and description hash in each episode's provenance; a holonomic base placed by
a sampler hook; ``mlspaces.robots``' list / load / check functions and their errors; the gym env
on the bundled xarm7 with its own cameras."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any, Callable

import h5py
import numpy as np
import pytest
import mujoco
from mujoco import MjData

import mlspaces
from mlspaces.configs import (CameraSystemConfig, PickBaseConfig, PickTaskSamplerConfig,
                              RobotCameraSystem, to_native)
from mlspaces.configs._base import DEFAULTS
from mlspaces.configs.robot_configs import BaseRobotConfig, FrankaRobotConfig
from mlspaces.data_generation.config_registry import register_config
from mlspaces.datagen import main as datagen_main
from mlspaces.datagen import run_config
from mlspaces.errors import MlspacesError, MlspacesFileError, MlspacesKeyError, UsageError
from mlspaces.robots import check_robot_description, list_robots, load_robot_description
from mlspaces.robots.abstract import Robot
from mlspaces.robots.robot_views.abstract import RobotView, RobotViewFactory
from mlspaces.env import create_mlspaces_body
from mlspaces.tasks import PickTaskSampler
from mlspaces.utils.pose import pose_mat_to_7d

from conftest import EXAMPLE_DIR, SOURCE_DIR

ROBOTS = SOURCE_DIR / "assets" / "robots"
HOME = [0.1, -0.7853, 0.0, -2.35619, 0.0, 1.57079, 0.0]  # franka_droid's home, joint 1 + 0.1


class NamingSampler(PickTaskSampler):
    """The engine's placement, noting the robot the Python env shows."""

    seen: list[tuple[str, str]] = []

    def _sample_and_place_robot(self, env) -> None:
        robot = env.current_robot
        type(self).seen.append((robot.name, robot.robot_view.name))
        super()._sample_and_place_robot(env)


def _robot_config_class(folder: Path) -> type:
    """The tutorial's robot config, field for field, for a user robot folder."""

    class MyFrankaRobotConfig(BaseRobotConfig):
        robot_cls: type[Robot] | None = Robot
        robot_factory: Callable[[MjData, Any], Robot] | None = Robot
        robot_namespace: str = "robot_0/"
        robot_view_factory: RobotViewFactory | None = RobotView
        default_world_pose: list[float] = [0, 0, 0, 1, 0, 0, 0]  # (xyz + quat)
        name: str = "my_franka"
        robot_xml_path: Path = Path("franka_droid.xml")
        robot_dir: Path = folder
        base_size: list[float] | None = [0.25, 0.25, 0.25]
        init_qpos: dict[str, list[float]] = {"base": [], "arm": HOME,
                                             "gripper": [0.00296, 0.00296]}
        init_qpos_noise_range: dict[str, list[float]] | None = None
        command_mode: dict[str, str | None] = {"arm": "joint_position",
                                               "gripper": "joint_position"}
        gravcomp: bool = True

        def model_post_init(self, __context):
            super().model_post_init(__context)
            if "gripper" in self.command_mode:
                assert self.command_mode["gripper"] == "joint_position"
            if "arm" in self.command_mode:
                assert self.command_mode["arm"] in ["joint_position", "joint_rel_position"]

    return MyFrankaRobotConfig


def _experiment(robot: Any, cameras: Any = None) -> type:
    class UserRobotConfig(PickBaseConfig):
        robot_config: BaseRobotConfig = robot
        camera_config: CameraSystemConfig = cameras or CameraSystemConfig(cameras=[])
        task_sampler_config: PickTaskSamplerConfig = PickTaskSamplerConfig(
            task_sampler_class=NamingSampler, scene_xml_paths=[str(EXAMPLE_DIR / "scene.xml")],
            samples_per_house=1)
        seed: int = 11

        def model_post_init(self, ctx) -> None:
            super().model_post_init(ctx)
            self.task_config.enable_rendering = False

    return UserRobotConfig


@pytest.fixture(scope="module", autouse=True)
def libraries():
    reg = mlspaces.default_registry()
    if "custom_assets" not in reg.user_asset_libraries:
        mlspaces.register_user_asset_library("custom_assets", EXAMPLE_DIR / "asset_library")
        mlspaces.register_user_grasp_library("custom_grasps", EXAMPLE_DIR / "asset_library",
                                             "custom_assets")


@pytest.fixture
def user_robot(tmp_path) -> Path:
    """A user robot folder: franka_droid copied and renamed my_franka."""
    dst = tmp_path / "my_franka"
    shutil.copytree(ROBOTS / "franka_droid", dst)
    yaml = dst / "robot.yaml"
    yaml.write_text(yaml.read_text().replace("name: franka_droid", "name: my_franka"))
    return dst


# ---- mlspaces.robots -----------------------------------------------------------------------

def test_list_load_and_check_the_bundled_and_a_user_robot(user_robot):
    names = list_robots()
    assert "franka_droid" in names and names == sorted(names)
    franka = load_robot_description("franka_droid")
    assert franka["file"] == str(ROBOTS / "franka_droid" / "robot.yaml")
    assert franka["mjcf"] == str(ROBOTS / "franka_droid" / "franka_droid.xml")
    assert len(franka["hash"]) == 16 and franka["arm"]["home"][3] == -2.35619
    assert franka["gripper"]["closed_ctrl"] == 255 and franka["base"]["kind"] == "mocap"
    mine = load_robot_description(user_robot)  # a folder (PathLike)
    assert mine["name"] == "my_franka" and mine["file"] == str(user_robot / "robot.yaml")
    assert mine["hash"] != franka["hash"]  # robot.yaml differs
    assert load_robot_description(str(user_robot / "robot.yaml"))["hash"] == mine["hash"]
    assert check_robot_description(user_robot) == []
    assert check_robot_description("franka_droid") == []


def test_a_bad_robot_yaml_names_the_file_and_the_field(user_robot):
    yaml = user_robot / "robot.yaml"
    yaml.write_text(yaml.read_text().replace("tcp_site: gripper/grasp_site",
                                             "tcp_site: gripper/no_such_site"))
    with pytest.raises(MlspacesError) as err:
        load_robot_description(user_robot)
    assert err.value.path == str(yaml) and err.value.field == "tcp_site"
    assert str(err.value).startswith(f"{yaml}: tcp_site: ") and "\n" not in str(err.value)
    yaml.write_text(yaml.read_text() + "colour: red\n")
    problems = check_robot_description(yaml)
    assert problems and all(p.startswith(f"{yaml}: ") for p in problems)
    assert any("colour" in p for p in problems), problems
    with pytest.raises(MlspacesKeyError, match="did you mean 'franka_droid'"):
        load_robot_description("franka")
    with pytest.raises(KeyError):  # MolmoSpaces' type for an unknown name
        check_robot_description("no_such_robot")
    with pytest.raises(MlspacesFileError, match="no robot description"):
        load_robot_description(user_robot.parent / "missing")
    with pytest.raises(TypeError):
        load_robot_description(3)


# ---- configs -------------------------------------------------------------------------------

def test_franka_config_is_a_base_robot_config_with_the_engines_defaults():
    assert issubclass(FrankaRobotConfig, BaseRobotConfig)
    assert to_native(PickBaseConfig())["robot_config"] == DEFAULTS["robot_config"]
    cfg = FrankaRobotConfig(init_qpos={"base": [], "arm": HOME, "gripper": []},
                            command_mode={"arm": "joint_rel_position", "gripper":
                                          "joint_position", "base": None})
    native = to_native(PickBaseConfig(robot_config=cfg))["robot_config"]
    assert native["init_qpos"] == {"arm": HOME, "gripper": []}
    assert native["command_mode"] == {"arm": "joint_rel_position", "gripper": "joint_position"}
    with pytest.raises(UsageError, match=r"init_qpos\['base'\]"):
        to_native(PickBaseConfig(robot_config=FrankaRobotConfig(
            init_qpos={"base": [0.1, 0.0, 0.0], "arm": []})))
    with pytest.raises(UsageError, match="K_stiffness"):
        to_native(PickBaseConfig(robot_config=BaseRobotConfig(K_stiffness=[100.0] * 7)))


def test_the_tutorials_robot_config_subclass_runs_datagen_on_a_user_robot(user_robot, tmp_path):
    robot_cls = _robot_config_class(user_robot)
    native = to_native(PickBaseConfig(robot_config=robot_cls()))["robot_config"]
    assert native["robot_dir"] == str(user_robot)
    assert native["robot_xml_path"] == str(user_robot / "franka_droid.xml")
    assert native["init_qpos_noise_range"] == {"arm": [0.0] * 7}  # None: no noise
    register_config("UserRobotDataGenConfig", strict=False)(_experiment(robot_cls()))
    NamingSampler.seen = []
    out = tmp_path / "run"
    datagen_main(["UserRobotDataGenConfig", "--output", str(out), "-q"])  # the entry point
    assert NamingSampler.seen and NamingSampler.seen[0] == ("my_franka", "robot_0/my_franka")
    [h5] = sorted(out.rglob("trajectories_batch_*.h5"))
    expected = {"name": "my_franka", "description_hash": load_robot_description(user_robot)["hash"]}
    with h5py.File(h5, "r") as f:
        trajs = [k for k in f if k.startswith("traj_")]
        assert len(trajs) == 1
        assert json.loads(f[trajs[0]].attrs["provenance"])["robot"] == expected
    [episode] = list(mlspaces.read_dataset(out))
    assert episode.robot == expected
    # The first step starts at init_qpos exactly (init_qpos_noise_range None: no noise).
    np.testing.assert_allclose(episode["obs/agent/qpos"][0]["arm"], HOME, atol=1e-6)
    # The wrong number of home values for the robot: the engine names the field.
    bad = _experiment(robot_cls(init_qpos={"arm": [0.0] * 6}))()
    with pytest.raises(MlspacesError, match=r"robot_config\.init_qpos\.arm"):
        run_config(bad, output_dir=tmp_path / "bad", progress=False)


class TurningSampler(PickTaskSampler):
    """The tutorial's hook shape: the base moved through ``robot_view.base.pose``."""

    poses: list[list[float]] = []

    def _sample_and_place_robot(self, env) -> None:
        base = env.current_robot.robot_view.base
        pose = base.pose
        turn = np.array([[np.cos(0.2), -np.sin(0.2), 0, 0.03], [np.sin(0.2), np.cos(0.2), 0, -0.02],
                         [0, 0, 1, 0], [0, 0, 0, 1]])
        base.pose = pose @ turn
        mujoco.mj_fwdPosition(env.current_model, env.current_data)
        self.config.task_config.robot_base_pose = pose_mat_to_7d(base.pose).tolist()
        type(self).poses.append(self.config.task_config.robot_base_pose)
        lifted = pose.copy()
        lifted[2, 3] += 0.1
        with pytest.raises(UsageError, match="height"):
            base.pose = lifted
        obj = create_mlspaces_body(env.current_data, self.config.task_config.pickup_obj_name)
        start = pose_mat_to_7d(obj.pose)
        self.config.task_config.pickup_obj_start_pose = start.tolist()
        start[2] += 0.05
        self.config.task_config.pickup_obj_goal_pose = start.tolist()


def test_a_holonomic_base_is_placed_from_python(user_robot, tmp_path):
    yaml = user_robot / "robot.yaml"
    yaml.write_text(yaml.read_text().replace("  kind: mocap\n  body: base", "  kind: holonomic"))
    cfg = _experiment(BaseRobotConfig(robot_dir=user_robot, gravcomp=True))()
    cfg.task_sampler_config.task_sampler_class = TurningSampler
    TurningSampler.poses = []
    run_config(cfg, output_dir=tmp_path / "run", progress=False)
    assert TurningSampler.poses
    [episode] = list(mlspaces.read_dataset(tmp_path / "run"))
    # The engine's base is where the hook put it: x, y and yaw 0.2 rad.
    np.testing.assert_allclose(episode["obs/extra/robot_base_pose"][0], TurningSampler.poses[-1],
                               atol=1e-9)
    assert episode["obs/extra/robot_base_pose"][0][3] == pytest.approx(np.cos(0.1))


# ---- the gym env on any robot --------------------------------------------------------------

def _gym_steps(robot_config: Any, name: str, cameras: Any = None) -> dict[str, Any]:
    """A reset and three steps; the last observation."""
    from mlspaces.tasks.gym_env import GymEnv
    env = GymEnv(exp_config=_experiment(robot_config, cameras)())
    try:
        description = load_robot_description(robot_config.robot_dir or robot_config.name)
        assert env.action_space["arm"].shape == (len(description["arm"]["joints"]),)
        assert (env.action_space["gripper"].low[0], env.action_space["gripper"].high[0]) == (0, 255)
        obs, info = env.reset(seed=5)
        assert env.observation_space.contains(obs)
        robot = env.task_sampler.env.current_robot
        assert (robot.name, robot.robot_view.name) == (name, f"robot_0/{name}")
        target = obs["agent"]["qpos"]["arm"].copy()
        for _ in range(3):
            obs, reward, terminated, truncated, info = env.step(
                {"arm": target, "gripper": np.array([255.0])})
        assert np.isfinite(obs["agent"]["qpos"]["arm"]).all() and info["task"]["steps"] == 3
        assert env.observation_space.contains(obs)
        return obs
    finally:
        env.close()


def test_the_gym_env_runs_a_user_robot(user_robot):
    _gym_steps(_robot_config_class(user_robot)(), "my_franka")


@pytest.mark.skipif(not (ROBOTS / "xarm7" / "robot.yaml").is_file(), reason="no xarm7 robot")
def test_the_gym_env_runs_xarm7_with_its_own_cameras():
    cameras = RobotCameraSystem(img_resolution=(64, 48), shadows=False, reflections=False)
    obs = _gym_steps(BaseRobotConfig(name="xarm7", gravcomp=True), "xarm7", cameras)
    # robot.yaml's cameras, rendered (not blank).
    assert list(obs["sensor_data"]) == ["wrist_camera", "exo_camera_1"]
    for frame in obs["sensor_data"].values():
        assert frame.shape == (48, 64, 3) and frame.std() > 1.0
