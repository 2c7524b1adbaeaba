"""Grasp generation end to end (issue 31, point 5, CI-sized): a box and a mug written as OBJ
meshes of convex parts by bench/graspgen/make_mesh_library.py -> `mlspaces index-assets` ->
`mlspaces generate-grasps` -> the NPZ files and grasps_index.json -> `mlspaces datagen` pick
with only those grasps. The full figure (12 objects, 100+ episodes) is bench/graspgen_bench.sh."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import SOURCE_DIR

CLI = os.environ.get("MLSPACES_CLI_PATH")
MAKE_LIBRARY = SOURCE_DIR / "bench" / "graspgen" / "make_mesh_library.py"
# box_tall, not box_small: the 4 cm cube is picked 0 times in 27 by the bench (grasps that hold
# in zero gravity but push it away on the floor, bench/results/graspgen_bench.txt); the
# other boxes are the ones this smoke test can rely on.
UIDS = ["box_tall", "mug_small"]
MAX_GRASPS = 20

pytestmark = pytest.mark.skipif(not CLI, reason="needs MLSPACES_CLI_PATH (the ctest sets it)")


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    out = subprocess.run([str(a) for a in args], cwd=cwd, capture_output=True, text=True)
    assert out.returncode == 0, f"{args[:2]} exit {out.returncode}:\n{out.stdout}\n{out.stderr}"
    return out


@pytest.fixture(scope="module")
def project(tmp_path_factory) -> Path:
    """The two-object pick project with generated grasps."""
    root = tmp_path_factory.mktemp("graspgen_e2e")
    _run(sys.executable, MAKE_LIBRARY, root, "--project", "--only", *UIDS, cwd=root)
    _run(CLI, "index-assets", root / "library", "--compute-metadata", cwd=root)
    gen = _run(CLI, "generate-grasps", root / "library", "--max-grasps", MAX_GRASPS, "--seed", 0,
               "-j", 2, cwd=root)
    (root / "generate.txt").write_text(gen.stdout + gen.stderr)
    return root


def test_the_library_is_closed_convex_parts_with_outward_faces(project):
    for uid in UIDS:
        parts = sorted((project / "library" / uid).glob(f"{uid}_part_*.obj"))
        assert parts, uid
        for obj in parts:
            lines = obj.read_text().splitlines()
            v = np.array([[float(x) for x in l.split()[1:]] for l in lines if l.startswith("v ")])
            f = np.array([[int(x) - 1 for x in l.split()[1:]] for l in lines if l.startswith("f ")])
            a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
            assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() > 0, obj  # volume > 0
            edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
            _, counts = np.unique(edges, axis=0, return_counts=True)
            assert (counts == 2).all(), f"{obj}: not closed"
    assert len(list((project / "library" / "mug_small").glob("*.obj"))) == 10


def test_generate_grasps_writes_float16_poses_and_the_index(project):
    report = (project / "generate.txt").read_text()
    index = json.loads((project / "library" / "grasps_index.json").read_text())
    for uid in UIDS:
        assert f"{uid}: " in report and "grasps (" in report, report
        path = project / "library" / uid / "droid" / "grasps.npz"
        with np.load(path) as npz:
            assert list(npz.keys()) == ["transforms"]
            t = npz["transforms"]
        assert t.dtype == np.float16
        assert t.ndim == 3 and t.shape[1:] == (4, 4) and 0 < t.shape[0] <= MAX_GRASPS, t.shape
        t = t.astype(np.float64)
        assert np.isfinite(t).all()
        rot = t[:, :3, :3]
        eye = np.broadcast_to(np.eye(3), rot.shape)
        assert np.allclose(np.einsum("nji,njk->nik", rot, rot), eye, atol=5e-3)
        assert np.allclose(np.linalg.det(rot), 1.0, atol=5e-3)
        assert np.allclose(t[:, 3], [0, 0, 0, 1])
        # TCP near the object (body frame: footprint centred, bottom at z = 0).
        assert (np.abs(t[:, :3, 3]) < 0.2).all()
        assert index["grasp_paths"]["droid"][uid] == f"{uid}/droid/grasps.npz"


def test_datagen_picks_with_the_generated_grasps(project):
    out = project / "run"
    _run(CLI, "datagen", project / "datagen.yaml", "--episodes", 1, "--seed", 1, "--output", out,
         "-q", cwd=project)
    rows = [json.loads(l) for l in (out / "journal.jsonl").read_text().splitlines()]
    assert len(rows) == len(UIDS)  # one attempt per object (every attempt counted)
    # house_<i> is the i-th entry of scene_xml_paths, scenes/scene_<uid>.xml.
    listed = re.search(r"scene_xml_paths: \[(.*)\]", (project / "datagen.yaml").read_text())
    order = re.findall(r"scene_(\w+)\.xml", listed.group(1))
    assert sorted(order) == sorted(UIDS)
    scenes = {f"house_{i}": uid for i, uid in enumerate(order)}
    for r in rows:
        uid = scenes[r["scene"]]
        with np.load(project / "library" / uid / "droid" / "grasps.npz") as npz:
            n = npz["transforms"].shape[0]
        # The planner saw exactly the generated grasps (the only grasp library registered).
        assert r["extra"]["num_grasps"] == n, (uid, r)
    assert any(r["outcome"] == "success" for r in rows), rows
