"""The bundled xarm7 robot (assets/robots/xarm7): its forward kinematics against UFactory's
published modified DH table of the xArm 7 (written out below, independently of the MJCF), the
model compiling alone with the names robot.yaml gives, the gripper travel against robot.yaml's
finger_range, a grasp held against gravity, the tutorial's workspace reached top-down (real
MuJoCo, no engine build needed), and the tutorial config run by the CLI with only the robot's
name changed (when MLSPACES_CLI_PATH is set, as the ctest does)."""

from __future__ import annotations

import itertools
import json
import math
import os
import re
import subprocess
from pathlib import Path

import h5py
import mujoco
import numpy as np
import pytest

from conftest import SOURCE_DIR

ROBOT_DIR = SOURCE_DIR / "assets" / "robots" / "xarm7"
XML = ROBOT_DIR / "xarm7.xml"
CLI = os.environ.get("MLSPACES_CLI_PATH")

# UFactory, "Kinematic and Dynamic Parameters of xArm 7", table 1 (modified D-H):
# (a [m], d [m], alpha [rad]) per joint, theta offsets all 0. Frame i = frame i-1 *
# RotX(alpha) TransX(a) RotZ(q_i) TransZ(d). The flange is frame 7.
MDH = [
    (0.0, 0.267, 0.0),
    (0.0, 0.0, -math.pi / 2),
    (0.0, 0.293, math.pi / 2),
    (0.0525, 0.0, math.pi / 2),
    (0.0775, 0.3425, math.pi / 2),
    (0.0, 0.0, math.pi / 2),
    (0.076, 0.097, -math.pi / 2),
]
# Published joint working ranges (UFactory robot specifications), rad.
RANGES = [
    (-2 * math.pi, 2 * math.pi), (-2.059, 2.0944), (-2 * math.pi, 2 * math.pi),
    (-0.19198, 3.927), (-2 * math.pi, 2 * math.pi), (-1.69297, math.pi),
    (-2 * math.pi, 2 * math.pi),
]
TOL = 1e-9


# ---- a reader for the YAML subset robot.yaml uses (block maps, "- " items, flow [..] {..}) --

def _flow(text: str):
    tokens = re.findall(r"[\[\]{},:]|[^\s\[\]{},:]+", text)
    pos = 0

    def scalar(tok: str):
        try:
            return int(tok)
        except ValueError:
            try:
                return float(tok)
            except ValueError:
                return {"true": True, "false": False, "null": None}.get(tok, tok)

    def value():
        nonlocal pos
        tok = tokens[pos]
        pos += 1
        if tok == "[":
            out = []
            while tokens[pos] != "]":
                out.append(value())
                pos += tokens[pos] == ","
            pos += 1
            return out
        if tok == "{":
            out = {}
            while tokens[pos] != "}":
                key = tokens[pos]
                assert tokens[pos + 1] == ":", text
                pos += 2
                out[key] = value()
                pos += tokens[pos] == ","
            pos += 1
            return out
        return scalar(tok)

    out = value()
    assert pos == len(tokens), text
    return out


def read_robot_yaml(path: Path) -> dict:
    lines = []
    for raw in path.read_text().splitlines():
        line = raw.split("#", 1)[0].rstrip()
        if not line.strip():
            continue
        if lines and lines[-1][1].count("[") + lines[-1][1].count("{") > \
                lines[-1][1].count("]") + lines[-1][1].count("}"):
            lines[-1] = (lines[-1][0], lines[-1][1] + " " + line.strip())
        else:
            lines.append((len(line) - len(line.lstrip()), line.strip()))

    def block(i: int, indent: int):
        if lines[i][1].startswith("- "):
            out = []
            while i < len(lines) and lines[i][0] == indent and lines[i][1].startswith("- "):
                out.append(_flow(lines[i][1][2:]))
                i += 1
            return out, i
        out = {}
        while i < len(lines) and lines[i][0] == indent:
            key, _, rest = lines[i][1].partition(":")
            i += 1
            if rest.strip():
                out[key] = _flow(rest.strip())
            else:
                out[key], i = block(i, lines[i][0])
        return out, i

    out, end = block(0, 0)
    assert end == len(lines), path
    return out


ROBOT = read_robot_yaml(ROBOT_DIR / "robot.yaml")


# ---- helpers -------------------------------------------------------------------------------

def load() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_path(str(XML))
    return model, mujoco.MjData(model)


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def trans(x: float, y: float, z: float) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = (x, y, z)
    return out


def mdh_frames(q: np.ndarray, base: np.ndarray) -> list[np.ndarray]:
    frames, t = [], base
    for (a, d, alpha), qi in zip(MDH, q):
        t = t @ rot_x(alpha) @ trans(a, 0, 0) @ rot_z(qi) @ trans(0, 0, d)
        frames.append(t)
    return frames


