"""``python -m mlspaces.resources.generate_user_asset_library_index SOURCE_DIR [-o/--output PATH]
[--overwrite] [--compute-metadata] [--suppress-missing-metadata]``: writes
``SOURCE_DIR/assets_index.json`` (MolmoSpaces' module of the same name).

It is ``mlspaces index-assets`` (the same C++ code, messages and exit codes: 0 done, 1 an
error, 2 a usage error; one ``mlspaces: error: ...`` line on stderr, no traceback). Where the
original has bugs, this keeps the CLI's behaviour (docs/cli.md): with ``--compute-metadata``
an existing ``<uid>_computed.json`` is reused and stays in the index (the original leaves the
asset out), an asset that fails is left out of the index and named (exit code 1), the bounding
box contains the whole geometry, a missing SOURCE_DIR is an error (the original writes an
empty index), and assets are computed on all cores.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from . import run_index_command

PROG = "python -m mlspaces.resources.generate_user_asset_library_index"


def main(argv: Sequence[str] | None = None) -> int:
    """Runs the generator on ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    return run_index_command("index-assets", PROG, argv)


if __name__ == "__main__":
    sys.exit(main())
