"""The config base class and the engine's defaults.

Configs are pydantic v2 models, as MolmoSpaces' are: a subclass overrides a default by
annotating a class attribute, instances take keyword arguments, fields can be assigned. Every
default comes from the C++ engine's own (``mlspaces._core.default_config``), so the Python and
YAML forms of a config cannot drift apart. ``to_native`` turns a config into the engine's
config dict (docs/python.md).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict

from .. import _core

#: The engine's defaults (PickBaseConfig), as nested dicts.
DEFAULTS: dict[str, Any] = _core.default_config()


def default(*keys: str) -> Any:
    """The engine's default at a key path, e.g. default("robot_config", "base_size")."""
    value: Any = DEFAULTS
    for k in keys:
        value = value[k]
    return value


class Config(BaseModel):
    """Base of every config: arbitrary types allowed (class objects), assignment unvalidated,
    unknown keyword arguments rejected (a typo is an error, not a silent default)."""

    model_config = ConfigDict(arbitrary_types_allowed=True, extra="forbid",
                              validate_assignment=False, protected_namespaces=())


def class_name(cls: Any) -> str:
    """``module:qualname`` of a class (how a Python sampler is named in the engine config)."""
    return f"{cls.__module__}:{cls.__qualname__}"


def native_value(value: Any, template: Any) -> Any:
    """A config value shaped as the engine's `template` (its default): models and dicts by the
    template's keys (fields the engine does not know are left out), paths as str, tuples as
    lists, an infinite count as null."""
    if isinstance(value, BaseModel):
        engine_fields = getattr(value, "_engine_fields", None)  # a robot config's own mapping
        value = engine_fields() if engine_fields is not None else {
            name: getattr(value, name) for name in type(value).model_fields}
    if isinstance(template, dict) and isinstance(value, dict):
        if not template:  # a free-form mapping (added_objects, visibility constraints)
            return {str(k): native_value(v, None) for k, v in value.items()}
        return {k: native_value(value[k], template[k]) for k in template if k in value}
    if isinstance(value, (list, tuple)):
        item_template = template[0] if isinstance(template, list) and template else None
        return [native_value(v, item_template) for v in value]
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, float) and math.isinf(value):
        return None
    if isinstance(value, type):
        return class_name(value)
    return value
