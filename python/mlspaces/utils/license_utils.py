"""Licences (``molmo_spaces.utils.license_utils`` and ``print_license_info`` of
``molmo_spaces.molmo_spaces_constants``), answered by the C++ engine (docs/licenses.md).

The rules are the original's: THOR objects, the objathor metadata, scenes and grasps are
CC-BY-4.0 (Ai2); an Objaverse object's licence comes from its annotation's ``license_info``
(``by``, ``by-sa``, ``cc0``, ``by-nc``, ``by-nc-sa``); built-in identifiers are checked by
substring against the source's archive names. Unlike the original, an asset of a user library
is answered too: from its metadata's ``license_info``, else ``"license": "unknown"``.
Errors are :class:`mlspaces.errors.MlspacesError` (a ``ValueError``).
"""

from __future__ import annotations

import json
from typing import Any

from .. import _core
from .. import _validate as _v
from .._registry import Registry, default_registry

NON_COMMERCIAL_LICENSES = frozenset({"by-nc", "by-nc-sa"})
"""The Creative Commons short names the ``commercial_safe`` policy leaves out."""


def _context(registry: Registry | None, func: str = "resolve_license") -> tuple[Any, str]:
    reg = _registry(registry, func)
    return reg._r, "" if reg.assets_dir is None else str(reg.assets_dir)


def _registry(registry: Any, func: str) -> Registry:
    if registry is None:
        return default_registry()
    if not isinstance(registry, Registry):
        raise _v.type_error(func, "registry", "a mlspaces.Registry or None", registry)
    return registry


def _source(data_type: Any, data_source: Any, func: str) -> tuple[str, str]:
    return (_v.string(data_type, "data_type", func, empty=False),
            _v.string(data_source, "data_source", func, empty=False))


def _identifier(identifier: Any, name: str, func: str) -> str:
    """A UID or archive identifier (str) or a scene index (int), as text."""
    if isinstance(identifier, str):
        return str(identifier)
    if isinstance(identifier, int) and not isinstance(identifier, bool):
        return str(identifier)
    raise _v.type_error(func, name, "a str (UID or identifier) or an int (scene index)",
                        identifier)


def resolve_license(data_type: str, data_source: str, identifier: Any = None, *,
                    registry: Registry | None = None) -> dict[str, Any]:
    """The licence record of one item, as the original's ``resolve_license`` returns it
    (same keys, same order, same texts). ``data_type`` is ``objects``, ``scenes``,
    ``grasps`` or ``robots``; ``identifier`` a UID, an archive identifier (matched as a
    substring) or a scene index (an ``int``); for robots it defaults to ``data_source``."""
    func = "resolve_license"
    data_type, data_source = _source(data_type, data_source, func)
    if identifier is None:
        if data_type != "robots":
            raise ValueError(f"Missing identifier for {data_type=} {data_source=}")
        identifier = data_source
    identifier = _identifier(identifier, "identifier", func)
    r, assets_dir = _context(registry, func)
    return _core.resolve_license(r, assets_dir, data_type, data_source, identifier)


def license_identifiers(data_type: str, data_source: str, *,
                        registry: Registry | None = None) -> list[str]:
    """Every identifier of a built-in source (its archive names without ``<source>_`` and
    ``.tar.zst``), sorted."""
    func = "license_identifiers"
    data_type, data_source = _source(data_type, data_source, func)
    r, assets_dir = _context(registry, func)
    return _core.license_identifiers(r, assets_dir, data_type, data_source)


def object_license_key(identifier: str, *, registry: Registry | None = None) -> str:
    """The short licence key of an object (``by``, ``by-nc``, ...), as the original's
    non-commercial filter computes it: the annotation's ``license_info.license``, ``"by"`` for
    an asset whose annotation says it is not from Objaverse. Raises ``ValueError`` for an
    unknown UID; a user asset without ``license_info`` gives ``"unknown"``."""
    func = "object_license_key"
    identifier = _v.string(identifier, "identifier", func)
    anno = _registry(registry, func).annotation(identifier)
    if anno is None:
        raise ValueError(f"Unknown object identifier: {identifier}")
    info = anno.get("license_info")
    if isinstance(info, dict) and "license" in info:
        return info["license"]
    return "by" if anno.get("isObjaverse") is False else "unknown"


def resolve_license_policy(policy: str | None = None) -> str:
    """The licence policy in force: ``policy`` when given (``"all"`` or
    ``"commercial_safe"``), else ``MLSPACES_LICENSE_POLICY``, else ``"all"``."""
    return _core.resolve_license_policy(
        _v.optional_string(policy, "policy", "resolve_license_policy"))


def print_license_info(data_type: str, data_source: str, asset_or_tar_id: Any = None, *,
                       registry: Registry | None = None) -> None:
    """Prints the licence record as JSON (indent 2), as the original does.
    ``asset_or_tar_id="--list_all"`` prints every identifier instead. An identifier that
    matches nothing prints the error and up to ten identifiers (the first ten, sorted, where
    the original picks ten at random)."""
    func = "print_license_info"
    data_type, data_source = _source(data_type, data_source, func)
    if asset_or_tar_id is not None:
        asset_or_tar_id = _identifier(asset_or_tar_id, "asset_or_tar_id", func)
    _registry(registry, func)
    if asset_or_tar_id is None and data_type != "robots":
        raise ValueError(
            f"Missing asset_or_tar_id for {data_type=} {data_source=}. Maybe try with '--list_all'")
    if asset_or_tar_id == "--list_all":
        print(f"Possible identifiers: {license_identifiers(data_type, data_source, registry=registry)}")
        return
    try:
        info = resolve_license(data_type, data_source, asset_or_tar_id, registry=registry)
    except ValueError as e:
        print(e)
        try:
            ids = license_identifiers(data_type, data_source, registry=registry)
        except ValueError:
            return
        shown = "\n".join(ids[:10])
        print(f"Possible identifiers:\n{shown}{'...' if len(ids) > 10 else ''}")
        return
    print(json.dumps(info, indent=2))


__all__ = ["NON_COMMERCIAL_LICENSES", "license_identifiers", "object_license_key",
           "print_license_info", "resolve_license", "resolve_license_policy"]
