"""Library-lookup workers of bench/python_api_bench.py: the user library it measures on
(numpy only), the per-implementation lookup worker (mlspaces, or the original molmo_spaces in
its bench venv, made to set up offline) and the --splits layer timings of the mlspaces calls.
Imported by the worker processes too: nothing here imports mlspaces or molmo_spaces at import
time."""

from __future__ import annotations

import hashlib
import json
import os
import statistics
import sys
import time
from pathlib import Path


# ------------------------------------------------------------------------------------------
# The library (numpy only: both venvs run this).


def write_library(root: Path, n_uids: int, n_grasps: int, robot: str = "droid") -> list[str]:
    """A user asset + grasp library of `n_uids` UIDs with `n_grasps` grasps each for `robot`,
    as the Python tests write it (python/tests/library_files.py). Returns the UIDs. Imported
    here, not at the top: a worker's import_s must still include numpy's import."""
    tests = str(Path(__file__).resolve().parents[1] / "python" / "tests")
    if tests not in sys.path:
        sys.path.insert(0, tests)
    import library_files

    uids = [f"block_{k:04d}" for k in range(n_uids)]
    library_files.write_library(root, {uid: n_grasps for uid in uids}, robots=(robot,))
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
