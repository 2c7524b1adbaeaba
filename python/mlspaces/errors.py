"""Exceptions raised by mlspaces.

Every error of the C++ library (``mlspaces::Error``) arrives as :class:`MlspacesError`, a
``ValueError`` (the type MolmoSpaces raises for bad input), carrying the file, the field in it
and the asset UID it is about. Lookups of an unknown key raise :class:`MlspacesKeyError`,
which is also a ``KeyError``, where MolmoSpaces raises ``KeyError``. A bad argument to a public
function is a :class:`UsageError` (a bad value) or :class:`MlspacesTypeError` (a wrong type, also
a ``TypeError``), naming the function and the argument; a file that cannot be read is a
:class:`MlspacesFileError` (also an ``OSError``) naming the file.
"""

from __future__ import annotations


class MlspacesError(ValueError):
    """Bad input: a file, a field in it, or a UID.

    ``str(err)`` is one line, ``"<path>: <field>: <message>"`` without the empty parts.
    """

    def __init__(self, what: str, message: str | None = None, path: str = "", field: str = "",
                 uid: str = "") -> None:
        super().__init__(what)
        self.message = what if message is None else message
        #: The file the error is about ("" when none).
        self.path = path
        #: Where in the file: a JSON pointer, "line N" or a zip member ("" when none).
        self.field = field
        #: The asset UID involved ("" when none).
        self.uid = uid

    def __str__(self) -> str:  # ValueError's str would quote nothing anyway; keep one line
        return str(self.args[0]) if self.args else ""


class UsageError(MlspacesError):
    """A bad argument to an API call or command (the CLI exits with 2 for it)."""


class MlspacesTypeError(UsageError, TypeError):
    """An argument of the wrong type (``None`` where a value is needed included), named in the
    message. A ``TypeError`` as Python has it, and a ``ValueError`` as MolmoSpaces' callers
    catch for bad input."""


class MlspacesFileError(MlspacesError, OSError):
    """A file that cannot be read or is not what it should be (a corrupt HDF5 file, bad JSON):
    the message starts with the file's path, also in ``.path`` and ``.filename``. An ``OSError``
    (what ``open`` and h5py raise) and a ``ValueError`` (what a parser raises)."""

    def __init__(self, what: str, message: str | None = None, path: str = "", field: str = "",
                 uid: str = "") -> None:
        super().__init__(what, message, path, field, uid)
        self.filename = path or None


class MlspacesKeyError(MlspacesError, KeyError):
    """An unknown name or UID where MolmoSpaces raises ``KeyError``."""

    def __str__(self) -> str:  # KeyError's str quotes its argument; keep the message plain
        return MlspacesError.__str__(self)


class RobotPlacementError(Exception):
    """Raised by a task sampler hook that cannot place the robot for this candidate."""


class HouseInvalidForTask(Exception):
    """The scene holds nothing the task can use (e.g. no object with grasps)."""


__all__ = ["MlspacesError", "UsageError", "MlspacesTypeError", "MlspacesFileError",
           "MlspacesKeyError", "RobotPlacementError", "HouseInvalidForTask"]
