"""Errors as documented (docs/python.md, "Errors"): every public function checks its
arguments and names the function and the argument in one line (a wrong type is a TypeError that
is also a ValueError, a bad value a ValueError); a file that cannot be read is named; the gym
env says how to get frames; an env left open at exit prints nothing."""

from __future__ import annotations

import gc
import os
import subprocess
import sys
import weakref
from collections.abc import Mapping

import mujoco
import numpy as np
import pytest

import mlspaces
from mlspaces import errors, render
from mlspaces.configs import PickBaseConfig
from mlspaces.datagen import get_config_class, register_config, run_config
from mlspaces.env import CPUMujocoEnv, create_mlspaces_body
from mlspaces.tasks import PickTaskSampler
from mlspaces.utils import lazy_loading_utils as llu
from mlspaces.utils import license_utils as lic
from mlspaces.utils.object_metadata import ObjectMeta
from mlspaces.utils.object_retriever import ObjectRetriever
from mlspaces.utils.scene_metadata_utils import SceneMeta

from conftest import EXAMPLE_DIR, write_library

_XML = """<mujoco><worldbody>
  <body name="base" mocap="true"><geom size="0.1"/></body>
  <body name="box"><freejoint/><geom type="box" size="0.1 0.1 0.1"/></body>
</worldbody></mujoco>"""


@pytest.fixture(scope="module")
def data() -> mujoco.MjData:
    return mujoco.MjData(mujoco.MjModel.from_xml_string(_XML))


def _one_line_naming(err: BaseException, *names: str) -> str:
    text = str(err)
    assert "\n" not in text, text
    assert "incompatible function arguments" not in text, text
    for name in names:
        assert name in text, (name, text)
    return text


# -- the cases of the issue ---------------------------------------------------------------

def test_load_pickup_grasps_none_is_a_value_error_naming_the_argument():
    with pytest.raises(ValueError) as err:
        mlspaces.load_pickup_grasps(None)
    assert isinstance(err.value, TypeError)
    assert _one_line_naming(err.value, "load_pickup_grasps", "uid").startswith(
        "load_pickup_grasps: uid: expected a str, got None")


def test_num_grasps_negative_or_not_an_int_is_refused(tmp_path):
    reg = mlspaces.Registry()
    write_library(tmp_path / "lib", {"blk": 3})
    reg.register_user_asset_library("lib", tmp_path / "lib")
    reg.register_user_grasp_library("g", tmp_path / "lib", "lib")
    assert reg.load_pickup_grasps("blk", num_grasps=0).shape == (0, 4, 4)
    assert reg.load_pickup_grasps("blk", num_grasps=np.int64(2)).shape == (2, 4, 4)
    with pytest.raises(ValueError) as err:
        reg.load_pickup_grasps("blk", num_grasps=-1)
    assert not isinstance(err.value, TypeError)
    _one_line_naming(err.value, "num_grasps", ">= 0", "-1")
    for bad in ("5", 2.0, True, None):
        with pytest.raises(TypeError) as err:
            reg.load_pickup_grasps("blk", num_grasps=bad)
        _one_line_naming(err.value, "load_pickup_grasps", "num_grasps", "expected an int")
    with pytest.raises(ValueError, match="has_valid_pickup_grasps: num_grasps"):
        reg.has_valid_pickup_grasps("blk", num_grasps=-1)


def test_annotation_none_is_the_whole_mapping_as_the_original_and_says_so(tmp_path):
    # MolmoSpaces' ObjectMeta.annotation(None) returns every annotation (spec section 3); the
    # mapping says what it is instead of looking like one annotation.
    write_library(tmp_path / "lib", {"blk_a": 1, "blk_b": 1})
    mlspaces.register_user_asset_library("errors_test_lib", tmp_path / "lib")
    every = ObjectMeta.annotation(None)
    assert isinstance(every, Mapping) and {"blk_a", "blk_b"} <= set(every)
    assert "every annotation" in repr(every) and "UIDs" in repr(every)
    assert every["blk_a"]["uid"] == "blk_a"
    with pytest.raises(KeyError, match="keys are UIDs"):
        every[None]
    for bad in (5, [None], {"blk_a": 1}):
        with pytest.raises(TypeError) as err:
            ObjectMeta.annotation(bad)
        _one_line_naming(err.value, "ObjectMeta.annotation", "asset_ids")


