"""Pictures through mlspaces' headless renderer (docs/render.md), as ``mlspaces render`` makes
them, returned as fresh ``uint8`` ``(H, W, 3)`` numpy arrays (rows top to bottom):

- :func:`asset_sheet`: a contact sheet of assets labelled with their UIDs,
- :func:`asset`: one asset alone,
- :func:`grasps`: an asset with its grasps drawn as gripper outlines from several views,
- :func:`scene`: a datagen config's scene as the data engine composes and samples it,
- :func:`episode_phases`: a recorded episode's camera frames at each planner phase,

and :func:`write_png` / :func:`read_png`. ``gl`` is ``"osmesa"`` or ``"egl"`` (default: the
``MLSPACES_GL`` environment variable, else osmesa); one process renders with one of them.
Bad input raises :class:`mlspaces.errors.MlspacesError` (a ``ValueError``) with one line.
"""

from __future__ import annotations

import errno
import json
import os
import random
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import _core
from . import _validate as _v

__all__ = ["asset", "asset_sheet", "episode_phases", "grasps", "read_png", "scene", "write_png"]


def _gl(gl: Any, func: str) -> str:
    # "": the engine takes MLSPACES_GL, else osmesa (sim::ResolveGlBackend).
    if gl is None:
        return ""
    return _v.choice(gl, "gl", func, ("osmesa", "egl"))


def _size(size: Any, func: str) -> tuple[int, int]:
    if not isinstance(size, (tuple, list)) or len(size) != 2:
        raise _v.type_error(func, "size", "a (width, height) pair", size)
    return (_v.integer(size[0], "size[0]", func, minimum=_core.MIN_PICTURE_SIDE,
                       maximum=_core.MAX_PICTURE_SIDE),
            _v.integer(size[1], "size[1]", func, minimum=_core.MIN_PICTURE_SIDE,
                       maximum=_core.MAX_PICTURE_SIDE))


def _existing(path: Any, name: str, func: str) -> str:
    """A path that exists: a missing one is Python's FileNotFoundError naming it (as
    docs/python.md promises), not the engine's error."""
    text = _v.path(path, name, func)
    if not os.path.exists(text):
        raise FileNotFoundError(errno.ENOENT, f"{func}: {name}: no such file or folder", text)
    return text


def _registry(registry: Any) -> Any:
    if registry is None:
        from ._registry import default_registry
        registry = default_registry()
    return registry._r


def asset_sheet(uids: Sequence[str] | None = None, *, registry: Any = None,
                size: tuple[int, int] = (256, 256), columns: int | None = None,
                gl: str | None = None) -> np.ndarray:
    """A contact sheet: each asset rendered alone (``size`` pixels) and labelled with its UID
    below it, in a grid of ``columns`` (default: about square). ``uids`` defaults to every
    asset of the registry's user libraries, library by library. A sheet over 16384 pixels a
    side raises ``UsageError`` before any asset is rendered."""
    func = "asset_sheet"
    r = _registry(registry)
    names = _core.render_user_uids(r) if uids is None else _v.strings(uids, "uids", func)
    w, h = _size(size, func)
    cols = 0 if columns is None else _v.integer(columns, "columns", func, minimum=1,
                                                maximum=_v.INT32_MAX)
    return _core.render_asset_sheet(r, names, w, h, cols, _gl(gl, func))


def asset(uid: str, *, registry: Any = None, size: tuple[int, int] = (256, 256),
          gl: str | None = None) -> np.ndarray:
    """One asset alone (lights, no floor, a plain background), from its front right above."""
    func = "asset"
    w, h = _size(size, func)
    return _core.render_asset(_registry(registry), _v.string(uid, "uid", func, empty=False), w, h,
                              _gl(gl, func))


def grasps(uid: str, *, joint: str | None = None, transforms: Any = None, registry: Any = None,
           grasp_libraries: Sequence[str] | None = None, num: int = 20, seed: int = 0,
           views: int = 4, gripper: str = "franka_droid", size: tuple[int, int] = (320, 320),
           gl: str | None = None) -> np.ndarray:
    """The asset with grasps drawn as gripper outlines (two fingers as wide apart as the open
    ``gripper``'s fingers, palm bar, stem; one colour per grasp) from ``views`` views around it.
    ``transforms``: ``(N, 4, 4)`` TCP poses in the asset's body frame (with ``joint``: in the
    frame of the body owning that joint, as joint grasp files store them); default ``num`` of
    the asset's pickup (or ``joint``) grasps from the registry (``grasp_libraries`` filters
    them): all when the file holds at most ``num``, else ``random.Random(seed).sample`` of
    them, as :func:`mlspaces.utils.grasps.load_pickup_grasps` draws them (``mlspaces render
    grasps --seed`` draws with the engine's own seeded subsampling instead)."""
    func = "grasps"
    name = _v.string(uid, "uid", func, empty=False)
    r = _registry(registry)
    joint_name = "" if joint is None else _v.string(joint, "joint", func, empty=False)
    gripper = _v.string(gripper, "gripper", func, empty=False)
    views = _v.integer(views, "views", func, minimum=1, maximum=64)
    w, h = _size(size, func)
    gl = _gl(gl, func)
    if transforms is None:
        libs = None if grasp_libraries is None else _v.strings(grasp_libraries,
                                                               "grasp_libraries", func)
        rng = random.Random(_v.integer(seed, "seed", func, minimum=0))
        transforms = r.load_grasps(name, joint_name, libs, _v.count(num, "num", func, minimum=1),
                                   rng.getrandbits)
    poses = np.ascontiguousarray(_v.array(transforms, "transforms", func, (None, 4, 4)),
                                 dtype=np.float64)
    return _core.render_grasps(r, name, poses, joint_name, gripper, views, w, h, gl)


