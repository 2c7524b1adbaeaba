"""The data engine from Python: the tutorial's datagen.py as written, Python samplers on the
C++ runner (seeding, determinism, workers, resume after Ctrl-C, hook errors), and the env's
model and data shared with the real `mujoco` module."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import mujoco
import numpy as np
import pytest

import mlspaces
from mlspaces import Registry
from mlspaces.configs import (FrankaRobotConfig, PickBaseConfig, PickTaskSamplerConfig,
                              to_native)
from mlspaces.datagen import run_config
from mlspaces.env import CPUMujocoEnv, create_mlspaces_body
from mlspaces.tasks import PickTaskSampler, RobotPlacementError
from mlspaces.utils.pose import pose_mat_to_7d

from conftest import EXAMPLE_DIR, jitter_robot_base, run_datagen_module

CLI = os.environ.get("MLSPACES_CLI_PATH")


def _tree_digest(folder: Path) -> dict[str, str]:
    """sha256 of every data file of a run folder (journals and summaries hold times)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.suffix in (".h5", ".mp4"):
            out[str(p.relative_to(folder))] = hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _episodes(h5: Path) -> list[str]:
    with h5py.File(h5, "r") as f:
        return sorted(k for k in f.keys() if k.startswith("traj_"))


@pytest.fixture
def project(tmp_path, monkeypatch) -> Path:
    """A copy of the tutorial folder as the current directory."""
    dst = tmp_path / "custom_assets"
    shutil.copytree(EXAMPLE_DIR, dst, ignore=shutil.ignore_patterns("experiment_output"))
    monkeypatch.chdir(dst)
    return dst


def test_the_mirrored_entry_point_answers_help(project):
    # The tutorial's datagen.py run as written (cameras and all) is
    # test_tutorial.py::test_the_seed_tutorial_step_by_step.
    again = subprocess.run(
        [sys.executable, "-m", "mlspaces.data_generation.main", "--help"], cwd=project,
        capture_output=True, text=True)
    assert again.returncode == 0 and "CONFIG" in again.stdout


# A sampler and config of this module, without cameras (fast).

class RecordingSampler(PickTaskSampler):
    """The tutorial's hook shape, drawing through np.random, random and self.rng, writing
    the object's pose through data.qpos directly (the engine must see it)."""

    calls: list = []
    fail_at: int | None = None
    interrupt_at: int | None = None

    def _sample_and_place_robot(self, env: CPUMujocoEnv) -> None:
        import random
        n = len(type(self).calls)
        if type(self).interrupt_at is not None and n == type(self).interrupt_at:
            type(self).calls.append("interrupt")
            raise KeyboardInterrupt
        assert isinstance(env.current_model, mujoco.MjModel)
        assert isinstance(env.current_data, mujoco.MjData)
        task_cfg = self.config.task_config
        jitter_robot_base(env, task_cfg)
        body = env.current_model.body(task_cfg.pickup_obj_name)
        adr = env.current_model.jnt_qposadr[env.current_model.body_jntadr[body.id]]
        env.current_data.qpos[adr] += random.uniform(-0.02, 0.02)
        env.current_data.qpos[adr + 1] += float(self.rng.uniform(-0.02, 0.02))
        mujoco.mj_forward(env.current_model, env.current_data)
        obj = create_mlspaces_body(env.current_data, task_cfg.pickup_obj_name)
        np.testing.assert_allclose(env.current_data.body(task_cfg.pickup_obj_name).xpos,
                                   obj.position, atol=1e-12)
        start = pose_mat_to_7d(obj.pose)
        task_cfg.pickup_obj_start_pose = start.tolist()
        start[2] += 0.05
        task_cfg.pickup_obj_goal_pose = start.tolist()
        type(self).calls.append(task_cfg.pickup_obj_start_pose[:2])
        if type(self).fail_at is not None and n >= type(self).fail_at:
            raise RobotPlacementError("no room")


class FastConfig(PickBaseConfig):
    robot_config: FrankaRobotConfig = FrankaRobotConfig(base_size=None)
    task_sampler_config: PickTaskSamplerConfig = PickTaskSamplerConfig(
        task_sampler_class=RecordingSampler, scene_xml_paths=["scene.xml"],
        samples_per_house=3, episodes_per_batch=2)
    seed: int = 7

    def model_post_init(self, ctx) -> None:
        super().model_post_init(ctx)
        self.task_config.enable_rendering = False
        self.camera_config.cameras = []