def test_a_corrupt_h5_names_the_file(tmp_path):
    pytest.importorskip("h5py")
    house = tmp_path / "run" / "house_0"
    house.mkdir(parents=True)
    bad = house / "trajectories_batch_1_of_1.h5"
    bad.write_bytes(b"this is not HDF5\0" * 64)
    with pytest.raises(OSError) as err:
        list(mlspaces.read_dataset(tmp_path / "run"))
    assert isinstance(err.value, ValueError) and err.value.filename == str(bad)
    assert _one_line_naming(err.value, str(bad)).startswith(str(bad))
    with pytest.raises(OSError, match="trajectories_batch_1_of_1.h5"):
        len(mlspaces.read_dataset(tmp_path / "run"))


def test_a_corrupt_index_json_names_the_file(tmp_path):
    (tmp_path / "assets_index.json").write_text("{not json")
    with pytest.raises(ValueError) as err:
        llu.get_user_library_index(tmp_path)
    assert isinstance(err.value, OSError)
    _one_line_naming(err.value, str(tmp_path / "assets_index.json"))
    with pytest.raises(FileNotFoundError, match="grasps_index.json"):
        llu.get_user_grasp_library_index(tmp_path)
    assert callable(llu.get_user_library_index.cache_clear)


# -- the sweep: every public function with None, wrong types, negative counts ------------

