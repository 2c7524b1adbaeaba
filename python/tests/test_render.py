"""mlspaces.render and `mlspaces render` (docs/render.md): real renderings of the example library,
scene and a 1-episode run at small sizes; colours at known pixels; one-line errors."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mlspaces
import mlspaces.render as render
from conftest import EXAMPLE_DIR
from mlspaces.errors import MlspacesError, MlspacesTypeError, UsageError

CLI = os.environ.get("MLSPACES_CLI_PATH")
needs_cli = pytest.mark.skipif(not CLI, reason="needs MLSPACES_CLI_PATH (the ctest sets it)")
BACKGROUND = (235, 235, 235)


def is_red(c) -> bool:
    return c[0] > 120 and c[1] < 60 and c[2] < 60


@pytest.fixture
def registry() -> mlspaces.Registry:
    r = mlspaces.Registry()
    lib = EXAMPLE_DIR / "asset_library"
    r.register_user_asset_library("custom_assets", lib)
    r.register_user_grasp_library("custom_grasps", lib, "custom_assets")
    return r


def cli(*args: str, cwd: Path = EXAMPLE_DIR) -> subprocess.CompletedProcess:
    return subprocess.run([CLI, *args], cwd=cwd, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def small_run(tmp_path_factory) -> Path:
    """The tutorial, one episode, 96x64 cameras without shadows or reflections."""
    if not CLI:
        pytest.skip("needs MLSPACES_CLI_PATH")
    out = tmp_path_factory.mktemp("render") / "run"
    r = cli("datagen", "datagen.yaml", "--episodes", "1", "--seed", "1", "--output", str(out),
            "-q", "--set", "camera_config.img_resolution=[96,64]",
            "--set", "camera_config.shadows=false", "--set", "camera_config.reflections=false")
    assert r.returncode == 0, r.stderr
    return out


def test_asset_sheet_shows_the_red_block_labelled(registry):
    sheet = render.asset_sheet(registry=registry, size=(64, 48))
    assert sheet.dtype == np.uint8 and sheet.shape == (4 + 48 + 15 + 4, 4 + 64 + 4, 3)
    assert is_red(sheet[4 + 24, 4 + 32])                   # the block at the tile's centre
    assert tuple(sheet[5, 5]) == BACKGROUND                # the studio's plain background
    label = sheet[4 + 48:4 + 48 + 15, 4:4 + 64]
    assert (label.max(axis=2) < 50).sum() > 10             # "red_block" in black
    assert (label.min(axis=2) == 255).sum() > 500          # on white
    one = render.asset("red_block", registry=registry, size=(64, 48))
    assert np.array_equal(one, sheet[4:52, 4:68])
    # A sheet over 16384 pixels a side is refused before anything is rendered.
    with pytest.raises(UsageError, match="3364 tiles of 256x256 in 58 columns .* 16384 pixels"):
        render.asset_sheet(["red_block"] * 58 * 58, registry=registry)


def test_grasps_are_outlined_in_colour(registry):
    g = render.grasps("red_block", registry=registry, size=(96, 96), views=2)
    assert g.shape[1] == 4 + 2 * (96 + 4)
    green = (g[..., 1] > 100) & (g[..., 1] > 2 * g[..., 0].astype(int)) & \
        (g[..., 1] > g[..., 2].astype(int) + 40)
    assert green.sum() > 20
    none = render.grasps("red_block", registry=registry, transforms=np.zeros((0, 4, 4)),
                         size=(96, 96), views=2)
    assert ((none[..., 1] > 100) & (none[..., 1] > 2 * none[..., 0].astype(int))).sum() == 0
    with pytest.raises(UsageError, match="transforms"):
        render.grasps("red_block", registry=registry, transforms=np.zeros((2, 3, 4)))
    with pytest.raises(UsageError, match="gripper: unknown robot 'nobot'"):
        render.grasps("red_block", registry=registry, gripper="nobot")


def test_joint_grasps_on_the_example_cabinet():
    r = mlspaces.Registry()
    lib = EXAMPLE_DIR.parent / "objects"
    r.register_user_asset_library("example_objects", lib)
    r.register_user_grasp_library("example_objects_grasps", lib, "example_objects")
    g = render.grasps("cabinet_drawer_door", joint="door_hinge", registry=r, num=4,
                      size=(96, 96))
    green = (g[..., 1] > 100) & (g[..., 1] > 2 * g[..., 0].astype(int)) & \
        (g[..., 1] > g[..., 2].astype(int) + 40)
    assert green.sum() > 5
    with pytest.raises(MlspacesError, match="has no joint 'lid'"):
        render.grasps("cabinet_drawer_door", joint="lid", registry=r,
                      transforms=np.eye(4)[None], size=(32, 32))


def test_scene_from_a_config_file():
    picture = render.scene(EXAMPLE_DIR / "datagen.yaml", size=(96, 72))
    assert picture.shape[1] == 4 + 3 * (96 + 4)            # overview, wrist, exo
    tiles = picture[-(4 + 15 + 72):-(4 + 15)]
    assert sum(is_red(c) for c in tiles[:, 4:100].reshape(-1, 3)) > 0  # the block, overview
    assert len(np.unique(tiles.reshape(-1, 3), axis=0)) > 50
    with pytest.raises(MlspacesError, match="scene_xml_paths"):
        render.scene(EXAMPLE_DIR / "datagen.yaml", house=4, size=(32, 32))
    with pytest.raises(MlspacesError, match="missing.yaml"):
        render.scene(EXAMPLE_DIR / "missing.yaml")


def test_scene_from_a_config_object_runs_its_python_sampler(monkeypatch):
    monkeypatch.syspath_prepend(str(EXAMPLE_DIR))
    monkeypatch.chdir(EXAMPLE_DIR)
    # The tutorial's module registers its libraries in the default registry on import: a fresh
    # one, and a fresh import, whatever other test files did in this process (both restored).
    import mlspaces._registry
    monkeypatch.setattr(mlspaces._registry, "_default", None)
    monkeypatch.delitem(sys.modules, "datagen", raising=False)
    from datagen import FrankaPickDroidDataGenConfig  # the tutorial's, sampler in Python
    picture = render.scene(FrankaPickDroidDataGenConfig(), size=(64, 48))
    assert picture.shape[1] == 4 + 3 * (64 + 4)
    tiles = picture[-(4 + 15 + 48):-(4 + 15)]
    assert len(np.unique(tiles.reshape(-1, 3), axis=0)) > 50


def test_episode_phases_from_the_video(small_run):
    sheet, frames, info = render.episode_phases(small_run, frames=True, width=48, columns=3)
    assert info["camera"] == "exo_camera_1" and info["traj"] == "traj_0"
    assert info["steps"][0] == 0 and info["steps"][-1] == info["num_steps"] - 1
    names = info["phase_names"]
    assert names.index("pregrasp") < names.index("grasp") < names.index("gripper-close") \
        < names.index("lift")
    assert all(f.shape == (64, 96, 3) for f in frames)
    assert sheet.shape[1] == 4 + 3 * (48 + 4)
    assert any(is_red(c) for c in frames[0].reshape(-1, 3))
    wrist = render.episode_phases(small_run, camera="wrist_camera", width=48)
    assert wrist.shape == sheet.shape and not np.array_equal(wrist, sheet)
    with pytest.raises(MlspacesError, match=r"no camera 'top' \(cameras: exo_camera_1, "):
        render.episode_phases(small_run, camera="top")
    with pytest.raises(MlspacesError, match="episode 3 out of range"):
        render.episode_phases(small_run, 3)


def test_png_round_trip_and_type_errors(tmp_path):
    image = np.zeros((5, 7, 3), np.uint8)
    image[1:3, 2:5] = (250, 0, 128)
    render.write_png(tmp_path / "a.png", image)
    assert np.array_equal(render.read_png(tmp_path / "a.png"), image)
    with pytest.raises(MlspacesTypeError, match="uint8"):
        render.write_png(tmp_path / "b.png", image.astype(np.float32))
    # A missing file is Python's FileNotFoundError (docs/python.md), not the engine's error.
    with pytest.raises(FileNotFoundError, match="b.png"):
        render.read_png(tmp_path / "b.png")
    (tmp_path / "c.png").write_bytes(b"not a PNG")
    with pytest.raises(MlspacesError, match="c.png"):
        render.read_png(tmp_path / "c.png")
    with pytest.raises(UsageError, match="gl"):
        render.asset("red_block", gl="vulkan")


def test_mlspaces_gl_chooses_the_backend_and_a_bad_one_is_named(monkeypatch, registry):
    # gl=None: MLSPACES_GL, else osmesa; the same rule as the CLI's (sim::ResolveGlBackend).
    # (One process renders with one backend: this file's is osmesa.)
    monkeypatch.setenv("MLSPACES_GL", "osmesa")
    assert is_red(render.asset("red_block", registry=registry, size=(64, 48))[24, 32])
    monkeypatch.setenv("MLSPACES_GL", "vulkan")
    with pytest.raises(UsageError, match="MLSPACES_GL: unknown GL backend 'vulkan'"):
        render.asset("red_block", registry=registry, size=(64, 48))
    # An explicit gl wins over the environment.
    assert is_red(render.asset("red_block", registry=registry, size=(64, 48), gl="osmesa")[24, 32])
    monkeypatch.setenv("MLSPACES_GL", "")
    assert is_red(render.asset("red_block", registry=registry, size=(64, 48))[24, 32])


@needs_cli
def test_cli_writes_pngs_and_reports_bad_input_in_one_line(tmp_path, small_run):
    out = tmp_path / "sheet.png"
    r = cli("render", "assets", "--libraries", "libraries.yaml", "--size", "64x48",
            "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert "render: asset 1/1 red_block" in r.stderr and f"wrote {out}" in r.stdout
    sheet = render.read_png(out)
    assert is_red(sheet[4 + 24, 4 + 32])
    # The same sheet through EGL (Mesa's surfaceless platform on a machine without a GPU).
    r = cli("render", "assets", "red_block", "--libraries", "libraries.yaml", "--size", "64x48",
            "--gl", "egl", "-q", "--out", str(tmp_path / "egl.png"))
    assert r.returncode == 0, r.stderr
    assert is_red(render.read_png(tmp_path / "egl.png")[4 + 24, 4 + 32])
    r = cli("render", "grasps", "red_block", "--libraries", "libraries.yaml", "--size", "64x64",
            "--views", "2", "-q", "--out", str(tmp_path / "g.png"))
    assert r.returncode == 0 and r.stderr == "", r.stderr
    r = cli("render", "scene", "datagen.yaml", "--size", "64x48", "-q",
            "--out", str(tmp_path / "s.png"))
    assert r.returncode == 0, r.stderr
    r = cli("render", "episode", str(small_run), "--width", "48", "--out", str(tmp_path / "e.png"))
    assert r.returncode == 0, r.stderr
    assert np.array_equal(render.read_png(tmp_path / "e.png"),
                          render.episode_phases(small_run, width=48))
    for args, code, message in [
        (["assets", "nope", "--libraries", "libraries.yaml"], 1, "nope not found"),
        (["assets", "--size", "3x", "--libraries", "libraries.yaml"], 2, "--size"),
        (["assets", "--gl", "vulkan", "--libraries", "libraries.yaml"], 2, "--gl"),
        (["episode", str(tmp_path / "none")], 1, "dataset not found"),
        (["episode", str(small_run), "--episode", "5"], 1, "out of range"),
        (["grasps", "red_block", "--libraries", "libraries.yaml", "--robot", "xarm"], 1,
         "no grasp library for robot xarm"),
        (["scene", "datagen.yaml", "--house", "2"], 1, "scene_xml_paths"),
    ]:
        r = cli("render", *args, "--out", str(tmp_path / "x.png"))
        assert r.returncode == code, (args, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert lines[-1].startswith("mlspaces: error: ") and message in lines[-1], (args, r.stderr)
        assert not (tmp_path / "x.png").exists()
