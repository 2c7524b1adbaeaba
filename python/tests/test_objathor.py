"""ObjectMeta on the built-in objathor metadata: the original's LMDB (written here with
pickle, numpy, lmdb and zstandard) converted on first use, unioned with a user library in the
original's order, with its helpers; a hostile pickle raises instead of running."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import SOURCE_DIR, write_library


@pytest.fixture(scope="module")
def objathor(tmp_path_factory):
    out = tmp_path_factory.mktemp("objathor")
    subprocess.run([sys.executable, str(SOURCE_DIR / "tests/resources/testdata/make_objathor.py"),
                    str(out), str(SOURCE_DIR)], check=True)
    return out, json.loads((out / "expected.json").read_text())


def test_object_meta_on_the_builtin_store(objathor, tmp_path, monkeypatch):
    from mlspaces import _registry
    from mlspaces.utils.object_metadata import ObjectMeta

    out, expected = objathor
    index = out / "lmdb/cache/objects/objathor_metadata/20260129/.mlspaces/index"
    assert not index.exists()
    reg = _registry.Registry(out / "lmdb" / "assets")
    reg.register_user_asset_library("mine", write_library(tmp_path / "user",
                                                          {"obj_1000": 2, "user_only": 2}))
    monkeypatch.setattr(_registry, "_default", reg)

    first = ObjectMeta.annotation("0a1b2c3d4e")  # converts on first use
    assert (index / "metadata.mlsm").is_file() and (index / "clip_features.mlsc").is_file()
    want = expected["0a1b2c3d4e"]
    assert list(first) == list(want)  # the dict's order, then the two CLIP arrays
    assert first["clip_img_features"].dtype == np.float16
    assert first["clip_img_features"].shape == (3, 768)
    np.testing.assert_array_equal(first["clip_img_features"].astype(np.float64),
                                  np.array(want["clip_img_features"]))
    assert {k: v for k, v in first.items() if not k.startswith("clip_")} == {
        k: v for k, v in want.items() if not k.startswith("clip_")}

    # Arrays: read-only views of one buffer shared by every call (no copy); dicts: new per call.
    second = ObjectMeta.annotation("0a1b2c3d4e")
    assert second is not first and list(second) == list(first)
    for arr in (first["clip_img_features"], first["clip_text_features"]):
        assert not arr.flags.writeable
        with pytest.raises(ValueError):
            arr[0] = 1
    assert np.shares_memory(first["clip_img_features"], second["clip_img_features"])
    # The cached template is out of the cyclic GC, a caller's copy with a cycle is not.
    import gc
    second["self"] = second
    assert gc.is_tracked(second)

    # Union order: objathor first, then the user library.
    assert "clip_img_features" in ObjectMeta.annotation("obj_1000")
    assert "clip_img_features" not in ObjectMeta.annotation("user_only")
    assert ObjectMeta.annotation(["Mug_1", "nope"])[1] is None
    uids = ObjectMeta.all_uids()
    assert uids[:4] == sorted(expected) and uids.count("obj_1000") == 1 and uids[-1] == "user_only"
    assert len(ObjectMeta.annotation()) == len(uids)
    assert "0a1b2c3d4e" in ObjectMeta.annotation()

    # Helpers.
    assert ObjectMeta.short_descriptions("0a1b2c3d4e") == [f"short 0.{k}" for k in range(4)]
    assert ObjectMeta.short_descriptions("nope") == []
    assert ObjectMeta.get_short_description("Mug_1") == ["Mug"] * 4
    assert ObjectMeta.all_descriptions("0a1b2c3d4e")[-2:] == ["description 0",
                                                              "long description 0"]
    assert ObjectMeta.img_features(["0a1b2c3d4e", "Mug_1"]).shape == (2, 3, 768)
    assert ObjectMeta.description_text_features("Mug_1").shape == (1, 768)
    with pytest.raises(KeyError, match="Missing user_only for clip_img_features"):
        ObjectMeta.img_features("user_only")

    # A fresh registry opens the converted store without converting again.
    mtime = (index / "metadata.mlsm").stat().st_mtime_ns
    again = _registry.Registry(out / "lmdb" / "assets")
    assert again.annotation("Mug_1")["category"] == "Mug"
    assert (index / "metadata.mlsm").stat().st_mtime_ns == mtime

    # A store without its source marker (an older index-builtin's) is converted again, even
    # though the new Registry opened it first.
    (index / "objathor_source.json").unlink()
    stale = _registry.Registry(out / "lmdb" / "assets")
    assert stale.annotation("Mug_1")["category"] == "Mug"
    assert (index / "objathor_source.json").is_file()


def test_hostile_pickle_raises_and_runs_nothing(objathor):
    from mlspaces import _registry

    out, _ = objathor
    reg = _registry.Registry(out / "hostile" / "assets")
    with pytest.raises(Exception, match="obj_1000: pickle: global posix.system is not allowed"):
        reg.annotation("obj_1000")
    assert not (out / "pwned").exists()