def _cases(data: mujoco.MjData):
    """(call, exception type, words the message names)."""
    body = create_mlspaces_body(data, "box")
    env = CPUMujocoEnv(data.model, data, None, "scene.xml", "", "base")
    sampler = PickTaskSampler(PickBaseConfig())
    T, V = TypeError, ValueError
    return [
        # registration and lookups
        (lambda: mlspaces.register_user_asset_library(None, "x"), T, "name"),
        (lambda: mlspaces.register_user_asset_library("", "x"), V, "name"),
        (lambda: mlspaces.register_user_asset_library("a", None), T, "path"),
        (lambda: mlspaces.register_user_asset_library("a", 5), T, "path"),
        (lambda: mlspaces.register_user_grasp_library(None, "x", "lib"), T, "root_name"),
        (lambda: mlspaces.register_user_grasp_library("r", None, "lib"), T, "path"),
        (lambda: mlspaces.register_user_grasp_library("r", "x", None), T, "object_library"),
        (lambda: mlspaces.locate_uid_package(None), T, "uid"),
        (lambda: mlspaces.locate_uid_package(["a"]), T, "uid"),
        (lambda: mlspaces.locate_uid_package("a", extension=None), T, "extension"),
        (lambda: mlspaces.install_uid(None), T, "uid"),
        (lambda: mlspaces.install_uid("a", grasp_source=5), T, "grasp_source"),
        (lambda: mlspaces.get_grasp_libraries_for_object(None), T, "uid"),
        (lambda: mlspaces.get_pickup_grasp_path(None), T, "uid"),
        (lambda: mlspaces.get_pickup_grasp_path("a", grasp_libraries=5), T, "grasp_libraries"),
        (lambda: mlspaces.get_pickup_grasp_path("a", grasp_libraries=[None]), T,
         "grasp_libraries[0]"),
        (lambda: mlspaces.get_joint_grasp_path("a", None), T, "joint_name"),
        (lambda: mlspaces.has_pickup_grasp_path(None), T, "uid"),
        (lambda: mlspaces.has_joint_grasp_path("a", 5), T, "joint_name"),
        (lambda: mlspaces.has_valid_pickup_grasps("a", num_grasps=-1), V, "num_grasps"),
        (lambda: mlspaces.has_valid_pickup_grasps("a", num_grasps=1.5), T, "num_grasps"),
        (lambda: mlspaces.has_valid_joint_grasps("a", "j", num_grasps=-2), V, "num_grasps"),
        (lambda: mlspaces.load_pickup_grasps("a", num_grasps="5"), T, "num_grasps"),
        (lambda: mlspaces.load_joint_grasps("a", None), T, "joint_name"),
        (lambda: mlspaces.load_joint_grasps("a", "j", num_grasps=-1), V, "num_grasps"),
        # "" is no joint (it read as the pickup grasps); past int64 is no count (nanobind's
        # multi-line "incompatible function arguments" before)
        (lambda: mlspaces.load_joint_grasps("a", ""), V, "joint_name"),
        (lambda: mlspaces.has_joint_grasp_path("a", ""), V, "joint_name"),
        (lambda: mlspaces.load_pickup_grasps("a", num_grasps=2**63), V, "num_grasps"),
        (lambda: mlspaces.load_pickup_grasps("a", num_grasps=np.uint64(2**64 - 1)), V,
         "num_grasps"),
        (lambda: mlspaces.get_scene_metadata(None), T, "mj_base_scene_path"),
        (lambda: SceneMeta.get_scene_metadata(5), T, "mj_base_scene_path"),
        (lambda: mlspaces.Registry(assets_dir=5), T, "assets_dir"),
        (lambda: mlspaces.read_dataset(None), T, "folder"),
        # grasps and poses
        (lambda: mlspaces.flip_grasps(None), T, "grasps"),
        (lambda: mlspaces.flip_grasps("abc"), T, "grasps"),
        (lambda: mlspaces.flip_grasps(np.full((4, 4), np.nan)), V, "grasps"),
        # numbers only: numpy reads "1", True and 1+0j as floats
        (lambda: mlspaces.flip_grasps(np.ones((1, 4, 4), bool)), T, "grasps"),
        (lambda: mlspaces.flip_grasps(np.eye(4).astype(str)), T, "grasps"),
        (lambda: mlspaces.flip_grasps(np.eye(4) + 0j), T, "grasps"),
        (lambda: mlspaces.pose_mat_to_7d(None), T, "pose_matrix"),
        (lambda: mlspaces.pose_mat_to_7d(np.full((4, 4), np.inf)), V, "pose_matrix"),
        (lambda: mlspaces.pos_quat_to_pose_mat(None), T, "pos"),
        (lambda: mlspaces.pos_quat_to_pose_mat([0, 0, 0], [1, 0, 0]), V, "quat"),
        (lambda: mlspaces.pos_quat_to_pose_mat([0, 0, 0], [0, 0, 0, 0]), V, "quat"),
        (lambda: mlspaces.pose_mat_to_pos_quat(None), T, "pose"),
        # metadata
        (lambda: ObjectMeta.short_descriptions(None), T, "asset_ids"),
        (lambda: ObjectMeta.short_descriptions([None]), T, "asset_ids[0]"),
        (lambda: ObjectMeta.get_short_description(None), T, "object_uid"),
        (lambda: ObjectMeta.all_descriptions(5), T, "asset_ids"),
        (lambda: ObjectMeta.get_features(None), T, "feature_type_str"),
        (lambda: ObjectMeta.get_features("clip_img_features", 5), T, "asset_ids"),
        (lambda: ObjectMeta.get_target_object_uid(None), T, "task"),
        (lambda: ObjectMeta.clean_object_name(None), T, "task"),
        # lazy loading and installing
        (lambda: llu.get_user_library_index(None), T, "path"),
        (lambda: llu.get_user_grasp_library_index([1]), T, "path"),
        (lambda: llu.install_objects_for_scene(None), T, "xml_path"),
        (lambda: llu.install_grasps_for_scene("s.xml", grasp_source=None), T, "grasp_source"),
        (lambda: llu.find_object_paths(None), T, "scene_xml"),
        (lambda: llu.install_scene_with_objects_and_grasps_from_path(None), T, "xml_path"),
        (lambda: llu.install_scene_with_objects_and_grasps_from_path({"x": 1}), V, "base"),
        (lambda: llu.install_scene_with_objects_and_grasps_from_path(-1), V, "xml_path"),
        # licences and search
        (lambda: lic.resolve_license(None, "thor", "x"), T, "data_type"),
        (lambda: lic.resolve_license("objects", None, "x"), T, "data_source"),
        (lambda: lic.resolve_license("objects", "thor", 1.5), T, "identifier"),
        (lambda: lic.resolve_license("objects", "thor", "x", registry=5), T, "registry"),
        (lambda: lic.license_identifiers(None, "thor"), T, "data_type"),
        (lambda: lic.object_license_key(None), T, "identifier"),
        (lambda: lic.resolve_license_policy(5), T, "policy"),
        (lambda: lic.print_license_info(None, "thor"), T, "data_type"),
        (lambda: ObjectRetriever(sim_thres="a"), T, "sim_thres"),
        (lambda: ObjectRetriever(sim_thres=float("nan")), V, "sim_thres"),
        (lambda: ObjectRetriever(max_results=-1), V, "max_results"),
        (lambda: ObjectRetriever(approximate="yes"), T, "approximate"),
        (lambda: ObjectRetriever(registry=5), T, "registry"),
        (lambda: ObjectRetriever(registry=mlspaces.Registry(), clip_store=5), T, "clip_store"),
        # env and bodies
        (lambda: create_mlspaces_body(None, "box"), T, "data"),
        (lambda: create_mlspaces_body(data, 1.5), T, "body_name_or_id"),
        (lambda: create_mlspaces_body(data, None), T, "body_name_or_id"),
        (lambda: setattr(body, "position", [1, 2]), V, "position"),
        (lambda: setattr(body, "quat", None), T, "quat"),
        (lambda: setattr(body, "pose", np.zeros((3, 3))), V, "pose"),
        (lambda: setattr(env, "current_batch_index", 1), V, "current_batch_index"),
        (lambda: setattr(env, "current_batch_index", "0"), T, "current_batch_index"),
        # samplers and datagen
        (lambda: PickTaskSampler(None), T, "config"),
        (lambda: sampler.seed_task_sampling(-1), V, "seed"),
        (lambda: sampler.seed_task_sampling("5"), T, "seed"),
        (lambda: register_config(None), T, "name"),
        (lambda: register_config("ErrorsTestConfig", strict="no"), T, "strict"),
        (lambda: get_config_class(None), T, "name"),
        (lambda: run_config(None), T, "config"),
        (lambda: run_config(PickBaseConfig(), workers=0), V, "workers"),
        (lambda: run_config(PickBaseConfig(), seed=-1), V, "seed"),
        (lambda: run_config(PickBaseConfig(), seed=2**64), V, "seed"),
        # pictures: past what the engine's ints hold, more than a sheet's views, no camera
        (lambda: render.asset_sheet(["a"], columns=2**31), V, "columns"),
        (lambda: render.asset_sheet(["a"], size=(9000, 8)), V, "size[0]"),
        (lambda: render.grasps("a", views=65), V, "views"),
        (lambda: render.grasps("a", joint=""), V, "joint"),
        (lambda: render.scene("c.yaml", house=2**63), V, "house"),
        (lambda: render.scene("c.yaml", seed=2**64), V, "seed"),
        (lambda: render.scene("c.yaml", overviews=17), V, "overviews"),
        (lambda: render.episode_phases("run", episode=2**63), V, "episode"),
        (lambda: render.episode_phases("run", camera=""), V, "camera"),
        (lambda: render.episode_phases("run", width=9000), V, "width"),
        (lambda: render.episode_phases("run", frames="no"), T, "frames"),
        (lambda: render.episode_phases("no_such_run"), FileNotFoundError, "no_such_run"),
        (lambda: render.read_png("no_such.png"), FileNotFoundError, "no_such.png"),
        (lambda: run_config(PickBaseConfig(), log_level="loud"), V, "log_level"),
        (lambda: run_config(PickBaseConfig(), resume="yes"), T, "resume"),
    ]


