"""`mlspaces datagen --format lerobot` (docs/lerobot.md, "Direct from datagen") on the tutorial
config with small cameras: the same bytes as export-lerobot of the HDF5 run of the same config
and seed, with workers, after a kill and --resume, and from shards combined by `merge`; no
HDF5 left outside meta/mlspaces/ and no staging folder."""

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


def _files(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()
            and not str(p.relative_to(d)).startswith(RUN_FILES)}


@pytest.fixture(scope="module")
def expected(tmp_path_factory) -> dict[str, bytes]:
    """export-lerobot of the HDF5 run."""
    tmp = tmp_path_factory.mktemp("lerobot_datagen")
    _datagen(tmp / "h5")
    _run("export-lerobot", tmp / "h5", tmp / "exported", "-q")
    return _files(tmp / "exported")


def _check(out: Path, expected: dict[str, bytes]) -> None:
    got = _files(out)
    assert got.keys() == expected.keys()
    for k in got:
        assert got[k] == expected[k], k
    assert [p.name for p in out.rglob("*.h5") if "mlspaces" not in p.parts] == []
    assert sorted((out / RUN_FILES).iterdir())
    assert not list(out.parent.glob("*staging*")) and not list(out.parent.glob("*.tmp.*"))


def test_lerobot_run_with_workers_is_the_export_of_the_hdf5_run(expected, tmp_path):
    out = tmp_path / "ds"
    r = _datagen(out, "--format", "lerobot", "--workers", "2")
    assert f"run folder: {out} (LeRobot v3.0)" in r.stdout
    _check(out, expected)
    assert _run("validate-dataset", out).stdout.endswith(": ok\n")
    # Finished: another run is refused, --resume has nothing to do.
    r = _datagen(out, "--format", "lerobot", check=False)
    assert r.returncode == 1 and "holds a LeRobot dataset already" in r.stderr
    assert "already complete" in _datagen(out, "--format", "lerobot", "--resume").stdout


def test_killed_lerobot_run_resumes_to_the_same_bytes(expected, tmp_path):
    counter = tmp_path / "steps"
    _datagen(tmp_path / "count", "--format", "lerobot",
             env={"MLSPACES_CRASH_COUNTER": str(counter)})
    steps = int.from_bytes(counter.read_bytes(), "little")
    assert steps > 4
    # In the HDF5 run, inside the export (its helper counts on the same file), and after the
    # export was renamed into place (the staging folder is still there).
    for n in (steps // 2, steps - 1, steps):
        out = tmp_path / f"killed_{n}"
        c = tmp_path / f"c{n}"
        r = _datagen(out, "--format", "lerobot", check=False,
                     env={"MLSPACES_CRASH_COUNTER": str(c), "MLSPACES_CRASH_AT": str(n)})
        assert r.returncode != 0, n
        _datagen(out, "--format", "lerobot", "--resume")
        _check(out, expected)


def test_shards_merge_into_the_whole_run(expected, tmp_path):
    for i in (0, 1):
        _datagen(tmp_path / f"shard{i}", "--format", "lerobot", "--shard", f"{i}/2")
    r = _run("merge", tmp_path / "merged", tmp_path / "shard0", tmp_path / "shard1")
    assert "merged 2 LeRobot datasets" in r.stdout
    _check(tmp_path / "merged", expected)
