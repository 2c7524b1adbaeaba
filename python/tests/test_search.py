"""CLIP search (mlspaces.utils.object_retriever) against the original's numpy formula, on
features written by numpy: a store written through ClipStoreWriter, and a user library whose
metadata NPZ (np.savez) carries clip_img_features / clip_text_features."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mlspaces import _core
from mlspaces._registry import Registry
from mlspaces.errors import MlspacesError
from mlspaces.utils.object_retriever import ObjectRetriever

DIM = 768


def clustered(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(n,3,768) image and (n,768) text features, clustered like CLIP's, not normalised."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(25, DIM)).astype(np.float32)
    base = centres[rng.integers(0, 25, size=n)] + 0.7 * rng.normal(size=(n, DIM))
    img = base[:, None, :] + 0.4 * rng.normal(size=(n, 3, DIM))
    text = base + 0.6 * rng.normal(size=(n, DIM))
    return (3 * img).astype(np.float32), (2 * text).astype(np.float32)


def original_clip_sim(clip_img, clip_text, num_views):
    """molmo_spaces.utils.object_metadata.clip_sim with normalize=False."""
    res = np.einsum("od,qd->oq", clip_img[:, 0, :], clip_text)
    for i in range(1, num_views):
        res = np.maximum(res, np.einsum("od,qd->oq", clip_img[:, i, :], clip_text))
    return res


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    n = 400
    img, text = clustered(n, 11)
    uids = [f"obj_{(i * 7) % n:04d}" for i in range(n)]
    path = tmp_path_factory.mktemp("clip") / "clip_features.mlsc"
    writer = _core.ClipStoreWriter(str(path), 3, DIM)
    for i, uid in enumerate(uids):
        writer.add(uid, np.ascontiguousarray(img[i].reshape(-1)), text[i])
    writer.finish()
    # The original's stored keys: each vector normalised, then float16.
    ik = (img / np.linalg.norm(img, axis=-1, keepdims=True)).astype("float16")
    tk = (text / np.linalg.norm(text, axis=-1, keepdims=True)).astype("float16")[:, None, :]
    return path, np.array(uids), ik, tk


def test_stored_vectors_are_numpys_float16(store):
    path, uids, ik, tk = store
    s = _core.ClipStore.open(str(path))
    assert len(s) == len(uids) and s.views == 3 and s.dim == DIM and s.has_approximate
    s.check()
    diff_img = diff_text = 0
    for row in range(len(uids)):
        assert s.uid(row) == uids[row]
        a = s.image_features(row).astype(np.float16).view(np.int16).astype(np.int32)
        b = ik[row].view(np.int16).astype(np.int32)
        assert np.abs(a - b).max() <= 1  # numpy normalises in float32, we in float64
        diff_img += int((a != b).sum())
        t = s.text_feature(row).astype(np.float16).view(np.int16).astype(np.int32)
        diff_text += int((t != tk[row, 0].view(np.int16).astype(np.int32)).sum())
    assert diff_img + diff_text < 0.001 * ik.size  # almost every value bit-identical


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_query_matches_numpy_formula(store, seed):
    path, uids, ik, tk = store
    rng = np.random.default_rng(seed)
    q = tk[rng.integers(len(uids)), 0].astype(np.float32) + 0.02 * rng.normal(size=DIM)
    retriever = ObjectRetriever(sim_thres=0.5, max_results=50, registry=Registry(None),
                                clip_store=path)
    got_uids, got_sims = retriever.query(q.astype(np.float32))
    assert got_uids.dtype.kind == "U" and got_sims.dtype == np.float32
    # Reference: the formula in float64 over the same float16 keys.
    q64 = q.astype(np.float64) / np.linalg.norm(q)
    sim = (original_clip_sim(ik.astype(np.float64), q64[None], 3)
           + 0.5 * original_clip_sim(tk.astype(np.float64), q64[None], 1)).flatten()
    order = sorted((i for i in range(len(uids)) if sim[i] >= 0.5),
                   key=lambda i: (-sim[i], uids[i]))[:50]
    assert len(got_uids) == len(order) > 5
    np.testing.assert_allclose(got_sims, sim[order], atol=1e-5)
    ref_uids = [uids[i] for i in order]
    ref_sims = sim[order]
    for h, uid in enumerate(got_uids):  # same UID at each rank unless the reference near-ties
        near_tie = ((h > 0 and ref_sims[h - 1] - ref_sims[h] < 1e-5)
                    or (h + 1 < len(order) and ref_sims[h] - ref_sims[h + 1] < 1e-5))
        assert near_tie or uid == ref_uids[h]
    # The original's own float16 computation: same scores to float16 accuracy, same set.
    q16 = q.astype("float16")
    q16 = q16 / np.linalg.norm(q16)
    sim16 = (original_clip_sim(ik, q16[None], 3) + 0.5 * original_clip_sim(tk, q16[None], 1)
             ).flatten()
    mask = sim16 >= 0.5
    rank = np.argsort(sim16[mask])[::-1][:50]
    orig_uids, orig_sims = uids[mask][rank], sim16[mask][rank]
    np.testing.assert_allclose(np.sort(got_sims), np.sort(orig_sims.astype(np.float32)),
                               atol=3e-3)
    assert len(set(orig_uids) ^ set(got_uids)) <= 2  # only float16 ties at the cut may differ
    # Fewer results and a higher threshold.
    retriever.max_results, retriever.thres = 5, float(got_sims[2])
    few_uids, few_sims = retriever.query(q)
    assert list(few_uids) == list(got_uids[:3]) and np.all(few_sims >= got_sims[2])
    # The approximate pass with every row as a candidate is exact.
    all_candidates = _core.ClipStore.open(str(path)).search(q.astype(np.float32), 50, 0.5, True)
    assert all_candidates[0] == list(got_uids)


def test_query_errors(store):
    path = store[0]
    retriever = ObjectRetriever(registry=Registry(None), clip_store=path)
    with pytest.raises(MlspacesError, match="no text-to-CLIP model"):
        retriever.query("a red cellphone")
    with pytest.raises(MlspacesError, match="shape"):
        retriever.query(np.zeros(5, dtype=np.float32))
    with pytest.raises(MlspacesError, match="float"):
        retriever.query(np.ones(DIM, dtype=np.int64))
    with pytest.raises(MlspacesError, match="zero vector"):
        retriever.query(np.zeros(DIM, dtype=np.float16))
    with pytest.raises(MlspacesError, match="nope"):
        retriever.query_uid("nope")


def write_user_library(root: Path, features: dict[str, tuple | None]) -> Path:
    """A user asset library; assets with features carry them in a metadata NPZ (np.savez)."""
    index = {}
    for uid, feats in sorted(features.items()):
        d = root / uid
        d.mkdir(parents=True)
        (d / f"{uid}.xml").write_text("<mujoco/>")
        meta = {"category": uid.split("_")[0], "description": f"a {uid.replace('_', ' ')}"}
        if uid.endswith("_nc"):
            meta["license_info"] = {"license": "by-nc"}
        (d / f"{uid}.json").write_text(json.dumps(meta))
        entry = {"uid": uid, "object_path": f"{uid}/{uid}.xml",
                 "metadata_path": f"{uid}/{uid}.json", "metadata_npz_path": None}
        if feats is not None:
            np.savez(d / f"{uid}.npz", clip_img_features=feats[0], clip_text_features=feats[1])
            entry["metadata_npz_path"] = f"{uid}/{uid}.npz"
        index[uid] = entry
    (root / "assets_index.json").write_text(json.dumps(index, indent=4))
    return root


def test_user_library_features_policy_and_words(tmp_path):
    img, text = clustered(3, 5)
    lib = write_user_library(tmp_path / "lib", {
        "mug_nc": (img[0].astype(np.float16), text[0].astype(np.float16)),
        "mug_blue": (img[1], text[1].astype(np.float64)),
        "plate_white": None,  # no CLIP arrays: skipped and counted, not a KeyError
    })
    reg = Registry(None)
    reg.register_user_asset_library("user", lib)
    retriever = ObjectRetriever(sim_thres=-10, registry=reg)
    assert len(retriever) == 2 and retriever.skipped_without_features == 1
    uids, sims = retriever.query_uid("mug_nc")
    assert list(uids) == ["mug_nc", "mug_blue"] and sims[0] > sims[1]
    uids, _ = ObjectRetriever(sim_thres=-10, registry=reg, license_policy="commercial_safe"
                              ).query_uid("mug_nc")
    assert list(uids) == ["mug_blue"]
    words, scores = retriever.text_search("MUG, white")
    assert list(words) == ["mug_blue", "mug_nc", "plate_white"]
    np.testing.assert_allclose(scores, [0.5, 0.5, 0.25])
