"""Asset metadata (``molmo_spaces.utils.object_metadata.ObjectMeta``), on the process-default
registry. Every call returns new objects: editing a returned dict never changes a later
answer (MolmoSpaces shares one dict per UID)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from .. import _registry
from .. import _validate as _v
from .._registry import default_registry
from ..errors import MlspacesKeyError


class _Annotations(Mapping):
    """The read-only mapping UID -> annotation over every registered library: what
    ``ObjectMeta.annotation()`` (no argument, or ``None``) returns, as MolmoSpaces' does."""

    def __getitem__(self, uid: str) -> dict[str, Any]:
        if not isinstance(uid, str):
            raise MlspacesKeyError(f"ObjectMeta.annotation(): the keys are UIDs (str), got "
                                   f"{_v.describe(uid)}")
        found = default_registry().annotation(uid)
        if found is None:
            raise MlspacesKeyError(f"{uid}: no annotation in the registered libraries", uid=uid)
        return found

    def __iter__(self) -> Iterator[str]:
        return iter(default_registry().all_uids())

    def __len__(self) -> int:
        return len(default_registry().all_uids())

    def __contains__(self, uid: object) -> bool:
        return isinstance(uid, str) and default_registry().annotation(uid) is not None

    def __repr__(self) -> str:
        return (f"<every annotation of the registered libraries: a read-only mapping of "
                f"{len(self)} UIDs (ObjectMeta.annotation() with no UID)>")


def _uids(asset_ids: Any, func: str, expected: str = "a UID (str) or a list of UIDs"
          ) -> list[str]:
    """A list of UIDs (the list form of an ``asset_ids`` argument)."""
    if isinstance(asset_ids, (bytes, Mapping)) or not hasattr(asset_ids, "__iter__"):
        raise _v.type_error(func, "asset_ids", expected, asset_ids)
    return _v.strings(asset_ids, "asset_ids", func)


def _short(annotation: dict[str, Any] | None, uid: str) -> list[str]:
    if annotation is None:
        return []
    short = annotation["description_short"]  # KeyError when missing, as the original
    return list(short.values()) if isinstance(short, dict) else list(short)


class ObjectMeta:
    """Static accessors of asset annotations (MolmoSpaces' names and return types)."""

    @staticmethod
    def annotation(asset_ids: str | list[str] | None = None):
        """``None`` (or no argument): the whole mapping UID -> annotation, as MolmoSpaces;
        a UID: its dict or ``None``; a list of UIDs: a list of those. Another type is a
        ``TypeError`` naming ``asset_ids``."""
        reg = _registry._default or default_registry()
        if type(asset_ids) is str:  # the hot path: one UID
            return reg.annotation(asset_ids)
        if asset_ids is None:
            return _Annotations()
        if isinstance(asset_ids, str):
            return reg.annotation(str(asset_ids))
        return [reg.annotation(uid) for uid in _uids(asset_ids, "ObjectMeta.annotation",
                                                        "a UID (str), a list of UIDs or None")]

    @staticmethod
    def all_uids() -> list[str]:
        return default_registry().all_uids()

    @staticmethod
    def short_descriptions(asset_ids: str | list[str]):
        """The ``description_short`` values of a UID (``[]`` when unknown), or a list of
        those for a list of UIDs."""
        reg = default_registry()
        if isinstance(asset_ids, str):
            return _short(reg.annotation(str(asset_ids)), asset_ids)
        out = []
        for uid in _uids(asset_ids, "ObjectMeta.short_descriptions"):
            found = reg.annotation(uid)
            if found is None:
                raise TypeError(f"short_descriptions: no annotation for {uid!r}")
            out.append(_short(found, uid))
        return out

    @staticmethod
    def get_short_description(object_uid: str) -> list[str]:
        object_uid = _v.string(object_uid, "object_uid", "ObjectMeta.get_short_description")
        found = default_registry().annotation(object_uid)
        if found is not None and found.get("description_short"):
            return _short(found, object_uid)
        return [object_uid.split("_")[0]] * 4

    @staticmethod
    def all_descriptions(asset_ids: str | list[str]):
        """Short descriptions followed by ``description`` and ``description_long``."""
        def one(uid: str) -> list[str]:
            found = default_registry().annotation(uid)
            if found is None:
                raise TypeError(f"all_descriptions: no annotation for {uid!r}")
            return _short(found, uid) + [found["description"], found["description_long"]]
        if isinstance(asset_ids, str):
            return one(str(asset_ids))
        return [one(uid) for uid in _uids(asset_ids, "ObjectMeta.all_descriptions")]

    @staticmethod
    def get_features(feature_type_str: str, asset_ids: str | list[str] | None = None
                     ) -> np.ndarray:
        """A feature array of each UID stacked: ``(1, *feat)`` for one UID, ``(n, *feat)`` for
        a list, every annotated UID for ``None``. ``KeyError`` for a UID or feature missing."""
        func = "ObjectMeta.get_features"
        feature_type_str = _v.string(feature_type_str, "feature_type_str", func)
        reg = default_registry()
        uids = (reg.all_uids() if asset_ids is None
                else [str(asset_ids)] if isinstance(asset_ids, str)
                else _uids(asset_ids, func, "a UID (str), a list of UIDs or None"))
        rows = []
        for uid in uids:
            found = reg.annotation(uid)
            if found is None:
                raise MlspacesKeyError(f"Missing {uid} for {feature_type_str}", uid=uid)
            if feature_type_str not in found:
                raise MlspacesKeyError(f"Missing {uid} for {feature_type_str}", uid=uid,
                                       field=feature_type_str)
            rows.append(np.asarray(found[feature_type_str]))
        return np.stack(rows)

    @classmethod
    def img_features(cls, asset_ids: str | list[str] | None = None) -> np.ndarray:
        return cls.get_features("clip_img_features", asset_ids)

    @classmethod
    def description_text_features(cls, asset_ids: str | list[str] | None = None) -> np.ndarray:
        return cls.get_features("clip_text_features", asset_ids)

    @staticmethod
    def get_target_object_uid(task: Any) -> str:
        if not hasattr(task, "config") or not hasattr(task, "env"):
            raise _v.type_error("ObjectMeta.get_target_object_uid", "task",
                                "a task (with .config and .env)", task)
        name = task.config.task_config.pickup_obj_name
        return task.env.current_scene_metadata["objects"][name]["asset_id"]

    @classmethod
    def clean_object_name(cls, task: Any) -> str:
        if not hasattr(task, "config"):
            raise _v.type_error("ObjectMeta.clean_object_name", "task",
                                "a task (with .config and .env)", task)
        custom = getattr(task.config.task_config, "eval_object_name", None)
        if custom:
            return custom
        return cls.get_short_description(cls.get_target_object_uid(task))[0]


__all__ = ["ObjectMeta"]
