"""``molmo_spaces.resources``: the index generators of user libraries, as modules.

``python -m mlspaces.resources.generate_user_asset_library_index SOURCE_DIR`` and
``python -m mlspaces.resources.generate_user_grasp_library_index SOURCE_DIR`` run the same C++
code as ``mlspaces index-assets`` / ``mlspaces index-grasps`` (docs/cli.md).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from .. import _core
from .. import _validate as _v


def run_index_command(command: str, prog: str, argv: Sequence[str] | None = None) -> int:
    """Runs ``mlspaces COMMAND ARGV...`` (``index-assets``, ``index-grasps`` or ``generate-grasps``) in this
    process, with ``prog`` as the program name in ``--help``; returns its exit code. Output and
    error lines go to the process's stdout and stderr, as the CLI prints them."""
    args = _v.strings(sys.argv[1:] if argv is None else argv, "argv", "run_index_command")
    sys.stdout.flush()
    sys.stderr.flush()
    return _core.run_index_command(command, prog, args)


__all__ = ["run_index_command"]
