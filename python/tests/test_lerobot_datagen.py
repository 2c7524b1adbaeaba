"""`mlspaces datagen --format lerobot` (docs/lerobot.md, "Direct from datagen") on the tutorial
config with small cameras: no HDF5 run (its workers keep episode records, the dataset is
written from them at the end), yet the same bytes as export-lerobot of the HDF5 run of the same
config and seed, with 1 or 2 workers, after kills anywhere and --resume, and from shards
combined by `merge`; import-lerobot gives the HDF5 run back; no staging folder is left."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

from conftest import EXAMPLE_DIR

# 2 work items (one episode each) of house_0, 96x64 cameras without shadows: ~1 s a run.
SETS = ["--set", "camera_config.img_resolution=[96,64]", "--set", "camera_config.shadows=false",
        "--set", "camera_config.reflections=false", "--set",
        "task_sampler_config.samples_per_house=2", "--set",
        "task_sampler_config.episodes_per_batch=1", "--seed", "0", "-q"]
RUN_FILES = "meta/mlspaces/run/"  # config.yaml (output_dir), journal and summary (timings)
SIDECAR_H5 = "meta/mlspaces/hdf5/"  # the episode copies import-lerobot needs (the only HDF5)


def _cli() -> str:
    cli = os.environ.get("MLSPACES_CLI_PATH")
    if not cli:
        pytest.skip("MLSPACES_CLI_PATH is not set (ctest sets it)")
    return cli


def _run(*args, env=None, check=True) -> subprocess.CompletedProcess:
    r = subprocess.run([_cli(), *map(str, args)], capture_output=True, text=True,
                       env={**os.environ, **(env or {})})
    if check:
        assert r.returncode == 0, r.stdout + r.stderr
    return r


def _datagen(out: Path, *args, **kw) -> subprocess.CompletedProcess:
    return _run("datagen", EXAMPLE_DIR / "datagen.yaml", *SETS, "--output", out, *args, **kw)


def _files(d: Path, skip: tuple[str, ...] = (RUN_FILES,)) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()
            and not str(p.relative_to(d)).startswith(skip)}


@pytest.fixture(scope="module")
def hdf5_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("lerobot_datagen") / "h5"
    _datagen(out)
    return out


@pytest.fixture(scope="module")
def expected(hdf5_run) -> dict[str, bytes]:
    """export-lerobot of the HDF5 run."""
    _run("export-lerobot", hdf5_run, hdf5_run.parent / "exported", "-q")
    return _files(hdf5_run.parent / "exported")


def _no_hdf5_run(folder: Path) -> None:
    """A staging folder (or a dataset) holds no HDF5 file but the dataset's episode copies."""
    assert [str(p) for p in folder.rglob("*.h5") if SIDECAR_H5 not in p.as_posix()] == []
    assert not list(folder.rglob("*.parts/*.h5")) and not list(folder.rglob("trajectories_*.h5"))


def _check(out: Path, expected: dict[str, bytes]) -> None:
    got = _files(out)
    assert got.keys() == expected.keys()
    for k in got:
        assert got[k] == expected[k], k
    _no_hdf5_run(out)
    assert sorted((out / RUN_FILES).iterdir())
    assert not list(out.parent.glob(out.name + "*.partial"))
    assert not list(out.parent.glob(out.name + "*.tmp.*"))


@pytest.mark.parametrize("workers", [1, 2])
def test_lerobot_run_is_the_export_of_the_hdf5_run(expected, hdf5_run, tmp_path, workers):
    out = tmp_path / "ds"
    r = _datagen(out, "--format", "lerobot", "--workers", workers)
    assert f"run folder: {out} (LeRobot v3.0)" in r.stdout
    _check(out, expected)
    assert _run("validate-dataset", out).stdout.endswith(": ok\n")
    if workers == 1:
        # import-lerobot gives the HDF5 run back, byte for byte.
        _run("import-lerobot", out, tmp_path / "imported", "-q")
        run_files = ("config.yaml", "journal", "summary", ".lock")
        assert _files(tmp_path / "imported", run_files) == _files(hdf5_run, run_files)
        return
    # Finished: another run is refused, --resume has nothing to do.
    r = _datagen(out, "--format", "lerobot", check=False)
    assert r.returncode == 1 and "holds a LeRobot dataset already" in r.stderr
    assert "already complete" in _datagen(out, "--format", "lerobot", "--resume").stdout


def test_killed_lerobot_run_resumes_to_the_same_bytes(expected, tmp_path):
    counter = tmp_path / "steps"
    _datagen(tmp_path / "count", "--format", "lerobot",
             env={"MLSPACES_CRASH_COUNTER": str(counter)})
    steps = int.from_bytes(counter.read_bytes(), "little")
    assert steps > 6
    # In the run after the first episode's record was written, inside the dataset writer (its
    # helper counts on the same file; its temp folder then holds the episode copies), and after
    # the dataset was renamed into place (the staging folder still there).
    for n in (steps // 3, steps - 5, steps):
        out = tmp_path / f"killed_{n}"
        c = tmp_path / f"c{n}"
        r = _datagen(out, "--format", "lerobot", check=False,
                     env={"MLSPACES_CRASH_COUNTER": str(c), "MLSPACES_CRASH_AT": str(n)})
        assert r.returncode != 0, n
        staging = tmp_path / f"killed_{n}.partial"
        if n < steps:
            assert staging.is_dir(), n
            _no_hdf5_run(staging)
            assert list(staging.rglob("*.rec")), n
        _datagen(out, "--format", "lerobot", "--resume")
        _check(out, expected)


def test_shards_merge_into_the_whole_run(expected, tmp_path):
    for i in (0, 1):
        _datagen(tmp_path / f"shard{i}", "--format", "lerobot", "--shard", f"{i}/2")
        _check(tmp_path / f"shard{i}", _files(tmp_path / f"shard{i}"))
    r = _run("merge", tmp_path / "merged", tmp_path / "shard0", tmp_path / "shard1")
    assert "merged 2 LeRobot datasets" in r.stdout
    _check(tmp_path / "merged", expected)
