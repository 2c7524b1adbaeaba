"""Reading a dataset: its episodes as dicts of numpy arrays, camera frames decoded on demand.

A dataset is what ``mlspaces datagen`` writes (docs/dataset.md): a run folder of
``house_<i>/trajectories_batch_<b>_of_<n>.h5`` files, each holding episodes ``traj_<k>``, and
one MP4 per camera and episode beside them. :func:`read_dataset` walks it in order (house
index, then batch, then ``k``, all numeric) and yields one :class:`Episode` per ``traj_<k>``::

    for ep in mlspaces.read_dataset("run"):
        qpos = ep["obs"]["agent"]["qpos"]          # list of T dicts (JSON rows decoded)
        rgb = ep["obs/sensor_data/wrist_camera"]   # (T, H, W, 3) uint8, decoded now

An episode reads its HDF5 group completely when it is created (no frames are stored in HDF5,
so that is small) and keeps no file open. What it holds:

- numeric and bool datasets as numpy arrays of their stored dtype and shape;
- the JSON datasets (uint8, zero-padded: ``actions/*``, ``obs/agent/*``, the uint8 ones of
  ``obs/extra``) as Python objects: a (T, W) dataset as a list of T values, a 1-D one as one
  value; ``obs_scene`` as a dict;
- ``obs/sensor_data``: a mapping of camera name to that camera's frames, decoded from its MP4
  only when a camera is looked up (``in`` and ``keys()`` decode nothing), then cached in the
  episode. Frames are RGB, one per observation, (T, H, W, 3) uint8, H and W as encoded
  (multiples of 16; a ``<cam>_depth`` video is depth as grey).

Needs h5py (``pip install h5py``, or the ``data`` extra: ``pip install 'mlspaces[data]'``);
``import mlspaces`` does not. Part files of an unfinished batch (``*.parts/``) are not read.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from . import _core
from . import _validate as _v
from .errors import MlspacesError

_HOUSE = re.compile(r"house_(\d+)")
_BATCH = re.compile(r"trajectories_batch_(\d+)_of_(\d+)\.h5")
_TRAJ = re.compile(r"traj_(\d+)")
#: Where uint8 datasets hold zero-padded JSON (docs/dataset.md, "Schema of traj_k").
_JSON_GROUPS = ("actions/", "obs/agent/", "obs/extra/")
_SENSOR_DATA = "obs/sensor_data"
_NOT_HDF5 = "cannot read it as an HDF5 batch file"


def _h5py() -> Any:
    try:
        import h5py
    except ImportError as e:
        raise ImportError("mlspaces.reader needs h5py to read datasets: pip install h5py "
                          "(or pip install 'mlspaces[data]')") from e
    return h5py


def _text(data: np.ndarray) -> bytes:
    return data.tobytes().rstrip(b"\0")


def _json(data: np.ndarray, where: str) -> Any:
    """One zero-padded JSON value (1-D uint8), or a list of one per row (2-D)."""
    try:
        if data.ndim == 1:
            return json.loads(_text(data))
        return [json.loads(_text(row)) for row in data]
    except ValueError as e:
        raise MlspacesError(f"{where}: not JSON text: {e}", path=where) from None


class CameraFrames(Mapping):
    """An episode's ``obs/sensor_data``: camera name -> (T, H, W, 3) uint8 frames, each camera
    decoded from its MP4 when first looked up (:meth:`Episode.frames`)."""

    def __init__(self, episode: Episode) -> None:
        self._episode = episode

    def __getitem__(self, camera: str) -> np.ndarray:
        if camera not in self._episode.video_files:
            raise KeyError(camera)
        return self._episode.frames(camera)

    def __contains__(self, camera: object) -> bool:  # Mapping's would decode the video
        return camera in self._episode.video_files

    def __iter__(self) -> Iterator[str]:
        return iter(self._episode.video_files)

    def __len__(self) -> int:
        return len(self._episode.video_files)

    def __repr__(self) -> str:
        return f"CameraFrames({list(self)!r})"

    # Identity, not Mapping's item-by-item comparison (which would decode every video).
    __eq__ = object.__eq__
    __hash__ = object.__hash__


class Episode(Mapping):
    """One episode (``traj_<k>`` of a batch file) as a mapping of its top-level
    members (``actions``, ``env_states``, ``obs``, ``obs_scene``, ``rewards``, ``success``,
    ``terminated``, ``truncated``, ``fail``) to numpy arrays, decoded JSON and nested dicts.

    ``ep["obs/agent/qpos"]`` is ``ep["obs"]["agent"]["qpos"]``. Camera frames under
    ``obs/sensor_data/<camera>`` are decoded on first access and cached (:meth:`frames`).
    """

    def __init__(self, batch_file: Path, traj: str, house: int | None, index: int,
                 data: dict[str, Any], video_files: dict[str, str],
                 provenance: dict[str, Any] | None) -> None:
        #: The house index ``i`` of ``house_<i>`` (``None`` for a folder not named so).
        self.house = house
        #: The ``trajectories_batch_<b>_of_<n>.h5`` file holding the episode.
        self.batch_file = batch_file
        #: The episode's group in the batch file, ``"traj_<k>"``.
        self.traj = traj
        #: The episode's 0-based position in the whole dataset, in :func:`read_dataset` order.
        self.index = index
        #: Camera name -> the MP4's file name (beside the batch file), as ``obs/sensor_data``
        #: records it.
        self.video_files = video_files
        #: The ``provenance`` attribute of the group, decoded (``None`` when absent).
        self.provenance = provenance
        self._data = data
        self._frames: dict[str, np.ndarray] = {}
        data.setdefault("obs", {})["sensor_data"] = CameraFrames(self)

    @property
    def robot(self) -> dict[str, str] | None:
        """The robot that recorded the episode, ``{"name", "description_hash"}`` from the
        provenance (the hash is :func:`mlspaces.robots.load_robot_description`'s ``hash``);
        ``None`` for a run written before robots were recorded."""
        robot = (self.provenance or {}).get("robot")
        return dict(robot) if isinstance(robot, dict) else None

    @property
    def cameras(self) -> list[str]:
        """The camera names of ``obs/sensor_data``, in file order (``<cam>_depth`` included)."""
        return list(self.video_files)

    @property
    def num_steps(self) -> int:
        """T, the number of observations (rows of ``success``)."""
        return len(self._data["success"])

    def video_path(self, camera: str) -> Path:
        """The MP4 of ``camera``. Raises ``KeyError`` for a camera the episode does not have."""
        camera = _v.string(camera, "camera", "Episode.video_path")
        if camera not in self.video_files:
            raise KeyError(f"{self.traj} of {self.batch_file} has no camera {camera!r}; "
                           f"cameras: {', '.join(self.video_files) or 'none'}")
        return self.batch_file.parent / self.video_files[camera]

    def frames(self, camera: str) -> np.ndarray:
        """Every frame of ``camera`` as a (T, H, W, 3) uint8 RGB array, decoded from its MP4 on
        the first call and cached. Raises ``KeyError`` for an unknown camera and ``ValueError``
        (:class:`MlspacesError`) naming the file for a missing or corrupt video."""
        camera = _v.string(camera, "camera", "Episode.frames")
        if camera not in self._frames:
            self._frames[camera] = _core.decode_video(self.video_path(camera))
        return self._frames[camera]

    def __getitem__(self, key: str) -> Any:
        if key not in self:
            raise KeyError(key)
        value: Any = self._data
        for part in key.split("/"):
            value = value[part]
        return value

    def __contains__(self, key: object) -> bool:  # Mapping's would decode a camera's video
        if not isinstance(key, str):
            return False
        parts = key.split("/")
        value: Any = self._data
        for i, part in enumerate(parts):
            if not isinstance(value, Mapping) or part not in value:
                return False
            if isinstance(value, CameraFrames):
                return i == len(parts) - 1
            value = value[part]
        return True

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    # Identity, not Mapping's item-by-item comparison (which would decode every video).
    __eq__ = object.__eq__
    __hash__ = object.__hash__

    def __repr__(self) -> str:
        return (f"Episode(house={self.house}, batch_file={str(self.batch_file)!r}, "
                f"traj={self.traj!r}, index={self.index}, steps={self.num_steps}, "
                f"cameras={self.cameras})")


def _read_group(group: Any, path: str, h5py: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, item in group.items():
        where = f"{path}/{name}" if path else name
        if where == _SENSOR_DATA:
            out[name] = None  # Episode puts its CameraFrames here (keeping the file's order)
            continue
        if isinstance(item, h5py.Group):
            out[name] = _read_group(item, where, h5py)
        elif h5py.check_string_dtype(item.dtype) is not None:
            text = item.asstr()[()]
            out[name] = json.loads(text) if where == "obs_scene" else text
        else:
            data = item[()]
            if data.dtype == np.uint8 and where.startswith(_JSON_GROUPS):
                data = _json(data, f"{group.file.filename}: {group.name}/{name}")
            out[name] = data
    return out


def _read_episode(f: Any, batch_file: Path, traj: str, house: int | None, index: int,
                  h5py: Any) -> Episode:
    group = f[traj]
    data = _read_group(group, "", h5py)
    video_files = {}
    if _SENSOR_DATA in group:
        for camera, item in group[_SENSOR_DATA].items():
            video_files[camera] = _text(item[()]).decode()
    provenance = group.attrs.get("provenance")
    if provenance is not None:
        try:
            provenance = json.loads(provenance)
        except ValueError as e:
            raise MlspacesError(f"{batch_file}: {traj} attribute provenance: not JSON text: {e}",
                                path=str(batch_file), field=f"{traj}/provenance") from None
    return Episode(batch_file, traj, house, index, data, video_files, provenance)


def _number(pattern: re.Pattern[str], name: str) -> int | None:
    m = pattern.fullmatch(name)
    return int(m.group(1)) if m else None


def _trajs(f: Any) -> list[str]:
    return sorted((k for k in f.keys() if _number(_TRAJ, k) is not None),
                  key=lambda k: _number(_TRAJ, k))


class Dataset:
    """The episodes of a run folder (or of one ``house_<i>`` folder), in order: house index,
    batch, then ``traj_<k>`` (all numeric). Iterate it for :class:`Episode` objects (every
    iteration reads the files again); ``len()`` is the number of episodes."""

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(_v.path(folder, "folder", "read_dataset"))
        if not self.folder.is_dir():
            why = (" (a file: read_dataset takes a run folder or a house_<i> folder)"
                   if self.folder.exists() else "")
            raise FileNotFoundError(f"dataset folder not found: {self.folder}{why}")
        houses = sorted(((n, p) for p in self.folder.iterdir()
                         if p.is_dir() and (n := _number(_HOUSE, p.name)) is not None),
                        key=lambda x: x[0])
        if not houses:
            if not any(_BATCH.fullmatch(p.name) for p in self.folder.iterdir()):
                raise MlspacesError(f"{self.folder}: not a dataset folder (no house_<i> folders "
                                    "and no trajectories_batch_<b>_of_<n>.h5 files)",
                                    path=str(self.folder))
            houses = [(_number(_HOUSE, self.folder.name), self.folder)]
        #: ``(house index, batch file)`` of every batch file, in reading order.
        self.batch_files: list[tuple[int | None, Path]] = []
        for house, d in houses:
            batches = sorted((p for p in d.iterdir() if _BATCH.fullmatch(p.name)),
                             key=lambda p: _number(_BATCH, p.name))
            self.batch_files += [(house, p) for p in batches]
        self._num_episodes: int | None = None

    @property
    def num_episodes(self) -> int:
        """How many episodes the batch files hold (counted once, on first use)."""
        if self._num_episodes is None:
            h5py = _h5py()
            n = 0
            for _, path in self.batch_files:
                with _v.reading(path, _NOT_HDF5), h5py.File(path, "r") as f:
                    n += len(_trajs(f))
            self._num_episodes = n
        return self._num_episodes

    def __len__(self) -> int:
        return self.num_episodes

    def __iter__(self) -> Iterator[Episode]:
        h5py = _h5py()
        index = 0
        for house, path in self.batch_files:
            # A file that is not HDF5 (or is cut short) raises from h5py without its name.
            with _v.reading(path, _NOT_HDF5), h5py.File(path, "r") as f:
                for traj in _trajs(f):
                    yield _read_episode(f, path, traj, house, index, h5py)
                    index += 1

    def __repr__(self) -> str:
        return f"Dataset({str(self.folder)!r}, batch_files={len(self.batch_files)})"


def read_dataset(folder: str | os.PathLike[str]) -> Dataset:
    """The episodes of the dataset in ``folder`` (a run folder of ``house_<i>`` folders, or one
    house folder): a :class:`Dataset`, iterated for one :class:`Episode` per ``traj_<k>``.

    Raises ``FileNotFoundError`` for a missing folder, ``ValueError`` (:class:`MlspacesError`)
    for a folder holding no dataset, ``TypeError`` for a ``folder`` that is not a path, and
    ``ImportError`` without h5py. Reading a batch file that is not HDF5 or is cut short raises
    :class:`~mlspaces.errors.MlspacesFileError` (an ``OSError``) naming it."""
    _h5py()
    return Dataset(folder)


__all__ = ["CameraFrames", "Dataset", "Episode", "read_dataset"]
