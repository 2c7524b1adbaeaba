"""mlspaces.grasp_generation: generate_grasps (the C++ job of ``mlspaces generate-grasps``) on a
small library written here, and ``python -m mlspaces.grasp_generation``."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import mlspaces.grasp_generation as gg
from mlspaces.errors import MlspacesError, UsageError

BOX = """<mujoco model="box"><worldbody>
  <body name="box"><freejoint/><geom type="box" size="0.02 0.025 0.035"/></body>
</worldbody></mujoco>
"""
GHOST = """<mujoco model="ghost"><worldbody>
  <body name="ghost"><freejoint/><geom type="box" size="0.02 0.02 0.02" contype="0" conaffinity="0"/></body>
</worldbody></mujoco>
"""


@pytest.fixture
def library(tmp_path):
    for uid, xml in (("box", BOX), ("ghost", GHOST)):
        (tmp_path / uid).mkdir()
        (tmp_path / uid / f"{uid}.xml").write_text(xml)
        (tmp_path / uid / f"{uid}.json").write_text(json.dumps({"assetId": uid}))
    return tmp_path


def test_generate_grasps_writes_files_and_reports(library) -> None:
    report = gg.generate_grasps(library, max_grasps=3, seed=1, threads=1, progress=False)
    by_uid = {o["uid"]: o for o in report.objects}
    box = by_uid["box"]
    assert box["status"] == "done", box["reason"]
    assert box["accepted"] == 3 and box["tested"] >= 3 and box["candidates"] >= box["tested"]
    assert box["joint"] is None and box["reason"] is None and box["steps"] > 0
    with np.load(box["output"]) as npz:
        assert list(npz.keys()) == ["transforms"]
        t = npz["transforms"]
    assert t.dtype == np.float16 and t.shape == (3, 4, 4)
    r = t[:, :3, :3].astype(np.float64)
    assert np.allclose(r @ r.transpose(0, 2, 1), np.eye(3), atol=5e-3)
    ghost = by_uid["ghost"]
    assert ghost["status"] == "failed" and "no collision geometry" in ghost["reason"]
    assert report.failed == [ghost]
    index = json.loads((library / "grasps_index.json").read_text())
    assert index["grasp_paths"] == {"droid": {"box": "box/droid/grasps.npz"}}
    assert report["index"] == str(library / "grasps_index.json")

    # Resume: skipped; f8 with overwrite gives the same grasps to float16 precision.
    again = gg.generate_grasps(library, "box", max_grasps=3, seed=1, progress=False)
    assert again.objects[0]["status"] == "skipped"
    f8 = gg.generate_grasps(library, ["box"], max_grasps=3, seed=1, overwrite=True, dtype="f8",
                            output_dir=library / "f8", progress=False)
    assert f8.objects[0]["status"] == "done"
    t8 = np.load(library / "f8" / "box" / "droid" / "grasps.npz")["transforms"]
    assert t8.dtype == np.float64
    assert np.array_equal(t8.astype(np.float16), t)


def test_another_robots_gripper(library) -> None:
    # The xArm7's own gripper (its robot.yaml and MJCF): files under box/xarm7, grasps that
    # differ from franka_droid's for the same seed.
    x = gg.generate_grasps(library, "box", robot="xarm7", max_grasps=3, seed=1, threads=1,
                           progress=False)
    assert x.objects[0]["status"] == "done", x.objects[0]["reason"]
    assert x.objects[0]["output"] == str(library / "box" / "xarm7" / "grasps.npz")
    d = gg.generate_grasps(library, "box", max_grasps=3, seed=1, threads=1, progress=False)
    tx = np.load(library / "box" / "xarm7" / "grasps.npz")["transforms"]
    td = np.load(library / "box" / "droid" / "grasps.npz")["transforms"]
    assert tx.shape == td.shape == (3, 4, 4) and d.objects[0]["status"] == "done"
    assert not np.array_equal(tx, td)
    index = json.loads((library / "grasps_index.json").read_text())
    assert index["grasp_paths"] == {"droid": {"box": "box/droid/grasps.npz"},
                                    "xarm7": {"box": "box/xarm7/grasps.npz"}}


def test_errors(library) -> None:
    with pytest.raises(MlspacesError, match="nope"):
        gg.generate_grasps(library, ["nope"], progress=False)
    with pytest.raises(UsageError, match="dtype"):
        gg.generate_grasps(library, dtype="f4", progress=False)
    with pytest.raises(UsageError, match="max_grasps"):
        gg.generate_grasps(library, max_grasps=0, progress=False)
    with pytest.raises(UsageError, match=r"no robot 'ur5'.*xarm7"):
        gg.generate_grasps(library, robot="ur5", progress=False)
    with pytest.raises(TypeError):
        gg.generate_grasps(library, max_grasps=2.5, progress=False)
    with pytest.raises(UsageError, match="min_quality"):
        gg.generate_grasps(library, min_quality=-0.1, progress=False)
    with pytest.raises(MlspacesError, match="not found"):
        gg.generate_grasps(library / "missing", progress=False)


def test_module_runs_the_command(library) -> None:
    run = subprocess.run([sys.executable, "-m", "mlspaces.grasp_generation", "--help"],
                         capture_output=True, text=True)
    assert run.returncode == 0
    assert "python -m mlspaces.grasp_generation" in run.stdout and "--max-grasps" in run.stdout
    run = subprocess.run([sys.executable, "-m", "mlspaces.grasp_generation", str(library),
                          "--uid", "ghost", "-q"], capture_output=True, text=True)
    assert run.returncode == 1
    assert run.stderr.count("\n") == 1 and "ghost: failed:" in run.stderr
