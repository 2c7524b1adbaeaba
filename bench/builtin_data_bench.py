"""Built-in data bench (issue 28, point 7): one run, figures side by side with the original.

  1. objathor annotation lookup, first call in a process and warm: mlspaces (Python
     ObjectMeta.annotation and the `meta` CLI) against the original's LMDB path (PickleLMDBMap of
     molmospaces-resources 0.0.2, the store molmo_spaces' ObjectMeta reads), on a store of
     `--annotations` UIDs with CLIP rows, built by both from the same installed source files;
  2. install throughput (archives/s) from a local MolmoSpaces-format remote over HTTP on
     127.0.0.1: `mlspaces install --library objaverse` against the original's install_packages;
  3. SEARCH's CLIP search benchmark (bench/clip_search_bench.sh) when it is there.

Run through bench/builtin_data_bench.sh. The same file is the worker of each side (`--worker`),
so it imports neither mlspaces nor the original at the top.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


# ---- workers (run in the interpreter of one side) --------------------------------------------


def _rounds(fn, uids: list[str], rounds: int, per_round: int) -> list[float]:
    """Per-call mean (us) of each round of `per_round` calls on a shuffled UID list."""
    rng = random.Random(1)
    out = []
    for _ in range(rounds):
        batch = [uids[rng.randrange(len(uids))] for _ in range(per_round)]
        t0 = time.perf_counter()
        for u in batch:
            fn(u)
        out.append((time.perf_counter() - t0) / per_round * 1e6)
    return out


def _warm(fn, uids: list[str], rounds: int, per_round: int) -> dict:
    """'new': each UID once, none looked up before in the process (per-call mean of chunks of
    `per_round`); 'repeat': rounds over 100 UIDs looked up before."""
    fresh_uids = uids[1:]
    new = []
    for i in range(0, min(len(fresh_uids), rounds * per_round), per_round):
        chunk = fresh_uids[i:i + per_round]
        t0 = time.perf_counter()
        for u in chunk:
            fn(u)
        new.append((time.perf_counter() - t0) / len(chunk) * 1e6)
    return {"new": new, "repeat": _rounds(fn, fresh_uids[:100], rounds, per_round)}


def _plain(v):
    """JSON-able copy of an annotation (arrays as float lists)."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if hasattr(v, "tolist"):
        return v.tolist()
    return v


def worker_original_build(args) -> dict:
    """What molmo_spaces' ObjectMeta does on first use: the LMDB from the installed files."""
    import gzip
    import pickle

    from molmospaces_resources.lmdb_data import PickleLMDBMap

    src = Path(args.source_dir)
    t0 = time.perf_counter()
    with gzip.open(src / "objects_metadata.json.gz", "rb") as f:
        annotations = json.load(f)
    with open(src / "clip_features.pkl", "rb") as f:
        clip = pickle.load(f)
    values = {}
    for i, uid in enumerate(clip["uids"]):
        v = dict(annotations[uid])
        v["clip_img_features"] = clip["img_features"][i]
        v["clip_text_features"] = clip["text_features"][i]
        values[uid] = v
    PickleLMDBMap.from_dict(values, args.lmdb)
    return {"build_s": time.perf_counter() - t0}


def worker_original_lookup(args) -> dict:
    t0 = time.perf_counter()
    import numpy  # noqa: F401 - loaded long before in molmo_spaces; not the lookup's cost
    from molmospaces_resources.lmdb_data import PickleLMDBMap

    t1 = time.perf_counter()
    db = PickleLMDBMap(args.lmdb)
    first = db.get(args.first_uid)
    t2 = time.perf_counter()
    assert first is not None
    uids = json.loads(Path(args.uids).read_text())
    warm = _warm(db.get, uids, args.rounds, args.per_round)
    sample = {u: _plain(db.get(u)) for u in uids[:20]}
    return {"import_s": t1 - t0, "first_s": t2 - t1, "warm_us": warm, "sample": sample}


