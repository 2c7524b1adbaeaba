#!/usr/bin/env python3
"""Benchmarks of the mlspaces Python API against its targets (issue point 10), and side by side
with the original MolmoSpaces (`molmo-spaces` from PyPI) when a bench venv holds it.

    bench/python_api_bench.sh [--quick]                  # from the repo root
    PYTHONPATH=build/python .venv/bin/python bench/python_api_bench.py [--quick] [--splits]

One run prints, as medians over several rounds of the per-call (or per-run) mean:

1. Library lookups, on a user library written here with numpy (the files of
   python/tests/conftest.py's write_library): 1,000 UIDs, each with an MJCF, a metadata JSON and
   a grasps NPZ of 1,000 float64 (N,4,4) transforms.
   - locate_uid_package(uid), cycling through the 1,000 UIDs (each looked up once before);
   - ObjectMeta.annotation(uid), warm (the same UID again after a first call);
   - load_pickup_grasps(uid, num_grasps=50) from a 1,000-grasp file.
   Each implementation runs in its own worker process (this file with --worker) on the same
   library: mlspaces with this interpreter, molmo_spaces with the bench venv's interpreter
   (--molmospaces-python, $MLSPACES_BENCH_MOLMOSPACES_PYTHON, else
   build/bench-venv-molmospaces/bin/python; `bench/python_api_bench.sh --setup-molmospaces`
   makes it). The original's lookups set up its resource manager first; the worker makes that
   setup offline and leaves the measured calls untouched (see setup_molmospaces_offline).
2. Datagen, physics only (task_config.enable_rendering=false, no cameras), on a copy of
   examples/custom_assets:
   (a) a Python sampler (the tutorial's BlockPickupTaskSampler, imported from its datagen.py)
       versus the engine's built-in 'block_pickup' sampler, both through
       mlspaces.datagen.run_config in one process, alternating (the built-in side falls back to
       the CLI on the same config when run_config rejects an engine sampler by name). The
       figure is the engine's own 'sample' stage timer (journal.jsonl): the two samplers draw
       different poses, so their episodes, and physics times, differ;
   (b) `python -m mlspaces.datagen` versus the CLI `mlspaces datagen` on the equivalent YAML
       (examples/custom_assets/datagen.yaml), same seed, alternating, whole processes timed:
       episodes kept per hour of an N-episode run, and without startup (from the difference
       between N- and 2-episode runs).
3. With --splits: each layer of the three mlspaces calls timed on its own, estimates of the
   per-call work of alternatives, and a check of the C++ random.sample port.

Targets: locate and warm annotation < 1 us per call, load 50 grasps < 15 us; the Python sampler
adds < 2 % to a physics-only episode; `python -m mlspaces.datagen` within 5 % of the CLI's
episodes per hour.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLE_DIR = REPO / "examples" / "custom_assets"

#: The original's figures on this machine class, from the issue text (us per call).
ISSUE_ORIGINAL_US = {"locate": 6.9, "annotation": 3.6, "load50": 148.0}
#: Targets (us per call) of the mlspaces calls.
TARGET_US = {"locate": 1.0, "annotation": 1.0, "load50": 15.0}
TARGET_SAMPLER_OVERHEAD_PCT = 2.0
TARGET_FRONTEND_RATIO = 0.95

LOOKUP_ROWS = [
    # key, label, headline (compared with a target)
    ("locate", "locate_uid_package(uid), 1,000 UIDs cycled", True),
    ("locate_same", "locate_uid_package(uid), one UID repeated", False),
    ("annotation", "ObjectMeta.annotation(uid), warm", True),
    ("load50", "load_pickup_grasps(uid, num_grasps=50), 1,000 in file", True),
    ("load_all", "load_pickup_grasps(uid, num_grasps=1000), whole file", False),
]


# ------------------------------------------------------------------------------------------
# The library (numpy only: both venvs run this).


def _rotations(q):
    import numpy as np
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
    ], 1)


def random_poses(n: int, seed: int):
    import numpy as np
    rng = np.random.default_rng(seed)
    out = np.tile(np.eye(4), (n, 1, 1))
    out[:, :3, :3] = _rotations(rng.normal(size=(n, 4)))
    out[:, :3, 3] = rng.uniform(-0.2, 0.2, size=(n, 3))
    return out


MINIMAL_MJCF = """<mujoco model="{uid}">
  <worldbody><body name="{uid}"><freejoint/><geom type="box" size="0.02 0.02 0.02"/></body>
  </worldbody>
