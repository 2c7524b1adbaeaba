"""Interop of mlspaces with the original molmospaces-resources 0.0.2 on one MolmoSpaces-format
remote (tests/fixtures/make_molmo_remote.py, served over HTTP on 127.0.0.1). Run by
bench/molmo_remote_interop.sh with the bench venv's interpreter (the original importable).

  (a) the original's ResourceManager installs into cache A + assets A (setup, a scene with its
      objects and grasps as molmo_spaces' install_scene_with_objects_and_grasps_from_path does,
      one more Objaverse UID as install_uid does); mlspaces then reads that tree: index-builtin,
      locate, grasps (pickup and joint), meta, and inspect compiles the scene.
  (b) mlspaces installs into cache B + assets B (`install --scene`, `install UID`); the
      original's manager, opened on B with a dead remote, finds everything installed (no
      download), and its tries / find_archives / index_lookup answer as on a tree it made.

Prints one PASS/FAIL line per check and exits 1 if any failed.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

FAILS: list[str] = []


def check(name: str, ok: bool, detail: str = "") -> bool:
    print(("PASS " if ok else "FAIL ") + name + ("" if ok or not detail else f": {detail}"),
          flush=True)
    if not ok:
        FAILS.append(name)
    return ok


def run_cli(cli: str, *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([cli, *args], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, timeout=600)


def npz_rows(path: Path) -> int:
    """Rows of transforms.npy (or the first member) in an NPZ, from its .npy header."""
    with zipfile.ZipFile(path) as z:
        name = "transforms.npy" if "transforms.npy" in z.namelist() else z.namelist()[0]
        head = z.open(name).read(512)
    m = re.search(rb"'shape': \((\d+),", head)
    return int(m.group(1)) if m else -1


# ---- the original's side ----------------------------------------------------------------------


def original_manager(remote_url: str, assets: Path, cache: Path, versions: dict):
    from molmospaces_resources import R2RemoteStorage
    from molmospaces_resources.setup_utils import setup_resource_manager

    return setup_resource_manager(R2RemoteStorage(remote_url), assets, versions, cache)


def original_install_uid(rm, uid: str, source: str = "objaverse") -> None:
    """As molmo_spaces' install_uid: the UID's archive, then grasp archives by MJCF-stem token."""
    archives = rm.index_lookup("objects", source, uid)
    rm.install_packages("objects", {source: sorted(archives)})
    grasp = set()
    for tok in re.split(r"[./_\s]+", uid):
        if tok:
            grasp |= rm.index_lookup("grasps", "droid_objaverse", tok)
    if grasp:
        rm.install_packages("grasps", {"droid_objaverse": sorted(grasp)})


def original_install_scene(rm, source: str, xml_rel: str) -> None:
    """As molmo_spaces' install_scene_with_objects_and_grasps_from_path: the scene archive, then
    the objects its ../ mesh references need (THOR excluded) and their grasps by basename token."""
    rm.install_packages("scenes", {source: rm.find_archives("scenes", source, [xml_rel])})
    xml = rm.symlink_dir / "scenes" / source / xml_rel
    objects: dict[str, set] = {}
    grasps: set = set()
    for kind in ("mesh", "texture", "material", "hfield", "skin"):
        for el in ET.parse(xml).getroot().findall(f".//asset/{kind}"):
            f = el.attrib.get("file", "")
            if not f.startswith("../") or "/objects/thor/" in f:
                continue
            full = (xml.parent / f).resolve()
            src = full.relative_to(Path(rm.cache_dir).resolve() / "objects").parts[0]
            rel = full.relative_to(Path(rm.source_dir("objects", src)).resolve())
            objects.setdefault(src, set()).update(rm.find_archives("objects", src, [rel]))
            for tok in re.split(r"[./_\s]+", rel.name):
                if tok:
                    grasps |= rm.index_lookup("grasps", "droid_objaverse", tok)
    rm.install_packages("objects", {s: sorted(a) for s, a in objects.items()})
    if grasps:
        rm.install_packages("grasps", {"droid_objaverse": sorted(grasps)})


# ---- (a) the original installs, mlspaces reads ------------------------------------------------


def side_a(fx: dict, fxdir: Path, url: str, work: Path, cli: str) -> None:
    assets, cache = work / "a_assets", work / "a_cache"
    rm = original_manager(url, assets, cache, fx["versions"])
    scene = fx["scenes"]["ithor"]["FloorPlan1"]
    original_install_scene(rm, "ithor", scene["xml"])
    obja = list(fx["objects"]["objaverse"])
    extra = obja[-1]  # the UID without grasps: install_uid installs no grasp archive
    original_install_uid(rm, extra)
    installed = set(scene["objaverse_uids"]) | {extra}
    check("a: original installed the scene, its objects and grasps",
          (assets / "scenes/ithor" / scene["xml"]).is_file()
          and all((assets / "objects/objaverse" / fx["objects"]["objaverse"][u]["mjcf"]).is_file()
                  for u in installed))
    # molmo_spaces' ObjectMeta builds <assets>/.lmdb/objathor_metadata/<version>/ from the
    # installed source files; do the same (the generator's writer is the original's format).
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "fixtures"))
    import gzip
    import pickle

    import make_molmo_remote as gen

    meta_dir = assets / "objects" / "objathor_metadata"
    with gzip.open(meta_dir / "objects_metadata.json.gz", "rb") as f:
        annotations = json.load(f)
    with open(meta_dir / "clip_features.pkl", "rb") as f:
        clip = pickle.load(f)
    version = fx["versions"]["objects"]["objathor_metadata"]
    gen.write_pickle_lmdb(assets / ".lmdb" / "objathor_metadata" / version,
                          gen.objathor_lmdb_values(annotations, clip))
    env = {"MLSPACES_ASSETS_DIR": str(assets), "MLSPACES_CACHE_DIR": str(cache)}
    r = run_cli(cli, "index-builtin", "--assets-dir", str(assets))
    check("a: mlspaces index-builtin on the original's tree", r.returncode == 0, r.stderr.strip())
    for source in ("thor", "objaverse"):
        for uid, info in fx["objects"][source].items():
            r = run_cli(cli, "locate", "--json", uid, env=env)
            ok = r.returncode == 0
            if ok:
                j = json.loads(r.stdout)
                want = assets / "objects" / source / info["mjcf"]
                inst = source == "thor" or uid in installed
                ok = (j["library"] == source and Path(j["mjcf_path"]) == want
                      and j.get("archive") == info["archive"] and j.get("installed") == inst)
            check(f"a: locate {source} {uid[:12]}", ok, (r.stdout + r.stderr).strip()[:300])
    for source in ("droid", "droid_objaverse"):
        for uid, g in fx["grasps"][source].items():
            if source == "droid_objaverse" and uid not in installed:
                continue
            entries = ([(None, g["pickup"])] if g["pickup"] else []) + list(g["joints"].items())
            for joint, e in entries:
                out = work / f"a_{uid}_{joint}.npz"
                args = ["grasps", uid, "--out", str(out)] + (["--joint", joint] if joint else [])
                r = run_cli(cli, *args, env=env)
                ok = r.returncode == 0 and npz_rows(out) == e["count"]
                check(f"a: grasps {uid[:12]}{'/' + joint if joint else ''} = {e['count']}", ok,
                      (r.stderr or r.stdout).strip()[:300])
    for uid in ["Bowl_1", *sorted(installed)]:
        r = run_cli(cli, "meta", uid, env=env)
        ok = r.returncode == 0
        detail = r.stderr.strip()[:300]
        if ok:
            try:
                ok = json.loads(r.stdout).get("assetId") == uid
            except json.JSONDecodeError as e:
                ok, detail = False, str(e)
        check(f"a: meta {uid[:12]} (objathor annotation)", ok, detail)
    r = run_cli(cli, "inspect", str(assets / "scenes/ithor" / scene["xml"]), env=env)
    check("a: mlspaces inspect compiles the original's installed scene", r.returncode == 0,
          r.stderr.strip()[:300])


# ---- (b) mlspaces installs, the original reads -------------------------------------------------


def side_b(fx: dict, fxdir: Path, url: str, work: Path, cli: str) -> None:
    assets, cache = work / "b_assets", work / "b_cache"
    env = {"MLSPACES_ASSETS_DIR": str(assets), "MLSPACES_CACHE_DIR": str(cache),
           "MLSPACES_PINNED_ASSETS_FILE": str(fxdir / fx["pins_file"])}
    scene = fx["scenes"]["ithor"]["FloorPlan1"]
    obja = list(fx["objects"]["objaverse"])
    extra = obja[-1]  # the UID without grasps: install_uid installs no grasp archive
    r = run_cli(cli, "install", "--remote", url, "--quiet", "--scene",
                f"ithor/{scene['xml']}", env=env)
    if not check("b: mlspaces install --scene (scene, objects, grasps)", r.returncode == 0,
                 (r.stderr or r.stdout).strip()[-400:]):
        return
    r = run_cli(cli, "install", "--remote", url, "--quiet", extra, env=env)
    check("b: mlspaces install UID", r.returncode == 0, (r.stderr or r.stdout).strip()[-400:])
    scene2 = fx["scenes"]["ithor"]["FloorPlan2"]
    r = run_cli(cli, "install", "--remote", url, "--quiet", "--scene", str(scene2["index"]),
                env=env)
    check("b: mlspaces install --scene N (by number)", r.returncode == 0,
          (r.stderr or r.stdout).strip()[-400:])
    installed = set(scene["objaverse_uids"]) | set(scene2["objaverse_uids"]) | {extra}

    from molmospaces_resources.setup_utils import _get_current_install, _needs_install

    current = _get_current_install(assets, fx["versions"])
    check("b: original sees every pinned source installed (no setup)",
          not _needs_install(current, fx["versions"]), json.dumps(current))
    try:
        rm = original_manager("http://127.0.0.1:9", assets, cache, fx["versions"])
    except Exception as e:  # noqa: BLE001 - report any failure of the original as a FAIL line
        check("b: original manager opens mlspaces' tree with a dead remote", False, repr(e))
        return
    check("b: original manager opens mlspaces' tree with a dead remote", True)
    for dtype, sources in fx["sources"].items():
        for source, info in sources.items():
            try:
                names = sorted(rm.tries(dtype, source).keys())
            except Exception as e:  # noqa: BLE001
                names = [repr(e)]
            check(f"b: tries {dtype}/{source}", names == sorted(info["archives"]), str(names)[:200])
    try:
        for source in ("thor", "objaverse"):
            for uid, info in fx["objects"][source].items():
                got = rm.find_archives("objects", source, [info["mjcf"]])
                check(f"b: find_archives {source} {uid[:12]}", got == [info["archive"]], str(got))
        for uid in sorted(installed):
            a = fx["objects"]["objaverse"][uid]["archive"]
            check(f"b: index_lookup objaverse {uid[:12]}",
                  rm.index_lookup("objects", "objaverse", uid) == {a})
        check("b: index_lookup scenes 1", rm.index_lookup("scenes", "ithor", "1") == {
            scene["archive"]})
        # Everything mlspaces installed counts as installed: a dead remote is never asked.
        rm.install_packages("objects", {"objaverse": sorted(
            fx["objects"]["objaverse"][u]["archive"] for u in installed)})
        rm.install_packages("grasps", {"droid_objaverse": sorted(
            fx["grasps"]["droid_objaverse"][u]["archive"] for u in installed
            if u in fx["grasps"]["droid_objaverse"])})
        rm.install_packages("scenes", {"ithor": [scene["archive"], scene2["archive"]]})
        check("b: original install_packages needs no download on mlspaces' tree", True)
    except Exception as e:  # noqa: BLE001
        check("b: original lookups on mlspaces' tree", False, repr(e)[:400])
    for uid in sorted(installed):
        p = assets / "objects/objaverse" / fx["objects"]["objaverse"][uid]["mjcf"]
        check(f"b: objects/objaverse/{uid[:12]} reachable through the install link", p.is_file())
        g = fx["grasps"]["droid_objaverse"].get(uid)
        if g:
            p = assets / "grasps/droid_objaverse" / g["pickup"]["path"]
            check(f"b: grasp file of {uid[:12]} ({g['pickup']['count']} rows)",
                  p.is_file() and npz_rows(p) == g["pickup"]["count"])
    for uid, g in fx["grasps"]["droid"].items():
        for joint, e in g["joints"].items():
            p = assets / "grasps/droid" / e["path"]
            check(f"b: droid joint grasps {uid}/{joint}", p.is_file() and npz_rows(p) == e["count"])
    robot = fx["robots"]["franka_droid"]
    rd = assets / "robots/franka_droid"
    check("b: robot linked per file (EAGER) with the original's flag",
          all((rd / f).is_symlink() for f in robot["files"])
          and (rd / f".{robot['archive']}_complete_links").exists())
    bench_src = next(iter(fx["benchmarks"]))
    bench_dir = assets / "benchmarks" / bench_src
    check("b: benchmarks linked GLOBAL into the cache version dir",
          bench_dir.is_symlink() and (bench_dir / fx["benchmarks"][bench_src]["files"][0]).is_file())
    r = run_cli(cli, "verify", "--remote", url, env=env)
    check("b: mlspaces verify (SHA-256 of every installed file)", r.returncode == 0,
          (r.stderr or r.stdout).strip()[-300:])
    sd = assets / "scenes/ithor"
    flag = sd / f".{scene['archive']}_complete_links"
    check("b: scene linked per file with the original's flag",
          (sd / scene["xml"]).is_symlink() and flag.exists())
    for sc in (scene, scene2):
        r = run_cli(cli, "inspect", str(sd / sc["xml"]), env=env)
        check(f"b: {sc['xml']} compiles from mlspaces' tree", r.returncode == 0,
              r.stderr.strip()[:300])


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--fixture", type=Path, required=True, help="the generator's OUT dir")
    ap.add_argument("--url", required=True, help="where OUT/remote is served")
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--cli", required=True)
    ap.add_argument("--side", choices=["a", "b", "both"], default="both")
    args = ap.parse_args()
    fx = json.loads((args.fixture / "fixture.json").read_text())
    if args.side in ("a", "both"):
        side_a(fx, args.fixture, args.url, args.work, args.cli)
    if args.side in ("b", "both"):
        side_b(fx, args.fixture, args.url, args.work, args.cli)
    print(f"{'FAIL' if FAILS else 'PASS'}: {len(FAILS)} failed check(s)"
          + (": " + ", ".join(FAILS) if FAILS else ""))
    return 1 if FAILS else 0


if __name__ == "__main__":
    sys.exit(main())