def worker_mlspaces_lookup(args) -> dict:
    t0 = time.perf_counter()
    import mlspaces
    from mlspaces import ObjectMeta

    t1 = time.perf_counter()
    first = ObjectMeta.annotation(args.first_uid)
    t2 = time.perf_counter()
    if first is None:
        return {"error": f"mlspaces has no annotation for {args.first_uid}"}
    uids = json.loads(Path(args.uids).read_text())
    warm = _warm(ObjectMeta.annotation, uids, args.rounds, args.per_round)
    sample = {u: _plain(ObjectMeta.annotation(u)) for u in uids[:20]}
    return {"import_s": t1 - t0, "first_s": t2 - t1, "warm_us": warm, "sample": sample,
            "module": str(Path(mlspaces.__file__).parent)}


def worker_original_install(args) -> dict:
    """From a fresh cache: set-up (EAGER sources extracted, as molmo_spaces' import does), then
    every objaverse object archive and every droid_objaverse grasp archive."""
    t0 = time.perf_counter()
    from molmospaces_resources import R2RemoteStorage
    from molmospaces_resources.setup_utils import setup_resource_manager

    rm = setup_resource_manager(R2RemoteStorage(args.url), Path(args.assets),
                                json.loads(args.versions), Path(args.cache))
    for dtype, source in (("objects", "objaverse"), ("grasps", "droid_objaverse")):
        rm.install_packages(dtype, {source: sorted(rm.find_all_packages_for_source(dtype,
                                                                                   source))})
    return {"seconds": time.perf_counter() - t0}


WORKERS = {"original-build": worker_original_build, "original-lookup": worker_original_lookup,
           "mlspaces-lookup": worker_mlspaces_lookup, "original-install": worker_original_install}


# ---- orchestration ----------------------------------------------------------------------------


def run_worker(python: str, name: str, env: dict | None = None, **kw) -> dict:
    cmd = [python, str(Path(__file__).resolve()), "--worker", name]
    for k, v in kw.items():
        cmd += [f"--{k.replace('_', '-')}", str(v)]
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **(env or {})},
                       timeout=1800)
    if p.returncode != 0:
        return {"error": (p.stderr or p.stdout).strip()[-600:]}
    return json.loads(p.stdout.strip().splitlines()[-1])


def wall(cmd: list[str], env: dict) -> tuple[float, subprocess.CompletedProcess]:
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **env},
                       timeout=1800)
    return time.perf_counter() - t0, p


def med(xs):
    return statistics.median(xs) if xs else float("nan")


def same_answers(a: dict, b: dict) -> tuple[bool, str]:
    """mlspaces' answer must hold every key of the original's with equal values (arrays compared
    as float16 values; mlspaces may hold them at higher precision)."""
    for uid, ov in a.items():
        mv = b.get(uid)
        if mv is None:
            return False, f"{uid}: missing"
        for k, x in ov.items():
            if k not in mv:
                return False, f"{uid}: key {k} missing"
            y = mv[k]
            if k.startswith("clip_"):
                import numpy as np

                if not np.array_equal(np.asarray(x, np.float16), np.asarray(y, np.float16)):
                    return False, f"{uid}: {k} differs"
            elif x != y:
                return False, f"{uid}: {k}: {x!r} != {y!r}"
    return True, ""


class Server:
    def __init__(self, directory: Path, log: Path):
        self.log = log
        self.proc = subprocess.Popen(
            [sys.executable, "-u", "-m", "http.server", "0", "--bind", "127.0.0.1", "--directory",
             str(directory)], stdout=open(log, "w"), stderr=subprocess.STDOUT)
        self.port = None
        for _ in range(3000):  # waits for the "Serving HTTP on ... port N" line, not a time
            text = log.read_text()
            if "port " in text:
                self.port = int(text.split("port ")[1].split()[0])
                break
            if self.proc.poll() is not None:
                raise RuntimeError(text)
            time.sleep(0.01)
        if self.port is None:
            raise RuntimeError("http.server did not start")
        self.url = f"http://127.0.0.1:{self.port}"

    def close(self):
        self.proc.terminate()
        self.proc.wait()


def fresh(d: Path) -> Path:
    if d.exists():
        subprocess.run(["chmod", "-R", "u+w", str(d)], check=False)
        shutil.rmtree(d)
    d.mkdir(parents=True)
    return d


