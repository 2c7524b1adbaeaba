"""LeRobot v3.0 import (mlspaces.lerobot.import_lerobot / `mlspaces import-lerobot`) of a real
export of the tutorial run (small cameras): the round trip gives back every HDF5 group,
dataset and attribute and every video byte for byte; and `mlspaces validate-dataset` of an
export, good and broken (one line per problem naming the file)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest

from mlspaces.errors import MlspacesError
from mlspaces.lerobot import export_lerobot, import_lerobot
from mlspaces.reader import read_dataset

from conftest import small_camera_run

VIDEO = "videos/observation.images.wrist_camera/chunk-000/file-000.mp4"
DATA = "data/chunk-000/file-000.parquet"


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    return small_camera_run(tmp_path_factory.mktemp("lerobot_import"), 2)


@pytest.fixture(scope="module")
def exported(run_folder, tmp_path_factory) -> Path:
    return export_lerobot(run_folder, tmp_path_factory.mktemp("export") / "ds")


def _cli() -> str:
    cli = os.environ.get("MLSPACES_CLI_PATH")
    if not cli:
        pytest.skip("MLSPACES_CLI_PATH is not set (ctest sets it)")
    return cli


def _tree(path: Path) -> dict[str, object]:
    """Every group, dataset (dtype, shape, values) and attribute of an HDF5 file."""
    out: dict[str, object] = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            for k, v in obj.attrs.items():
                out[f"{name}@{k}"] = v
            if isinstance(obj, h5py.Dataset):
                out[name] = (obj.dtype.str, h5py.check_enum_dtype(obj.dtype), obj.shape,
                             obj[()].tobytes() if obj.dtype.kind != "O" else obj[()])
            else:
                out[name] = "group"
        for k, v in f.attrs.items():
            out[f"@{k}"] = v
        f.visititems(visit)
    return out


def test_round_trip_gives_back_every_dataset_attribute_and_video(run_folder, exported, tmp_path):
    side = json.loads((exported / "meta/mlspaces/mlspaces.json").read_text())
    assert side["format"] == "mlspaces" and side["codec"] == "copy"
    assert [e["traj"] for e in side["episodes"]] == ["traj_0", "traj_1"]
    back = import_lerobot(exported, tmp_path / "back")
    # Every file of the run but its lock file (.lock: no data).
    originals = sorted(p.relative_to(run_folder) for p in run_folder.rglob("*")
                       if p.is_file() and p.name != ".lock")
    assert sorted(p.relative_to(back) for p in back.rglob("*") if p.is_file()) == originals
    for rel in originals:
        if rel.suffix == ".h5":
            a, b = _tree(run_folder / rel), _tree(back / rel)
            assert a.keys() == b.keys()
            for k in a:
                assert np.array_equal(a[k], b[k]) if isinstance(a[k], np.ndarray) else a[k] == b[k], k
        # Batch files, videos (the same packets, muxed as datagen muxes), config, journal,
        # summary: the same bytes.
        assert (run_folder / rel).read_bytes() == (back / rel).read_bytes(), rel
    # The reader (and so replay) sees the same episodes and frames.
    for a, b in zip(read_dataset(run_folder), read_dataset(back), strict=True):
        assert a.num_steps == b.num_steps and a.cameras == b.cameras
        np.testing.assert_array_equal(a.frames("wrist_camera"), b.frames("wrist_camera"))
    out = subprocess.run([_cli(), "validate-dataset", str(back)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    assert out.stdout.strip() == "2 trajectories in 1 file, 4 videos: ok"


def test_import_refuses_what_mlspaces_did_not_make(exported, run_folder, tmp_path):
    # As LeRobot or another tool would write it: no meta/mlspaces/.
    foreign = export_lerobot(run_folder, tmp_path / "foreign", mlspaces_meta=False)
    assert not (foreign / "meta/mlspaces").exists()
    with pytest.raises(MlspacesError, match=r"mlspaces\.json: not a LeRobot dataset made by "
                                            r"mlspaces") as e:
        import_lerobot(foreign, tmp_path / "a")
    assert "\n" not in str(e.value)
    with pytest.raises(MlspacesError, match=r"info\.json: not a LeRobot dataset"):
        import_lerobot(run_folder, tmp_path / "b")
    with pytest.raises(MlspacesError, match="already exists"):
        import_lerobot(exported, run_folder)
    h264 = export_lerobot(run_folder, tmp_path / "h264", codec="h264")
    with pytest.raises(MlspacesError, match=r"re-encoded \(--codec h264\)"):
        import_lerobot(h264, tmp_path / "c")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["foreign", "h264"]


def test_validate_dataset_checks_an_export(exported, tmp_path):
    cli = _cli()
    out = subprocess.run([cli, "validate-dataset", str(exported)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
    frames = json.loads((exported / "meta/info.json").read_text())["total_frames"]
    assert out.stdout == f"LeRobot v3.0: 2 episodes, {frames} frames, 2 videos: ok\n"

    def broken(name: str, damage) -> list[str]:
        copy = tmp_path / name
        shutil.copytree(exported, copy)
        damage(copy)
        r = subprocess.run([cli, "validate-dataset", str(copy)], capture_output=True, text=True)
        assert r.returncode == 1, r.stdout + r.stderr
        lines = r.stdout.splitlines()
        assert lines[-1].endswith("1 problem"), r.stdout
        return lines[:-1]

    def truncate(p: Path, n: int) -> None:
        p.write_bytes(p.read_bytes()[:n])

    [line] = broken("novideo", lambda d: (d / VIDEO).unlink())
    assert line.startswith(f"{tmp_path / 'novideo' / VIDEO}: ") and "missing video" in line
    [line] = broken("cutvideo", lambda d: truncate(d / VIDEO, 2000))
    assert line.startswith(f"{tmp_path / 'cutvideo' / VIDEO}: ")
    [line] = broken("cutdata", lambda d: truncate(d / DATA, 1000))
    assert line.startswith(f"{tmp_path / 'cutdata' / DATA}: not a readable parquet file")

    def totals(d: Path) -> None:
        info = json.loads((d / "meta/info.json").read_text())
        info["total_episodes"] += 1
        (d / "meta/info.json").write_text(json.dumps(info))
    [line] = broken("totals", totals)
    assert line == (f"{tmp_path / 'totals' / 'meta/info.json'}: total_episodes: 3 but "
                    "meta/episodes has 2 rows")

    def stats(d: Path) -> None:
        s = json.loads((d / "meta/stats.json").read_text())
        del s["action"]["std"]
        (d / "meta/stats.json").write_text(json.dumps(s))
    [line] = broken("stats", stats)
    assert line == f"{tmp_path / 'stats' / 'meta/stats.json'}: action/std: missing"
    [line] = broken("nohdf5", lambda d: (d / "meta/mlspaces/hdf5/episode_000001.h5").unlink())
    assert line == f"{tmp_path / 'nohdf5' / 'meta/mlspaces/hdf5/episode_000001.h5'}: missing"
