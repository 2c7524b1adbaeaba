"""``python -m mlspaces.grasp_generation LIBRARY_DIR [flags]``: ``mlspaces generate-grasps``
(the same C++ command: help, messages and exit codes)."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from ..resources import run_index_command

PROG = "python -m mlspaces.grasp_generation"


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the command on ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    return run_index_command("generate-grasps", PROG, argv)


if __name__ == "__main__":
    sys.exit(main())
