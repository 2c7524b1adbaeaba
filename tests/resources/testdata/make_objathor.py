"""Writes the objathor metadata cases tests/resources/objathor_test.cc reads, each an assets
dir in the original's layout (versions file, objects/objathor_metadata -> cache version dir):

  OUT/<case>/assets/...        the input
  OUT/expected.json            {uid: the annotation as the original returns it, arrays as lists}

Cases: lmdb (the original's LMDB, built as PickleLMDBMap.from_dict does), src (only
objects_metadata.json.gz + clip_features.pkl, pickled as numpy 1.x did), mismatch (one CLIP
row fewer than annotations), nosentinel, truncated (a value cut mid-frame), hostile (a value
whose pickle calls os.system), corrupt (data pages overwritten). Uses the LMDB writers of
tests/fixtures/make_molmo_remote.py. Usage: make_objathor.py OUT SOURCE_ROOT
"""

import gzip
import json
import os
import pickle
import sys
from pathlib import Path

import numpy as np
import zstandard

VERSION = "20260129"


class Gadget:
    def __init__(self, path):
        self.path = path

    def __reduce__(self):
        return (os.system, (f"touch {self.path}",))


def layout(root: Path) -> Path:
    assets = root / "assets"
    cache = root / "cache" / "objects" / "objathor_metadata" / VERSION
    cache.mkdir(parents=True)
    (assets / "objects").mkdir(parents=True)
    os.symlink(cache, assets / "objects" / "objathor_metadata")
    (assets / "mjthor_data_type_to_source_to_versions.json").write_text(
        json.dumps({"objects": {"objathor_metadata": VERSION}}))
    return assets


def main():
    out = Path(sys.argv[1])
    sys.path.insert(0, str(Path(sys.argv[2]) / "tests" / "fixtures"))
    import make_molmo_remote as fx

    rng = np.random.default_rng(3)
    uids = ["0a1b2c3d4e", "Mug_1", "obj_1000", "zz_émoji_\U0001F600"]
    annotations = {}
    for i, uid in enumerate(uids):
        annotations[uid] = {
            "uid": uid, "category": ["Mug", "Mug", "Block", "Chair"][i],
            "description": f"description {i}", "description_long": f"long description {i}",
            "description_short": {str(k): f"short {i}.{k}" for k in range(4)},
            "isObjaverse": i % 2 == 0, "scale": 0.5 + i, "pose_z_rot_angle": None,
            "tags": ["a", 1, 2.5, False, None, {"nested": [1, 2]}],
            "license_info": {"license": "by-nc" if i == 1 else "by", "creator_username": "x"},
        }
    annotations["Mug_1"].pop("description_short")  # get_short_description falls back
    img = (rng.standard_normal((len(uids), 3, 768)) * 0.3).astype(np.float16)
    txt = (rng.standard_normal((len(uids), 768)) * 0.3).astype(np.float16)
    clip = {"uids": uids, "img_features": img, "text_features": txt}
    values = fx.objathor_lmdb_values(annotations, clip)

    expected = {}
    for uid, v in values.items():
        expected[uid] = {k: (x.tolist() if isinstance(x, np.ndarray) else x) for k, x in v.items()}
    (out).mkdir(parents=True, exist_ok=True)
    (out / "expected.json").write_text(json.dumps(expected, ensure_ascii=False))

    assets = layout(out / "lmdb")
    fx.write_pickle_lmdb(assets / ".lmdb" / "objathor_metadata" / VERSION, values)

    def sources(assets: Path, clip_dict):
        src = assets / "objects" / "objathor_metadata"
        (src / "objects_metadata.json.gz").write_bytes(gzip.compress(json.dumps(annotations).encode()))
        (src / "clip_features.pkl").write_bytes(fx.numpy1_pickle(clip_dict, protocol=4))

    sources(layout(out / "src"), clip)
    sources(layout(out / "mismatch"), {"uids": uids[:3], "img_features": img[:3],
                                       "text_features": txt[:3]})
    assets = layout(out / "nosentinel")
    fx.write_pickle_lmdb(assets / ".lmdb" / "objathor_metadata" / VERSION, values, complete=False)

    raw = {k: zstandard.compress(pickle.dumps(v)) for k, v in values.items()}
    cut = dict(raw)
    cut["Mug_1"] = raw["Mug_1"][: len(raw["Mug_1"]) // 2]
    fx.write_raw_lmdb(layout(out / "truncated") / ".lmdb" / "objathor_metadata" / VERSION, cut)

    bad = dict(raw)
    bad["obj_1000"] = zstandard.compress(pickle.dumps(
        {"uid": "obj_1000", "x": Gadget(out / "pwned")}))
    fx.write_raw_lmdb(layout(out / "hostile") / ".lmdb" / "objathor_metadata" / VERSION, bad)

    lmdb_dir = layout(out / "corrupt") / ".lmdb" / "objathor_metadata" / VERSION
    fx.write_pickle_lmdb(lmdb_dir, values)
    data = bytearray((lmdb_dir / "data.mdb").read_bytes())
    page = 4096
    for off in range(2 * page, len(data), 7):  # every data page: flags, bounds, pointers
        data[off] = (data[off] * 131 + 0x5A) & 0xFF
    (lmdb_dir / "data.mdb").write_bytes(bytes(data))


if __name__ == "__main__":
    main()
