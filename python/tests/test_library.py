"""The library API on real libraries: the tutorial's, and ones written here with numpy."""

from __future__ import annotations

import json
import random
from pathlib import Path

import numpy as np
import pytest

import mlspaces
from mlspaces import MlspacesError, Registry

from conftest import random_poses, write_library


def test_tutorial_library_locate_annotation_and_grasps(tutorial_library):
    reg = Registry()
    reg.register_user_asset_library("custom_assets", tutorial_library)
    reg.register_user_grasp_library("custom_grasps", tutorial_library, "custom_assets")

    source, package, xml = reg.locate_uid_package("red_block")
    assert (source, package) == ("custom_assets", None)
    assert isinstance(xml, Path) and xml.is_absolute()
    assert xml == (tutorial_library / "red_block" / "red_block.xml").absolute()
    assert reg.locate_uid_package("no_such_uid") == (None, None, None)

    ann = reg.annotation("red_block")
    expected = json.loads((tutorial_library / "red_block" / "red_block_computed.json").read_text())
    assert ann == expected
    assert list(ann) == list(expected)  # key order as in the file
    assert reg.annotation("no_such_uid") is None

    assert reg.get_grasp_libraries_for_object("red_block") == ["custom_grasps/droid"]
    assert reg.object_library_to_grasp_libraries["custom_assets"] == ["custom_grasps/droid"]
    assert reg.user_grasp_libraries == {"custom_grasps/droid": tutorial_library.absolute()}
    path = reg.get_pickup_grasp_path("red_block")
    assert path == (tutorial_library / "red_block" / "droid" / "grasps.npz").absolute()
    assert reg.has_pickup_grasp_path("red_block")
    assert reg.has_valid_pickup_grasps("red_block", num_grasps=1)
    assert not reg.has_valid_pickup_grasps("red_block", num_grasps=2)

    grasps = reg.load_pickup_grasps("red_block")
    stored = np.load(path)["transforms"]
    assert grasps.shape == (1, 4, 4) and grasps.dtype == np.float64
    np.testing.assert_array_equal(grasps, stored)
    assert grasps.flags.writeable and grasps.flags.c_contiguous
    grasps[0, 0, 0] = 99.0  # a fresh array: the next call does not see it
    np.testing.assert_array_equal(reg.load_pickup_grasps("red_block"), stored)


def test_annotation_is_a_new_dict_each_call_with_npz_arrays_as_stored(tmp_path):
    lib = write_library(tmp_path / "lib", {"a": 3, "b": 2}, npz_meta=True)
    reg = Registry()
    reg.register_user_asset_library("mine", lib)
    first = reg.annotation("a")
    first["mass"] = -1
    first["description_short"]["one_word"] = "changed"
    second = reg.annotation("a")
    assert second["mass"] == 0.05
    assert second["description_short"]["one_word"] == "block"
    feats = second["clip_img_features"]
    assert feats.dtype == np.float32 and feats.shape == (3, 4)
    np.testing.assert_array_equal(feats, np.arange(12, dtype=np.float32).reshape(3, 4))
    ids = second["extra"]["ids"]
    assert ids.dtype == np.int64 and ids.tolist() == [1, 2, 3]
    assert reg.all_uids() == ["a", "b"]


def test_subsampling_draws_with_python_random_as_the_original(tmp_path):
    lib = write_library(tmp_path / "lib", {"many": 100})
    reg = Registry()
    reg.register_user_asset_library("mine", lib)
    reg.register_user_grasp_library("g", lib, "mine")
    stored = np.load(lib / "many" / "droid" / "grasps.npz")["transforms"]

    random.seed(3)
    got = reg.load_pickup_grasps("many", num_grasps=10)
    random.seed(3)
    rows = random.sample(range(100), 10)
    np.testing.assert_array_equal(got, stored[rows])
    # Not more than the file holds: all of them, in file order, no draw.
    state = random.getstate()
    np.testing.assert_array_equal(reg.load_pickup_grasps("many", num_grasps=100), stored)
    assert random.getstate() == state


