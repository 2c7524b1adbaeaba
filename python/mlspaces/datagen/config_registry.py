"""The config registry (``molmo_spaces.data_generation.config_registry``)."""

from __future__ import annotations

import warnings
from typing import Any, Callable

from .. import _validate as _v
from ..errors import MlspacesError

_CONFIGS: dict[str, type] = {}


def register_config(name: str, strict: bool = True) -> Callable[[type], type]:
    """A class decorator registering a config class under `name` (returns the class
    unchanged). A name taken raises ``ValueError`` when `strict`, else warns and replaces."""
    name = _v.string(name, "name", "register_config", empty=False)
    strict = _v.boolean(strict, "strict", "register_config")

    def decorate(cls: type) -> type:
        if not isinstance(cls, type):
            raise _v.type_error(f"register_config({name!r})", "cls", "a config class", cls)
        if name in _CONFIGS and _CONFIGS[name] is not cls:
            if strict:
                raise MlspacesError(f"config {name!r} is already registered "
                                    f"({_CONFIGS[name].__module__}.{_CONFIGS[name].__qualname__})")
            warnings.warn(f"config {name!r} re-registered: {cls.__qualname__} replaces "
                          f"{_CONFIGS[name].__qualname__}", stacklevel=2)
        _CONFIGS[name] = cls
        return cls
    return decorate


def get_config_class(name: str) -> type:
    """The class registered as `name`; ``ValueError`` listing the known ones if none."""
    name = _v.string(name, "name", "get_config_class")
    try:
        return _CONFIGS[name]
    except KeyError:
        raise MlspacesError(f"unknown config {name!r}; registered: "
                            f"{', '.join(sorted(_CONFIGS)) or 'none'}") from None


def list_available_configs() -> list[str]:
    return sorted(_CONFIGS)


def _registry() -> dict[str, Any]:
    return _CONFIGS


__all__ = ["get_config_class", "list_available_configs", "register_config"]
