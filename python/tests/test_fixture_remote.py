"""The MolmoSpaces-format test remote (tests/fixtures/make_molmo_remote.py) is self-consistent:
manifests match the archives, tries list exactly the archives' files, every archive is a
checksummed zstd frame of a tar stream, the pickles and the LMDB load back as the original
reads them, the MJCFs and scenes compile in MuJoCo from an install-shaped tree, and the damaged
variants fail the way fixture.json says. Other tests read fixture.json for their expectations,
so this test guards what they rely on."""

from __future__ import annotations

import gzip
import hashlib
import io
import json
import os
import pickle
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import numpy as np
import pytest

SOURCE_DIR = Path(os.environ.get("MLSPACES_SOURCE_DIR", Path(__file__).resolve().parents[2]))
GENERATOR = SOURCE_DIR / "tests" / "fixtures" / "make_molmo_remote.py"
MANIFEST = "mjthor_resource_file_to_size_mb.json"
TRIES = "mjthor_resources_combined_meta.json.gz"

zstandard = pytest.importorskip("zstandard")


def generate(out: Path, *extra: str) -> dict:
    subprocess.run([sys.executable, str(GENERATOR), str(out), *extra], check=True)
    return json.loads((out / "fixture.json").read_text())


@pytest.fixture(scope="module")
def fx(tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("molmo_remote")
    return out, generate(out, "--corrupt", "--objaverse", "7", "--assets-lmdb",
                         str(out / "objathor_lmdb"))


def leaves(trie: dict, prefix: str = "") -> list[str]:
    out = []
    for key, child in trie.items():
        path = f"{prefix}/{key}" if prefix else key
        out.extend(leaves(child, path) if child else [path])
    return out


def single_chains(trie: dict) -> list[str]:
    """Keys whose child is a single non-empty node (what compaction must have merged)."""
    bad = []
    for key, child in trie.items():
        if len(child) == 1 and next(iter(child.values())):
            bad.append(key)
        bad.extend(single_chains(child))
    return bad


def read_archive(path: Path) -> dict[str, bytes]:
    data = path.read_bytes()
    params = zstandard.get_frame_parameters(data)
    assert params.has_checksum, path
    with zstandard.ZstdDecompressor().stream_reader(io.BytesIO(data)) as reader:
        raw = reader.read()
    files = {}
    with tarfile.open(fileobj=io.BytesIO(raw), mode="r:") as tar:
        for m in tar.getmembers():
            assert not m.name.startswith(("/", "..")), m.name
            assert m.isdir() or m.isfile(), m.name
            if m.isfile():
                files[m.name] = tar.extractfile(m).read()
    return files


def test_every_source_is_consistent(fx):
    out, f = fx
    assert json.loads((out / f["pins_file"]).read_text()) == f["versions"]
    for dtype, sources in f["sources"].items():
        for source, info in sources.items():
            d = out / info["dir"]
            assert d == out / "remote" / dtype / source / f["versions"][dtype][source]
            manifest = json.loads((d / MANIFEST).read_text())
            with gzip.open(d / TRIES, "rb") as g:
                tries = json.load(g)
            on_disk = sorted(p.name for p in d.glob("*.tar.zst"))
            assert sorted(manifest) == sorted(tries) == on_disk == sorted(info["archives"])
            assert on_disk, (dtype, source)
            for arc in on_disk:
                assert arc.startswith(source + "_"), arc
                size = (d / arc).stat().st_size
                assert size == info["archives"][arc]["bytes"]
                assert abs(manifest[arc] * f["size_mb_unit"] - size) <= 1.0
                assert hashlib.sha256((d / arc).read_bytes()).hexdigest() == \
                    info["archives"][arc]["sha256"]
                files = read_archive(d / arc)
                assert sorted(files) == sorted(leaves(tries[arc])) == \
                    info["archives"][arc]["files"]
                for name, data in files.items():
                    assert hashlib.sha256(data).hexdigest() == \
                        info["archives"][arc]["file_sha256"][name]
                if info["tries_compacted"]:
                    assert single_chains(tries[arc]) == []
                else:
                    assert all("/" not in k for k in tries[arc])


def test_behaviours_follow_the_original(fx):
    _, f = fx
    s = f["sources"]
    assert (s["objects"]["thor"]["install"], s["objects"]["objaverse"]["install"]) == \
        ("eager", "on_demand")
    assert s["objects"]["objathor_metadata"]["install"] == "eager"
    assert s["grasps"]["droid"]["install"] == "eager"
    assert s["scenes"]["ithor"]["link"] == "per_file"
    assert s["scenes"]["ithor"]["index"] == "numeric"
    assert s["robots"]["franka_droid"]["link"] == "per_file"
    assert f["versions"]["objects"] == {"thor": "20251117", "objaverse": "20260131",
                                        "objathor_metadata": "20260129"}
    assert f["versions"]["grasps"] == {"droid": "20251116", "droid_objaverse": "20251218"}


def test_objaverse_has_one_archive_per_uid_named_by_token(fx):
    _, f = fx
    uids = f["objects"]["objaverse"]
    assert len(uids) == 7
    for uid, info in uids.items():
        assert len(uid) == 32 and int(uid, 16) >= 0
        assert info["archive"] == f"objaverse_{uid}.tar.zst"
        assert info["mjcf"].endswith(f"{uid}.xml")
    graspless = [u for u in uids if u not in f["grasps"]["droid_objaverse"]]
    assert len(graspless) == 1
    for uid, g in f["grasps"]["droid_objaverse"].items():
        assert g["archive"] == f"droid_objaverse_{uid}.tar.zst"


def test_annotations_clip_features_and_licences(fx):
    out, f = fx
    meta = f["objathor_metadata"]
    d = out / f["sources"]["objects"]["objathor_metadata"]["dir"]
    files = read_archive(d / "objathor_metadata_all.tar.zst")
    annotations = json.loads(gzip.decompress(files["objects_metadata.json.gz"]))
    assert list(annotations) == meta["uids"]
    assert set(annotations) == set(f["objects"]["thor"]) | set(f["objects"]["objaverse"])
    blob = files["clip_features.pkl"]
    assert blob[:2] == b"\x80\x04"  # protocol 4
    assert b"numpy.core.multiarray" in blob and b"numpy._core" not in blob  # numpy 1.x names
    assert meta["clip_pickle"]["numpy_module"] == "numpy.core.multiarray"
    clip = pickle.loads(blob)
    assert clip["uids"] == meta["clip_uids"] and sorted(clip["uids"]) == sorted(annotations)
    assert clip["uids"] != list(annotations)  # consumers must map by UID, not by position
    assert clip["img_features"].shape == (len(annotations), 3, 768)
    assert clip["text_features"].shape == (len(annotations), 768)
    assert clip["img_features"].dtype == clip["text_features"].dtype == np.float16
    assert np.isfinite(clip["img_features"]).all()
    allowed = {"by", "by-sa", "cc0", "by-nc", "by-nc-sa"}
    nc = []
    for uid, a in annotations.items():
        for key in ("assetId", "category", "description", "description_long", "synset",
                    "primaryProperty", "boundingBox", "receptacle", "split", "isObjaverse"):
            assert key in a, (uid, key)
        assert list(a["description_short"]) == ["one_word", "two_words", "three_words",
                                                "five_words"]
        assert a["isObjaverse"] == (uid not in f["objects"]["thor"])
        if a["isObjaverse"]:
            li = a["license_info"]
            assert li["license"] in allowed and "sketchfab" in li["creator_profile_url"]
            if li["license"] in ("by-nc", "by-nc-sa"):
                nc.append(uid)
    assert sorted(nc) == meta["non_commercial"] and len(nc) >= 2
    assert any(a["split"] is None for a in annotations.values())


def test_lmdb_is_written_as_the_original_reads_it(fx):
    lmdb = pytest.importorskip("lmdb")
    out, f = fx
    meta = f["objathor_metadata"]
    env = lmdb.open(f["objathor_lmdb"], readonly=True, lock=False, max_readers=2048)
    with env.begin() as txn:
        assert txn.stat()["entries"] - 1 == meta["count"]
        done = txn.get(meta["lmdb_complete_key"].encode())
        assert pickle.loads(zstandard.decompress(done)) == meta["lmdb_complete_key"]
        d = out / f["sources"]["objects"]["objathor_metadata"]["dir"]
        clip = pickle.loads(read_archive(d / "objathor_metadata_all.tar.zst")["clip_features.pkl"])
        for row, uid in enumerate(clip["uids"]):
            value = pickle.loads(zstandard.decompress(txn.get(uid.encode())))
            assert value["assetId"] == uid
            assert value["clip_img_features"].shape == (3, 768)
            np.testing.assert_array_equal(value["clip_img_features"], clip["img_features"][row])
            np.testing.assert_array_equal(value["clip_text_features"], clip["text_features"][row])
    env.close()


def test_grasp_files_are_numpy_npz(fx):
    out, f = fx
    for source in ("droid", "droid_objaverse"):
        d = out / f["sources"]["grasps"][source]["dir"]
        for uid, g in f["grasps"][source].items():
            files = read_archive(d / g["archive"])
            entries = ([g["pickup"]] if g["pickup"] else []) + list(g["joints"].values())
            assert entries, uid
            for e in entries:
                blob = files[e["path"]]
                with zipfile.ZipFile(io.BytesIO(blob)) as z:
                    assert [i.compress_type for i in z.infolist()] == [zipfile.ZIP_DEFLATED]
                t = np.load(io.BytesIO(blob))["transforms"]
                assert t.shape == (e["count"], 4, 4) and t.dtype == np.float16
                np.testing.assert_array_equal(t[:, 3], np.tile([0, 0, 0, 1], (e["count"], 1)))
    fridge = f["grasps"]["droid"]["Fridge_1"]
    assert sorted(fridge["joints"]) == f["objects"]["thor"]["Fridge_1"]["joints"] == \
        ["door_hinge", "drawer_slide"]


def extract_install_tree(out: Path, f: dict) -> Path:
    """Everything extracted into an <assets>-shaped tree (GLOBAL sources as real dirs)."""
    assets = out / "assets_tree"
    for dtype, sources in f["sources"].items():
        for source, info in sources.items():
            for arc in info["archives"]:
                for name, data in read_archive(out / info["dir"] / arc).items():
                    p = assets / dtype / source / name
                    p.parent.mkdir(parents=True, exist_ok=True)
                    p.write_bytes(data)
    return assets


def test_mjcfs_and_scenes_compile_from_an_install_tree(fx):
    mujoco = pytest.importorskip("mujoco")
    out, f = fx
    assets = extract_install_tree(out, f)
    for source in ("thor", "objaverse"):
        for uid, info in f["objects"][source].items():
            m = mujoco.MjModel.from_xml_path(str(assets / "objects" / source / info["mjcf"]))
            names = {m.joint(i).name for i in range(m.njnt)}
            assert names == set(info["joints"]), uid
    robot = f["robots"]["franka_droid"]
    m = mujoco.MjModel.from_xml_path(str(assets / "robots" / "franka_droid" / robot["mjcf"]))
    assert m.nu == 2
    for name, scene in f["scenes"]["ithor"].items():
        xml = assets / "scenes" / "ithor" / scene["xml"]
        m = mujoco.MjModel.from_xml_path(str(xml))
        meta = json.loads((xml.parent / scene["metadata"]).read_text())
        for body, entry in meta["objects"].items():
            assert m.body(body).name == body and entry["asset_id"] == scene["bodies"][body]
            for sj in entry["name_map"]["joints"]:
                assert m.joint(sj).name == sj
        for ref in scene["references"]:
            assert ref["path"] in f["sources"]["objects"][ref["source"]]["archives"][
                f["objects"][ref["source"]][next(
                    u for u, i in f["objects"][ref["source"]].items()
                    if ref["path"] in i["files"])]["archive"]]["files"]
        assert name in scene["archive"] and scene["object_archives"]["objaverse"]
        assert f["scenes"]["ithor"][name]["joints"] or name != "FloorPlan1"


def test_output_is_deterministic(fx, tmp_path):
    out, _ = fx
    again = tmp_path / "again"
    generate(again, "--corrupt", "--objaverse", "7")
    for p in sorted((out / "remote").rglob("*")):
        if p.is_file():
            q = again / p.relative_to(out)
            assert q.read_bytes() == p.read_bytes(), p


def test_corrupt_variants_fail_as_described(fx):
    out, f = fx
    whats = {c["what"]: c for c in f["corrupt"]["cases"]}
    assert set(whats) == {"zstd_checksum", "tar_header_checksum", "truncated_zstd",
                          "path_traversal", "symlink_outside", "html_manifest",
                          "truncated_tries_gzip", "tries_not_a_dict"}
    with pytest.raises(zstandard.ZstdError, match="checksum"):
        read_archive(out / whats["zstd_checksum"]["file"])
    with pytest.raises(tarfile.ReadError):
        read_archive(out / whats["tar_header_checksum"]["file"])
    truncated = (out / whats["truncated_zstd"]["file"]).read_bytes()
    with pytest.raises(zstandard.ZstdError):
        zstandard.ZstdDecompressor().decompress(truncated)
    with pytest.raises(AssertionError):
        read_archive(out / whats["path_traversal"]["file"])
    with pytest.raises(AssertionError):
        read_archive(out / whats["symlink_outside"]["file"])
    with pytest.raises(json.JSONDecodeError):
        json.loads((out / whats["html_manifest"]["file"]).read_text())
    with pytest.raises(EOFError):
        gzip.decompress((out / whats["truncated_tries_gzip"]["file"]).read_bytes())
    bad = json.loads(gzip.decompress((out / whats["tries_not_a_dict"]["file"]).read_bytes()))
    assert not all(isinstance(v, dict) for v in bad.values())


def test_clip_features_group_by_category(fx):
    """The synthetic features are category centres plus noise, so a "more like this" query
    with the original's score (best image view + 0.5 x text) finds a UID of the same category."""
    out, f = fx
    d = out / f["sources"]["objects"]["objathor_metadata"]["dir"]
    files = read_archive(d / "objathor_metadata_all.tar.zst")
    annotations = json.loads(gzip.decompress(files["objects_metadata.json.gz"]))
    clip = pickle.loads(files["clip_features.pkl"])
    img = clip["img_features"].astype(np.float32)
    img /= np.linalg.norm(img, axis=2, keepdims=True)
    txt = clip["text_features"].astype(np.float32)
    txt /= np.linalg.norm(txt, axis=1, keepdims=True)
    cats = [annotations[u]["category"] for u in clip["uids"]]
    for i, cat in enumerate(cats):
        if cats.count(cat) < 2:
            continue
        q = txt[i]
        score = (img @ q).max(axis=1) + 0.5 * (txt @ q)
        score[i] = -np.inf
        assert cats[int(np.argmax(score))] == cat, clip["uids"][i]
