"""The MolmoSpaces custom-asset tutorial (the seed), every step in the tutorial's order, each as
the tutorial writes it with only ``molmo_spaces`` renamed to ``mlspaces``: the library files,
the asset index module (--compute-metadata), the grasp file from numpy, the grasp index module,
registration, lookups, annotation, grasps (the libraries page), scene metadata, and datagen.py
run with the tutorial's command. Plus the index modules' errors (the CLI's lines and codes)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from conftest import EXAMPLE_DIR

CLI = os.environ.get("MLSPACES_CLI_PATH")

# ---- The tutorial's files and code, verbatim ---------------------------------------------

RED_BLOCK_XML = """\
<mujoco model="red_block">
  <worldbody>
    <body name="red_block" pos="0 0 0">
      <freejoint/>
      <geom name="red_block_geom" type="box" size="0.025 0.025 0.025" rgba="1 0 0 1"/>
    </body>
  </worldbody>
</mujoco>
"""

RED_BLOCK_JSON = """\
{
  "assetId": "red_block",
  "category": "block",
  "description_long": "This is a red block.",
  "description": "A red block.",
  "description_short": {
    "one_word": "block",
    "two_words": "red block",
    "three_words": "red wooden block"
  },
  "synset": "block.n.01"
}
"""

WRITE_GRASPS_PY = """\
from pathlib import Path
import numpy as np

grasp_path = Path("asset_library/red_block/droid/grasps.npz")
grasp_path.parent.mkdir(parents=True, exist_ok=True)

grasp_pose = np.eye(4)
grasp_pose[:3, 1] = [0, -1, 0]
grasp_pose[:3, 2] = [0, 0, -1]

np.savez(
    grasp_path,
    transforms=grasp_pose.reshape(1, 4, 4),
)
"""

SCENE_XML = """\
<mujoco model="custom_assets_scene">
  <option integrator="implicit" timestep="0.002"/>
  <asset>
    <model name="red_block_model" file="asset_library/red_block/red_block.xml"/>
    <texture name="floor_checker" type="2d" builtin="checker" rgb1="0.2 0.3 0.4" rgb2="0.1 0.2 0.3" width="512" height="512"/>
    <material name="floor_checker_mat" texture="floor_checker" texrepeat="4 4" texuniform="true" reflectance="0.2"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" pos="0 0 0" material="floor_checker_mat"/>
    <light name="key_light" pos="1 -1 2" dir="-0.5 0.5 -1" directional="true" diffuse="0.8 0.8 0.8"/>
    <light name="fill_light" pos="-1 1 2" dir="0.5 -0.5 -1" directional="true" diffuse="0.4 0.4 0.4"/>
    <frame pos="0.4 0 0.025">
      <attach model="red_block_model" prefix=""/>
    </frame>
  </worldbody>
</mujoco>
"""

SCENE_METADATA_JSON = """\
{
  "objects": {
    "red_block": {
      "asset_id": "red_block",
      "object_id": "red_block",
      "category": "block",
      "is_static": false
    }
  }
}
"""

# The tutorial's datagen.py: the original example's imports with molmo_spaces -> mlspaces, then
# the tutorial's code ("Register user libraries", "Create task sampler", "Datagen config").
DATAGEN_PY = """\
from pathlib import Path

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation as R

from mlspaces.configs import PickTaskSamplerConfig
from mlspaces.configs.base_pick_config import PickBaseConfig
from mlspaces.configs.camera_configs import (
    FrankaDroidCameraSystem,
)
from mlspaces.configs.robot_configs import (
    FrankaRobotConfig,
)
from mlspaces.data_generation.config_registry import register_config
from mlspaces.env.data_views import create_mlspaces_body
from mlspaces.env.env import CPUMujocoEnv
from mlspaces.molmo_spaces_constants import (
    register_user_asset_library,
    register_user_grasp_library,
)
from mlspaces.tasks.pick_task_sampler import PickTaskSampler
from mlspaces.utils.pose import pose_mat_to_7d

register_user_asset_library("custom_assets", Path("asset_library"))
register_user_grasp_library("custom_grasps", Path("asset_library"), "custom_assets")


def random_pose(x_noise: float, y_noise: float, yaw_noise: float):
    pose = np.eye(4)
    pose[0, 3] = np.random.uniform(-x_noise, x_noise)
    pose[1, 3] = np.random.uniform(-y_noise, y_noise)
    pose[:3, :3] = R.from_euler(
        "z", np.random.uniform(-yaw_noise, yaw_noise), degrees=True
    ).as_matrix()
    return pose


