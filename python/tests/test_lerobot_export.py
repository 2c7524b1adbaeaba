"""LeRobot v3.0 export (mlspaces.lerobot.export_lerobot / `mlspaces export-lerobot`) of a real
dataset written by `mlspaces datagen` (the tutorial's config, two cameras, small cheap
renders), checked against the v3 layout with pyarrow and ffprobe, and against the HDF5
episodes' numbers (h5py) and the episodes' own videos (frames decoded bit for bit)."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from mlspaces import _core
from mlspaces.errors import MlspacesError, UsageError
from mlspaces.lerobot import export_lerobot
from mlspaces.reader import read_dataset

from conftest import SMALL_CAMERA_SIZE, small_camera_run

WIDTH, HEIGHT = SMALL_CAMERA_SIZE
CAMERAS = ["exo_camera_1", "wrist_camera"]
INDEX_COLUMNS = ["timestamp", "frame_index", "episode_index", "index", "task_index"]


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    """A run folder of 3 successful episodes with wrist and exo camera videos."""
    return small_camera_run(tmp_path_factory.mktemp("lerobot"), 3)


@pytest.fixture(scope="module")
def exported(run_folder, tmp_path_factory) -> Path:
    return export_lerobot(run_folder, tmp_path_factory.mktemp("export") / "ds",
                          repo_id="local/pick")


def _rows(ds) -> list[dict]:
    return [json.loads(bytes(r).rstrip(b"\0")) for r in ds[()]]


def _flat(row: dict) -> list[float]:
    return [v for g in sorted(row) for v in row[g]]


def _ffprobe(path: Path, *args: str) -> str:
    return subprocess.run(["ffprobe", "-v", "error", *args, str(path)], check=True,
                          capture_output=True, text=True).stdout


def test_layout_matches_lerobot_v3(exported):
    info = json.loads((exported / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0"
    assert info["robot_type"] == "franka_droid"
    assert info["total_episodes"] == 3 and info["total_tasks"] == 1
    assert info["fps"] == pytest.approx(1000 / 66)
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["video_path"] == \
        "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
    for key in ("chunks_size", "data_files_size_in_mb", "video_files_size_in_mb", "splits"):
        assert key in info
    features = info["features"]
    data = pq.read_table(exported / "data/chunk-000/file-000.parquet")
    assert data.num_rows == info["total_frames"]
    videos = {k for k, f in features.items() if f["dtype"] == "video"}
    assert videos == {f"observation.images.{c}" for c in CAMERAS}
    # Every non-video feature is a column of its dtype and shape, and nothing else is.
    assert set(data.column_names) == set(features) - videos
    for key in set(features) - videos:
        ft, col = features[key], data.schema.field(key).type
        assert "/" not in key
        if ft["shape"] == [1]:
            assert str(col) == {"float32": "float", "int64": "int64", "bool": "bool"}[ft["dtype"]]
        else:
            assert col.list_size == ft["shape"][0] and len(ft["names"]) == ft["shape"][0], key
    for key in videos:
        assert features[key]["shape"] == [HEIGHT, WIDTH, 3]
        assert features[key]["names"] == ["height", "width", "channels"]
    for key in INDEX_COLUMNS + ["observation.state", "action"]:
        assert key in features
    tasks = pq.read_table(exported / "meta/tasks.parquet")
    assert tasks.column("task_index").to_pylist() == [0]
    assert json.loads(tasks.schema.metadata[b"pandas"])["index_columns"] == ["task"]
    stats = json.loads((exported / "meta/stats.json").read_text())
    assert set(stats) == set(features)
    for key, s in stats.items():
        assert set(s) == {"min", "max", "mean", "std", "count"}, key
    assert np.array(stats["observation.images.wrist_camera"]["mean"]).shape == (3, 1, 1)


def test_numbers_equal_the_hdf5_episodes(run_folder, exported):
    data = pq.read_table(exported / "data/chunk-000/file-000.parquet").to_pydict()
    eps = pq.read_table(exported / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    tasks = pq.read_table(exported / "meta/tasks.parquet").column("task").to_pylist()
    col = {k: np.array(v) for k, v in data.items()}
    h5 = h5py.File(run_folder / "house_0/trajectories_batch_1_of_1.h5", "r")
    start = 0
    for e, ep in enumerate(eps):
        g = h5[f"traj_{e}"]
        t = len(g["success"])
        n = t - 1  # frame i: observation i, the command that followed it (row i + 1)
        assert ep["episode_index"] == e and ep["length"] == n
        assert (ep["dataset_from_index"], ep["dataset_to_index"]) == (start, start + n)
        sl = slice(start, start + n)
        scene = json.loads(g["obs_scene"][()])
        assert ep["tasks"] == [scene["task_description"]]
        assert tasks[col["task_index"][start]] == scene["task_description"]
        qpos = np.array([_flat(r) for r in _rows(g["obs/agent/qpos"])], np.float32)
        np.testing.assert_array_equal(col["observation.state"][sl], qpos[:-1])
        cmd = np.array([_flat(r) for r in _rows(g["actions/commanded_action"])[1:]], np.float32)
        np.testing.assert_array_equal(col["action"][sl], cmd)
        np.testing.assert_array_equal(col["next.reward"][sl], g["rewards"][1:])
        np.testing.assert_array_equal(col["next.success"][sl], g["success"][1:])
        assert col["next.done"][sl].tolist() == [False] * (n - 1) + [True]
        tcp = g["obs/extra/tcp_pose"][:-1].reshape(n, -1).astype(np.float32)
        np.testing.assert_array_equal(col["extra.tcp_pose"][sl], tcp)
        panda = g["env_states/articulations/panda"][:-1].astype(np.float32)
        np.testing.assert_array_equal(col["env_state.articulations.panda"][sl], panda)
        intr = g["obs/sensor_param/wrist_camera/intrinsic_cv"][:-1].reshape(n, 9)
        np.testing.assert_array_equal(col["camera.wrist_camera.intrinsic_cv"][sl],
                                      intr.astype(np.float32))
        assert col["frame_index"][sl].tolist() == list(range(n))
        assert col["index"][sl].tolist() == list(range(start, start + n))
        assert set(col["episode_index"][sl].tolist()) == {e}
        np.testing.assert_allclose(col["timestamp"][sl], np.arange(n) * 0.066, atol=1e-5)
        start += n
    assert start == len(col["index"])


def test_videos_hold_every_episode_re_muxed(run_folder, exported):
    eps = pq.read_table(exported / "meta/episodes/chunk-000/file-000.parquet").to_pylist()
    originals = list(read_dataset(run_folder))
    for cam in CAMERAS:
        key = f"observation.images.{cam}"
        mp4 = exported / f"videos/{key}/chunk-000/file-000.mp4"
        stream = _ffprobe(mp4, "-select_streams", "v", "-show_entries",
                          "stream=codec_name,width,height,avg_frame_rate,nb_frames",
                          "-of", "json")
        s = json.loads(stream)["streams"][0]
        assert (s["codec_name"], s["width"], s["height"]) == ("h264", WIDTH, HEIGHT)
        assert s["avg_frame_rate"] == "500/33"
        assert int(s["nb_frames"]) == sum(ep.num_steps for ep in originals)
        pts = np.array([float(f["pts_time"]) for f in json.loads(_ffprobe(
            mp4, "-select_streams", "v", "-show_entries", "frame=pts_time",
            "-of", "json"))["frames"]])
        assert len(pts) == int(s["nb_frames"]) and pts[0] == 0
        assert np.all(np.diff(pts) > 0)
        frames = _core.decode_video(mp4)
        for ep, orig in zip(eps, originals):
            assert ep[f"videos/{key}/chunk_index"] == 0 and ep[f"videos/{key}/file_index"] == 0
            # LeRobot's lookup: a frame at from_timestamp + timestamp, within 1e-4 s.
            want = ep[f"videos/{key}/from_timestamp"] + np.arange(ep["length"]) * 0.066
            near = np.abs(pts[None, :] - want[:, None]).min(axis=1)
            assert near.max() < 1e-4
            first = int(np.argmin(np.abs(pts - want[0])))
            # Same packets: the decoded frames are the episode's own, bit for bit.
            np.testing.assert_array_equal(frames[first:first + orig.num_steps], orig.frames(cam))
            assert ep[f"videos/{key}/to_timestamp"] == pytest.approx(
                ep[f"videos/{key}/from_timestamp"] + orig.num_steps * 0.066)


def test_failed_episodes_are_left_out_and_errors_are_one_line(run_folder, tmp_path):
    bad = tmp_path / "run"
    shutil.copytree(run_folder, bad)
    with h5py.File(bad / "house_0/trajectories_batch_1_of_1.h5", "r+") as f:
        f["traj_1/success"][-1] = False
    out = export_lerobot(bad, tmp_path / "ds")
    eps = pq.read_table(out / "meta/episodes/chunk-000/file-000.parquet")
    assert eps.num_rows == 2
    with pytest.raises(MlspacesError, match="already exists"):
        export_lerobot(bad, tmp_path / "ds")
    with pytest.raises(MlspacesError, match=r"--fps 30 is not the dataset's 15\.1515"):
        export_lerobot(bad, tmp_path / "ds30", fps=30)
    with pytest.raises(UsageError, match="codec"):
        export_lerobot(bad, tmp_path / "dsx", codec="vp9")
    (bad / "house_0/episode_00000002_exo_camera_1_batch_1_of_1.mp4").unlink()
    with pytest.raises(MlspacesError, match="episode_00000002_exo_camera_1_batch_1_of_1.mp4"):
        export_lerobot(bad, tmp_path / "dsv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ds", "run"]


def test_cli_prints_what_it_wrote(run_folder, tmp_path):
    import os
    cli = os.environ.get("MLSPACES_CLI_PATH")
    if not cli:
        pytest.skip("MLSPACES_CLI_PATH is not set (ctest sets it)")
    out = subprocess.run([cli, "export-lerobot", str(run_folder), str(tmp_path / "ds"),
                          "--repo-id", "local/pick", "--fps", "15.1515"],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "3 episodes (0 left out)" in out.stdout
    assert 'LeRobotDataset("local/pick"' in out.stdout
    assert "export-lerobot: episodes 3/3" in out.stderr  # progress lines when not a terminal


@pytest.mark.parametrize("codec", ["h264", "av1"])
def test_re_encoded_videos_hold_every_frame(run_folder, tmp_path, codec):
    out = export_lerobot(run_folder, tmp_path / "ds", codec=codec)
    info = json.loads((out / "meta/info.json").read_text())
    originals = list(read_dataset(run_folder))
    for cam in CAMERAS:
        key = f"observation.images.{cam}"
        assert info["features"][key]["info"]["video.codec"] == codec
        s = json.loads(_ffprobe(out / f"videos/{key}/chunk-000/file-000.mp4", "-select_streams",
                                "v", "-count_frames", "-show_entries",
                                "stream=codec_name,nb_read_frames,avg_frame_rate,pix_fmt",
                                "-of", "json"))["streams"][0]
        assert (s["codec_name"], s["avg_frame_rate"], s["pix_fmt"]) == (codec, "500/33", "yuv420p")
        assert int(s["nb_read_frames"]) == sum(ep.num_steps for ep in originals)


def test_without_the_arrow_helper_the_error_says_so(run_folder, tmp_path, monkeypatch):
    # A CLI without mlspaces-lerobot beside it (a wheel's): it runs, export-lerobot refuses.
    import os
    cli = os.environ.get("MLSPACES_CLI_PATH")
    if not cli:
        pytest.skip("MLSPACES_CLI_PATH is not set (ctest sets it)")
    lone = tmp_path / "bin" / "mlspaces"
    lone.parent.mkdir()
    shutil.copy2(cli, lone)
    out = subprocess.run([str(lone), "export-lerobot", str(run_folder), str(tmp_path / "ds")],
                         capture_output=True, text=True)
    assert out.returncode == 1
    assert out.stderr.startswith("mlspaces: error: ") and out.stderr.count("\n") == 1
    assert "built without Arrow C++" in out.stderr
    monkeypatch.setenv("MLSPACES_CLI_PATH", str(lone))
    with pytest.raises(RuntimeError, match="without Arrow C"):
        export_lerobot(run_folder, tmp_path / "ds")
    assert not (tmp_path / "ds").exists()
