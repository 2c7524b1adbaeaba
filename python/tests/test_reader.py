"""Reading datasets back (mlspaces.reader, mlspaces._core.decode_video / video_info): a real
dataset with two cameras written by the tutorial's config, small and fast (96x64 renders, no
shadows or reflections), compared with what h5py reads directly."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import h5py
import numpy as np
import pytest

from mlspaces import _core
from mlspaces.errors import MlspacesError
from mlspaces.reader import CameraFrames, Dataset, Episode, read_dataset

from conftest import SMALL_CAMERA_SIZE, small_camera_run

WIDTH, HEIGHT = SMALL_CAMERA_SIZE
CAMERAS = ["exo_camera_1", "wrist_camera"]


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    """A run folder of 2 episodes (house_0, one batch), wrist and exo camera videos."""
    return small_camera_run(tmp_path_factory.mktemp("reader"), 2)


def _batch_file(run: Path) -> Path:
    return run / "house_0" / "trajectories_batch_1_of_1.h5"


def _text(data: np.ndarray) -> bytes:
    return data.tobytes().rstrip(b"\0")


def _h5_trajs(path: Path) -> list[str]:
    with h5py.File(path, "r") as f:
        return [k for k in f.keys() if k.startswith("traj_")]


# -- the dataset ---------------------------------------------------------------------------

def test_read_dataset_yields_every_episode_of_the_batch_files(run_folder):
    trajs = _h5_trajs(_batch_file(run_folder))
    assert trajs == ["traj_0", "traj_1"]
    ds = read_dataset(run_folder)
    assert isinstance(ds, Dataset)
    assert len(ds) == ds.num_episodes == len(trajs)
    episodes = list(ds)
    assert [e.traj for e in episodes] == trajs
    assert [e.index for e in episodes] == [0, 1]
    assert all(e.house == 0 and e.batch_file == _batch_file(run_folder) for e in episodes)
    assert all(isinstance(e, Episode) and isinstance(e, Mapping) for e in episodes)
    # Iterating again reads the files again, same result; a house folder reads alike.
    assert [e.traj for e in ds] == trajs
    assert [e.traj for e in read_dataset(str(run_folder / "house_0"))] == trajs


def test_order_is_numeric_house_batch_traj(run_folder, tmp_path):
    """house_2 before house_10, batch 2 before batch 10, traj_2 before traj_10."""
    src = _batch_file(run_folder)
    for house in (10, 2):
        d = tmp_path / f"house_{house}"
        d.mkdir()
        for b in (10, 2):
            with h5py.File(src, "r") as f, h5py.File(d / f"trajectories_batch_{b}_of_10.h5",
                                                     "w") as g:
                for k in (10, 2):
                    f.copy(f["traj_0"], g, name=f"traj_{k}")
    (tmp_path / "house_x").mkdir()  # not a house folder: ignored
    order = [(e.house, e.batch_file.name, e.traj, e.index) for e in read_dataset(tmp_path)]
    assert order == [
        (2, "trajectories_batch_2_of_10.h5", "traj_2", 0),
        (2, "trajectories_batch_2_of_10.h5", "traj_10", 1),
        (2, "trajectories_batch_10_of_10.h5", "traj_2", 2),
        (2, "trajectories_batch_10_of_10.h5", "traj_10", 3),
        (10, "trajectories_batch_2_of_10.h5", "traj_2", 4),
        (10, "trajectories_batch_2_of_10.h5", "traj_10", 5),
        (10, "trajectories_batch_10_of_10.h5", "traj_2", 6),
        (10, "trajectories_batch_10_of_10.h5", "traj_10", 7),
    ]
    assert len(read_dataset(tmp_path)) == 8


def test_missing_or_empty_folder_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="dataset folder not found: .*nope"):
        read_dataset(tmp_path / "nope")
    (tmp_path / "batch.h5").write_bytes(b"")
    with pytest.raises(FileNotFoundError, match="a file: read_dataset takes a run folder"):
        read_dataset(tmp_path / "batch.h5")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="not a dataset folder"):
        read_dataset(tmp_path / "empty")


def test_without_h5py_the_error_says_what_to_install(run_folder, monkeypatch):
    monkeypatch.setitem(sys.modules, "h5py", None)  # import h5py now raises ImportError
    with pytest.raises(ImportError, match="pip install h5py"):
        read_dataset(run_folder)


# -- an episode ------------------------------------------------------------------------------

def _check_group(h5_group, value, where: str) -> None:
    """`value` (the reader's) holds what h5py reads from `h5_group`, member by member."""
    assert list(value.keys()) == list(h5_group.keys()), where
    for name, item in h5_group.items():
        path = f"{where}/{name}"
        got = value[name] if not isinstance(value, CameraFrames) else None
        if isinstance(item, h5py.Group):
            _check_group(item, got, path)
        elif path.startswith("/obs/sensor_data/"):
            continue  # frames, checked below
        elif item.dtype == np.uint8:  # zero-padded JSON rows
            raw = item[()]
            want = ([json.loads(_text(row)) for row in raw] if raw.ndim == 2
                    else json.loads(_text(raw)))
            assert got == want, path
        else:
            raw = item[()]
            assert isinstance(got, np.ndarray), path
            assert got.dtype == raw.dtype and got.shape == raw.shape, path
            np.testing.assert_array_equal(got, raw, err_msg=path)


def test_episode_holds_what_h5py_reads(run_folder):
    episodes = list(read_dataset(run_folder))
    with h5py.File(_batch_file(run_folder), "r") as f:
        for ep in episodes:
            g = f[ep.traj]
            assert list(ep.keys()) == list(g.keys())
            assert set(ep) == set(g) and len(ep) == len(g)
            assert "obs" in ep and "obs/agent/qpos" in ep and "nope" not in ep
            assert "obs/agent/nope" not in ep and "rewards/x" not in ep and 3 not in ep
            assert ep["obs_scene"] == json.loads(g["obs_scene"][()])
            assert ep["obs_scene"]["task_type"] == "pick"
            assert ep.provenance == json.loads(g.attrs["provenance"])
            assert ep.provenance["episode_index"] == ep.index
            _check_group(g["obs"], ep["obs"], "/obs")
            for name in ("actions", "env_states"):
                _check_group(g[name], ep[name], f"/{name}")
            for name in ("rewards", "success", "terminated", "truncated", "fail"):
                np.testing.assert_array_equal(ep[name], g[name][()])
                assert ep[name].dtype == g[name].dtype
            # Paths and nested dicts are the same objects; JSON rows decoded.
            assert ep["obs/agent/qpos"] is ep["obs"]["agent"]["qpos"]
            T = g["success"].shape[0]
            assert ep.num_steps == T and len(ep["obs/agent/qpos"]) == T
            assert len(ep["obs/agent/qpos"][0]["arm"]) == 7
            assert ep["success"].dtype == np.bool_ and ep["success"][-1]
            # The cameras and their videos, as obs/sensor_data names them.
            assert ep.cameras == CAMERAS == list(g["obs/sensor_data"].keys())
            for cam in CAMERAS:
                name = _text(g["obs/sensor_data"][cam][()]).decode()
                assert ep.video_files[cam] == name
                assert ep.video_path(cam) == run_folder / "house_0" / name
                assert name == f"episode_{ep.index:08d}_{cam}_batch_1_of_1.mp4"


def test_frames_are_decoded_on_demand_and_cached(run_folder, monkeypatch):
    calls = []
    real = _core.decode_video

    def spy(path):
        calls.append(Path(path).name)
        return real(path)

    monkeypatch.setattr(_core, "decode_video", spy)
    ep = next(iter(read_dataset(run_folder)))
    # Reading the episode, listing and testing keys decode nothing.
    sensor_data = ep["obs"]["sensor_data"]
    assert isinstance(sensor_data, CameraFrames)
    assert list(sensor_data) == CAMERAS and len(sensor_data) == 2
    assert "wrist_camera" in sensor_data and "nope" not in sensor_data
    assert "obs/sensor_data/wrist_camera" in ep and "obs/sensor_data/nope" not in ep
    assert "obs/sensor_data/wrist_camera/x" not in ep
    assert list(ep["obs"].keys()) == ["agent", "extra", "sensor_data", "sensor_param"]
    assert repr(ep) and repr(sensor_data)
    assert ep == ep and sensor_data == sensor_data and len({ep, sensor_data}) == 2
    assert calls == []
    # The key decodes that camera only, once.
    frames = sensor_data["wrist_camera"]
    assert calls == ["episode_00000000_wrist_camera_batch_1_of_1.mp4"]
    assert ep["obs/sensor_data/wrist_camera"] is frames
    assert ep.frames("wrist_camera") is frames
    assert len(calls) == 1
    ep.frames("exo_camera_1")
    assert calls[1:] == ["episode_00000000_exo_camera_1_batch_1_of_1.mp4"]
    # An unknown camera is a KeyError and decodes nothing.
    with pytest.raises(KeyError):
        sensor_data["nope"]
    with pytest.raises(KeyError, match="no camera 'nope'"):
        ep.frames("nope")
    assert sensor_data.get("nope") is None
    assert len(calls) == 2


def test_frames_are_the_configured_size_one_per_observation(run_folder):
    for ep in read_dataset(run_folder):
        T = len(ep["success"])
        for cam in ep.cameras:
            frames = ep["obs"]["sensor_data"][cam]
            assert isinstance(frames, np.ndarray)
            assert frames.dtype == np.uint8 and frames.shape == (T, HEIGHT, WIDTH, 3)
            assert frames.flags.c_contiguous and frames.flags.writeable
            # A real image: pixels differ within a frame, and the scene changes over time.
            assert frames[0].std() > 5
            assert len(np.unique(frames[0].reshape(-1, 3), axis=0)) > 10
            assert not np.array_equal(frames[0], frames[-1])
            info = _core.video_info(ep.video_path(cam))
            assert info["frames"] == T
            assert (info["width"], info["height"]) == (WIDTH, HEIGHT)
            assert info["fps"] == pytest.approx(15.15, abs=0.01)
            assert info["codec"] == "h264"


def test_decode_video_gives_a_fresh_array_each_call(run_folder):
    path = run_folder / "house_0" / "episode_00000000_wrist_camera_batch_1_of_1.mp4"
    a = _core.decode_video(path)
    b = _core.decode_video(str(path))
    np.testing.assert_array_equal(a, b)
    a[:] = 0
    assert b.any()  # no shared buffer
    del b
    assert a.sum() == 0  # a keeps its own buffer alive


def test_corrupt_or_missing_video_is_a_value_error_naming_the_file(run_folder, tmp_path):
    run = tmp_path / "run"
    shutil.copytree(run_folder, run)
    house = run / "house_0"
    truncated = house / "episode_00000000_wrist_camera_batch_1_of_1.mp4"
    truncated.write_bytes(truncated.read_bytes()[: truncated.stat().st_size // 2])
    garbage = house / "episode_00000000_exo_camera_1_batch_1_of_1.mp4"
    garbage.write_bytes(np.random.default_rng(0).bytes(garbage.stat().st_size))
    (house / "episode_00000001_wrist_camera_batch_1_of_1.mp4").unlink()
    ep0, ep1 = read_dataset(run)  # reading the episodes does not touch the videos
    for ep, cam, name in [(ep0, "wrist_camera", truncated.name),
                          (ep0, "exo_camera_1", garbage.name),
                          (ep1, "wrist_camera", "episode_00000001_wrist_camera_batch_1_of_1.mp4")]:
        with pytest.raises(ValueError, match=name) as e:
            ep["obs"]["sensor_data"][cam]
        assert isinstance(e.value, MlspacesError)
        assert e.value.path.endswith(name)
    assert ep1.frames("exo_camera_1").shape[0] == ep1.num_steps  # the intact ones still read
    with pytest.raises(ValueError, match="file not found"):
        _core.video_info(tmp_path / "nope.mp4")


def test_object_image_points_are_read_as_the_original_writes_them(run_folder):
    """obs/extra/object_image_points: per task object and camera, up to 10 (x / W, y / H)
    pixels of the object, NaN after num_points; the block's points are red in its video."""
    red = seen = 0
    for ep in read_dataset(run_folder):
        points_of = ep["obs"]["extra"]["object_image_points"]
        assert sorted(points_of) == ["gripper", "pickup_obj"]
        T = ep.num_steps
        for obj, cams in points_of.items():
            assert sorted(cams) == sorted(CAMERAS)
            for cam, arrays in cams.items():
                points, count = arrays["points"], arrays["num_points"]
                assert points.shape == (T, 10, 2) and points.dtype == np.float32
                assert count.shape == (T, 1) and count.dtype == np.int32
                for t in range(T):
                    n = int(count[t, 0])
                    assert 0 <= n <= 10
                    assert np.isfinite(points[t, :n]).all() and np.isnan(points[t, n:]).all()
                    assert ((points[t, :n] >= 0) & (points[t, :n] < 1)).all()
                    # The original rounds (x / W, y / H) to 4 decimals: pixels of the image.
                    cols = points[t, :n, 0] * WIDTH
                    np.testing.assert_allclose(cols, np.round(cols), atol=0.01)
        # The gripper is in the wrist camera's view throughout.
        assert (points_of["gripper"]["wrist_camera"]["num_points"] == 10).all()
        frames = ep["obs/sensor_data/exo_camera_1"]
        block = points_of["pickup_obj"]["exo_camera_1"]
        for t in range(T):
            for x, y in block["points"][t, :int(block["num_points"][t, 0])]:
                r, g, b = frames[t, int(round(y * HEIGHT)), int(round(x * WIDTH))].astype(int)
                red += r > g + 40 and r > b + 40
                seen += 1
    assert seen > 0
    assert red > 0.8 * seen, f"{red} of {seen} points of the red block are red in the video"