_GYM_CASES = [
    ("env_id_for_config", lambda g: g.env_id_for_config(None), TypeError, "config_name"),
    ("env_id_for_config", lambda g: g.env_id_for_config("X", version=-1), ValueError, "version"),
    ("register_configs", lambda g: g.register_configs(version="0"), TypeError, "version"),
    ("GymEnv", lambda g: g.GymEnv(config_name=5), TypeError, "config_name"),
    ("GymEnv", lambda g: g.GymEnv(exp_config=5), TypeError, "exp_config"),
    ("GymEnv", lambda g: g.GymEnv("X", render_mode="human"), ValueError, "render_mode"),
    ("GymEnv", lambda g: g.GymEnv("X", config_overrides=[1]), TypeError, "config_overrides"),
    ("GymEnv", lambda g: g.GymEnv("X", render_camera=5), TypeError, "render_camera"),
    ("GymEnv", lambda g: g.GymEnv("X", episode=-1), ValueError, "episode"),
    ("GymEnv", lambda g: g.GymEnv("X", house_index=2**63), ValueError, "house_index"),
]


def test_every_public_function_names_a_bad_argument(data):
    failures = []
    for i, (call, kind, name) in enumerate(_cases(data)):
        try:
            call()
        except kind as e:
            text = str(e)
            if name not in text or "\n" in text or "incompatible function" in text \
                    or not isinstance(e, OSError if kind is FileNotFoundError else ValueError):
                failures.append(f"case {i} ({name}): {type(e).__name__}: {text}")
        except Exception as e:  # noqa: BLE001 - collected, reported together
            failures.append(f"case {i} ({name}): {type(e).__name__} instead of "
                            f"{kind.__name__}: {e}")
        else:
            failures.append(f"case {i} ({name}): no error")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("func,call,kind,name", _GYM_CASES,
                         ids=[f"{c[0]}-{c[3]}" for c in _GYM_CASES])
