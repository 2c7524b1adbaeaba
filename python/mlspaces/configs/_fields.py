"""Builds config classes whose fields and defaults are the engine's (configs/_base.py)."""

from __future__ import annotations

from typing import Any

from pydantic import Field, create_model

from ._base import Config, default


def _annotation(value: Any) -> Any:
    if value is None:
        return Any
    if isinstance(value, bool):
        return bool
    if isinstance(value, int):
        return int
    if isinstance(value, float):
        return float
    if isinstance(value, str):
        return str
    if isinstance(value, list):
        return list[Any]
    if isinstance(value, dict):
        return dict[str, Any]
    return Any


def engine_model(name: str, module: str, section: tuple[str, ...], doc: str,
                 base: type[Config] = Config, **overrides: Any) -> type[Config]:
    """A config class named `name` with one field per key of the engine's defaults at
    `section`, typed and defaulted from them; `overrides` maps a field to (annotation, default)
    (a default of a model instance is copied per instance), or to None to leave it out."""
    fields: dict[str, Any] = {}
    for key, value in default(*section).items():
        if key in overrides:
            continue
        if isinstance(value, (list, dict)):
            fields[key] = (_annotation(value), Field(default_factory=lambda v=value: _copy(v)))
        else:
            fields[key] = (_annotation(value), value)
    for key, override in overrides.items():
        if override is None:
            continue
        annotation, value = override
        if isinstance(value, Config):
            fields[key] = (annotation, Field(default_factory=lambda v=value: v.model_copy(deep=True)))
        else:
            fields[key] = (annotation, value)
    cls = create_model(name, __base__=base, __module__=module, __doc__=doc, **fields)
    return cls


def _copy(value: Any) -> Any:
    if isinstance(value, list):
        return [_copy(v) for v in value]
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    return value