def annotation_bench(args, work: Path, lines: list[str]) -> None:
    fx_dir = work / "fx_meta"
    t0 = time.perf_counter()
    subprocess.run([sys.executable, str(ROOT / "tests/fixtures/make_molmo_remote.py"),
                    str(fx_dir), "--objaverse", "6", "--extra-annotations",
                    str(max(0, args.annotations - 11))], check=True)
    fx = json.loads((fx_dir / "fixture.json").read_text())
    n = fx["objathor_metadata"]["count"]
    lines.append(f"1. objathor annotations: {n:,} UIDs with CLIP rows (3x768 + 768 float16), "
                 f"fixture written in {time.perf_counter() - t0:.1f} s")
    uids = fx["objathor_metadata"]["uids"]
    rng = random.Random(5)
    sample = rng.sample(uids, min(args.rounds * args.per_round + 1, len(uids)))
    (work / "uids.json").write_text(json.dumps(sample))
    versions = {"objects": {"objathor_metadata": fx["versions"]["objects"]["objathor_metadata"],
                            "thor": fx["versions"]["objects"]["thor"],
                            "objaverse": fx["versions"]["objects"]["objaverse"]}}
    srv = Server(fx_dir / "remote", work / "http_meta.log")
    try:
        assets, cache = fresh(work / "m_assets"), fresh(work / "m_cache")
        # The original installs the source (EAGER); both sides read that one tree.
        code = ("import json,sys; from pathlib import Path; from molmospaces_resources import "
                "R2RemoteStorage; from molmospaces_resources.setup_utils import "
                "setup_resource_manager as s; s(R2RemoteStorage(sys.argv[1]), Path(sys.argv[2]), "
                "json.loads(sys.argv[4]), Path(sys.argv[3]))")
        subprocess.run([args.original_python, "-c", code, srv.url, str(assets), str(cache),
                        json.dumps(versions)], check=True, env={**os.environ, "TQDM_DISABLE": "1"})
    finally:
        srv.close()
    src = assets / "objects" / "objathor_metadata"
    lmdb = assets / ".lmdb" / "objathor_metadata" / versions["objects"]["objathor_metadata"]
    ob = run_worker(args.original_python, "original-build", {"TQDM_DISABLE": "1"},
                    source_dir=src, lmdb=lmdb)
    env = {"MLSPACES_ASSETS_DIR": str(assets), "MLSPACES_CACHE_DIR": str(cache)}
    conv_s, p = wall([args.cli, "index-builtin", "--assets-dir", str(assets)], env)
    failed = "" if p.returncode == 0 else f" (FAILED: {p.stderr.strip()[-200:]})"
    lines.append(f"   one-time preparation: original LMDB build (ObjectMeta's first use) "
                 f"{ob.get('build_s', float('nan')):.2f} s; mlspaces index-builtin "
                 f"{conv_s:.2f} s{failed}")
    first = sample[0]
    orig, mls = [], []
    for _ in range(args.first_reps):
        orig.append(run_worker(args.original_python, "original-lookup", lmdb=lmdb,
                               first_uid=first, uids=work / "uids.json", rounds=args.rounds,
                               per_round=args.per_round))
        mls.append(run_worker(args.mlspaces_python, "mlspaces-lookup",
                              {**env, "PYTHONPATH": args.mlspaces_pythonpath}, first_uid=first,
                              uids=work / "uids.json", rounds=args.rounds,
                              per_round=args.per_round))
    cli_first = []
    for _ in range(args.first_reps):
        s, p = wall([args.cli, "meta", first], env)
        cli_first.append(s if p.returncode == 0 else float("nan"))
    o_err = next((r["error"] for r in orig if "error" in r), None)
    m_err = next((r["error"] for r in mls if "error" in r), None)
    fmt = "   {:<52} {:>12} {:>12} {:>9}"
    lines.append(fmt.format("", "mlspaces", "original", "ratio"))

    def row(name, m, o, unit, scale=1.0):
        ratio = o / m if m and m == m and o == o else float("nan")
        lines.append(fmt.format(name, f"{m * scale:.1f} {unit}", f"{o * scale:.1f} {unit}",
                                f"{ratio:.1f}x"))

    nan = float("nan")
    o_first = med([r["first_s"] for r in orig if "first_s" in r]) if not o_err else nan
    m_first = med([r["first_s"] for r in mls if "first_s" in r]) if not m_err else nan
    row("first lookup in a process (open + get), median", m_first, o_first, "us", 1e6)
    o_imp = med([r["import_s"] for r in orig if "import_s" in r]) if not o_err else nan
    m_imp = med([r["import_s"] for r in mls if "import_s" in r]) if not m_err else nan
    row("  module import before it", m_imp, o_imp, "ms", 1e3)
    for kind, name in (("new", "warm process, UIDs not looked up before"),
                       ("repeat", "warm process, 100 UIDs looked up before")):
        o_warm = med([x for r in orig for x in r.get("warm_us", {}).get(kind, [])])
        m_warm = med([x for r in mls for x in r.get("warm_us", {}).get(kind, [])])
        row(name, m_warm, o_warm, "us")
    lines.append(f"   `mlspaces meta UID` whole process (CLI first lookup), median of "
                 f"{args.first_reps}: {med(cli_first) * 1e3:.1f} ms")
    if o_err:
        lines.append(f"   original FAILED: {o_err}")
    if m_err:
        lines.append(f"   mlspaces FAILED: {m_err}")
    if not o_err and not m_err:
        ok, why = same_answers(orig[0]["sample"], mls[0]["sample"])
        lines.append(f"   same answers on 20 UIDs (every key of the original's value): "
                     f"{'yes' if ok else 'NO: ' + why}")
        lines.append(f"   mlspaces package: {mls[0].get('module')}")