def test_engine_sampling_is_pythons_random_sample_draw_for_draw():
    """The engine draws grasp rows as CPython's random.sample (both of its branches) from
    random.getrandbits: the same rows and the same generator state afterwards."""
    from mlspaces import _core
    # (277, 50) and (278, 50) sit on either side of CPython's pool/set switch for k = 50.
    for n, k in ((1, 1), (2, 1), (10, 3), (21, 6), (30, 6), (60, 50), (100, 10), (277, 50),
                 (278, 50), (1000, 50), (1000, 999), (5000, 1), (7, 7), (10**6, 7)):
        for seed in (0, 1, 12345):
            random.seed(seed)
            want = random.sample(range(n), k)
            after = random.getrandbits(64)
            random.seed(seed)
            got = _core.Registry._random_sample(n, k, random.getrandbits)
            assert got == want, (n, k, seed)
            assert random.getrandbits(64) == after


def test_a_rewritten_grasp_file_is_read_again(tmp_path):
    lib = write_library(tmp_path / "lib", {"a": 3})
    reg = Registry()
    reg.register_user_asset_library("mine", lib)
    reg.register_user_grasp_library("g", lib, "mine")
    first = reg.load_pickup_grasps("a")
    np.testing.assert_array_equal(first, reg.load_pickup_grasps("a"))  # cached decode
    new = random_poses(5, 99)
    np.savez(lib / "a" / "droid" / "grasps.npz", transforms=new)
    np.testing.assert_array_equal(reg.load_pickup_grasps("a"), new)


def test_grasp_library_priority_newest_first_robots_sorted(tmp_path):
    lib_a = write_library(tmp_path / "a", {"x": 2}, robots=("zeta", "alpha"))
    lib_b = write_library(tmp_path / "b", {"x": 3}, robots=("droid",))
    reg = Registry()
    reg.register_user_asset_library("assets", lib_a)
    reg.register_user_grasp_library("old", lib_a, "assets")
    assert reg.get_grasp_libraries_for_object("x") == ["old/alpha", "old/zeta"]
    reg.register_user_grasp_library("new", lib_b, "assets")
    assert reg.get_grasp_libraries_for_object("x") == ["new/droid", "old/alpha", "old/zeta"]
    assert reg.load_pickup_grasps("x").shape == (3, 4, 4)
    # A filter keeps its own order.
    assert reg.load_pickup_grasps("x", grasp_libraries=["old/zeta", "new/droid"]).shape == (2, 4, 4)
    np.testing.assert_array_equal(
        reg.load_pickup_grasps("x", grasp_libraries=("old/zeta",)),
        np.load(lib_a / "x" / "zeta" / "grasps.npz")["transforms"])
    assert reg.get_pickup_grasp_path("x", ["nope"]) is None
    # As MolmoSpaces filters the object's libraries by the list, [] keeps none (None is all).
    assert reg.get_pickup_grasp_path("x", []) is None
    assert not reg.has_pickup_grasp_path("x", grasp_libraries=[])
    with pytest.raises(ValueError, match="No grasp file found for x"):
        reg.load_pickup_grasps("x", grasp_libraries=[])
    assert reg.get_pickup_grasp_path("x", None) is not None


def test_joint_grasps(tmp_path):
    lib = write_library(tmp_path / "lib", {"cab": 2}, joints={"cab": ["door", "drawer"]})
    reg = Registry()
    reg.register_user_asset_library("assets", lib)
    reg.register_user_grasp_library("g", lib, "assets")
    assert reg.has_joint_grasp_path("cab", "door")
    assert not reg.has_joint_grasp_path("cab", "lid")
    assert reg.has_valid_joint_grasps("cab", "drawer", num_grasps=3)
    got = reg.load_joint_grasps("cab", "door")
    np.testing.assert_array_equal(
        got, np.load(lib / "cab" / "droid" / "joint_grasps_door.npz")["transforms"])
    with pytest.raises(ValueError, match="No joint grasp file found for cab/lid"):
        reg.load_joint_grasps("cab", "lid")