</mujoco>
"""


def write_library(root: Path, n_uids: int, n_grasps: int, robot: str = "droid") -> list[str]:
    """A user asset + grasp library as python/tests/conftest.py's write_library writes it
    (np.savez grasps, json metadata, MolmoSpaces' index files). Returns the UIDs."""
    import numpy as np
    root.mkdir(parents=True, exist_ok=True)
    uids = [f"block_{k:04d}" for k in range(n_uids)]
    assets, grasp_paths = {}, {}
    for k, uid in enumerate(uids):
        d = root / uid
        (d / robot).mkdir(parents=True, exist_ok=True)
        (d / f"{uid}.xml").write_text(MINIMAL_MJCF.format(uid=uid))
        meta = {"uid": uid, "category": "block", "description": f"a {uid}",
                "description_long": f"a long {uid}",
                "description_short": {"one_word": "block", "two_words": f"{uid} block",
                                      "three_words": f"small {uid} block"},
                "mass": 0.05 + k, "boundingBox": {"x": 0.04, "y": 0.04, "z": 0.04}}
        (d / f"{uid}.json").write_text(json.dumps(meta, indent=2))
        assets[uid] = {"uid": uid, "object_path": f"{uid}/{uid}.xml",
                       "metadata_path": f"{uid}/{uid}.json", "metadata_npz_path": None}
        np.savez(d / robot / "grasps.npz", transforms=random_poses(n_grasps, 100 * k))
        grasp_paths.setdefault(robot, {})[uid] = f"{uid}/{robot}/grasps.npz"
    (root / "assets_index.json").write_text(json.dumps(assets, indent=4, sort_keys=True))
    (root / "grasps_index.json").write_text(json.dumps(
        {"articulated_grasp_paths": {}, "grasp_paths": grasp_paths}, indent=4))
    return uids


# ------------------------------------------------------------------------------------------
# Lookup worker: runs in the venv of the implementation it measures.


def setup_molmospaces_offline(home: Path) -> list[str]:
    """Makes molmo_spaces' resource-manager setup succeed offline, so that its lookups for a
    user UID run the code they run on an installed machine. Needs MLSPACES_ASSETS_DIR and
    MLSPACES_CACHE_DIR (set by the parent before this interpreter started) under `home`.
    Returns the steps taken (printed in the report). Nothing on the measured path is patched:

    1. the local manifest (ASSETS_DIR/mjthor_data_type_to_source_to_versions.json) lists the
       pinned versions, so setup_resource_manager finds everything "up to date" and downloads
       nothing (no setup(), no post_setup);
    2. the combined tries of the two non-thor object sources (objathor_metadata, objaverse)
       exist in the versioned cache, with a few made-up archives: the manager builds its
       trie LMDBs and substring indexes from them, as it does from the real ones; a user UID's
       tokens match none of them, as they match none of the real archive names;
    3. ASSETS_DIR/objects/objathor_metadata holds a small objects_metadata.json.gz and
       clip_features.pkl (100 made-up objaverse UIDs), from which ObjectMeta's first
       get_db() builds the objathor LMDB, as it does from the downloaded 129k-entry files;
    4. as a guard (off the measured path), requests.get raises, so a download attempt fails
       loudly instead of hanging.
    """
    import gzip
    import pickle

    import numpy as np
    import requests

    import molmo_spaces.molmo_spaces_constants as C
    from molmospaces_resources import COMBINED_TRIES_NAME, LOCAL_MANIFEST_NAME

    def no_network(*args, **kwargs):
        raise RuntimeError(f"molmo-spaces tried to download ({args[:1]}): bench setup is wrong")

    requests.get = no_network  # guard only: never reached when the setup below is right

    assets, cache = Path(C.ASSETS_DIR), Path(C.DATA_CACHE_DIR)
    assert str(assets).startswith(str(home)) and str(cache).startswith(str(home)), (assets, cache)
    versions = C.DATA_TYPE_TO_SOURCE_TO_VERSION
    assets.mkdir(parents=True, exist_ok=True)
    (assets / LOCAL_MANIFEST_NAME).write_text(json.dumps(versions))
    steps = [f"local manifest {LOCAL_MANIFEST_NAME} = the pinned versions (no setup, no download)"]

    rng = np.random.default_rng(0)
    fake = [hashlib.sha1(str(i).encode()).hexdigest() for i in range(100)]
    tries = {
        "objaverse": {f"{h}.tar.zst": {h: {f"{h}.xml": {}, f"{h}.obj": {}}} for h in fake},
        "objathor_metadata": {"objathor_metadata_v1.tar.zst": {
            "objects_metadata.json.gz": {}, "clip_features.pkl": {}}},
    }
    for source, content in tries.items():
        d = cache / "objects" / source / versions["objects"][source]
        d.mkdir(parents=True, exist_ok=True)
        with gzip.open(d / COMBINED_TRIES_NAME, "wt") as f:
            json.dump(content, f)
    steps.append("combined tries of objaverse (100 made-up archives) and objathor_metadata in "
                 "the versioned cache")

    meta_dir = assets / "objects" / "objathor_metadata"
    meta_dir.mkdir(parents=True, exist_ok=True)
    annotation = {h: {"uid": h, "category": "thing", "description": f"a {h}",
                      "description_long": f"a long {h}",
                      "description_short": {"one_word": "thing", "two_words": "a thing",
                                            "three_words": "a small thing"}} for h in fake}
    with gzip.open(meta_dir / "objects_metadata.json.gz", "wt") as f:
        json.dump(annotation, f)
    with open(meta_dir / "clip_features.pkl", "wb") as f:
        pickle.dump({"uids": fake,
                     "img_features": rng.normal(size=(100, 3, 768)).astype(np.float16),
                     "text_features": rng.normal(size=(100, 768)).astype(np.float16)}, f)
    steps.append("objathor metadata (100 made-up UIDs) under ASSETS_DIR/objects/"
                 "objathor_metadata, from which get_db() builds its LMDB")
    steps.append("guard: requests.get raises (off the measured path; never called)")
    return steps


def _time(loop, rounds: int, round_s: float) -> dict:
    """Median over `rounds` of the per-call mean of `loop(n)` (-> (seconds, calls)), with n
    calibrated so that one round lasts about `round_s`."""
    loop(1)
    n = 1
    while True:
        dt, calls = loop(n)
        if dt >= round_s / 4 or n >= 1 << 24:
            break
        n *= 4
    n = max(1, int(n * round_s / max(dt, 1e-9)))
    per_call = []
    for _ in range(rounds):
        dt, calls = loop(n)
        per_call.append(dt / calls)
    return {"median_us": statistics.median(per_call) * 1e6, "min_us": min(per_call) * 1e6,
            "max_us": max(per_call) * 1e6, "rounds": rounds, "calls_per_round": calls}


def lookup_worker(pkg: str, library: Path, rounds: int, round_s: float,
                  home: Path | None) -> dict:
    out: dict = {"pkg": pkg, "python": sys.version.split()[0], "executable": sys.executable}
    t0 = time.perf_counter()
    if pkg == "molmo_spaces":
        out["setup"] = setup_molmospaces_offline(home)
        from importlib.metadata import version
        out["version"] = version("molmo-spaces")
    else:
        import mlspaces
        out["version"] = getattr(mlspaces, "__version__", "?")
        out["module"] = str(Path(mlspaces.__file__).parent)
    consts = __import__(f"{pkg}.molmo_spaces_constants", fromlist=["x"])
    lazy = __import__(f"{pkg}.utils.lazy_loading_utils", fromlist=["x"])
    meta_mod = __import__(f"{pkg}.utils.object_metadata", fromlist=["x"])
    grasps_mod = __import__(f"{pkg}.utils.grasps", fromlist=["x"])
    out["import_s"] = time.perf_counter() - t0
    import numpy as np
    out["numpy"] = np.__version__
    if pkg == "mlspaces":
        reg = __import__("mlspaces").default_registry()
        out["assets_dir"] = None if reg.assets_dir is None else str(reg.assets_dir)

    consts.register_user_asset_library("bench", library)
    consts.register_user_grasp_library("bench_grasps", library, "bench")
    locate = lazy.locate_uid_package
    annotation = meta_mod.ObjectMeta.annotation
    load = grasps_mod.load_pickup_grasps
    uids = json.loads((library / "assets_index.json").read_text())
    uids = sorted(uids)
    uid = uids[len(uids) // 2]

    # Cold calls (first of the process: the original sets up its resource manager and
    # metadata DB here), then one warm pass over every UID.
    t = time.perf_counter()
    located = locate(uid)
    out["first_locate_s"] = time.perf_counter() - t
    t = time.perf_counter()
    ann = annotation(uid)
    out["first_annotation_s"] = time.perf_counter() - t
    for u in uids:
        locate(u)
    import random
    random.seed(1234)
    g = load(uid, num_grasps=50)
    out["check"] = {
        "locate": [located[0], located[1], str(located[2])],
        "annotation": hashlib.sha1(json.dumps(ann, sort_keys=True).encode()).hexdigest(),
        "grasps": [list(g.shape), str(g.dtype), hashlib.sha1(
            np.ascontiguousarray(g, dtype=np.float64).tobytes()).hexdigest()],
    }

    def loop_locate(n):
        f, us = locate, uids
        k = max(1, n // len(us)) if n else 1
        if n == 0:
            return 0.0, 0
        t = time.perf_counter()
        for _ in range(k):
            for x in us:
                f(x)
        return time.perf_counter() - t, k * len(us)

    def same(fn, *args, **kw):
        def loop(n):
            if n == 0:
                return 0.0, 0
            r = range(n)
            if kw:
                t = time.perf_counter()
                for _ in r:
                    fn(*args, **kw)
            else:
                t = time.perf_counter()
                for _ in r:
                    fn(*args)
            return time.perf_counter() - t, n
        return loop

    def noop(x):
        return x

    random.seed(0)
    results = {
        "noop": _time(same(noop, uid), rounds, round_s),
        "locate": _time(loop_locate, rounds, round_s),
        "locate_same": _time(same(locate, uid), rounds, round_s),
        "annotation": _time(same(annotation, uid), rounds, round_s),
        "load50": _time(same(load, uid, num_grasps=50), rounds, round_s),
        "load_all": _time(same(load, uid, num_grasps=1000), rounds, round_s),
    }
    out["results"] = results
    return out


# ------------------------------------------------------------------------------------------
# Layer splits of the mlspaces calls (--splits).


def splits_worker(library: Path, rounds: int, round_s: float) -> dict:
    """Per-layer costs of the three mlspaces calls: each layer timed on its own."""
    import random

    import numpy as np

    import mlspaces
    from mlspaces import _core
    from mlspaces.utils.grasps import load_pickup_grasps
    from mlspaces.utils.lazy_loading_utils import locate_uid_package
    from mlspaces.utils.object_metadata import ObjectMeta

    mlspaces.register_user_asset_library("bench", library)
    mlspaces.register_user_grasp_library("bench_grasps", library, "bench")
    reg = mlspaces.default_registry()
    r = reg._r
    uids = sorted(json.loads((library / "assets_index.json").read_text()))
    uid = uids[len(uids) // 2]
    locate_uid_package(uid)
    ObjectMeta.annotation(uid)
    path = reg.get_pickup_grasp_path(uid)
    data = np.load(path)["transforms"]
    meta_json = json.loads((library / uid / f"{uid}.json").read_text())
    rows = list(range(50))
    # The binding takes random.sample (draws in Python) or random.getrandbits (a C++ port of
    # random.sample's algorithm), depending on the build.
    new_api = "getrandbits" in (r.load_grasps.__doc__ or "")

    def same(fn, *args):
        def loop(n):
            if n == 0:
                return 0.0, 0
            t = time.perf_counter()
            for _ in range(n):
                fn(*args)
            return time.perf_counter() - t, n
        return loop

    def py_ann():  # a dict as big as the annotation, built in Python (the floor of a new dict)
        return {"uid": uid, "category": "block", "description": "x", "description_long": "y",
                "description_short": {"one_word": "a", "two_words": "b", "three_words": "c"},
                "mass": 1.0, "boundingBox": {"x": 0.04, "y": 0.04, "z": 0.04}}

    import copy
    rs = random.sample
    rng = range
    steps = {
        # locate
        "locate: module function (cached dict hit)": same(locate_uid_package, uid),
        "locate: Registry.locate_uid_package (method)": same(reg.locate_uid_package, uid),
        "locate: default_registry()": same(mlspaces.default_registry),
        "locate: _core Registry.locate (C++ lookup + Path)": same(r.locate, uid),
        # annotation
        "annotation: ObjectMeta.annotation": same(ObjectMeta.annotation, uid),
        "annotation: _core Registry.annotation (C++ cache hit + dict build)":
            same(r.annotation, uid),
        "annotation: dict literal of the same shape (Python floor)": same(py_ann),
        "annotation: copy.deepcopy of the dict": same(copy.deepcopy, meta_json),
        "annotation: json.loads of the file text":
            same(json.loads, (library / uid / f"{uid}.json").read_text()),
        # grasps
        "load50: load_pickup_grasps(uid, num_grasps=50)": same(
            lambda: load_pickup_grasps(uid, num_grasps=50)),
        **({
            "load50: _core Registry.load_grasps(..., random.getrandbits)": same(
                lambda: r.load_grasps(uid, "", None, 50, random.getrandbits)),
            "load50: _core Registry._random_sample(1000, 50, random.getrandbits) (the port)":
                same(lambda: type(r)._random_sample(1000, 50, random.getrandbits)),
        } if new_api else {
            "load50: _core Registry.load_grasps(..., random.sample)": same(
                lambda: r.load_grasps(uid, "", None, 50, rs)),
            "load50: _core load_grasps with a no-op sampler (C++ + NPZ + numpy)": same(
                lambda: r.load_grasps(uid, "", None, 50, lambda p, k: rows)),
        }),
        "load50: _core load_grasps, num_grasps=1000 (whole file, no draw)": same(
            lambda: r.load_grasps(uid, "", None, 1000, random.getrandbits if new_api else rs)),
        "load50: random.sample(range(1000), 50) alone": same(lambda: rs(rng(1000), 50)),
        "load50: _core Registry.grasp_path (library walk + stat)": same(
            r.grasp_path, uid, "", None),
        "load50: _core Registry.count_grasps (walk + stat + NPZ header)": same(
            r.count_grasps, uid, "", None),
        "load50: os.stat of the grasp file": same(os.stat, path),
        "load50: open+read whole file (128 KB) in Python": same(
            lambda: open(path, "rb").read()),
        "load50: numpy fancy-index of 50 rows (in memory)": same(lambda: data[rows]),
    }
    # Estimates of the proposed changes' per-call work, from Python (upper bounds: each
    # os/mmap call adds ~0.1 us of interpreter overhead).
    import mmap
    size = os.path.getsize(path)
    picked = sorted(random.sample(range(1000), 50))

    def via_mmap():
        fd = os.open(path, os.O_RDONLY)
        os.fstat(fd)
        mm = mmap.mmap(fd, 0, prot=mmap.PROT_READ)
        os.close(fd)
        mm[size - 22:size]
        mm[0:128]
        for r in picked:
            mm[128 + 128 * r:256 + 128 * r]
        mm.close()

    def via_pread():
        fd = os.open(path, os.O_RDONLY)
        os.fstat(fd)
        os.pread(fd, size, 0)
        os.close(fd)

    template = ObjectMeta.annotation(uid)

    def copy3():
        d = template.copy()
        d["description_short"] = d["description_short"].copy()
        d["boundingBox"] = d["boundingBox"].copy()
        return d

    grb = random.getrandbits
    steps.update({
        "estimate: open+fstat+mmap+50 row reads+munmap+close (what NpzReader does)": same(
            via_mmap),
        "estimate: open+fstat+pread(whole file)+close (no mmap)": same(via_pread),
        "estimate: random.getrandbits(32*50) (one batch of 50 words)": same(grb, 1600),
        "estimate: dict.copy() of a cached annotation + its 2 nested dicts": same(copy3),
    })
    out = {k: _time(v, rounds, round_s) for k, v in steps.items()}
    bad = 0
    for seed in range(200):
        for n, k in ((1000, 50), (1000, 1000), (60, 50), (277, 50), (278, 50), (10, 3), (1, 1),
                     (10 ** 6, 7)):
            random.seed(seed)
            a, a2 = random.sample(range(n), k), random.random()
            random.seed(seed)
            b = mlspaces._core.Registry._random_sample(n, k, random.getrandbits)
            b2 = random.random()
            bad += (a != b) or (a2 != b2)
    out["_port_mismatches"] = bad
    return out


# ------------------------------------------------------------------------------------------
# Datagen.

BENCH_MODULE = '''\
"""Physics-only variants of the tutorial's config (written by bench/python_api_bench.py).
Importing datagen runs the tutorial's module as written: it registers the libraries and
CustomAssetsDataGenConfig, and defines BlockPickupTaskSampler."""
import os

from datagen import FrankaPickDroidDataGenConfig
from mlspaces.data_generation.config_registry import register_config

EPISODES = int(os.environ.get("BENCH_EPISODES", "20"))


@register_config("BenchPhysicsOnly")
class BenchPhysicsOnly(FrankaPickDroidDataGenConfig):
    """The tutorial's config (Python BlockPickupTaskSampler), no cameras, no rendering."""

    def model_post_init(self, ctx) -> None:
        super().model_post_init(ctx)
        self.task_config.enable_rendering = False
        self.camera_config.cameras = []
        self.task_sampler_config.samples_per_house = EPISODES


@register_config("BenchPhysicsOnlyBuiltin")
class BenchPhysicsOnlyBuiltin(BenchPhysicsOnly):
    """The same with the engine's built-in block_pickup sampler (the YAML's)."""

    def model_post_init(self, ctx) -> None:
        super().model_post_init(ctx)
        self.task_sampler_config.task_sampler_class = "block_pickup"
'''


def make_project(root: Path) -> Path:
    proj = root / "custom_assets"
    shutil.copytree(EXAMPLE_DIR, proj, ignore=shutil.ignore_patterns(
        "experiment_output", "__pycache__", "*.cc", "*.h"))
    (proj / "benchmod.py").write_text(BENCH_MODULE)
    return proj


def _stage(summary: str, name: str) -> float | None:
    m = re.search(rf"^{name}\s+([0-9.eE+-]+)\s+(\d+)\s+([0-9.eE+-]+)\s*$", summary, re.M)
    return float(m.group(1)) if m else None


def _data_hash(folder: Path) -> str | None:
    try:
        first = (folder / "summary.txt").read_text().splitlines()[0]
    except (OSError, IndexError):
        return None
    m = re.search(r"data hash (\w+)", first)
    return m.group(1) if m else None


def _journal(folder: Path) -> dict:
    """Per-attempt engine timings of a run folder's journal: mean seconds per attempt of each
    stage and of their sum (the episode, without process startup and file writing)."""
    rows = [json.loads(line) for line in (folder / "journal.jsonl").read_text().splitlines()
            if line.strip()]
    stages: dict[str, float] = {}
    for r in rows:
        for k, v in r.get("timings", {}).items():
            stages[k] = stages.get(k, 0.0) + v
    n = max(1, len(rows))
    out = {k: v / n for k, v in stages.items()}
    out["episode"] = sum(stages.values()) / n
    return out


CLI_PHYSICS_ONLY = ["--set", "task_config.enable_rendering=false",
                    "--set", "camera_config.cameras=[]"]


def sampler_worker(project: Path, episodes: int, rounds: int, seed: int, cli: str) -> dict:
    """(a): run_config with the Python sampler vs the built-in one, alternating, in-process.
    When run_config cannot run a built-in sampler (a binding bug), the built-in side runs
    through the CLI on the equivalent YAML (noted in the result)."""
    os.chdir(project)
    sys.path.insert(0, str(project))
    os.environ["BENCH_EPISODES"] = str(episodes)
    import benchmod
    from mlspaces.datagen import run_config

    configs = {"python": benchmod.BenchPhysicsOnly(), "builtin": benchmod.BenchPhysicsOnlyBuiltin()}
    runs: dict = {"python": [], "builtin": [], "builtin_via": "run_config", "error": None}
    scratch = project / "runs_a"

    def one(name: str, tag: str) -> dict:
        out = scratch / f"{name}_{tag}"
        if name == "python" or runs["builtin_via"] == "run_config":
            t = time.perf_counter()
            try:
                rep = run_config(configs[name], output_dir=out, seed=seed, progress=False,
                                 log_level="warning")
            except TypeError as e:
                if name == "python":
                    raise
                runs["builtin_via"] = "cli"
                text = str(e)
                runs["error"] = f"{type(e).__name__}: {text.splitlines()[0].split('. ')[0]}" + (
                    " (invoked with sampler=None)" if "NoneType" in text else "")
                return one(name, tag)
            wall = time.perf_counter() - t
            row = {"wall_s": wall, "engine_s": rep.get("seconds"), "kept": rep.get("episodes_kept"),
                   "attempts": rep.get("attempts"), "physics_steps": rep.get("physics_steps")}
        else:
            cmd = [cli, "datagen", "datagen.yaml", "--episodes", str(episodes), "--output",
                   str(out), "--seed", str(seed), "-q"] + CLI_PHYSICS_ONLY
            t = time.perf_counter()
            p = subprocess.run(cmd, capture_output=True, text=True, check=True)
            wall = time.perf_counter() - t
            m = re.search(r"episodes kept: (\d+) in ([0-9.]+) s \((\d+) policy steps, (\d+) "
                          r"physics steps\)", p.stdout)
            row = {"wall_s": wall, "engine_s": float(m.group(2)), "kept": int(m.group(1)),
                   "attempts": None, "physics_steps": int(m.group(4))}
        j = _journal(out)
        if row["attempts"] is None:
            row["attempts"] = len((out / "journal.jsonl").read_text().splitlines())
        row.update({"episode_s": j["episode"], "sample_s": j.get("sample"),
                    "physics_s": j.get("physics"), "hash": _data_hash(out)})
        shutil.rmtree(out, ignore_errors=True)
        return row

    one("python", "warm")  # imports, first-episode lazy init
    one("builtin", "warm")
    for r in range(rounds):
        for name in (("python", "builtin") if r % 2 == 0 else ("builtin", "python")):
            runs[name].append(one(name, str(r)))
    return runs


def frontend_compare(project: Path, cli: Path, episodes: int, small: int, rounds: int,
                     seed: int, python: str) -> dict:
    """(b): whole processes, alternating: python -m mlspaces.datagen (tutorial Python sampler;
    and with the built-in sampler) vs the CLI on datagen.yaml with the same overrides. Each
    variant runs `episodes` and `small` episodes: the difference of the two gives the
    startup-free rate."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env.pop("MLSPACES_ASSETS_DIR", None)
    scratch = project / "runs_b"
    scratch.mkdir(exist_ok=True)
    variants = {
        "cli": lambda n: [str(cli), "datagen", "datagen.yaml", "--episodes", str(n),
                          "--set", "task_config.enable_rendering=false",
                          "--set", "camera_config.cameras=[]"],
        "py_tutorial": lambda n: [python, "-m", "mlspaces.datagen", "benchmod:BenchPhysicsOnly"],
        "py_builtin": lambda n: [python, "-m", "mlspaces.datagen",
                                 "benchmod:BenchPhysicsOnlyBuiltin"],
    }

    def one(name: str, n: int, tag: str) -> dict:
        out = scratch / f"{name}_{n}_{tag}"
        cmd = variants[name](n) + ["--output", str(out), "--seed", str(seed), "-q"]
        t = time.perf_counter()
        p = subprocess.run(cmd, cwd=project, env=dict(env, BENCH_EPISODES=str(n)),
                           capture_output=True, text=True)
        wall = time.perf_counter() - t
        if p.returncode != 0:
            lines = p.stderr.strip().splitlines() or [""]
            err = next((x for x in lines if re.match(r"^\w+(Error|Exception): ", x)), lines[-1])
            if "NoneType" in p.stderr:
                err = err.split(". ")[0] + " (invoked with sampler=None)"
            failed[name] = (f"`{' '.join(cmd[1:4] if name != 'cli' else cmd[:3])}` exit "
                            f"{p.returncode}: {err[:300]}")
            return None
        m = (re.search(r"episodes kept: (\d+)", p.stdout) if name == "cli" else
             re.search(r"Success count: (\d+), Total count: (\d+)", p.stdout))
        kept = int(m.group(1)) if m else None
        steps = 0
        for line in (out / "journal.jsonl").read_text().splitlines():
            if line.strip():
                steps += json.loads(line).get("extra", {}).get("policy_steps", 0)
        row = {"wall_s": wall, "kept": kept, "hash": _data_hash(out), "policy_steps": steps}
        shutil.rmtree(out, ignore_errors=True)
        return row

    failed: dict[str, str] = {}
    for name in variants:
        one(name, small, "warm")
    order = [k for k in variants if k not in failed]
    runs: dict = {k: {episodes: [], small: []} for k in order}
    for r in range(rounds):
        for name in (order if r % 2 == 0 else order[::-1]):
            for n in ((episodes, small) if r % 2 == 0 else (small, episodes)):
                runs[name][n].append(one(name, n, str(r)))
    return {"runs": runs, "failed": failed}


# ------------------------------------------------------------------------------------------
# Driver.


def find_molmospaces_python(arg: str | None) -> tuple[str | None, str]:
    cand = arg or os.environ.get("MLSPACES_BENCH_MOLMOSPACES_PYTHON")
    if cand:
        return (cand, "") if Path(cand).exists() else (None, f"{cand} does not exist")
    default = REPO / "build" / "bench-venv-molmospaces" / "bin" / "python"
    if default.exists():
        return str(default), ""
    return None, (f"no bench venv (looked for {default.relative_to(REPO)}; make it with "
                  "bench/python_api_bench.sh --setup-molmospaces, or pass "
                  "--molmospaces-python / MLSPACES_BENCH_MOLMOSPACES_PYTHON)")


def run_worker(python: str, args: list[str], env_extra: dict | None = None,
               env_drop: tuple = ()) -> dict:
    env = dict(os.environ)
    for k in env_drop:
        env.pop(k, None)
    env.update(env_extra or {})
    p = subprocess.run([python, str(Path(__file__).resolve())] + args, env=env,
                       capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError((p.stderr or p.stdout).strip().splitlines()[-1] if
                           (p.stderr or p.stdout).strip() else f"exit {p.returncode}",
                           p.stderr[-4000:])
    return json.loads(p.stdout.strip().splitlines()[-1])


def merge_sessions(sessions: list[dict]) -> dict:
    """Medians over every round of every worker session (min/max over them)."""
    out = {}
    for key in sessions[0]["results"]:
        meds = [s["results"][key]["median_us"] for s in sessions]
        out[key] = {"median_us": statistics.median(meds),
                    "min_us": min(s["results"][key]["min_us"] for s in sessions),
                    "max_us": max(s["results"][key]["max_us"] for s in sessions),
                    "sessions": meds}
    return out


def fmt_us(v: float) -> str:
    return f"{v:8.3f}" if v < 10 else f"{v:8.1f}"


def mark(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer rounds and episodes (smoke run)")
    ap.add_argument("--molmospaces-python", help="python of a venv with molmo-spaces installed")
    ap.add_argument("--no-molmospaces", action="store_true", help="skip the original")
    ap.add_argument("--cli", help="the mlspaces CLI (default: build/apps/mlspaces/mlspaces, "
                    "$MLSPACES_CLI_PATH, or mlspaces on PATH)")
    ap.add_argument("--episodes", type=int, help="episodes per datagen run (default 24; quick 6)")
    ap.add_argument("--rounds", type=int, help="datagen rounds (default 7; quick 2)")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--skip-datagen", action="store_true")
    ap.add_argument("--skip-lookups", action="store_true")
    ap.add_argument("--splits", action="store_true",
                    help="also time each layer of the mlspaces calls on its own")
    ap.add_argument("--keep", action="store_true", help="keep the temp folder")
    ap.add_argument("--worker", choices=["mlspaces", "molmo_spaces", "sampler", "splits"],
                    help=argparse.SUPPRESS)
    ap.add_argument("--library", help=argparse.SUPPRESS)
    ap.add_argument("--home", help=argparse.SUPPRESS)
    ap.add_argument("--lookup-rounds", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    quick = args.quick
    lookup_rounds = args.lookup_rounds or (5 if quick else 15)
    round_s = 0.02 if quick else 0.05

    if args.worker in ("mlspaces", "molmo_spaces"):
        res = lookup_worker(args.worker, Path(args.library), lookup_rounds, round_s,
                            Path(args.home) if args.home else None)
        print(json.dumps(res))
        return 0
    if args.worker == "splits":
        print(json.dumps(splits_worker(Path(args.library), lookup_rounds, round_s)))
        return 0
    if args.worker == "sampler":
        print(json.dumps(sampler_worker(Path(args.home), args.episodes, args.rounds, args.seed,
                                        args.cli)))
        return 0

    # Workers and datagen processes run in other folders: make PYTHONPATH absolute.
    if os.environ.get("PYTHONPATH"):
        os.environ["PYTHONPATH"] = os.pathsep.join(
            str(Path(p).resolve()) for p in os.environ["PYTHONPATH"].split(os.pathsep) if p)
    episodes = args.episodes or (6 if quick else 24)
    rounds = args.rounds or (2 if quick else 7)
    sessions = 1 if quick else 2
    tmp = Path(tempfile.mkdtemp(prefix="mlspaces_pyapi_bench_"))

    def say(s: str = "") -> None:
        print(s, flush=True)

    summary: list[tuple[str, str, str, str]] = []  # what, measured, target, verdict

    try:
        import mlspaces
        rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "-uno"],
                               capture_output=True, text=True).stdout.strip()
        say(f"mlspaces Python API bench ({'quick' if quick else 'full'} run), "
            f"{time.strftime('%Y-%m-%d %H:%M:%S')}")
        say(f"  machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.platform()}")
        say(f"  mlspaces: {Path(mlspaces.__file__).parent} (git {rev}{'+dirty' if dirty else ''})")
        say(f"  python: {sys.executable} ({sys.version.split()[0]})")
        say(f"  timing: median over rounds of the per-call mean ({lookup_rounds} rounds of "
            f"~{round_s * 1000:.0f} ms per worker x {sessions} worker session(s) per package)")
        say()

        # --- lookups -------------------------------------------------------------------
        if not args.skip_lookups:
            lib = tmp / "library"
            t = time.perf_counter()
            write_library(lib, 1000, 1000)
            say(f"library: 1,000 UIDs x 1,000 grasps written in {time.perf_counter() - t:.1f} s "
                f"({lib})")
            say("  UIDs block_0000..block_0999: two tokens, as the tutorial's red_block (the "
                "original's locate does one index lookup per token and built-in object source)")
            worker_args = ["--library", str(lib), "--lookup-rounds", str(lookup_rounds)] + (
                ["--quick"] if quick else [])
            ms_python, ms_why = (None, "skipped (--no-molmospaces)") if args.no_molmospaces \
                else find_molmospaces_python(args.molmospaces_python)
            ours, orig, orig_err = [], [], None
            for s in range(sessions):
                ours.append(run_worker(sys.executable, ["--worker", "mlspaces"] + worker_args))
                if ms_python and orig_err is None:
                    home = tmp / f"molmospaces_home_{s}"
                    try:
                        orig.append(run_worker(
                            ms_python, ["--worker", "molmo_spaces", "--home", str(home)] +
                            worker_args,
                            {"MLSPACES_ASSETS_DIR": str(home / "assets"),
                             "MLSPACES_CACHE_DIR": str(home / "cache")}))
                    except RuntimeError as e:
                        orig_err = e.args[0]
                        sys.stderr.write(e.args[1] if len(e.args) > 1 else "")
            mine = merge_sessions(ours)
            theirs = merge_sessions(orig) if orig else None
            o0 = ours[0]
            say(f"mlspaces {o0['version']} ({o0['module']}), numpy {o0['numpy']}, install dir "
                f"of built-in data: {o0['assets_dir'] or 'none (user libraries only)'}")
            if orig:
                t0 = orig[0]
                say(f"molmo-spaces {t0['version']} ({ms_python}), numpy {t0['numpy']}; "
                    "offline resource-manager setup:")
                for step in t0["setup"]:
                    say(f"    - {step}")
                say(f"  first calls (cold, not in the table): locate {t0['first_locate_s']:.3f} s,"
                    f" annotation {t0['first_annotation_s']:.3f} s (mlspaces: "
                    f"{o0['first_locate_s'] * 1e6:.0f} us, {o0['first_annotation_s'] * 1e6:.0f} us)")
                agree = all(o["check"] == orig[0]["check"] for o in ours + orig)
                say(f"  same answers from both (locate tuple, annotation dict, the 50 grasps "
                    f"drawn after random.seed(1234)): {'yes' if agree else 'NO'}")
                if not agree:
                    say(f"    mlspaces: {o0['check']}\n    molmo-spaces: {orig[0]['check']}")
            else:
                why = orig_err or ms_why
                say(f"molmo-spaces: not installable here: {why}" if orig_err else
                    f"molmo-spaces: not run: {why}")
                say("  the original's figures below are the issue's, on this machine class")
            say(f"  Python call floor (a no-op Python function in the same loop): "
                f"{mine['noop']['median_us']:.3f} us")
            say()
            say("Library lookups, us per call (median; min-max over rounds)")
            hdr = (f"  {'call':<54} {'mlspaces':>9} {'min-max':>17} {'original':>9} "
                   f"{'ratio':>7} {'target':>8}  ")
            say(hdr)
            say("  " + "-" * (len(hdr) - 2))
            for key, label, headline in LOOKUP_ROWS:
                m = mine[key]
                if theirs:
                    ref = theirs[key]["median_us"]
                    ref_s = fmt_us(ref)
                else:
                    ref = ISSUE_ORIGINAL_US.get(key)
                    ref_s = (fmt_us(ref) + "*") if ref else "       -"
                ratio = f"{ref / m['median_us']:6.1f}x" if ref else "      -"
                tgt = TARGET_US.get(key) if headline else None
                verdict = (f"< {tgt:g} us  {mark(m['median_us'] < tgt)}" if tgt else "")
                if tgt:
                    vs = f" ({ref / m['median_us']:.1f}x faster than the original)" if theirs \
                        else ""
                    summary.append((label, f"{m['median_us']:.3g} us{vs}", f"< {tgt:g} us",
                                    mark(m["median_us"] < tgt)))
                say(f"  {label:<54} {fmt_us(m['median_us'])} "
                    f"{fmt_us(m['min_us']).strip():>8}-{fmt_us(m['max_us']).strip():<8} "
                    f"{ref_s:>9} {ratio:>7} {verdict}")
            say("  ratio = original / mlspaces (higher: mlspaces faster)" +
                ("" if theirs else "; * the issue's figure for the original"))
            if theirs:
                say("  the issue's figures for the original on this machine class: " + ", ".join(
                    f"{k} {v:g} us" for k, v in ISSUE_ORIGINAL_US.items()))
            say()
            if args.splits:
                sp = run_worker(sys.executable, ["--worker", "splits"] + worker_args)
                say("Layer splits of the mlspaces calls (each layer timed alone), us per call")
                bad = sp.pop("_port_mismatches")
                for k, v in sp.items():
                    say(f"  {k:<78} {fmt_us(v['median_us'])}")
                say(f"  the C++ port vs random.sample (same picks, same generator state after; "
                    f"1,600 seeded cases): {'exact' if bad == 0 else f'{bad} MISMATCHES'}")
                say()

        # --- datagen ---------------------------------------------------------------------
        if not args.skip_datagen:
            cli = Path(args.cli or os.environ.get("MLSPACES_CLI_PATH") or
                       REPO / "build" / "apps" / "mlspaces" / "mlspaces")
            if not cli.exists() and shutil.which("mlspaces"):
                cli = Path(shutil.which("mlspaces"))
            proj = make_project(tmp)
            say(f"Datagen, physics only (no cameras, enable_rendering=false), seed {args.seed}, "
                f"{episodes} episodes per run, {rounds} alternating rounds (+1 warm-up)")
            a = run_worker(sys.executable, ["--worker", "sampler", "--home", str(proj),
                                            "--episodes", str(episodes), "--rounds", str(rounds),
                                            "--seed", str(args.seed), "--cli", str(cli)],
                           env_drop=("MLSPACES_ASSETS_DIR",))

            def med(rows, f):
                vals = [f(r) for r in rows if f(r) is not None]
                return statistics.median(vals) if vals else float("nan")

            sides = ("python", "builtin")
            ep = {k: med(a[k], lambda r: r["episode_s"]) for k in sides}
            sample = {k: med(a[k], lambda r: r["sample_s"]) for k in sides}
            phys = {k: med(a[k], lambda r: r["physics_s"]) for k in sides}
            other = {k: med(a[k], lambda r: r["episode_s"] - r["physics_s"]) for k in sides}
            eng = {k: med(a[k], lambda r: r["engine_s"] / r["attempts"]) for k in sides}
            # The two samplers draw different poses (numpy's generator vs the engine's), so
            # their episodes differ: time per 1,000 physics steps compares equal work.
            per_kstep = {k: med(a[k], lambda r: r["engine_s"] / r["physics_steps"] * 1e3)
                         for k in sides}
            direct = (sample["python"] - sample["builtin"]) / ep["builtin"] * 100
            e2e = (eng["python"] / eng["builtin"] - 1) * 100
            norm = (per_kstep["python"] / per_kstep["builtin"] - 1) * 100
            via = ("run_config" if a["builtin_via"] == "run_config" else
                   "the CLI (run_config failed for it: " + a["error"] + ")")
            say("(a) Python sampler (the tutorial's BlockPickupTaskSampler, via run_config) vs "
                f"the built-in 'block_pickup' (via {via})")
            say("    ms per episode, median over rounds of the run's mean (engine timers: "
                "journal stages; run = the engine's run seconds)")
            say(f"  {'ms':<34} {'python':>10} {'built-in':>10} {'delta':>10}")
            for label, d, digits in (("episode (sum of stages)", ep, 2),
                                     ("  sample stage (the sampler)", sample, 3),
                                     ("  physics stage", phys, 2),
                                     ("  all stages but physics", other, 3),
                                     ("run seconds per episode", eng, 2),
                                     ("run seconds per 1,000 phys. steps", per_kstep, 2)):
                say(f"  {label:<34} {d['python'] * 1e3:10.{digits}f} "
                    f"{d['builtin'] * 1e3:10.{digits}f} "
                    f"{(d['python'] - d['builtin']) * 1e3:+10.{digits}f}")
            pa, ba = a["python"][0], a["builtin"][0]
            say(f"  per run: python {pa['kept']} kept / {pa['attempts']} attempts, "
                f"{pa['physics_steps']} physics steps; built-in {ba['kept']} / {ba['attempts']}, "
                f"{ba['physics_steps']} (other poses: numpy's draws vs the engine's)")
            say(f"  Python sampler overhead = sample-stage delta / built-in episode: "
                f"{direct:+.2f} %   target < {TARGET_SAMPLER_OVERHEAD_PCT:g} %  "
                f"{mark(direct < TARGET_SAMPLER_OVERHEAD_PCT)}")
            spread = {k: [r["engine_s"] / r["physics_steps"] * 1e6 for r in a[k]] for k in sides}
            say(f"  cross-checks (other episodes, and the machine's noise: run seconds per "
                f"physics step ranged {min(spread['python']):.1f}-{max(spread['python']):.1f} us "
                f"(python) and {min(spread['builtin']):.1f}-{max(spread['builtin']):.1f} us "
                f"(built-in) over the rounds): per physics step {norm:+.2f} %, per episode "
                f"{e2e:+.2f} %")
            summary.append(("Python sampler overhead per physics-only episode",
                            f"{direct:+.2f} % ({(sample['python'] - sample['builtin']) * 1e3:.2f} "
                            f"ms of {ep['builtin'] * 1e3:.0f} ms)",
                            f"< {TARGET_SAMPLER_OVERHEAD_PCT:g} %",
                            mark(direct < TARGET_SAMPLER_OVERHEAD_PCT)))
            say()

            small = 2
            fb = frontend_compare(proj, cli, episodes, small, rounds, args.seed, sys.executable)
            b = fb["runs"]
            wall = {k: {n: med(v[n], lambda r: r["wall_s"]) for n in v} for k, v in b.items()}
            kept = {k: {n: v[n][0]["kept"] for n in v} for k, v in b.items()}
            whole = {k: kept[k][episodes] / wall[k][episodes] * 3600 for k in b}
            steady = {k: (kept[k][episodes] - kept[k][small]) /
                      (wall[k][episodes] - wall[k][small]) * 3600 for k in b}
            steps = {k: {n: v[n][0]["policy_steps"] for n in v} for k, v in b.items()}
            steady_steps = {k: (steps[k][episodes] - steps[k][small]) /
                            (wall[k][episodes] - wall[k][small]) for k in b}
            per_ep_b = {k: 3600 / steady[k] for k in b}
            startup = {k: wall[k][small] - kept[k][small] * per_ep_b[k] for k in b}
            hashes = {k: {r["hash"] for r in v[episodes]} for k, v in b.items()}
            say(f"(b) whole processes, episodes kept per hour (median of {rounds} alternating "
                f"rounds of {episodes}- and {small}-episode runs)")
            say(f"  CLI: {cli} datagen datagen.yaml --episodes N " + " ".join(CLI_PHYSICS_ONLY))
            say(f"  {'command':<52} {'wall s':>7} {'ep/hour':>8} {'vs CLI':>7} "
                f"{'startup':>8} {'ep/h w/o':>9} {'vs CLI':>7} {'steps/s':>8} {'vs CLI':>7}")
            say(f"  {'':<52} {f'{episodes} ep':>7} {'':>8} {'':>7} {'s':>8} "
                f"{'startup':>9} {'':>7} {'w/o st.':>8} {'':>7}")
            labels = {"cli": "mlspaces datagen datagen.yaml (built-in sampler)",
                      "py_tutorial": "python -m mlspaces.datagen (tutorial Python sampler)",
                      "py_builtin": "python -m mlspaces.datagen (built-in sampler)"}
            verdicts = []
            for k in ("cli", "py_tutorial", "py_builtin"):
                if k in fb["failed"]:
                    say(f"  {labels[k]:<52} FAILED: {fb['failed'][k]}")
                    summary.append((f"{labels[k].split(' (')[0]} ({labels[k].split(' (')[1]} vs "
                                    "CLI", "did not run (see (b))",
                                    f">= {TARGET_FRONTEND_RATIO:.2f} x", "n/a"))
                    continue
                r1, r2 = whole[k] / whole["cli"], steady[k] / steady["cli"]
                r3 = steady_steps[k] / steady_steps["cli"]
                say(f"  {labels[k]:<52} {wall[k][episodes]:7.2f} {whole[k]:8.0f} {r1:7.3f} "
                    f"{startup[k]:8.2f} {steady[k]:9.0f} {r2:7.3f} {steady_steps[k]:8.0f} "
                    f"{r3:7.3f}")
                if k != "cli":
                    verdicts.append((k, r1, r2))
            for k, r1, r2 in verdicts:
                who = "python -m (tutorial sampler)" if k == "py_tutorial" else \
                    "python -m (built-in sampler)"
                summary.append((f"{who} vs CLI, episodes/hour w/o startup", f"{r2:.3f} x",
                                f">= {TARGET_FRONTEND_RATIO:.2f} x", mark(r2 >= TARGET_FRONTEND_RATIO)))
                summary.append((f"{who} vs CLI, whole process, {episodes} episodes",
                                f"{r1:.3f} x (startup {startup[k] - startup['cli']:+.2f} s)",
                                f">= {TARGET_FRONTEND_RATIO:.2f} x", mark(r1 >= TARGET_FRONTEND_RATIO)))
                say(f"  {labels[k]}: target >= {TARGET_FRONTEND_RATIO:.2f} x CLI: whole process "
                    f"({episodes} episodes) {r1:.3f} {mark(r1 >= TARGET_FRONTEND_RATIO)}; "
                    f"startup-free {r2:.3f} {mark(r2 >= TARGET_FRONTEND_RATIO)}")
            say(f"  startup = wall of the {small}-episode run less {small} episodes at the "
                f"startup-free rate; ep/h w/o startup = (kept({episodes}) - kept({small})) / "
                f"(wall({episodes}) - wall({small})); steps/s = policy steps (journal) per "
                "second, the same way (work-normalised: the Python sampler's episodes differ)")
            for k, _, _ in verdicts:
                gap = startup[k] - startup["cli"]
                # whole(N) / whole_cli(N) >= t  <=>  N >= t*S_p - S_c / (e_c - t*e_p) ...
                t = TARGET_FRONTEND_RATIO
                denom = per_ep_b["cli"] - t * per_ep_b[k]
                need = (t * startup[k] - startup["cli"]) / denom if denom > 0 else float("inf")
                when = (f"from about {max(0.0, need):.0f} episodes per run" if need != float("inf")
                        else "never (its startup-free rate is below that)")
                say(f"  {labels[k]}: startup {gap:+.2f} s vs the CLI; the whole-process ratio "
                    f"reaches {t:.2f} {when}")
            if "py_builtin" in b:
                same = hashes["py_builtin"] == hashes["cli"] and len(hashes["cli"]) == 1
                say(f"  data hash: CLI {','.join(sorted(map(str, hashes['cli'])))}, python -m "
                    f"built-in {','.join(sorted(map(str, hashes['py_builtin'])))} "
                    f"({'same episodes' if same else 'DIFFERENT'})")
            say()
        if summary:
            say("Summary (medians; targets of issue point 10)")
            w = max(len(r[0]) for r in summary)
            m = max(len(r[1]) for r in summary)
            for what, value, target, verdict in summary:
                say(f"  {what:<{w}}  {value:<{m}}  {target:<10} {verdict}")
            say()
    finally:
        if args.keep:
            print(f"(kept {tmp})")
        else:
            shutil.rmtree(tmp, ignore_errors=True)

    return 0


if __name__ == "__main__":
    sys.exit(main())
