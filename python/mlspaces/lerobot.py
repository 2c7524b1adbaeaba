"""LeRobot v3.0 export and import: an mlspaces dataset (HDF5 + MP4) as a LeRobot dataset and
back (docs/lerobot.md).

::

    from mlspaces.lerobot import export_lerobot, import_lerobot
    export_lerobot("runs/tutorial", "runs/tutorial_lerobot")
    # then, with lerobot installed:
    # LeRobotDataset("local/tutorial", root="runs/tutorial_lerobot")
    import_lerobot("runs/tutorial_lerobot", "runs/tutorial_again")   # the same HDF5 + MP4

The work is done by the ``mlspaces export-lerobot`` / ``import-lerobot`` commands (C++, Arrow C++ for parquet),
which this function runs: the one of the installed package (``mlspaces/bin``), else
``MLSPACES_CLI_PATH``, else the build tree's (``<build>/apps/mlspaces/mlspaces`` beside
``<build>/python``), which runs the helper ``mlspaces-lerobot`` beside it. A build without
Arrow C++ (no ``pyarrow`` where CMake looked; the wheels of ``pip install .`` are such builds)
has no helper: the function then raises ``RuntimeError`` saying so.
"""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

from . import _validate as _v
from .errors import MlspacesError, UsageError

_FUNC = "export_lerobot"


def _cli() -> Path:
    here = Path(__file__).resolve().parent
    candidates = [here / "bin" / "mlspaces"]
    if os.environ.get("MLSPACES_CLI_PATH"):
        candidates.append(Path(os.environ["MLSPACES_CLI_PATH"]))
    candidates.append(here.parent.parent / "apps" / "mlspaces" / "mlspaces")
    for exe in candidates:
        if exe.is_file() and os.access(exe, os.X_OK):
            return exe
    raise RuntimeError("mlspaces.lerobot: the mlspaces command is not installed with this package "
                       f"(looked for {', '.join(str(c) for c in candidates)})")


def export_lerobot(dataset_dir: str | os.PathLike[str], out_dir: str | os.PathLike[str], *,
                   fps: float | None = None, repo_id: str | None = None, codec: str = "copy",
                   mlspaces_meta: bool = True, quiet: bool = True) -> Path:
    """Writes the dataset in ``dataset_dir`` (a ``mlspaces datagen`` run folder) as a LeRobot
    v3.0 dataset in ``out_dir`` (which must not exist; it appears complete or not at all).
    Failed and truncated episodes are left out. ``fps``: check the dataset's frame rate is
    this. ``codec``: ``"copy"`` re-muxes the episodes' H.264 videos, ``"h264"`` or ``"av1"``
    re-encode them. ``mlspaces_meta=False`` leaves out ``meta/mlspaces/`` (the copy of the
    HDF5 episodes that ``import_lerobot`` needs, about the size of the HDF5 files).
    Returns ``out_dir`` as a Path.

    Raises :class:`~mlspaces.errors.MlspacesError` (a ``ValueError``, one line naming the file)
    for a dataset it cannot export (no successful episode, mismatched fps or cameras, an
    existing ``out_dir``, ...), :class:`~mlspaces.errors.UsageError` for a bad argument and
    ``RuntimeError`` when the command is missing or was built without Arrow C++."""
    dataset = _v.path(dataset_dir, "dataset_dir", _FUNC)
    out = _v.path(out_dir, "out_dir", _FUNC)
    codec = _v.choice(codec, "codec", _FUNC, ("copy", "h264", "av1"))
    args = ["export-lerobot", dataset, out, "--codec", codec]
    if fps is not None:
        args += ["--fps", repr(float(_v.number(fps, "fps", _FUNC, minimum=0)))]
    if repo_id is not None:
        args += ["--repo-id", _v.string(repo_id, "repo_id", _FUNC)]
    if not _v.boolean(mlspaces_meta, "mlspaces_meta", _FUNC):
        args.append("--no-mlspaces-meta")
    _run(args, _FUNC, quiet)
    return Path(out)


def import_lerobot(lerobot_dir: str | os.PathLike[str], out_dir: str | os.PathLike[str], *,
                   quiet: bool = True) -> Path:
    """Writes a LeRobot dataset that mlspaces made (``export_lerobot``, ``mlspaces datagen
    --format lerobot``) back as the HDF5 + MP4 dataset it came from, in ``out_dir`` (which must
    not exist; it appears complete or not at all): the same batch files, episodes and videos,
    byte for byte, and the run's config, journal and summary. Returns ``out_dir`` as a Path.

    Raises :class:`~mlspaces.errors.MlspacesError` (one line naming the file) for a folder
    that is not a LeRobot dataset, one not made by mlspaces (no
    ``meta/mlspaces/mlspaces.json``), one exported with re-encoded videos, missing or damaged
    files and an existing ``out_dir``; ``RuntimeError`` as ``export_lerobot``."""
    func = "import_lerobot"
    src = _v.path(lerobot_dir, "lerobot_dir", func)
    out = _v.path(out_dir, "out_dir", func)
    _run(["import-lerobot", src, out], func, quiet)
    return Path(out)


def _run(args: list[str], func: str, quiet: bool) -> None:
    command = args[0]
    args = [str(_cli()), *args]
    if quiet:
        args.append("-q")
    proc = subprocess.run(args, stdout=subprocess.PIPE, stderr=None if not quiet else subprocess.PIPE,
                          text=True)
    if proc.returncode != 0:
        err = (proc.stderr or "").strip().splitlines()
        line = next((e for e in reversed(err) if e.startswith("mlspaces: error: ")), "")
        message = line.removeprefix("mlspaces: error: ")
        if "built without Arrow C++" in message or (
                command in message and "unknown command" in message):
            raise RuntimeError(f"{func}: this mlspaces was built without Arrow C++ "
                               f"(pyarrow), so it has no {command} (docs/lerobot.md)")
        if proc.returncode == 2:
            raise UsageError(message or f"{func}: bad arguments")
        raise MlspacesError(message or f"{func}: mlspaces {command} failed "
                            f"(exit {proc.returncode})")


__all__ = ["export_lerobot", "import_lerobot"]