def test_lookups_before_a_registration_are_not_stale(tmp_path):
    lib = write_library(tmp_path / "lib", {"late": 1})
    reg = Registry()
    assert reg.locate_uid_package("late") == (None, None, None)
    assert not reg.has_pickup_grasp_path("late")
    reg.register_user_asset_library("assets", lib)
    assert reg.locate_uid_package("late")[0] == "assets"
    reg.register_user_grasp_library("g", lib, "assets")
    assert reg.has_pickup_grasp_path("late")


def test_registration_errors_are_value_errors_naming_the_file(tmp_path):
    lib = write_library(tmp_path / "lib", {"a": 1})
    reg = Registry()
    reg.register_user_asset_library("assets", str(lib))  # str paths are accepted
    with pytest.raises(ValueError, match="already registered"):
        reg.register_user_asset_library("assets", lib)
    with pytest.raises(ValueError):
        reg.register_user_asset_library("a/b", lib)
    with pytest.raises(ValueError):
        reg.register_user_asset_library("thor", lib)
    with pytest.raises(MlspacesError) as err:
        reg.register_user_asset_library("missing", tmp_path / "nowhere")
    assert "assets_index.json" in err.value.path

    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "assets_index.json").write_text('{"a": {"uid": "a", "object_path": 3}}')
    with pytest.raises(MlspacesError) as err:
        reg.register_user_asset_library("bad", bad)
    assert err.value.path.endswith("assets_index.json")
    assert err.value.field.startswith("/a/object_path")
    assert "\n" not in str(err.value)
    # Nothing changed after the failures.
    assert list(reg.user_asset_libraries) == ["assets"]

    with pytest.raises(ValueError):
        reg.register_user_grasp_library("g", lib, "unknown_library")
    (lib / "grasps_index.json").write_text("{not json")
    with pytest.raises(MlspacesError) as err:
        reg.register_user_grasp_library("g", lib, "assets")
    assert err.value.path.endswith("grasps_index.json") and "line 1" in err.value.field


def test_bad_grasp_files_are_errors_never_crashes(tmp_path):
    lib = write_library(tmp_path / "lib", {"a": 2, "b": 2, "c": 2})
    (lib / "a" / "droid" / "grasps.npz").write_bytes(b"PK\x03\x04garbage")
    np.savez(lib / "b" / "droid" / "grasps.npz", transforms=np.zeros((2, 3, 3)))
    bad = random_poses(2, 1)
    bad[1, 0, 3] = np.nan
    np.savez(lib / "c" / "droid" / "grasps.npz", transforms=bad)
    reg = Registry()
    reg.register_user_asset_library("assets", lib)
    reg.register_user_grasp_library("g", lib, "assets")
    for uid, what in (("a", None), ("b", r"\(N,4,4\)|shape"), ("c", "non-finite")):
        with pytest.raises(MlspacesError, match=what) as err:
            reg.load_pickup_grasps(uid)
        assert err.value.path.endswith(f"{uid}/droid/grasps.npz")
    with pytest.raises(ValueError, match="No grasp file found for zzz"):
        reg.load_pickup_grasps("zzz")
    with pytest.raises(TypeError):
        reg.load_pickup_grasps(None)


def test_scene_metadata(tmp_path):
    scene = mlspaces.get_scene_metadata(Path(__file__).resolve().parents[2] / "examples" /
                                        "custom_assets" / "scene.xml")
    assert scene["objects"]["red_block"]["asset_id"] == "red_block"
    assert mlspaces.get_scene_metadata(tmp_path / "nothing.xml") is None
    with pytest.raises(ValueError, match="xml"):
        mlspaces.get_scene_metadata(tmp_path / "scene.json")
    # The 'ceiling' bug of the original is fixed: only the file name's suffix counts.
    d = tmp_path / "ceiling_room"
    d.mkdir()
    (d / "house_metadata.json").write_text('{"objects": {}}')
    assert mlspaces.get_scene_metadata(d / "house.xml") == {"objects": {}}
    (d / "house_metadata.json").write_text('{"objects": [1]}')
    with pytest.raises(MlspacesError) as err:
        mlspaces.get_scene_metadata(d / "house.xml")
    assert err.value.path.endswith("house_metadata.json")


