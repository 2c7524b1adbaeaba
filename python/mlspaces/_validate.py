"""Argument and file checks shared by the public functions (docs/python.md, "Errors").

Each check returns the value in the form the caller uses, or raises one line naming the
function and the argument: ``"<func>: <arg>: expected <what>, got <value>"``. A wrong type
(``None`` where a value is needed included) is :class:`MlspacesTypeError` (a ``TypeError`` and a
``ValueError``); a bad value is :class:`UsageError` (a ``ValueError``). A file that cannot be read
is :class:`MlspacesFileError` (an ``OSError`` and a ``ValueError``) whose message starts with the
file's path. The checks take a fast path for the common well-typed call; hot lookups call them
only on a cache miss.
"""

from __future__ import annotations

import contextlib
import math
import operator
import os
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np

from .errors import MlspacesError, MlspacesFileError, MlspacesTypeError, UsageError


def describe(value: Any) -> str:
    """A value for a message: ``None``, an array's dtype and shape, or its repr (shortened, on
    one line, control characters escaped by repr) and type."""
    if value is None:
        return "None"
    if isinstance(value, np.ndarray):
        return f"a {value.dtype} array of shape {value.shape}"
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - a broken __repr__ must not hide the real error
        text = object.__repr__(value)
    if "\n" in text:  # a repr over several lines (a str's escapes its newlines)
        text = " ".join(text.split())
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def type_error(func: str, name: str, expected: str, value: Any) -> MlspacesTypeError:
    """The error for an argument of the wrong type."""
    return MlspacesTypeError(f"{func}: {name}: expected {expected}, got {describe(value)}",
                             field=name)


def value_error(func: str, name: str, message: str) -> UsageError:
    """The error for an argument of the right type and a bad value."""
    return UsageError(f"{func}: {name}: {message}", field=name)


def string(value: Any, name: str, func: str, *, empty: bool = True) -> str:
    """A ``str`` (a subclass becomes a plain ``str``); ``empty=False`` refuses ``""``."""
    if type(value) is not str:
        if not isinstance(value, str):
            raise type_error(func, name, "a str", value)
        value = str(value)
    if not empty and not value:
        raise value_error(func, name, "expected a non-empty str, got ''")
    return value


def optional_string(value: Any, name: str, func: str) -> str | None:
    return None if value is None else string(value, name, func)


def path(value: Any, name: str, func: str) -> str:
    """A filesystem path (``str`` or ``os.PathLike`` of ``str``) as a non-empty ``str``."""
    if type(value) is str:
        text = value
    elif isinstance(value, (str, os.PathLike)):
        text = os.fspath(value)
        if not isinstance(text, str):
            raise type_error(func, name, "a path (str or os.PathLike of str)", value)
    else:
        raise type_error(func, name, "a path (str or os.PathLike)", value)
    if not text:
        raise value_error(func, name, "expected a path, got ''")
    if "\0" in text:
        raise value_error(func, name, f"a path holds no NUL character, got {text!r}")
    return text


def optional_path(value: Any, name: str, func: str) -> str | None:
    return None if value is None else path(value, name, func)


INT64_MAX = 2**63 - 1
UINT64_MAX = 2**64 - 1
INT32_MAX = 2**31 - 1


def integer(value: Any, name: str, func: str, *, minimum: int | None = None,
            maximum: int | None = INT64_MAX) -> int:
    """An ``int`` (numpy integers too; not ``bool``) within ``[minimum, maximum]``; the
    maximum defaults to the int64 the engine takes (beyond it nanobind would raise its
    multi-line "incompatible function arguments")."""
    if type(value) is int:
        n = value
    elif isinstance(value, (bool, np.bool_)) or not hasattr(type(value), "__index__"):
        raise type_error(func, name, "an int", value)
    else:
        n = operator.index(value)
    if minimum is not None and n < minimum:
        # The word-size bounds go unsaid below them: "an int >= 0".
        bound = (f"an int >= {minimum}" if maximum is None or maximum >= INT64_MAX
                 else f"an int in [{minimum}, {maximum}]")
        raise value_error(func, name, f"expected {bound}, got {n}")
    if maximum is not None and n > maximum:
        bound = f"an int <= {maximum}" if minimum is None else f"an int in [{minimum}, {maximum}]"
        raise value_error(func, name, f"expected {bound}, got {n}")
    return n


def count(value: Any, name: str, func: str, *, minimum: int = 0) -> int:
    """A count: an ``int`` in ``[minimum, INT64_MAX]`` (``minimum`` 0 by default)."""
    if type(value) is int and minimum <= value <= INT64_MAX:
        return value
    return integer(value, name, func, minimum=minimum)


def optional_integer(value: Any, name: str, func: str, *, minimum: int | None = None,
                     maximum: int | None = INT64_MAX) -> int | None:
    return None if value is None else integer(value, name, func, minimum=minimum, maximum=maximum)