class BlockPickupTaskSampler(PickTaskSampler):
    \"\"\"
    Since we're using a custom scene, we need to implement custom sampling logic
    \"\"\"

    def _sample_and_place_robot(self, env: CPUMujocoEnv) -> None:
        task_cfg = self.config.task_config
        robot_view = env.current_robot.robot_view

        robot_view.base.pose = robot_view.base.pose @ random_pose(0.1, 0.1, 30)
        mujoco.mj_fwdPosition(env.current_model, env.current_data)
        task_cfg.robot_base_pose = pose_mat_to_7d(robot_view.base.pose).tolist()

        pickup_obj = create_mlspaces_body(env.current_data, task_cfg.pickup_obj_name)
        pickup_obj.pose = pickup_obj.pose @ random_pose(0.05, 0.05, 45)
        mujoco.mj_fwdPosition(env.current_model, env.current_data)

        task_cfg.pickup_obj_start_pose = pose_mat_to_7d(pickup_obj.pose).tolist()
        pickup_obj_goal_pose = pose_mat_to_7d(pickup_obj.pose)
        pickup_obj_goal_pose[2] += 0.05
        task_cfg.pickup_obj_goal_pose = pickup_obj_goal_pose.tolist()


@register_config("CustomAssetsDataGenConfig")
class FrankaPickDroidDataGenConfig(PickBaseConfig):
    scene_dataset: str = "user"
    num_workers: int = 1
    robot_config: FrankaRobotConfig = FrankaRobotConfig(base_size=None)
    camera_config: FrankaDroidCameraSystem = FrankaDroidCameraSystem()
    task_sampler_config: PickTaskSamplerConfig = PickTaskSamplerConfig(
        task_sampler_class=BlockPickupTaskSampler,
        dataset_name="user",
        scene_xml_paths=["scene.xml"],
        house_inds=None,
        samples_per_house=2,
        house_variant="base",
    )
    output_dir: Path = Path("experiment_output")

    @property
    def tag(self) -> str:
        return "tutorial_franka_pick_custom_assets"
"""

# The registration and the lookups of the libraries page (seed 001), on the tutorial's UID,
# in a script as a user runs them; the values are printed as JSON for the test to check.
LOOKUPS_PY = """\
import json
from pathlib import Path

from mlspaces.molmo_spaces_constants import (
    USER_ASSET_LIBRARIES,
    USER_GRASP_LIBRARIES,
    OBJECT_LIBRARY_TO_GRASP_LIBRARIES,
    register_user_asset_library,
    register_user_grasp_library,
)

register_user_asset_library("custom_assets", Path("asset_library"))
register_user_grasp_library("custom_grasps", Path("asset_library"), "custom_assets")

from mlspaces.utils.object_metadata import ObjectMeta

anno = ObjectMeta.annotation("red_block")
print(anno["category"], anno["description"])

from mlspaces.utils.lazy_loading_utils import locate_uid_package, install_uid

source, package, xml_path = locate_uid_package("red_block")
installed_xml_path = install_uid("red_block")

from mlspaces.utils.grasps import (
    get_pickup_grasp_path,
    has_valid_pickup_grasps,
    load_pickup_grasps,
)

if has_valid_pickup_grasps("red_block"):
    grasp_path = get_pickup_grasp_path("red_block")
    grasps = load_pickup_grasps("red_block", num_grasps=50)

from mlspaces.utils.scene_metadata_utils import get_scene_metadata

scene_metadata = get_scene_metadata("scene.xml")
asset_id = scene_metadata["objects"]["red_block"]["asset_id"]
grasp_libraries = OBJECT_LIBRARY_TO_GRASP_LIBRARIES["custom_assets"]
scene_grasps = load_pickup_grasps(asset_id, grasp_libraries, num_grasps=int(1e6))