def test_flip_and_world_grasps():
    g = random_poses(3, 5)
    rz = np.diag([-1.0, -1.0, 1.0, 1.0])
    np.testing.assert_allclose(mlspaces.flip_grasps(g), g @ rz, atol=0)
    np.testing.assert_allclose(mlspaces.flip_grasps(g[0]), g[0] @ rz, atol=0)
    with pytest.raises(ValueError, match=r"shape \(N, 4, 4\)"):
        mlspaces.flip_grasps(np.zeros((2, 3, 4)))
    with pytest.raises(ValueError, match="None"):
        mlspaces.flip_grasps(None)


def test_world_frame_pickup_and_joint_grasps(tmp_path):
    """get_pickup_grasps / get_joint_grasps on a real MuJoCo model and data: the object's
    pose (or the joint body's, from the current kinematics) times the stored grasps, then the
    flipped twins."""
    import types

    import mujoco

    from mlspaces.env import create_mlspaces_body
    from mlspaces.utils.grasps import get_joint_grasps, get_pickup_grasps

    lib = write_library(tmp_path / "lib", {"wcab": 2}, joints={"wcab": ["door"]})
    mlspaces.register_user_asset_library("world_frame_lib", lib)
    mlspaces.register_user_grasp_library("world_frame_grasps", lib, "world_frame_lib")
    model = mujoco.MjModel.from_xml_string("""
<mujoco><worldbody>
  <body name="cab" pos="0.4 0.1 0.3" euler="0 0 30"><freejoint/>
    <geom type="box" size="0.1 0.1 0.1"/>
    <body name="door_body" pos="0.1 0 0"><joint name="cab_door" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.01 0.1 0.1"/></body>
  </body></worldbody></mujoco>""")
    data = mujoco.MjData(model)
    data.qpos[7] = 0.3  # open the door a little
    mujoco.mj_forward(model, data)
    env = types.SimpleNamespace(
        current_model=model, current_data=data,
        current_scene_metadata={"objects": {"cab": {
            "asset_id": "wcab", "name_map": {"joints": {"cab_door": "door"}}}}})
    body = create_mlspaces_body(data, "cab")
    obj = types.SimpleNamespace(name="cab", pose=body.pose, joint_names=["cab_door"])
    stored = np.load(lib / "wcab" / "droid" / "grasps.npz")["transforms"]
    world = get_pickup_grasps(env, obj)
    rz = np.diag([-1.0, -1.0, 1.0, 1.0])
    np.testing.assert_allclose(world, np.concatenate([body.pose @ stored,
                                                      body.pose @ stored @ rz]), atol=1e-12)
    assert get_pickup_grasps(env, obj, include_flipped=False).shape == (2, 4, 4)

    joint_stored = np.load(lib / "wcab" / "droid" / "joint_grasps_door.npz")["transforms"]
    grasps, door_pose = get_joint_grasps(env, obj, 0, include_flipped=False)
    want = np.eye(4)
    want[:3, :3] = data.body("door_body").xmat.reshape(3, 3)
    want[:3, 3] = data.body("door_body").xpos
    np.testing.assert_allclose(door_pose, want, atol=1e-12)
    np.testing.assert_allclose(grasps, want @ joint_stored, atol=1e-12)

    env.current_scene_metadata = None
    with pytest.raises(ValueError, match="No scene metadata"):
        get_pickup_grasps(env, obj)
    env.current_scene_metadata = {"objects": {}}
    with pytest.raises(ValueError, match="not found in scene metadata"):
        get_pickup_grasps(env, obj)