def boolean(value: Any, name: str, func: str) -> bool:
    """A ``bool`` (numpy's too): ``0``, ``"yes"`` or ``None`` are refused, not read as truth."""
    if value is True or value is False:
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    raise type_error(func, name, "a bool", value)


def number(value: Any, name: str, func: str, *, minimum: float | None = None,
           maximum: float | None = None) -> float:
    """A finite real number (``int``, ``float`` or numpy's; not ``bool`` or ``str``)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)) \
            or isinstance(value, (complex, np.complexfloating)):
        raise type_error(func, name, "a number", value)
    x = float(value)
    if not math.isfinite(x):
        raise value_error(func, name, f"expected a finite number, got {x}")
    if minimum is not None and x < minimum:
        raise value_error(func, name, f"expected a number >= {minimum}, got {x}")
    if maximum is not None and x > maximum:
        raise value_error(func, name, f"expected a number <= {maximum}, got {x}")
    return x


def choice(value: Any, name: str, func: str, choices: tuple[str, ...]) -> str:
    """One of ``choices`` (strings)."""
    text = string(value, name, func)
    if text not in choices:
        raise value_error(func, name, f"expected one of {', '.join(map(repr, choices))}, got "
                                      f"{text!r}")
    return text


def strings(value: Any, name: str, func: str) -> list[str]:
    """A sequence of ``str`` (a list, tuple, ... but not one ``str`` or a mapping) as a list;
    a bad item is named ``<name>[<i>]``."""
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__iter__"):
        raise type_error(func, name, "a list of str", value)
    out = list(value)
    for i, item in enumerate(out):
        if type(item) is not str:
            out[i] = string(item, f"{name}[{i}]", func)
    return out


def libraries(value: Any, name: str, func: str) -> list[str] | None:
    """``None``, one library name, or a sequence of them (MolmoSpaces' ``grasp_libraries``)."""
    if value is None:
        return None
    if type(value) is str:
        return [value]
    return strings(value, name, func)


def mapping(value: Any, name: str, func: str) -> Mapping:
    if not isinstance(value, Mapping):
        raise type_error(func, name, "a dict", value)
    return value


def optional_mapping(value: Any, name: str, func: str) -> Mapping | None:
    return None if value is None else mapping(value, name, func)


def array(value: Any, name: str, func: str, shape: tuple[int | None, ...] | None = None, *,
          finite: bool = True) -> np.ndarray:
    """A real array-like as a float64 array of ``shape`` (``None`` in it: any length), with
    finite values unless ``finite=False``."""
    if value is None or isinstance(value, (str, bytes, Mapping)):
        raise type_error(func, name, _array_what(shape), value)
    try:
        a = np.asarray(value)
        # Numbers only: numpy would also read "1", True and 1+0j (with a warning) as floats.
        if a.dtype.kind not in "iuf":
            raise TypeError
        a = a.astype(np.float64, copy=False)
    except (TypeError, ValueError):
        raise type_error(func, name, _array_what(shape), value) from None
    if shape is not None and (a.ndim != len(shape) or
                              any(w is not None and w != n for w, n in zip(shape, a.shape))):
        raise value_error(func, name, f"expected shape {_shape_text(shape)}, got "
                                      f"{_shape_text(a.shape)}")
    if finite and not np.isfinite(a).all():
        raise value_error(func, name, "expected finite values, got NaN or infinity")
    return a


def _shape_text(shape: tuple[int | None, ...]) -> str:
    items = ["N" if n is None else str(n) for n in shape]
    return f"({items[0]},)" if len(items) == 1 else f"({', '.join(items)})"


def _array_what(shape: tuple[int | None, ...] | None) -> str:
    return "an array of numbers" if shape is None else f"a {_shape_text(shape)} array of numbers"


def file_error(file: Any, what: str, cause: BaseException | str | None = None
               ) -> MlspacesFileError:
    """The error for a file that cannot be read: ``"<file>: <what>[: <cause>]"``."""
    text = f"{os.fspath(file)}: {what}"
    if cause is not None:
        detail = str(cause).strip() or type(cause).__name__
        text += f": {detail.splitlines()[0]}"
    return MlspacesFileError(text, path=os.fspath(file))


@contextlib.contextmanager
def reading(file: Any, what: str = "cannot read the file") -> Iterator[None]:
    """Turns an ``OSError`` or ``ValueError`` raised inside (h5py, numpy, json, ...) into
    :class:`MlspacesFileError` naming ``file``. An :class:`MlspacesError` and an ``OSError``
    that carries a file name (``FileNotFoundError``, ``PermissionError``, ...) pass unchanged:
    they name their file already, and callers catch them by type."""
    try:
        yield
    except MlspacesError:
        raise
    except OSError as e:
        if e.filename is not None:
            raise
        raise file_error(file, what, e) from e
    except ValueError as e:
        raise file_error(file, what, e) from e
