"""The package as a MolmoSpaces user meets it: mirrored module paths, the process-default
registry behind the module functions, one MuJoCo shared with `import mujoco`."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import write_library


def test_mirrored_module_paths_and_process_default_registry(tmp_path, tutorial_library):
    from mlspaces.molmo_spaces_constants import (OBJECT_LIBRARY_TO_GRASP_LIBRARIES,
                                                 USER_ASSET_LIBRARIES, USER_GRASP_LIBRARIES,
                                                 register_user_asset_library,
                                                 register_user_grasp_library)
    from mlspaces.utils.grasps import (get_pickup_grasp_path, has_valid_pickup_grasps,
                                       load_pickup_grasps)
    from mlspaces.utils.lazy_loading_utils import install_uid, locate_uid_package
    from mlspaces.utils.object_metadata import ObjectMeta

    register_user_asset_library("custom_assets_pkg", tutorial_library)
    register_user_grasp_library("custom_grasps_pkg", tutorial_library, "custom_assets_pkg")
    assert USER_ASSET_LIBRARIES["custom_assets_pkg"] == tutorial_library.absolute()
    assert "custom_grasps_pkg/droid" in USER_GRASP_LIBRARIES
    assert OBJECT_LIBRARY_TO_GRASP_LIBRARIES["custom_assets_pkg"] == ["custom_grasps_pkg/droid"]
    with pytest.raises(ValueError):
        register_user_asset_library("custom_assets_pkg", tutorial_library)

    source, package, xml = locate_uid_package("red_block")
    # The first library registered in this process that holds red_block answers (another test
    # file of the same pytest run may have registered the tutorial library before this one).
    first = next(n for n, p in USER_ASSET_LIBRARIES.items() if p == tutorial_library.absolute())
    assert source == first and package is None
    assert xml == (tutorial_library / "red_block" / "red_block.xml").absolute()
    assert install_uid("red_block") == xml
    with pytest.raises(ValueError, match="not found"):
        install_uid("not_a_uid")
    assert has_valid_pickup_grasps("red_block")
    assert get_pickup_grasp_path("red_block").name == "grasps.npz"
    assert load_pickup_grasps("red_block").shape == (1, 4, 4)

    assert ObjectMeta.annotation("red_block")["mass"] > 0
    assert ObjectMeta.annotation(["red_block", "nope"])[1] is None
    assert "red_block" in ObjectMeta.annotation()
    assert ObjectMeta.short_descriptions("nope") == []
    assert ObjectMeta.get_short_description("mug_3") == ["mug"] * 4

    lib = write_library(tmp_path / "feat", {"f1": 1, "f2": 1}, npz_meta=True)
    register_user_asset_library("feat_pkg", lib)
    feats = ObjectMeta.img_features(["f1", "f2"])
    assert feats.shape == (2, 3, 4) and feats.dtype == np.float32
    assert ObjectMeta.img_features("f1").shape == (1, 3, 4)
    with pytest.raises(KeyError):
        ObjectMeta.description_text_features("f1")
    assert ObjectMeta.short_descriptions(["f1"]) == [["block", "f1 block", "small f1 block"]]


def test_one_mujoco_in_the_process():
    """The extension runs on the libmujoco of the `mujoco` package, whichever is imported
    first: one file mapped."""
    code = (
        "import sys\n"
        "first = sys.argv[1]\n"
        "if first == 'mlspaces':\n"
        "    import mlspaces, mujoco\n"
        "else:\n"
        "    import mujoco, mlspaces\n"
        "maps = {l.split()[-1] for l in open('/proc/self/maps') if 'libmujoco' in l}\n"
        "assert len(maps) == 1, maps\n"
        "assert mlspaces._core.mujoco_runtime_version() == mujoco.__version__\n"
        "print(maps.pop())\n")
    paths = set()
    for first in ("mlspaces", "mujoco"):
        out = subprocess.run([sys.executable, "-c", code, first], check=True,
                             capture_output=True, text=True)
        paths.add(Path(out.stdout.strip()).resolve())
    import mujoco
    assert paths == {next(Path(mujoco.__file__).parent.glob("libmujoco.so*")).resolve()}


# ---- What the package imports comes with the install (pyproject.toml) ---------------------

def _pyproject() -> dict:
    import tomllib
    from conftest import SOURCE_DIR
    return tomllib.loads((SOURCE_DIR / "pyproject.toml").read_text())


def _import_name(requirement: str) -> str:
    """The module a requirement installs (``scipy>=1.14,<2`` -> ``scipy``)."""
    import re
    return re.split(r"[<>=!~;\[ ]", requirement, maxsplit=1)[0].lower().replace("-", "_")


def _third_party_imports(path: Path) -> list[tuple[str, int]]:
    """(top-level module, line) of every absolute import in `path` that is neither the
    standard library nor mlspaces."""
    import ast
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        for name in names:
            top = name.split(".")[0]
            if top not in sys.stdlib_module_names and top != "mlspaces":
                out.append((top, node.lineno))
    return out


def test_every_import_is_stdlib_a_dependency_or_a_named_extra():
    """Each module the package imports is a dependency, or an extra whose name the importing
    file gives in its ImportError (``pip install 'mlspaces[EXTRA]'``)."""
    from conftest import SOURCE_DIR
    project = _pyproject()["project"]
    deps = {_import_name(r) for r in project["dependencies"]}
    extras = {_import_name(r): extra for extra, reqs in project["optional-dependencies"].items()
              for r in reqs}
    bad = []
    for path in sorted((SOURCE_DIR / "python" / "mlspaces").rglob("*.py")):
        for module, line in _third_party_imports(path):
            where = f"{path.relative_to(SOURCE_DIR)}:{line}: {module}"
            if module in deps:
                continue
            if module not in extras:
                bad.append(f"{where} is neither a dependency nor an extra")
            elif f"mlspaces[{extras[module]}]" not in path.read_text():
                bad.append(f"{where} (extra {extras[module]}) without an error naming the extra")
    assert not bad, "\n".join(bad)
    assert {"mujoco", "numpy", "pydantic", "scipy"} <= deps
    assert extras == {"gymnasium": "gym", "h5py": "data"}


def test_the_tutorial_script_needs_nothing_but_the_install():
    """The tutorial's datagen.py imports only what `pip install .` brings (scipy included)."""
    from conftest import EXAMPLE_DIR
    deps = {_import_name(r) for r in _pyproject()["project"]["dependencies"]}
    missing = [m for m, _ in _third_party_imports(EXAMPLE_DIR / "datagen.py") if m not in deps]
    assert not missing, missing