def install_bench(args, work: Path, lines: list[str]) -> None:
    fx_dir = work / "fx_install"
    subprocess.run([sys.executable, str(ROOT / "tests/fixtures/make_molmo_remote.py"),
                    str(fx_dir), "--objaverse", str(args.archives), "--mesh-kb",
                    str(args.mesh_kb)], check=True)
    fx = json.loads((fx_dir / "fixture.json").read_text())
    n = len(fx["sources"]["objects"]["objaverse"]["archives"])
    mb = sum(a["bytes"] for a in fx["sources"]["objects"]["objaverse"]["archives"].values()) / 1e6
    total = sum(len(s["archives"]) for per in fx["sources"].values() for s in per.values())
    lines.append(f"2. install throughput from a fresh cache: the objaverse library ({n} object "
                 f"archives, {mb * 1e3 / n:.1f} KB each, and their grasp archives) after the "
                 f"set-up of every pinned source ({total} archives on the remote), "
                 f"http.server on 127.0.0.1")
    srv = Server(fx_dir / "remote", work / "http_install.log")
    rates: dict[str, list[float]] = {"mlspaces": [], "original": []}
    counts: dict[str, int] = {}
    errs = []
    try:
        for rep in range(args.install_reps):
            for side in ("original", "mlspaces"):
                a, c = fresh(work / f"{side}_assets{rep}"), fresh(work / f"{side}_cache{rep}")
                if side == "original":
                    t0 = time.perf_counter()
                    r = run_worker(args.original_python, "original-install", {"TQDM_DISABLE": "1"},
                                   url=srv.url, assets=a, cache=c,
                                   versions=json.dumps(fx["versions"]))
                    s, err = time.perf_counter() - t0, r.get("error")
                else:
                    env = {"MLSPACES_ASSETS_DIR": str(a), "MLSPACES_CACHE_DIR": str(c),
                           "MLSPACES_PINNED_ASSETS_FILE": str(fx_dir / fx["pins_file"])}
                    s, p = wall([args.cli, "install", "--library", "objaverse", "--remote",
                                 srv.url, "--quiet"], env)
                    err = None if p.returncode == 0 else (p.stderr or p.stdout).strip()[-300:]
                if err:
                    errs.append(f"{side}: {err}")
                    continue
                flags = len(list(c.rglob(".*_complete_extract")))
                counts[side] = flags
                rates[side].append(flags / s)
    finally:
        srv.close()
    fmt = "   {:<52} {:>12} {:>12} {:>9}"
    lines.append(fmt.format("", "mlspaces", "original", "ratio"))
    mr, orr = med(rates["mlspaces"]), med(rates["original"])
    lines.append(fmt.format(f"archives/s, median of {args.install_reps} runs", f"{mr:.0f}",
                            f"{orr:.0f}", f"{mr / orr:.1f}x" if orr == orr and mr == mr else "-"))
    lines.append(f"   archives extracted per run: mlspaces {counts.get('mlspaces', '-')}, "
                 f"original {counts.get('original', '-')}; whole process timed on both sides "
                 f"(mlspaces `install --library objaverse`, -j 4, zstd frame checksums, SHA-256 "
                 f"of every file; the original: setup + install_packages, up to 10 threads)")
    for e in errs[:2]:
        lines.append(f"   FAILED {e}")


