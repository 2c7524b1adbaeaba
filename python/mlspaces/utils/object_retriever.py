"""CLIP object search (``molmo_spaces.utils.object_retriever.ObjectRetriever``).

The original embeds a text query with open_clip ViT-L-14 (``laion2b_s32b_b82k``) and scores
every asset as ``max over its 3 image views of cos(img, q) + 0.5 * cos(text, q)``, keeps
scores ``>= sim_thres``, sorts them best first and returns at most ``max_results``
``(uids, sims)``. mlspaces ships no CLIP model (none can be downloaded here), so ``query``
takes the embedding itself: a numpy array of 768 floats made elsewhere (any float dtype,
shape ``(768,)`` or ``(1, 768)``). ``query_uid`` searches with a stored asset's text feature
("more like this") and ``text_search`` matches words in category, synset and descriptions.

Differences from the original (docs/search.md): the features are read in place from the
converted objathor store (``clip_features.mlsc``) plus the user libraries' annotations, not
copied into an LMDB on first use; a user asset without ``clip_img_features`` /
``clip_text_features`` is skipped and counted (``skipped_without_features``) where the
original raises ``KeyError``; scores are float32 (the original's are float16); ties are
ordered by UID.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from .. import _core
from .. import _validate as _v
from .._registry import Registry, default_registry
from ..errors import MlspacesError

__all__ = ["ObjectRetriever"]

_NO_MODEL = (
    "ObjectRetriever.query needs a CLIP embedding, not text: no text-to-CLIP model is "
    "available to mlspaces. Pass a numpy array of {dim} floats (open_clip ViT-L-14 "
    "laion2b_s32b_b82k text or image features computed elsewhere), use query_uid(uid) for "
    "'more like this', or text_search(words) for a word search"
)


def _policy_name(policy: Any) -> str | None:
    """None (MLSPACES_LICENSE_POLICY, else all), a name, or an enum member (NONE/ALL -> all)."""
    if policy is None:
        return None
    name = getattr(policy, "name", None)
    if isinstance(name, str):
        return "all" if name.upper() in ("NONE", "ALL") else name.lower()
    text = str(policy)
    return "all" if text.lower() == "none" else text


class ObjectRetriever:
    """CLIP search over the registered libraries (the original's constructor arguments;
    ``registry`` and ``clip_store`` are mlspaces additions)."""

    def __init__(self, sim_thres: float = 0.5, max_results: int = 50,
                 license_policy: Any = None, *, registry: Registry | None = None,
                 clip_store: str | os.PathLike[str] | None = None,
                 approximate: bool = False) -> None:
        func = "ObjectRetriever"
        self.thres = _v.number(sim_thres, "sim_thres", func)
        self.max_results = _v.count(max_results, "max_results", func)
        if license_policy is not None and not isinstance(license_policy, str) \
                and not isinstance(getattr(license_policy, "name", None), str):
            raise _v.type_error(func, "license_policy", "None, a policy name or an enum member",
                                license_policy)
        self.license_policy = license_policy
        self.approximate = _v.boolean(approximate, "approximate", func)
        if registry is not None and not isinstance(registry, Registry):
            raise _v.type_error(func, "registry", "a mlspaces.Registry or None", registry)
        reg = registry if registry is not None else default_registry()
        assets = None if reg.assets_dir is None else os.fspath(reg.assets_dir)
        store = _v.optional_path(clip_store, "clip_store", func)
        self._search = _core.ObjectSearch(reg._r, assets, store)

    def __len__(self) -> int:
        return len(self._search)

    @property
    def skipped_without_features(self) -> int:
        """Annotated assets left out because they carry no CLIP arrays."""
        return self._search.skipped_without_features

    def _embedding(self, query: Any) -> np.ndarray:
        dim = self._search.dim or 768
        if isinstance(query, (str, bytes)):
            raise MlspacesError(_NO_MODEL.format(dim=dim))
        if query is None:
            raise _v.type_error("ObjectRetriever.query", "text", f"a CLIP embedding ({dim} "
                                "floats)", query)
        q = np.asarray(query)
        if q.dtype.kind != "f":
            raise MlspacesError(f"ObjectRetriever.query: the embedding must be a float array, "
                                f"got dtype {q.dtype}")
        if not np.isfinite(q).all():
            raise _v.value_error("ObjectRetriever.query", "text",
                                 "the embedding holds NaN or infinity")
        if not (q.ndim == 1 or (q.ndim == 2 and q.shape[0] == 1)) or q.size != dim:
            raise MlspacesError(f"ObjectRetriever.query: the embedding must have shape ({dim},) "
                                f"or (1, {dim}), got {q.shape}")
        return np.ascontiguousarray(q.reshape(-1), dtype=np.float32)

    def query(self, text: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(uids, sims)`` best first for a CLIP embedding (see the module doc)."""
        uids, sims = self._search.query(self._embedding(text), self.max_results, self.thres,
                                        self.approximate, 1, _policy_name(self.license_policy))
        return np.array(uids, dtype=str), sims

    def query_uid(self, uid: str) -> tuple[np.ndarray, np.ndarray]:
        """"More like this": searches with the stored text feature of ``uid``."""
        return self.query(self._search.uid_embedding(
            _v.string(uid, "uid", "ObjectRetriever.query_uid")))

    def text_search(self, words: str) -> tuple[np.ndarray, np.ndarray]:
        """Word search over category, synset and descriptions: ``(uids, scores)``, scores in
        (0, 1] (2 points per word in category/synset, 1 in a description, over 2 per word)."""
        words = _v.string(words, "words", "ObjectRetriever.text_search")
        uids, scores = self._search.text_search(words, self.max_results,
                                                _policy_name(self.license_policy))
        return np.array(uids, dtype=str), scores
