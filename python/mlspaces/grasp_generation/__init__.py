"""Grasp generation (MolmoSpaces' ``molmo_spaces.grasp_generation``, as one function).

``generate_grasps(library_dir, ...)`` is ``mlspaces generate-grasps``: for each object of an asset
library, antipodal candidates on its collision geometry (or, with ``joints=True``, on the handle
of each hinge and slide joint), tested with the franka_droid gripper floating in MuJoCo, and the
kept grasps written as ``<uid>/<robot>/grasps.npz`` / ``joint_grasps_<joint>.npz`` (key
``transforms``, shape (N, 4, 4), float16 unless ``dtype="f8"``); then ``grasps_index.json``.
Deterministic for a seed whatever ``threads``; objects whose file exists are skipped unless
``overwrite``. See docs/graspgen.md.

``python -m mlspaces.grasp_generation LIBRARY_DIR [flags]`` runs the command itself.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from typing import Any

from .. import _core

__all__ = ["generate_grasps", "GraspGenerationReport"]


class GraspGenerationReport(dict):
    """The result of :func:`generate_grasps`: ``objects`` (one dict per object or joint, with
    ``uid``, ``joint``, ``status`` in ``done``/``skipped``/``failed``, ``candidates``, ``tested``,
    ``accepted``, ``steps``, ``seconds``, ``reason``, ``failures``, ``output``) and ``index``
    (the grasps_index.json written, or None)."""

    @property
    def objects(self) -> list[dict[str, Any]]:
        return self["objects"]

    @property
    def failed(self) -> list[dict[str, Any]]:
        """The objects (or joints) that got no grasps, each with its ``reason``."""
        return [o for o in self["objects"] if o["status"] == "failed"]


def generate_grasps(
    library_dir: str | os.PathLike[str],
    uids: Iterable[str] | None = None,
    *,
    robot: str = "droid",
    joints: bool = False,
    max_grasps: int = 1000,
    seed: int = 0,
    threads: int = 0,
    overwrite: bool = False,
    dtype: str = "f2",
    output_dir: str | os.PathLike[str] | None = None,
    progress: bool = True,
    min_quality: float = 0.005,
) -> GraspGenerationReport:
    """Generates grasps for the objects of ``library_dir`` (all, or ``uids``).

    ``robot`` is the robot whose gripper grasps and the grasp-library folder (``<uid>/<robot>/``):
    ``"droid"`` (franka_droid's gripper), ``"xarm7"``, or a robot on ``$MLSPACES_ROBOT_PATH``.

    ``min_quality`` is the antipodal quality a candidate needs (the cosine between each contact
    normal and the closing line; 0.005 is the original's, 0.9 keeps near-perpendicular contacts).

    Raises ``mlspaces.errors.MlspacesError`` for a missing library or an unknown UID and
    ``ValueError`` (``MlspacesUsageError``) for bad arguments; an object that fails is reported
    in the result (``status == "failed"`` with its ``reason``) and the others are still done.
    """
    if isinstance(uids, str):
        uids = [uids]
    if isinstance(max_grasps, bool) or not isinstance(max_grasps, int):
        raise TypeError(f"max_grasps must be an int, got {type(max_grasps).__name__}")
    report = _core.generate_grasps(
        os.fspath(library_dir),
        uids=list(uids or []),
        robot=robot,
        joints=joints,
        max_grasps=max_grasps,
        seed=seed,
        threads=threads,
        overwrite=overwrite,
        dtype=dtype,
        output_dir=os.fspath(output_dir) if output_dir is not None else "",
        progress=progress,
        min_quality=float(min_quality),
    )
    return GraspGenerationReport(report)
