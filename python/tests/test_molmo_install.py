"""install_uid / install_scene_with_objects_and_grasps_from_path / find_object_paths against a
MolmoSpaces-format remote written by tests/fixtures/make_molmo_remote.py, over file://."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SOURCE_DIR = Path(os.environ.get("MLSPACES_SOURCE_DIR", Path(__file__).resolve().parents[2]))


@pytest.fixture(scope="module")
def remote(tmp_path_factory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("molmo_remote") / "out"
    subprocess.run([sys.executable, str(SOURCE_DIR / "tests" / "fixtures" / "make_molmo_remote.py"),
                    str(out)], check=True)
    return out, json.loads((out / "fixture.json").read_text())


@pytest.fixture
def env(remote, tmp_path, monkeypatch):
    out, fx = remote
    monkeypatch.setenv("MLSPACES_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("MLSPACES_ASSETS_DIR", str(tmp_path / "assets"))
    monkeypatch.setenv("MLSPACES_PINNED_ASSETS_FILE", str(out / fx["pins_file"]))
    monkeypatch.setenv("MLSPACES_REMOTE_URL", (out / fx["remote_dir"]).as_uri())
    return tmp_path, fx


def test_install_uid_brings_the_object_and_its_grasps(env):
    from mlspaces import _core

    tmp, fx = env
    uid = fx["scenes"]["ithor"]["FloorPlan1"]["objaverse_uids"][0]
    path = Path(_core.install_uid(uid, "droid_objaverse"))
    assert path == tmp / "assets" / "objects" / "objaverse" / fx["objects"]["objaverse"][uid]["mjcf"]
    assert path.is_file()
    grasp = fx["grasps"]["droid_objaverse"][uid]["pickup"]["path"]
    assert (tmp / "assets" / "grasps" / "droid_objaverse" / grasp).is_file()
    with pytest.raises(ValueError, match="not_a_uid_z not found in object sources"):
        _core.install_uid("not_a_uid_z", "droid_objaverse")


def test_install_scene_with_objects_and_grasps_from_path(env):
    from mlspaces.utils.lazy_loading_utils import (
        find_object_paths, install_scene_with_objects_and_grasps_from_path)

    tmp, fx = env
    scene = fx["scenes"]["ithor"]["FloorPlan1"]
    got = install_scene_with_objects_and_grasps_from_path({"base": "ithor/" + scene["xml"]})
    # The original's return: {type: {source: [archives]}}, THOR excluded.
    assert got["scenes"] == {"ithor": [scene["archive"]]}
    assert {k: sorted(v) for k, v in got["objects"].items()} == {
        "objaverse": sorted(scene["object_archives"]["objaverse"])}
    assert {k: sorted(v) for k, v in got["grasps"].items()} == {
        k: sorted(v) for k, v in scene["grasp_archives"].items()}
    xml = tmp / "assets" / "scenes" / "ithor" / scene["xml"]
    assert xml.is_file()
    for ref in scene["references"]:
        assert (tmp / "assets" / "objects" / ref["source"] / ref["path"]).is_file()
    found = sorted(find_object_paths(xml))
    want = sorted((r["source"], r["path"]) for r in scene["references"] if r["source"] != "thor")
    assert found == want
    for archive in scene["grasp_archives"]["droid_objaverse"]:
        flag = (tmp / "cache" / "grasps" / "droid_objaverse" /
                fx["versions"]["grasps"]["droid_objaverse"] / f".{archive}_complete_extract")
        assert flag.is_file()


def _flag(tmp, fx, data_type, source, archive):
    return (tmp / "cache" / data_type / source / fx["versions"][data_type][source] /
            f".{archive}_complete_extract")


def test_install_objects_and_grasps_for_scene_return_what_the_original_does(env):
    from mlspaces import _core
    from mlspaces.utils.lazy_loading_utils import install_grasps_for_scene, install_objects_for_scene

    tmp, fx = env
    scene = fx["scenes"]["ithor"]["FloorPlan2"]
    # Any install sets every pinned source up; the small scene source is installed whole.
    _core.install_uid(fx["scenes"]["ithor"]["FloorPlan1"]["objaverse_uids"][0], "droid_objaverse")
    xml = tmp / "assets" / "scenes" / "ithor" / scene["xml"]
    assert xml.is_file()
    objaverse = sorted(scene["object_archives"]["objaverse"])
    assert not all(_flag(tmp, fx, "objects", "objaverse", a).is_file() for a in objaverse)
    got = install_objects_for_scene(xml)
    assert {k: sorted(v) for k, v in got.items()} == {"objaverse": objaverse}
    assert all(_flag(tmp, fx, "objects", "objaverse", a).is_file() for a in objaverse)
    # With THOR: its archives are named too (installed EAGER already).
    with_thor = install_objects_for_scene(xml, exclude_thor=False)
    assert sorted(with_thor["thor"]) == sorted(scene["object_archives"]["thor"])
    grasps = install_grasps_for_scene(xml, grasp_source="droid_objaverse")
    assert {k: sorted(v) for k, v in grasps.items()} == {
        "droid_objaverse": sorted(scene["grasp_archives"]["droid_objaverse"])}
    for a in scene["grasp_archives"]["droid_objaverse"]:
        assert _flag(tmp, fx, "grasps", "droid_objaverse", a).is_file()
    assert install_grasps_for_scene(xml, "droid") == {}  # THOR-only, THOR excluded
    assert install_grasps_for_scene(xml, "no_such_grasps") == {}  # not configured
    with pytest.raises(Exception, match="not a scene file under"):
        install_objects_for_scene(tmp / "elsewhere.xml")


def _dead_url() -> str:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    return f"http://127.0.0.1:{port}/remote"


def test_a_complete_cache_installs_offline(env, monkeypatch):
    from mlspaces import _core
    from mlspaces.utils.lazy_loading_utils import install_scene_with_objects_and_grasps_from_path

    def install_uid(uid):  # the process-default registry is bound to another test's dirs
        return _core.install_uid(uid, "droid_objaverse")

    tmp, fx = env
    uid = fx["scenes"]["ithor"]["FloorPlan1"]["objaverse_uids"][1]
    path = install_uid(uid)
    online = install_scene_with_objects_and_grasps_from_path(1)
    # Nothing listens there: a complete cache must not need it.
    monkeypatch.setenv("MLSPACES_REMOTE_URL", _dead_url())
    assert install_uid(uid) == path
    assert install_scene_with_objects_and_grasps_from_path(1) == online
    # Something missing does reach for the remote, and says where.
    other = next(u for u, info in fx["objects"]["objaverse"].items()
                 if not _flag(tmp, fx, "objects", "objaverse", info["archive"]).is_file())
    with pytest.raises(Exception, match="127.0.0.1"):
        install_uid(other)


def test_user_library_index_readers(tmp_path):
    from mlspaces.utils.lazy_loading_utils import (UserAssetLibraryIndexEntry,
                                                   get_user_grasp_library_index,
                                                   get_user_library_index)

    lib = SOURCE_DIR / "examples" / "custom_assets" / "asset_library"
    want = json.loads((lib / "assets_index.json").read_text())
    got = get_user_library_index(lib)
    assert set(got) == set(want)
    for uid, entry in want.items():
        assert got[uid] == UserAssetLibraryIndexEntry(
            entry["uid"], Path(entry["object_path"]), Path(entry["metadata_path"]),
            None if entry["metadata_npz_path"] is None else Path(entry["metadata_npz_path"]))
    grasps = json.loads((lib / "grasps_index.json").read_text())
    index = get_user_grasp_library_index(lib)
    assert index.grasp_paths == {r: {u: Path(p) for u, p in m.items()}
                                 for r, m in grasps["grasp_paths"].items()}
    (tmp_path / "assets_index.json").write_text('{"x": {"uid": "x", "object_path": 3}}')
    with pytest.raises(ValueError, match="x/object_path"):
        get_user_library_index(tmp_path)