def pad_gap(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    left, right = ROBOT["gripper"]["finger_pads"]
    return mujoco.mj_geomDistance(model, data, model.geom(left).id, model.geom(right).id, 1.0,
                                  None)


def set_home(model: mujoco.MjModel, data: mujoco.MjData) -> None:
    for name, q in zip(ROBOT["arm"]["joints"], ROBOT["arm"]["home"]):
        data.qpos[model.joint(name).qposadr[0]] = q
        data.ctrl[model.actuator(name).id] = q
    for name, q in zip(ROBOT["gripper"]["joints"], ROBOT["gripper"]["home"]):
        data.qpos[model.joint(name).qposadr[0]] = q
    mujoco.mj_forward(model, data)


def step(model: mujoco.MjModel, data: mujoco.MjData, seconds: float) -> None:
    for _ in range(round(seconds / model.opt.timestep)):
        mujoco.mj_step(model, data)


# ---- (a) forward kinematics against the published table --------------------------------------

@pytest.mark.parametrize("moved_base", [False, True])
def test_fk_matches_published_modified_dh_table(moved_base: bool) -> None:
    model, data = load()
    rng = np.random.default_rng(30 + moved_base)
    base = np.eye(4)
    if moved_base:  # a raised, rotated mocap base moves every frame with it
        quat = rng.normal(size=4)
        quat /= np.linalg.norm(quat)
        data.mocap_pos[0] = (0.3, -0.2, 0.58)
        data.mocap_quat[0] = quat
        base[:3, :3] = np.array(
            [[1 - 2 * (quat[2] ** 2 + quat[3] ** 2), 2 * (quat[1] * quat[2] - quat[3] * quat[0]),
              2 * (quat[1] * quat[3] + quat[2] * quat[0])],
             [2 * (quat[1] * quat[2] + quat[3] * quat[0]), 1 - 2 * (quat[1] ** 2 + quat[3] ** 2),
              2 * (quat[2] * quat[3] - quat[1] * quat[0])],
             [2 * (quat[1] * quat[3] - quat[2] * quat[0]), 2 * (quat[2] * quat[3] + quat[1] * quat[0]),
              1 - 2 * (quat[1] ** 2 + quat[2] ** 2)]])
        base[:3, 3] = data.mocap_pos[0]
    lo, hi = np.array(RANGES).T
    for _ in range(20):
        q = rng.uniform(lo, hi)
        data.qpos[:7] = q
        mujoco.mj_forward(model, data)
        frames = mdh_frames(q, base)
        for i, want in enumerate(frames, start=1):
            body = model.body(f"link{i}").id
            np.testing.assert_allclose(data.xpos[body], want[:3, 3], atol=TOL, rtol=0,
                                       err_msg=f"link{i} position, q={q}")
            np.testing.assert_allclose(data.xmat[body].reshape(3, 3), want[:3, :3], atol=TOL,
                                       rtol=0, err_msg=f"link{i} rotation, q={q}")
        flange = model.site("flange").id
        np.testing.assert_allclose(data.site_xpos[flange], frames[-1][:3, 3], atol=TOL, rtol=0)
        np.testing.assert_allclose(data.site_xmat[flange].reshape(3, 3), frames[-1][:3, :3],
                                   atol=TOL, rtol=0)
        # The gripper is mounted with no rotation: TCP = flange + 0.172 m along the flange z.
        tcp = model.site(ROBOT["tcp_site"]).id
        np.testing.assert_allclose(data.site_xpos[tcp],
                                   frames[-1][:3, 3] + 0.172 * frames[-1][:3, 2], atol=TOL,
                                   rtol=0)


def test_joint_ranges_are_the_published_ones() -> None:
    model, _ = load()
    for i, (lo, hi) in enumerate(RANGES, start=1):
        joint = model.joint(f"joint{i}")
        np.testing.assert_allclose(joint.range, (lo, hi), atol=1e-12, err_msg=joint.name)
        np.testing.assert_allclose(model.actuator(f"joint{i}").ctrlrange, (lo, hi), atol=1e-12)


# ---- (b) compiles alone, names as robot.yaml says ----------------------------------------------

def test_compiles_alone_without_warnings_and_names_match_robot_yaml(capfd) -> None:
    model, data = load()
    assert ROBOT["name"] == "xarm7" and ROBOT["mjcf"] == "xarm7.xml"
    assert ROBOT["record"]["articulation"] == "xarm7"
    base = model.body(ROBOT["base"]["body"])
    assert ROBOT["base"]["kind"] == "mocap" and base.mocapid[0] == 0
    assert model.body(ROBOT["root_body"]).parentid[0] == base.id
    assert model.body(ROBOT["gripper"]["body"]).id > 0
    assert model.site(ROBOT["tcp_site"]).id >= 0
    arm = ROBOT["arm"]
    assert arm["joints"] == [f"joint{i}" for i in range(1, 8)]
    assert len(arm["home"]) == len(arm["home_noise"]) == 7
    for name in arm["joints"]:  # default actuators: position servos named like the joints
        actuator = model.actuator(name)
        assert actuator.trntype[0] == mujoco.mjtTrn.mjTRN_JOINT
        assert model.joint(actuator.trnid[0]).name == name
        assert actuator.biastype[0] == mujoco.mjtBias.mjBIAS_AFFINE
        assert actuator.gainprm[0] == -actuator.biasprm[1] > 0
    gripper = ROBOT["gripper"]
    assert model.actuator(gripper["actuator"]).ctrlrange.tolist() == \
        sorted([gripper["open_ctrl"], gripper["closed_ctrl"]])
    for name in gripper["joints"]:
        assert model.joint(name).id >= 0
    assert len(gripper["home"]) == len(gripper["joints"])
    for name in gripper["finger_pads"]:
        assert model.geom(name).contype[0] == 4
    for camera in ROBOT["cameras"]:
        if camera["type"] == "mjcf":
            assert model.camera(camera["mjcf_name"]).id >= 0
        else:
            assert model.body(camera["reference_body"]).id >= 0
    for target in ROBOT["aliases"].values():
        assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, target) >= 0 or \
            mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, target) >= 0
    # gravcomp on every body from the root down (13 bodies: base is the mocap body, no gravcomp)
    assert model.body_gravcomp[0] == model.body_gravcomp[base.id] == 0
    assert (model.body_gravcomp[base.id + 1:] == 1).all()
    # At home: no self-contact, the servos hold the pose 2 s, no simulation warning.
    set_home(model, data)
    assert data.ncon == 0
    step(model, data, 2.0)
    assert np.abs(data.qpos[:7] - arm["home"]).max() < 1e-3
    assert not any(w.number for w in data.warning)
    out, err = capfd.readouterr()
    assert "WARNING" not in (out + err).upper()