@pytest.fixture
def libraries(project):
    reg = mlspaces.default_registry()
    if "custom_assets" not in reg.user_asset_libraries:
        mlspaces.register_user_asset_library("custom_assets", EXAMPLE_DIR / "asset_library")
        mlspaces.register_user_grasp_library("custom_grasps", EXAMPLE_DIR / "asset_library",
                                             "custom_assets")
    RecordingSampler.calls = []
    RecordingSampler.fail_at = None
    RecordingSampler.interrupt_at = None
    return reg


def test_python_sampler_same_seed_same_bytes_and_engine_sees_its_writes(libraries, project):
    r1 = run_config(FastConfig(), output_dir=project / "a", progress=False)
    calls1 = list(RecordingSampler.calls)
    RecordingSampler.calls = []
    r2 = run_config(FastConfig(), output_dir=project / "b", progress=False)
    assert r1["episodes_kept"] == 3 and r1["attempts"] >= 3
    assert RecordingSampler.calls == calls1
    assert _tree_digest(project / "a") == _tree_digest(project / "b") != {}
    RecordingSampler.calls = []
    run_config(FastConfig(), output_dir=project / "c", seed=8, progress=False)
    assert RecordingSampler.calls != calls1
    # What the hook wrote into data.qpos is the episode's recorded start.
    with h5py.File(project / "a" / "house_0" / "trajectories_batch_1_of_2.h5", "r") as f:
        obs_scene = json.loads(f["traj_0"]["obs_scene"][()])
    np.testing.assert_allclose(obs_scene["frozen_config"]["pickup_obj_start_pose"][:2],
                               calls1[0], atol=1e-12)


def test_workers_and_shards_give_the_same_bytes(libraries, project):
    run_config(FastConfig(), output_dir=project / "one", workers=1, progress=False)
    run_config(FastConfig(), output_dir=project / "two", workers=2, progress=False)
    assert _tree_digest(project / "one") == _tree_digest(project / "two")
    for shard in ("0/2", "1/2"):
        run_config(FastConfig(), output_dir=project / "sharded", shard=shard, progress=False)
    assert _tree_digest(project / "one") == _tree_digest(project / "sharded")


def test_ctrl_c_stops_cleanly_and_the_run_resumes_to_the_same_bytes(libraries, project):
    run_config(FastConfig(), output_dir=project / "whole", progress=False)
    RecordingSampler.calls = []
    RecordingSampler.interrupt_at = 1  # the second hook call raises KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt):
        run_config(FastConfig(), output_dir=project / "cut", progress=False)
    RecordingSampler.interrupt_at = None
    report = run_config(FastConfig(), output_dir=project / "cut", resume=True, progress=False)
    assert report["episodes_kept"] >= 1
    assert _tree_digest(project / "whole") == _tree_digest(project / "cut")


def test_hook_rejections_and_errors(libraries, project):
    RecordingSampler.fail_at = 0
    report = run_config(FastConfig(), output_dir=project / "rejected", progress=False)
    assert report["episodes_kept"] == 0 and report["attempts"] > 0
    journal = (project / "rejected" / "journal.jsonl").read_text().splitlines()
    assert all(json.loads(line)["outcome"] == "sampler_reject" for line in journal)

    class Broken(PickTaskSampler):
        def _sample_and_place_robot(self, env):
            raise ZeroDivisionError("bug in the hook")

    class Unset(PickTaskSampler):
        def _sample_and_place_robot(self, env):
            self.config.task_config.robot_base_pose = [0, 0, 0]

    class MisCalled(PickTaskSampler):
        def _on_candidate_selected(self, env, reference_obj_name, reference_obj_id,
                                   supporting_geom_id):
            # A ValueError here rejects the candidate, but not a mis-called API: that is a
            # bug in the hook, raised, not every candidate quietly rejected.
            from mlspaces.utils.grasps import load_pickup_grasps
            load_pickup_grasps(None)
            return True

    for cls, exc, match in ((Broken, ZeroDivisionError, "bug in the hook"),
                            (Unset, mlspaces.MlspacesError, "robot_base_pose"),
                            (MisCalled, mlspaces.UsageError, "load_pickup_grasps: uid")):
        cfg = FastConfig()
        cfg.task_sampler_config.task_sampler_class = cls
        with pytest.raises(exc, match=match):
            run_config(cfg, output_dir=project / cls.__name__, progress=False)