@pytest.mark.parametrize("package,code,extra", [
    ("h5py", "from mlspaces.reader import read_dataset\nread_dataset('.')", "data"),
    ("gymnasium", "import mlspaces.tasks.gym_env", "gym"),
])
def test_a_missing_optional_package_names_its_extra(package, code, extra):
    out = subprocess.run([sys.executable, "-c", f"import sys\nsys.modules[{package!r}] = None\n"
                          f"{code}"], capture_output=True, text=True)
    assert out.returncode == 1
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith(("ImportError: ", "ModuleNotFoundError: ")), out.stderr
    assert f"pip install 'mlspaces[{extra}]'" in last and package in last, last


def test_dependencies_are_pinned_for_development_and_in_the_wheelhouse():
    """requirements.txt pins each dependency, and install-deps.sh downloads each into the
    wheelhouse the wheel test installs from offline."""
    from conftest import SOURCE_DIR
    pins = {_import_name(line) for line in
            (SOURCE_DIR / "requirements.txt").read_text().splitlines()
            if line and not line.startswith("#")}
    script = (SOURCE_DIR / "scripts" / "install-deps.sh").read_text()
    for req in _pyproject()["project"]["dependencies"]:
        assert _import_name(req) in pins, req
        assert f"|{_import_name(req)}" in script or f"({_import_name(req)}|" in script, req


def test_pip_builds_outside_the_source_tree_and_logs_its_steps():
    """scikit-build-core's settings as it reads them: no build-dir (a temporary folder, removed
    after the build) and INFO logging (`pip install -v .` shows the build's progress)."""
    pytest.importorskip("scikit_build_core")
    from scikit_build_core.settings.skbuild_read_settings import SettingsReader

    from conftest import SOURCE_DIR
    settings = SettingsReader.from_file(SOURCE_DIR / "pyproject.toml", state="wheel").settings
    assert settings.build_dir == ""
    assert settings.logging.level == "INFO"