def scene(config: Any, *, house: int = 0, episode: int = 0, seed: int | None = None,
          overviews: int = 1, size: tuple[int, int] = (320, 240),
          gl: str | None = None) -> np.ndarray:
    """The scene of house ``house`` as a datagen run composes it, robot placed and task sampled
    as episode ``episode`` (the next ones while the sampler rejects it), from ``overviews``
    overview views and each configured camera, labelled. ``config``: a YAML file path or a
    config object (``mlspaces.configs``, its Python task sampler class included, as
    :class:`mlspaces.tasks.gym_env.GymEnv` runs it); ``seed`` defaults to the config's, else
    0."""
    func = "scene"
    # The numbers first: a bad one is named before the config is read or its sampler made.
    house = _v.integer(house, "house", func, minimum=0)
    episode = _v.integer(episode, "episode", func, minimum=0)
    seed = _v.optional_integer(seed, "seed", func, minimum=0, maximum=_v.UINT64_MAX)
    overviews = _v.integer(overviews, "overviews", func, minimum=0, maximum=16)
    w, h = _size(size, func)
    gl = _gl(gl, func)
    if isinstance(config, (str, os.PathLike)):
        path = Path(_v.path(config, "config", func))
        try:
            text = path.read_text()
        except OSError as e:
            from .errors import MlspacesFileError
            raise MlspacesFileError(f"{path}: cannot read the config: {e.strerror}",
                                    path=str(path)) from None
        origin, base = str(path), str(path.resolve().parent)
        sampler = None
    else:
        from .configs import to_native
        from .tasks.opening_task_samplers import runs_in_python
        text = json.dumps(to_native(config))
        origin, base = f"<config {type(config).__qualname__}>", os.getcwd()
        # A sampler class written in Python runs its hooks (as GymEnv does); the engine's own
        # samplers go by name.
        cls = config.task_sampler_config.task_sampler_class
        sampler = cls(config) if runs_in_python(cls) else None
    return _core.render_scene(text, origin, base, house, episode, seed, overviews, w, h, gl,
                              sampler)


def episode_phases(dataset: str | os.PathLike[str], episode: int = 0, *,
                   camera: str | None = None, width: int = 320, columns: int | None = None,
                   frames: bool = False) -> Any:
    """An episode's camera frames (from its video) at each change of ``obs/extra/policy_phase``
    and at its end, each ``width`` pixels wide and labelled ``step <t>: <phase>``, in a grid.
    ``dataset``: a run folder, house folder or batch file; ``episode`` counts in
    :func:`mlspaces.read_dataset`'s order; ``camera`` defaults to the first by name. With
    ``frames=True`` returns ``(sheet, [frame, ...], info)``, the frames at their recorded size
    and ``info`` a dict (file, traj, camera, num_steps, steps, phases, phase_names)."""
    func = "episode_phases"
    frames = _v.boolean(frames, "frames", func)
    episode = _v.integer(episode, "episode", func, minimum=0)
    camera = "" if camera is None else _v.string(camera, "camera", func, empty=False)
    columns = 0 if columns is None else _v.integer(columns, "columns", func, minimum=1,
                                                   maximum=_v.INT32_MAX)
    width = _v.integer(width, "width", func, minimum=_core.MIN_PICTURE_SIDE,
                       maximum=_core.MAX_PICTURE_SIDE)
    sheet, images, info = _core.render_episode_phases(_existing(dataset, "dataset", func),
                                                      episode, camera, columns, width)
    return (sheet, images, info) if frames else sheet


def write_png(path: str | os.PathLike[str], image: Any) -> None:
    """Writes a ``uint8`` ``(H, W, 3)`` image as a PNG (to a temp file, renamed into place)."""
    func = "write_png"
    if (not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 3 or
            image.shape[2] != 3 or image.shape[0] < 1 or image.shape[1] < 1):
        raise _v.type_error(func, "image", "a uint8 (H, W, 3) array", image)
    _core.write_png(_v.path(path, "path", func), np.ascontiguousarray(image))


def read_png(path: str | os.PathLike[str]) -> np.ndarray:
    """A PNG as a fresh ``uint8`` ``(H, W, 3)`` array (alpha dropped)."""
    return _core.read_png(_existing(path, "path", "read_png"))