def test_gym_functions_name_a_bad_argument(func, call, kind, name):
    gym_env = pytest.importorskip("mlspaces.tasks.gym_env")
    with pytest.raises(kind) as err:
        call(gym_env)
    assert isinstance(err.value, ValueError)
    _one_line_naming(err.value, func, name)


# -- the gym env ----------------------------------------------------------------------------

def _gym_env(**kwargs):
    gym_env = pytest.importorskip("mlspaces.tasks.gym_env")
    from test_gym import GymTestConfig
    return gym_env.GymEnv(exp_config=GymTestConfig(), **kwargs)


def test_render_without_a_render_mode_says_how_to_get_frames():
    env = _gym_env()
    try:
        env.reset(seed=0)
        with pytest.raises(ValueError) as err:
            env.render()
        _one_line_naming(err.value, "GymEnv.render", 'render_mode="rgb_array"', "gymnasium.make")
        with pytest.raises(TypeError, match="GymEnv.reset: seed"):
            env.reset(seed="1")
        with pytest.raises(ValueError, match=r"GymEnv.step: action\['arm'\]"):
            env.step({"arm": [np.nan] * 7, "gripper": [0.0]})
    finally:
        env.close()
    env.close()  # idempotent
    with pytest.raises(RuntimeError, match="closed"):
        env.reset(seed=0)


def test_a_cycle_through_the_sampler_is_collected():
    # The engine env holds the Python sampler; the GC sees that reference (tp_traverse), so a
    # sampler that refers back to its env does not keep both alive forever.
    env = _gym_env()
    env.task_sampler.owner = env
    ref = weakref.ref(env)
    del env
    gc.collect()
    assert ref() is None


def test_an_env_left_open_at_exit_prints_nothing(tmp_path):
    # The tutorial's config (its sampler in the user's module, which registers the libraries):
    # an env still open at exit used to leak the default registry (nanobind's leak report).
    code = ("import datagen\n"
            "from mlspaces.tasks.gym_env import GymEnv\n"
            "env = GymEnv('CustomAssetsDataGenConfig')\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=EXAMPLE_DIR, capture_output=True,
                         text=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(
                             [str(EXAMPLE_DIR), os.environ.get("PYTHONPATH", "")])})
    assert out.returncode == 0, out.stderr
    assert out.stderr == ""
    assert out.stdout == ""