# The original's module paths and names a MolmoSpaces user imports (the tutorial, the libraries
# page, ../shared/spec/molmospaces-python-api.md), under mlspaces.
ORIGINAL_NAMES = {
    "molmo_spaces_constants": "DATA_TYPE_TO_SOURCE_TO_VERSION OBJECT_LIBRARY_TO_GRASP_LIBRARIES "
                              "USER_ASSET_LIBRARIES USER_GRASP_LIBRARIES ASSETS_DIR "
                              "DATA_CACHE_DIR register_user_asset_library "
                              "register_user_grasp_library",
    "utils.lazy_loading_utils": "locate_uid_package install_uid get_user_library_index "
                                "get_user_grasp_library_index UserAssetLibraryIndexEntry "
                                "UserAssetLibraryIndex UserGraspLibraryIndex",
    "utils.object_metadata": "ObjectMeta",
    "utils.grasps": "get_pickup_grasp_path get_joint_grasp_path has_pickup_grasp_path "
                    "has_joint_grasp_path has_valid_pickup_grasps has_valid_joint_grasps "
                    "load_pickup_grasps load_joint_grasps flip_grasps get_pickup_grasps "
                    "get_joint_grasps get_grasp_libraries_for_object",
    "utils.scene_metadata_utils": "get_scene_metadata SceneMeta",
    "utils.pose": "pose_mat_to_7d pos_quat_to_pose_mat pose_mat_to_pos_quat",
    "env.env": "CPUMujocoEnv",
    "env.data_views": "create_mlspaces_body MlSpacesMocapBody MlSpacesFreeJointBody "
                      "MlSpacesImmovableBody MlSpacesObject MlSpacesArticulationObject",
    "robots.franka": "FrankaRobot",
    "robots.abstract": "Robot",
    "robots.robot_views.abstract": "RobotViewFactory MocapRobotBaseGroup "
                                   "HoloJointsRobotBaseGroup",
    "tasks.pick_task_sampler": "PickTaskSampler",
    "tasks.task_sampler": "BaseMujocoTaskSampler",
    "tasks.task_sampler_errors": "RobotPlacementError HouseInvalidForTask",
    "configs": "PickTaskSamplerConfig PickBaseConfig FrankaRobotConfig FrankaDroidCameraSystem "
               "PickTaskConfig MlSpacesExpConfig",
    "configs.base_pick_config": "PickBaseConfig",
    "configs.camera_configs": "FrankaDroidCameraSystem",
    "configs.robot_configs": "FrankaRobotConfig BaseRobotConfig",
    "configs.task_configs": "PickTaskConfig",
    "configs.task_sampler_configs": "PickTaskSamplerConfig",
    "data_generation.config_registry": "register_config get_config_class list_available_configs",
    "data_generation.main": "main",
    "tasks.gym_env": "GymEnv env_id_for_config register_configs",
    "resources.generate_user_asset_library_index": "main",
    "resources.generate_user_grasp_library_index": "main",
}


def test_every_original_module_path_and_name_exists():
    import importlib
    missing = [f"mlspaces.{module}.{name}" for module, names in ORIGINAL_NAMES.items()
               for name in names.split()
               if not hasattr(importlib.import_module(f"mlspaces.{module}"), name)]
    assert not missing, missing
    from mlspaces.utils.object_metadata import ObjectMeta
    for method in ("annotation all_uids short_descriptions get_short_description "
                   "all_descriptions get_features img_features description_text_features "
                   "get_target_object_uid clean_object_name").split():
        assert callable(getattr(ObjectMeta, method)), method


def test_object_views_of_the_original(tmp_path):
    import mujoco

    from mlspaces.env.data_views import MlSpacesArticulationObject, MlSpacesObject
    from mlspaces.utils.lazy_loading_utils import UserAssetLibraryIndex
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body name="cab" pos="1 0 0"><freejoint/><geom size=".1"/>'
        '<body name="door"><joint name="hinge"/><geom size=".05"/></body></body>'
        '<body name="table"><geom size=".2"/></body></worldbody></mujoco>')
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cab = MlSpacesArticulationObject("cab", data)
    assert (cab.name, cab.object_id, cab.joint_names, cab.njoints) == ("cab", 1, ["hinge"], 1)
    data.qpos[7] = 0.3
    assert cab.get_joint_position(0) == pytest.approx(0.3)
    pose = cab.pose
    pose[:3, 3] = [0, 2, 0]
    cab.pose = pose
    np.testing.assert_array_equal(data.qpos[:3], [0, 2, 0])
    table = MlSpacesObject("table", data)
    assert table.njoints == 0
    with pytest.raises(ValueError, match="not movable"):
        table.pose = np.eye(4)
    text = '{"u": {"uid": "u", "object_path": "u/u.xml", "metadata_path": "u/u.json", ' \
           '"metadata_npz_path": null}}'
    index = UserAssetLibraryIndex.validate_json(text)
    assert index["u"].object_path == Path("u/u.xml") and index["u"].metadata_npz_path is None


