"""The ``mlspaces`` console script: runs the CLI binary installed with this package."""

from __future__ import annotations

import os
import sys
from pathlib import Path


def main() -> None:
    exe = Path(__file__).resolve().parent / "bin" / "mlspaces"
    if not exe.is_file():
        sys.stderr.write(f"mlspaces: the command is not installed with this package ({exe})\n")
        raise SystemExit(1)
    os.execv(exe, [str(exe), *sys.argv[1:]])


if __name__ == "__main__":
    main()