def test_home_is_a_ready_pose_pointing_down_in_front() -> None:
    model, data = load()
    set_home(model, data)
    tcp = model.site(ROBOT["tcp_site"]).id
    frame = data.site_xmat[tcp].reshape(3, 3)
    np.testing.assert_allclose(frame[:, 2], (0, 0, -1), atol=1e-3)  # approach down
    np.testing.assert_allclose(frame[:, 0], (1, 0, 0), atol=1e-3)  # gripper x forward
    x, y, z = data.site_xpos[tcp]
    assert 0.3 < x < 0.45 and abs(y) < 1e-6 and 0.25 < z < 0.45


# ---- (c) gripper travel -----------------------------------------------------------------------

def test_gripper_travel_matches_finger_range() -> None:
    model, data = load()
    set_home(model, data)
    gripper = ROBOT["gripper"]
    closed, opened = gripper["finger_range"]
    actuator = model.actuator(gripper["actuator"]).id
    data.ctrl[actuator] = gripper["open_ctrl"]
    step(model, data, 1.0)
    assert abs(pad_gap(model, data) - opened) < 0.002
    data.ctrl[actuator] = gripper["closed_ctrl"]
    step(model, data, 1.0)
    assert abs(pad_gap(model, data) - closed) < 0.002
    data.ctrl[actuator] = gripper["open_ctrl"]
    step(model, data, 1.0)
    assert abs(pad_gap(model, data) - opened) < 0.002