print(json.dumps({
    "anno": {k: anno[k] for k in ("assetId", "category", "description", "mass", "boundingBox")},
    "locate": [source, package, str(xml_path)],
    "install_uid": str(installed_xml_path),
    "user_asset_libraries": {k: str(v) for k, v in USER_ASSET_LIBRARIES.items()},
    "user_grasp_libraries": {k: str(v) for k, v in USER_GRASP_LIBRARIES.items()},
    "grasp_libraries": grasp_libraries,
    "grasp_path": str(grasp_path),
    "grasps": grasps.tolist(),
    "asset_id": asset_id,
    "scene_grasps": scene_grasps.tolist(),
}))
"""

# -------------------------------------------------------------------------------------------


def _python(project: Path, *args: str) -> subprocess.CompletedProcess:
    """`python ARGS` in the project folder, as the tutorial's shell runs it (no install dir of
    built-in data configured)."""
    env = dict(os.environ)
    env.pop("MLSPACES_ASSETS_DIR", None)
    return subprocess.run([sys.executable, *args], cwd=project, env=env, capture_output=True,
                          text=True)


def _ok(out: subprocess.CompletedProcess) -> str:
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Traceback" not in out.stderr, out.stderr
    return out.stdout


def test_the_seed_tutorial_step_by_step(tmp_path):
    # Project setup.
    project = tmp_path / "my_project"
    project.mkdir()
    lib = project / "asset_library"

    # Create asset library: object XML and metadata.
    (lib / "red_block").mkdir(parents=True)
    (lib / "red_block" / "red_block.xml").write_text(RED_BLOCK_XML)
    (lib / "red_block" / "red_block.json").write_text(RED_BLOCK_JSON)

    # Generate asset library index (with --compute-metadata).
    stdout = _ok(_python(project, "-m", "mlspaces.resources.generate_user_asset_library_index",
                         "asset_library", "--compute-metadata"))
    assert f"Wrote {lib / 'assets_index.json'} with 1 assets." in stdout.splitlines()
    # Byte for byte what the original writes (the committed example is the original's output).
    assert (lib / "assets_index.json").read_bytes() == (
        EXAMPLE_DIR / "asset_library" / "assets_index.json").read_bytes()
    computed = json.loads((lib / "red_block" / "red_block_computed.json").read_text())
    source = json.loads(RED_BLOCK_JSON)
    assert list(computed)[:len(source)] == list(source)
    assert {k: computed[k] for k in source} == source
    assert computed["mass"] == pytest.approx(0.125)
    assert computed["boundingBox"] == pytest.approx({"x": 0.05, "y": 0.05, "z": 0.05})

    # Create grasp library: the grasp file from the tutorial's numpy code.
    (project / "write_grasps.py").write_text(WRITE_GRASPS_PY)
    _ok(_python(project, "write_grasps.py"))
    grasp_pose = np.eye(4)
    grasp_pose[:3, 1], grasp_pose[:3, 2] = [0, -1, 0], [0, 0, -1]
    with np.load(lib / "red_block" / "droid" / "grasps.npz") as npz:
        np.testing.assert_array_equal(npz["transforms"], grasp_pose.reshape(1, 4, 4))

    # Generate grasp library index.
    stdout = _ok(_python(project, "-m", "mlspaces.resources.generate_user_grasp_library_index",
                         "asset_library"))
    assert (f"Wrote {lib / 'grasps_index.json'} with 1 robots / 1 grasp files."
            in stdout.splitlines())
    assert (lib / "grasps_index.json").read_bytes() == (
        EXAMPLE_DIR / "asset_library" / "grasps_index.json").read_bytes()

    # Create the scene: model and metadata.
    (project / "scene.xml").write_text(SCENE_XML)
    (project / "scene_metadata.json").write_text(SCENE_METADATA_JSON)

    # Register the libraries, then the lookups of the libraries page on the tutorial's UID.
    (project / "lookups.py").write_text(LOOKUPS_PY)
    lines = _ok(_python(project, "lookups.py")).splitlines()
    assert lines[0] == "block A red block."
    got = json.loads(lines[-1])
    xml = str(lib / "red_block" / "red_block.xml")
    assert got["anno"] == {"assetId": "red_block", "category": "block",
                           "description": "A red block.", "mass": computed["mass"],
                           "boundingBox": computed["boundingBox"]}
    assert got["locate"] == ["custom_assets", None, xml]
    assert got["install_uid"] == xml
    assert got["user_asset_libraries"] == {"custom_assets": str(lib)}
    assert got["user_grasp_libraries"] == {"custom_grasps/droid": str(lib)}
    assert got["grasp_libraries"] == ["custom_grasps/droid"]
    assert got["grasp_path"] == str(lib / "red_block" / "droid" / "grasps.npz")
    np.testing.assert_array_equal(got["grasps"], grasp_pose.reshape(1, 4, 4))
    assert got["asset_id"] == "red_block"
    np.testing.assert_array_equal(got["scene_grasps"], grasp_pose.reshape(1, 4, 4))

    # Configure datagen (datagen.py) and run it with the tutorial's command.
    (project / "datagen.py").write_text(DATAGEN_PY)
    stdout = _ok(_python(project, "-m", "mlspaces.data_generation.main",
                         "datagen:CustomAssetsDataGenConfig"))
    # The tutorial's config draws its seed at run time: two episodes kept, in as many attempts
    # as that took (the runner retries a failed attempt).
    counts = re.search(r"^Success count: (\d+), Total count: (\d+)$", stdout, re.M)
    assert counts and int(counts[1]) == 2 and int(counts[2]) >= 2, stdout
    runs = list((project / "experiment_output" / "CustomAssetsDataGenConfig").iterdir())
    assert len(runs) == 1 and len(runs[0].name) == len("YYYYmmdd_HHMMSS"), runs
    house = runs[0] / "house_0"
    with h5py.File(house / "trajectories_batch_1_of_1.h5", "r") as f:
        trajs = sorted(k for k in f if k.startswith("traj_"))
        assert trajs == ["traj_0", "traj_1"]
        for t in trajs:
            assert f[t]["success"].shape[0] > 0 and bool(f[t]["success"][-1])
    for k in range(2):
        for cam in ("wrist_camera", "exo_camera_1"):
            assert (house / f"episode_{k:08d}_{cam}_batch_1_of_1.mp4").stat().st_size > 0
    if CLI:
        check = subprocess.run([CLI, "validate-dataset", str(runs[0])], capture_output=True,
                               text=True)
        assert check.returncode == 0, check.stdout + check.stderr


def test_the_example_library_files_are_what_the_index_modules_write(tmp_path):
    """examples/custom_assets/README.md: the committed indexes and computed metadata are the
    index modules' output on the example's sources, byte for byte."""
    example = EXAMPLE_DIR / "asset_library"
    lib = tmp_path / "asset_library"
    shutil.copytree(example, lib)
    for generated in ("assets_index.json", "grasps_index.json",
                      "red_block/red_block_computed.json"):
        (lib / generated).unlink()
    _ok(_python(tmp_path, "-m", "mlspaces.resources.generate_user_asset_library_index",
                "asset_library", "--compute-metadata"))
    _ok(_python(tmp_path, "-m", "mlspaces.resources.generate_user_grasp_library_index",
                "asset_library"))
    for generated in ("assets_index.json", "grasps_index.json",
                      "red_block/red_block_computed.json"):
        assert (lib / generated).read_bytes() == (example / generated).read_bytes(), generated


# ---- The index modules are the CLI's commands --------------------------------------------

ASSET_MODULE = "mlspaces.resources.generate_user_asset_library_index"
GRASP_MODULE = "mlspaces.resources.generate_user_grasp_library_index"


def _library(root: Path) -> Path:
    (root / "red_block" / "droid").mkdir(parents=True)
    (root / "red_block" / "red_block.xml").write_text(RED_BLOCK_XML)
    (root / "red_block" / "red_block.json").write_text(RED_BLOCK_JSON)
    np.savez(root / "red_block" / "droid" / "grasps.npz", transforms=np.eye(4)[None])
    return root


def _one_error_line(out: subprocess.CompletedProcess, code: int) -> str:
    assert out.returncode == code, out.stdout + out.stderr
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("mlspaces: error: "), out.stderr
    return lines[0]


def test_index_modules_errors_are_the_cli_lines_and_codes(tmp_path):
    _library(tmp_path / "lib")
    _ok(_python(tmp_path, "-m", ASSET_MODULE, "lib"))
    line = _one_error_line(_python(tmp_path, "-m", ASSET_MODULE, "lib"), 1)
    assert line == (f"mlspaces: error: {tmp_path / 'lib' / 'assets_index.json'} already "
                    "exists. Use --overwrite to overwrite.")
    _one_error_line(_python(tmp_path, "-m", ASSET_MODULE, "lib", "--bogus"), 2)
    _one_error_line(_python(tmp_path, "-m", ASSET_MODULE), 2)
    _one_error_line(_python(tmp_path, "-m", GRASP_MODULE, "missing_dir"), 1)
    (tmp_path / "lib" / "stray.xml").write_text("<mujoco/>")
    line = _one_error_line(_python(tmp_path, "-m", ASSET_MODULE, "lib", "--overwrite"), 1)
    assert "stray.json" in line
    # --suppress-missing-metadata, -o: the original's flags.
    out = _python(tmp_path, "-m", ASSET_MODULE, "lib", "--overwrite",
                  "--suppress-missing-metadata", "-o", "other/index.json")
    assert "stray" in _ok(out) + out.stderr
    assert json.loads((tmp_path / "other" / "index.json").read_text()).keys() == {"red_block"}
    _ok(_python(tmp_path, "-m", GRASP_MODULE, "lib", "--overwrite", "--output", "g.json"))
    assert json.loads((tmp_path / "g.json").read_text())["grasp_paths"] == {
        "droid": {"red_block": "red_block/droid/grasps.npz"}}
    # The CLI's own parse-error handling (apps/mlspaces/cli_app.cc): the misspelled flag typed
    # first, with the flag it was meant to be, control characters escaped.
    line = _one_error_line(
        _python(tmp_path, "-m", ASSET_MODULE, "lib", "--compute-metdata", "--overwirte"), 2)
    assert "--compute-metdata: unknown flag" in line
    assert "did you mean '--compute-metadata'?" in line
    line = _one_error_line(_python(tmp_path, "-m", GRASP_MODULE, "mi\x1bss\ning"), 1)
    assert "mi\\x1bss\\x0aing" in line
    usage = _ok(_python(tmp_path, "-m", ASSET_MODULE, "--help"))
    assert f"python -m {ASSET_MODULE} [OPTIONS] DIR" in usage
    for flag in ("--output", "--overwrite", "--compute-metadata", "--suppress-missing-metadata"):
        assert flag in usage


def _messages(out: subprocess.CompletedProcess) -> list[str]:
    """The warning and error lines of stderr (not a progress display)."""
    return [line for line in out.stderr.splitlines() if line.startswith(("mlspaces", "Warning"))]


@pytest.mark.skipif(not CLI, reason="needs MLSPACES_CLI_PATH (the ctest sets it)")
def test_index_modules_print_what_the_cli_prints(tmp_path):
    for args in (["--compute-metadata"], []):
        a, b = _library(tmp_path / "a"), _library(tmp_path / "b")
        mod = _python(tmp_path, "-m", ASSET_MODULE, "a", *args)
        cli = subprocess.run([CLI, "index-assets", "b", *args], cwd=tmp_path,
                             capture_output=True, text=True)
        assert (mod.returncode, mod.stdout.replace(str(a), "LIB"), _messages(mod)) == (
            cli.returncode, cli.stdout.replace(str(b), "LIB"), _messages(cli))
        assert (a / "assets_index.json").read_bytes() == (b / "assets_index.json").read_bytes()
        # An error (the index exists): the same line and exit code.
        mod = _python(tmp_path, "-m", ASSET_MODULE, "a", *args)
        cli = subprocess.run([CLI, "index-assets", "b", *args], cwd=tmp_path,
                             capture_output=True, text=True)
        assert mod.returncode == cli.returncode == 1
        assert [m.replace(str(a), "LIB") for m in _messages(mod)] == [
            m.replace(str(b), "LIB") for m in _messages(cli)]
        mod = _python(tmp_path, "-m", GRASP_MODULE, "a")
        cli = subprocess.run([CLI, "index-grasps", "b"], cwd=tmp_path, capture_output=True,
                             text=True)
        assert (mod.returncode, mod.stdout.replace(str(a), "LIB")) == (
            cli.returncode, cli.stdout.replace(str(b), "LIB"))
        for d in (a, b):
            shutil.rmtree(d)


def test_index_module_main_from_code(tmp_path, capfd):
    from mlspaces.resources import generate_user_grasp_library_index as gen
    lib = _library(tmp_path / "lib")
    assert gen.main([str(lib)]) == 0
    assert capfd.readouterr().out == (
        f"Wrote {lib / 'grasps_index.json'} with 1 robots / 1 grasp files.\n")
    assert gen.main([str(lib)]) == 1
    with pytest.raises(TypeError, match=r"argv\[0\]"):
        gen.main([lib])
