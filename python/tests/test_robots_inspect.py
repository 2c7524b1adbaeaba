"""mlspaces.robots.inspect_robot: ``mlspaces inspect-robot --json`` as a dict (real MuJoCo,
small reachability grids)."""

from __future__ import annotations

import shutil

import pytest

from conftest import SOURCE_DIR

import mlspaces.robots
from mlspaces.errors import MlspacesFileError, MlspacesKeyError, MlspacesTypeError, UsageError

FRANKA = SOURCE_DIR / "assets" / "robots" / "franka_droid"


def test_franka_droid_has_no_problems() -> None:
    report = mlspaces.robots.inspect_robot("franka_droid", grid_x=(0.5, 0.5), grid_y=(-0.1, 0.1),
                                           grid_z=(0.3, 0.3), grid_step=0.1)
    assert report["problems"] == []
    assert report["name"] == "franka_droid"
    assert report["dof"]["arm"] == 7
    assert [b["body"] for b in report["chain"]][0] == "fr3_link0"
    assert report["tcp"]["ok"] is True
    travel = report["gripper_travel"]
    assert travel["ok"] is True
    assert abs(travel["closed_gap"] - 0.0) <= 0.002
    assert abs(travel["open_gap"] - 0.085) <= 0.002
    assert (report["reachability"]["targets"], report["reachability"]["reached"]) == (3, 3)


def test_path_and_problems(tmp_path) -> None:
    robot = tmp_path / "robot"
    shutil.copytree(FRANKA, robot)
    yaml = (robot / "robot.yaml").read_text()
    (robot / "robot.yaml").write_text(yaml.replace("[0.0, 0.085]", "[0.0, 0.06]"))
    report = mlspaces.robots.inspect_robot(robot, reachability=False)  # a PathLike
    assert report["reachability"]["skipped"] == "not asked for"
    assert len(report["problems"]) == 1
    assert report["problems"][0].startswith(f"{robot / 'robot.yaml'}: gripper.finger_range[1]: ")


def test_errors(tmp_path) -> None:
    with pytest.raises(MlspacesKeyError, match="did you mean 'franka_droid'"):
        mlspaces.robots.inspect_robot("franka_drod")
    with pytest.raises(MlspacesFileError, match="robot.yaml"):
        mlspaces.robots.inspect_robot(tmp_path)
    with pytest.raises(UsageError, match="settle_time"):
        mlspaces.robots.inspect_robot("franka_droid", settle_time=-1.0)
    with pytest.raises(UsageError, match="grid_x"):
        mlspaces.robots.inspect_robot("franka_droid", grid_x=(0.8, 0.3))
    with pytest.raises(MlspacesTypeError, match="reachability"):
        mlspaces.robots.inspect_robot("franka_droid", reachability="yes")


def test_grasp_generation_readiness(tmp_path) -> None:
    report = mlspaces.robots.inspect_robot("xarm7", reachability=False)
    ready = report["grasp_generation"]
    assert ready["ready"] is True and ready["on_search_path"] is True
    assert ready["gripper_boxes"] > 0 and 0.02 < ready["finger_offset"] < 0.08
    assert "problem" not in ready
    # A hand that opens far less at qpos0 than finger_range says: not ready, and why.
    robot = tmp_path / "robot"
    shutil.copytree(FRANKA, robot)
    yaml = (robot / "robot.yaml").read_text()
    (robot / "robot.yaml").write_text(yaml.replace("[0.0, 0.085]", "[0.0, 0.2]"))
    not_ready = mlspaces.robots.inspect_robot(robot, reachability=False)["grasp_generation"]
    assert not_ready["ready"] is False and not_ready["on_search_path"] is False
    assert f"{robot / 'robot.yaml'}" in not_ready["problem"]
    assert "gripper.finger_range" in not_ready["problem"]