def test_python_m_molmo_spaces_constants_sets_the_builtin_data_up(tmp_path):
    """As the original's: every pinned source set up (manifest, tries, link) and post_setup's
    archives installed, from a MolmoSpaces-format remote (tests/fixtures/make_molmo_remote.py);
    an unreachable remote is one error line and exit code 1."""
    import json
    import os

    from conftest import SOURCE_DIR
    out = tmp_path / "remote"
    subprocess.run([sys.executable, str(SOURCE_DIR / "tests" / "fixtures" /
                                        "make_molmo_remote.py"), str(out)], check=True)
    fx = json.loads((out / "fixture.json").read_text())

    def set_up(remote: Path, name: str) -> subprocess.CompletedProcess:
        env = dict(os.environ, MLSPACES_CACHE_DIR=str(tmp_path / name / "cache"),
                   MLSPACES_ASSETS_DIR=str(tmp_path / name / "assets"),
                   MLSPACES_PINNED_ASSETS_FILE=str(out / fx["pins_file"]),
                   MLSPACES_REMOTE_URL=remote.as_uri())
        return subprocess.run([sys.executable, "-m", "mlspaces.molmo_spaces_constants"],
                              env=env, capture_output=True, text=True)

    got = set_up(out / fx["remote_dir"], "ok")
    assert got.returncode == 0, got.stderr
    assets = tmp_path / "ok" / "assets"
    installed = json.loads((assets / "mjthor_data_type_to_source_to_versions.json").read_text())
    assert installed == fx["versions"]
    assert (assets / "objects" / "thor").is_dir()
    scene = fx["scenes"]["ithor"]["FloorPlan1"]["xml"]
    assert (assets / "scenes" / "ithor" / scene).is_file()  # post_setup: a small scene source
    assert got.stdout.startswith(f"Set up {sum(map(len, fx['versions'].values()))} sources")

    bad = set_up(tmp_path / "nowhere", "bad")
    assert bad.returncode == 1 and len(bad.stderr.splitlines()) == 1, bad.stderr
    assert bad.stderr.startswith("mlspaces: error: ") and "MLSPACES_REMOTE_URL" in bad.stderr


def _cmake_list(cmake: Path, variable: str) -> list[str]:
    """The items of `set(variable ...)` in a CMake file (one per line, as we write them)."""
    import re
    text = cmake.read_text()
    m = re.search(r"set\(" + variable + r"\n(.*?)\)", text, re.S)
    assert m, f"{cmake}: no set({variable} ...)"
    return [line.strip() for line in m.group(1).splitlines() if line.strip()]


def test_the_cmake_lists_name_every_python_file_and_test_file():
    # No file(GLOB) in the CMake files: what the build copies and what ctest runs are listed,
    # and this test is what keeps the lists whole.
    from conftest import SOURCE_DIR
    py = SOURCE_DIR / "python"
    on_disk = sorted(p.relative_to(py).as_posix() for p in (py / "mlspaces").rglob("*.py"))
    assert _cmake_list(py / "CMakeLists.txt", "_mlspaces_py") == on_disk
    tests = sorted(p.stem for p in (py / "tests").glob("test_*.py"))
    assert _cmake_list(SOURCE_DIR / "tests" / "CMakeLists.txt", "_pytest_files") == tests
    cmakes = [SOURCE_DIR / "CMakeLists.txt"]
    for top in ("apps", "bench", "examples", "fuzz", "python", "src", "tests"):
        cmakes += sorted((SOURCE_DIR / top).rglob("CMakeLists.txt"))
    for cmake in cmakes:
        assert "file(GLOB" not in cmake.read_text(), cmake