def test_grasp_holds_a_block_against_gravity_and_while_lifting() -> None:
    """The tutorial's 5 cm, 0.125 kg block on a mocap table at the TCP; close, drop the table
    away, then lift with joint 2: the block stays put in the TCP frame. Scene options as the
    tutorial's scene (implicit, 2 ms, pyramidal cone)."""
    spec = mujoco.MjSpec.from_file(str(XML))
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICIT
    spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    spec.option.impratio = 1
    model0, data0 = load()
    set_home(model0, data0)
    tcp_pos = data0.site(ROBOT["tcp_site"]).xpos.copy()
    table = spec.worldbody.add_body(name="table", mocap=True, pos=tcp_pos - (0, 0, 0.025 + 0.01))
    table.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=(0.1, 0.1, 0.01))
    block = spec.worldbody.add_body(name="block", pos=tcp_pos)
    block.add_freejoint()
    block.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=(0.025,) * 3, mass=0.125)
    model = spec.compile()
    data = mujoco.MjData(model)
    set_home(model, data)
    step(model, data, 0.3)
    actuator = model.actuator(ROBOT["gripper"]["actuator"]).id
    data.ctrl[actuator] = ROBOT["gripper"]["closed_ctrl"]
    step(model, data, 1.0)
    assert 0.048 < pad_gap(model, data) < 0.05

    tcp = model.site(ROBOT["tcp_site"]).id
    body = model.body("block").id

    def in_tcp() -> np.ndarray:
        return data.site_xmat[tcp].reshape(3, 3).T @ (data.xpos[body] - data.site_xpos[tcp])

    held = in_tcp()
    data.mocap_pos[model.body("table").mocapid[0]] -= (0, 0, 0.3)
    step(model, data, 1.0)
    assert np.linalg.norm(in_tcp() - held) < 0.003
    joint2 = model.actuator("joint2").id
    start = data.ctrl[joint2]
    for k in range(500):  # raise the arm over 1 s
        data.ctrl[joint2] = start - 0.3 * (k + 1) / 500
        step(model, data, model.opt.timestep)
    step(model, data, 1.0)
    assert data.xpos[body][2] > tcp_pos[2] + 0.05
    assert np.linalg.norm(in_tcp() - held) < 0.003


def test_tutorial_workspace_is_reachable_top_down_without_touching_the_floor() -> None:
    """TCP pointing down at the tutorial's block heights (block centre 2.5 cm up to 20 cm) over
    the robot-to-block offsets its noise gives (x 0.2..0.6, y +-0.2) and gripper yaws -90, 0,
    90 deg: damped-least-squares IK from home reaches every pose within the joint ranges, and
    no robot geom touches a floor plane there."""
    spec = mujoco.MjSpec.from_file(str(XML))
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=(2, 2, 0.1))
    model = spec.compile()
    data = mujoco.MjData(model)
    tcp = model.site(ROBOT["tcp_site"]).id
    lo, hi = np.array(RANGES).T
    jac_pos, jac_rot = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for x, y, z, yaw in itertools.product([0.2, 0.3, 0.4, 0.5, 0.6], [-0.2, 0, 0.2],
                                          [0.025, 0.1, 0.2], [-90, 0, 90]):
        c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
        want_rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ np.diag([1.0, -1, -1])
        q = np.array(ROBOT["arm"]["home"], dtype=float)
        for _ in range(200):
            data.qpos[:7] = q
            mujoco.mj_forward(model, data)
            err_pos = np.array([x, y, z]) - data.site_xpos[tcp]
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, (want_rot @ data.site_xmat[tcp].reshape(3, 3).T).ravel())
            err_rot = np.zeros(3)
            mujoco.mju_quat2Vel(err_rot, quat, 1.0)
            if np.linalg.norm(err_pos) < 1e-4 and np.linalg.norm(err_rot) < 1e-3:
                break
            mujoco.mj_jacSite(model, data, jac_pos, jac_rot, tcp)
            jac = np.r_[jac_pos, jac_rot][:, :7]
            step_q = jac.T @ np.linalg.solve(jac @ jac.T + 1e-3 * np.eye(6), np.r_[err_pos, err_rot])
            q = np.clip(q + np.clip(step_q, -0.2, 0.2), lo, hi)
        else:
            pytest.fail(f"IK did not reach ({x}, {y}, {z}) yaw {yaw}")
        assert data.ncon == 0, f"robot touches the floor at ({x}, {y}, {z}) yaw {yaw}"


# ---- the engine: the tutorial config with the robot's name changed ----------------------------

@pytest.mark.skipif(not CLI, reason="needs MLSPACES_CLI_PATH (the ctest sets it)")
def test_tutorial_config_runs_with_xarm7_by_name(tmp_path: Path) -> None:
    """examples/custom_assets/datagen.yaml with robot_config.name=xarm7 (cameras off to stay
    cheap): every attempt of a seeded 6-episode run lifts the block; the robot's articulation
    rows are recorded under its record.articulation name."""
    out = tmp_path / "run"
    run = subprocess.run(
        [CLI, "datagen", str(SOURCE_DIR / "examples" / "custom_assets" / "datagen.yaml"), "-q",
         "--seed", "1", "--episodes", "6", "--output", str(out),
         "--set", "robot_config.name=xarm7", "--set", "camera_config.cameras=[]",
         "--set", "filter_for_successful_trajectories=false",
         "--set", "task_sampler_config.episodes_per_batch=6"],
        capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    outcomes = [json.loads(line)["outcome"] for line in (out / "journal.jsonl").open()]
    assert outcomes == ["success"] * 6
    (h5,) = (out / "house_0").glob("*.h5")
    with h5py.File(h5) as f:
        rows = f["traj_0/env_states/articulations/xarm7"]
        assert rows.shape[1] == 2 * (7 + 2)
