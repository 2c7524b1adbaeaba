"""``python -m mlspaces.resources.generate_user_grasp_library_index SOURCE_DIR [-o/--output PATH]
[--overwrite]``: writes ``SOURCE_DIR/grasps_index.json`` from ``<uid>/<robot>/grasps.npz`` and
``<uid>/<robot>/joint_grasps_<joint>.npz`` (MolmoSpaces' module of the same name).

It is ``mlspaces index-grasps`` (the same C++ code, messages and exit codes: 0 done, 1 an
error, 2 a usage error; one ``mlspaces: error: ...`` line on stderr, no traceback).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from . import run_index_command

PROG = "python -m mlspaces.resources.generate_user_grasp_library_index"


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the generator on ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    return run_index_command("index-grasps", PROG, argv)


if __name__ == "__main__":
    sys.exit(main())