def search_bench(args, lines: list[str]) -> None:
    script = ROOT / "bench" / "clip_search_bench.sh"
    if not script.exists():
        lines.append("3. CLIP search: bench/clip_search_bench.sh is not there (skipped)")
        return
    # Its bench binary is built in (or taken from) the build dir of our CLI, not the lead's.
    build = Path(args.cli).resolve().parents[2]
    p = subprocess.run([str(script), *args.search_args.split()], capture_output=True, text=True,
                       env={**os.environ, "MLSPACES_CLI_PATH": args.cli,
                            "MLSPACES_BUILD_DIR": str(build)}, timeout=3600)
    lines.append(f"3. CLIP search (bench/clip_search_bench.sh {args.search_args}".rstrip()
                 + f", exit {p.returncode}):")
    lines += ["   " + x for x in p.stdout.rstrip().splitlines()]
    if p.returncode != 0:
        lines += ["   " + x for x in p.stderr.rstrip().splitlines()[-10:]]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--worker", choices=sorted(WORKERS))
    for k in ("source-dir", "lmdb", "first-uid", "uids", "url", "assets", "cache", "versions"):
        ap.add_argument(f"--{k}")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--per-round", type=int, default=200)
    ap.add_argument("--annotations", type=int, default=20000)
    ap.add_argument("--archives", type=int, default=300)
    ap.add_argument("--mesh-kb", type=int, default=128, help="padding per Objaverse mesh")
    ap.add_argument("--first-reps", type=int, default=5)
    ap.add_argument("--install-reps", type=int, default=3)
    ap.add_argument("--original-python")
    ap.add_argument("--mlspaces-python", default=sys.executable)
    ap.add_argument("--mlspaces-pythonpath", default="")
    ap.add_argument("--cli")
    ap.add_argument("--search-args", default="")
    ap.add_argument("--skip", default="", help="comma list of annotation,install,search")
    ap.add_argument("--work", type=Path)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(WORKERS[args.worker](args)))
        return 0
    skip = set(filter(None, args.skip.split(",")))
    rev = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"],
                         capture_output=True, text=True).stdout.strip()
    now = time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime())
    lines = [f"mlspaces built-in data bench, {now} UTC",
             f"  machine: {platform.machine()}, {os.cpu_count()} CPUs, {platform.platform()}, "
             f"load average at start {os.getloadavg()[0]:.1f}",
             f"  mlspaces: {args.cli} (git {rev}); original: molmospaces-resources 0.0.2 in "
             f"{Path(args.original_python).parents[1]}",
             "  timing: medians; 'first' = first call in a fresh process (files in the page "
             "cache), 'warm' = per-call mean of each round, median over rounds; "
             "ratio = original / mlspaces", ""]
    work = fresh(args.work)
    for name, fn in (("annotation", lambda: annotation_bench(args, work, lines)),
                     ("install", lambda: install_bench(args, work, lines)),
                     ("search", lambda: search_bench(args, lines))):
        if name in skip:
            continue
        start = len(lines)
        fn()
        lines.append("")
        print("\n".join(lines[start:]), flush=True)  # progress: each part as it finishes
    text = "\n".join(lines) + "\n"
    print(f"written to {args.out}" if args.out else text)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.out.with_name(args.out.name + ".tmp")
        tmp.write_text(text)
        os.replace(tmp, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