def test_yaml_and_python_forms_of_the_tutorial_config_agree(project):
    # A fresh process: importing datagen registers its libraries and config, once per process.
    code = ("import datagen, json\n"
            "from mlspaces.datagen import get_config_class, native_config_text\n"
            "print(native_config_text(get_config_class('CustomAssetsDataGenConfig')()))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=project, capture_output=True,
                         text=True, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert out.returncode == 0, out.stderr
    native = json.loads(out.stdout)
    assert native["libraries"]["asset_libraries"] == [
        {"name": "custom_assets", "path": str(project / "asset_library")}]
    py = mlspaces._core.config_yaml_to_dict(mlspaces._core.resolve_config_yaml(
        json.dumps(native), "python", str(project)))
    yaml = mlspaces._core.config_yaml_to_dict(mlspaces._core.resolve_config_yaml(
        (project / "datagen.yaml").read_text(), "datagen.yaml", str(project)))
    assert py["task_sampler_config"]["task_sampler_class"] == "datagen:BlockPickupTaskSampler"
    py["task_sampler_config"]["task_sampler_class"] = "block_pickup"
    assert py == yaml


def test_config_objects_are_pydantic_with_the_original_defaults():
    cfg = PickBaseConfig()
    assert cfg.policy_dt_ms == 66 and cfg.ctrl_dt_ms == 2 and cfg.task_horizon == 500
    assert cfg.robot_config.base_size == [0.5, 0.5, 0.58]
    assert cfg.camera_config.img_resolution == (640, 368)
    assert [c.name for c in cfg.camera_config.cameras] == ["wrist_camera", "exo_camera_1"]
    with pytest.raises(Exception):
        PickBaseConfig(no_such_field=1)
    with pytest.raises(ValueError, match="multiple of sim_dt_ms"):
        PickBaseConfig(policy_dt_ms=65, sim_dt_ms=2)
    # The engine's defaults round-trip: the default config is the engine's default config.
    native = to_native(cfg, Registry())
    assert mlspaces._core.resolve_config_yaml(json.dumps(native), "py", ".", False) == \
        mlspaces._core.resolve_config_yaml(mlspaces._core.default_config_yaml(), "cpp", ".",
                                           False)


class HookSampler(RecordingSampler):
    """Overrides the other hooks: randomize_scene (calling super()), _on_candidate_selected
    (declining the first candidate) and init_scene."""

    seen: list = []

    def init_scene(self, env):
        type(self).seen.append(("init", env.current_model_path))

    def randomize_scene(self, env, robot_view):
        model, data = env.current_model, env.current_data
        adr = model.jnt_qposadr[model.joint("robot_0/fr3_joint1").id]
        data.qpos[adr] = 99.0
        super().randomize_scene(env, robot_view)  # the engine's reset and arm noise
        # What the engine wrote in C++ is what Python reads: the reset replaced the 99.
        assert abs(data.qpos[adr]) < 3.0
        type(self).kept = (model, data)
        data.qpos[adr] = 0.25  # seen by the engine: recorded as the first arm joint
        type(self).seen.append(("randomize", float(np.random.uniform())))

    def _on_candidate_selected(self, env, reference_obj_name, reference_obj_id,
                               supporting_geom_id):
        type(self).seen.append(("candidate", reference_obj_name))
        return sum(1 for s in type(self).seen if s[0] == "candidate") > 1


def test_other_hooks_run_with_super_and_rejections(libraries, project):
    cfg = FastConfig()
    cfg.task_sampler_config.task_sampler_class = HookSampler
    cfg.task_sampler_config.samples_per_house = 1
    HookSampler.seen = []
    report = run_config(cfg, output_dir=project / "hooks", progress=False)
    kinds = [s[0] for s in HookSampler.seen]
    assert kinds[0] == "init" and HookSampler.seen[0][1] == "house_0"
    assert kinds.count("candidate") == 2 and kinds.count("randomize") == 2
    journal = [json.loads(line)["outcome"] for line in
               (project / "hooks" / "journal.jsonl").read_text().splitlines()]
    assert journal[0] == "sampler_reject" and report["episodes_kept"] == 1
    with h5py.File(project / "hooks" / "house_0" / "trajectories_batch_1_of_1.h5", "r") as f:
        q0 = json.loads(bytes(f["traj_0"]["obs/agent/qpos"][0]).rstrip(b"\0"))["arm"][0]
    assert abs(q0 - 0.25) < 1e-6
    # The model and data a hook held stay valid after the run (Python owns them).
    model, data = HookSampler.kept
    mujoco.mj_forward(model, data)
    assert data.qpos.shape == (model.nq,) and np.isfinite(data.xpos).all()
    first = HookSampler.seen
    HookSampler.seen = []
    run_config(cfg, output_dir=project / "hooks2", progress=False)
    assert HookSampler.seen == first  # the hook's np.random draws are seeded per episode


def test_an_engine_sampler_by_name_runs_from_python(libraries, project):
    cfg = FastConfig()
    cfg.task_sampler_config.task_sampler_class = "block_pickup"
    report = run_config(cfg, output_dir=project / "builtin", progress=False)
    assert report["episodes_kept"] == 3
    with pytest.raises(ValueError, match="task_sampler_class"):
        cfg.task_sampler_config.task_sampler_class = "no_such_sampler"
        run_config(cfg, output_dir=project / "unknown", progress=False)


def test_mlspaces_gl_is_read_and_a_bad_one_is_named(libraries, project, monkeypatch):
    # gl=None: MLSPACES_GL, else osmesa (sim::ResolveGlBackend, as `mlspaces datagen --gl`).
    monkeypatch.setenv("MLSPACES_GL", "vulkan")
    with pytest.raises(mlspaces.errors.UsageError, match="MLSPACES_GL: unknown GL backend"):
        run_config(FastConfig(), output_dir=project / "bad_gl", progress=False)
    with pytest.raises(mlspaces.errors.UsageError, match="^gl: unknown GL backend 'glfw'"):
        run_config(FastConfig(), output_dir=project / "bad_gl", progress=False, gl="glfw")
    assert not (project / "bad_gl").exists()


class DefaultPlacement(PickTaskSampler):
    """Overrides no placement: the engine's block_pickup runs."""


class NudgedPlacement(PickTaskSampler):
    """super() places as block_pickup does; the override then raises the goal."""

    def _sample_and_place_robot(self, env):
        super()._sample_and_place_robot(env)
        assert len(self.config.task_config.pickup_obj_start_pose) == 7
        self.config.task_config.pickup_obj_goal_pose[2] += 0.01


def _trajectories(folder: Path) -> list:
    out = []
    for h5 in sorted(folder.rglob("*.h5")):
        with h5py.File(h5, "r") as f:
            for traj in sorted(f):
                out.append((np.asarray(f[traj]["obs/agent/qpos"][()]),
                            np.asarray(f[traj]["actions/commanded_action"][()])))
    return out


def test_a_sampler_without_placement_runs_the_engines_block_pickup(libraries, project):
    cfg = FastConfig()
    cfg.task_sampler_config.task_sampler_class = "block_pickup"
    run_config(cfg, output_dir=project / "builtin", progress=False)
    cfg.task_sampler_config.task_sampler_class = DefaultPlacement
    run_config(cfg, output_dir=project / "default", progress=False)
    ours, theirs = _trajectories(project / "default"), _trajectories(project / "builtin")
    assert len(ours) == len(theirs) == 3
    for (q1, a1), (q2, a2) in zip(ours, theirs):
        np.testing.assert_array_equal(q1, q2)
        np.testing.assert_array_equal(a1, a2)
    cfg.task_sampler_config.task_sampler_class = NudgedPlacement
    report = run_config(cfg, output_dir=project / "nudged", progress=False)
    assert report["episodes_kept"] == 3
    with h5py.File(project / "nudged" / "house_0" / "trajectories_batch_1_of_2.h5", "r") as f:
        scene = json.loads(f["traj_0"]["obs_scene"][()])["frozen_config"]
    start, goal = scene["pickup_obj_start_pose"], scene["pickup_obj_goal_pose"]
    assert abs(goal[2] - start[2] - 0.05 - 0.01) < 1e-9


def test_a_nan_in_a_grasp_file_stops_the_run_before_simulating(project):
    """Broken input is no silent success: the tutorial run stops with one line naming the
    grasp file and its `transforms`, and writes no trajectory."""
    npz = project / "asset_library" / "red_block" / "droid" / "grasps.npz"
    grasps = dict(np.load(npz))
    grasps["transforms"][0, 0, 3] = np.nan
    np.savez(npz, **grasps)
    out = run_datagen_module(project, "datagen:CustomAssetsDataGenConfig")
    assert out.returncode != 0, out.stdout + out.stderr
    lines = out.stderr.splitlines()
    assert len(lines) == 1, out.stderr
    assert str(npz) in lines[0] and "transforms" in lines[0] and "grasp 0 " in lines[0]
    assert not list((project / "run").rglob("*.h5"))
