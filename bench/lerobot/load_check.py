"""Loads an exported dataset with LeRobot's own loader and checks it against the mlspaces run.

Run with the venv of bench/lerobot/make_venv.sh (lerobot 0.4.x, offline):

    <venv>/bin/python bench/lerobot/load_check.py EXPORT_DIR RUN_DIR [--repo-id local/x]

LeRobotDataset(repo_id, root=EXPORT_DIR) is opened offline with the PyAV video backend, every
frame is read (ds[i]: parquet row plus one decoded frame per camera), and compared with the run's
HDF5 episodes (h5py: qpos rows, the commanded action of the next row, rewards) and with the
episodes' own MP4 frames (PyAV). Prints one summary line; exits 1 on the first mismatch.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from pathlib import Path

os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("HF_DATASETS_OFFLINE", "1")

import av  # noqa: E402
import h5py  # noqa: E402
import numpy as np  # noqa: E402
from lerobot.datasets.lerobot_dataset import LeRobotDataset  # noqa: E402


def _rows(ds) -> list[dict]:
    return [json.loads(bytes(r).rstrip(b"\0")) for r in ds[()]]


def _flat(row: dict) -> list[float]:
    return [v for g in sorted(row) for v in row[g]]


def _episodes(run: Path):
    """(group, folder) of every exported episode, in export order."""
    num = lambda p, pat: int(re.fullmatch(pat, p.name).group(1))  # noqa: E731
    houses = sorted((p for p in run.iterdir() if re.fullmatch(r"house_(\d+)", p.name)),
                    key=lambda p: num(p, r"house_(\d+)")) or [run]
    for h in houses:
        pat = r"trajectories_batch_(\d+)_of_\d+\.h5"
        for b in sorted((p for p in h.iterdir() if re.fullmatch(pat, p.name)),
                        key=lambda p: num(p, pat)):
            f = h5py.File(b, "r")
            for k in sorted((k for k in f if re.fullmatch(r"traj_\d+", k)),
                            key=lambda k: int(k[5:])):
                g = f[k]
                if g["success"][-1] and not g["truncated"][-1] and len(g["success"]) > 1:
                    yield g, h


def _frames(path: Path) -> np.ndarray:
    with av.open(str(path)) as c:
        return np.stack([f.to_ndarray(format="rgb24") for f in c.decode(video=0)])


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("export_dir", type=Path)
    ap.add_argument("run_dir", type=Path)
    ap.add_argument("--repo-id", default="local/mlspaces_export")
    ap.add_argument("--max-pixel-diff", type=float, default=0.0,
                    help="largest allowed difference of a decoded pixel (0..1) from the "
                         "episode's own video: 0 for --codec copy, more for a re-encoded export")
    a = ap.parse_args()
    t0 = time.perf_counter()
    ds = LeRobotDataset(a.repo_id, root=a.export_dir, video_backend="pyav")
    cams = list(ds.meta.video_keys)
    for key, ft in ds.meta.features.items():  # stats as LeRobot's normalization reads them
        want = (3, 1, 1) if ft["dtype"] == "video" else tuple(ft["shape"])
        for stat in ("min", "max", "mean", "std"):
            got = np.asarray(ds.meta.stats[key][stat]).shape
            if got != want:
                print(f"FAIL: stats.json {key}/{stat} has shape {got}, expected {want}")
                return 1
    eps = list(_episodes(a.run_dir))
    if ds.num_episodes != len(eps):
        print(f"FAIL: LeRobot sees {ds.num_episodes} episodes, the run has {len(eps)}")
        return 1
    n = 0
    max_pixel_diff = 0.0
    for e, (g, folder) in enumerate(eps):
        qpos = np.array([_flat(r) for r in _rows(g["obs/agent/qpos"])], np.float32)
        cmd = np.array([_flat(r) for r in _rows(g["actions/commanded_action"])[1:]], np.float32)
        rewards = g["rewards"][1:]
        videos = {}
        for key in cams:
            cam = key.removeprefix("observation.images.")
            name = bytes(g[f"obs/sensor_data/{cam}"][()]).rstrip(b"\0").decode()
            videos[key] = _frames(folder / name)
        task = json.loads(g["obs_scene"][()])["task_description"]
        start = int(ds.meta.episodes[e]["dataset_from_index"])
        for i in range(len(qpos) - 1):
            item = ds[start + i]
            ok = (int(item["episode_index"]) == e and int(item["frame_index"]) == i
                  and np.array_equal(item["observation.state"].numpy(), qpos[i])
                  and np.array_equal(item["action"].numpy(), cmd[i])
                  and float(item["next.reward"]) == float(rewards[i])
                  and item["task"] == task)
            if not ok:
                print(f"FAIL: episode {e} frame {i} differs from {g.file.filename} {g.name}")
                return 1
            for key in cams:
                img = item[key].numpy()  # (3, H, W) float in [0, 1]
                want = videos[key][i].transpose(2, 0, 1).astype(np.float32) / 255.0
                if img.shape != want.shape:
                    print(f"FAIL: {key} episode {e} frame {i}: shape {img.shape} != {want.shape}")
                    return 1
                max_pixel_diff = max(max_pixel_diff, float(np.abs(img - want).max()))
            n += 1
    if n != ds.num_frames:
        print(f"FAIL: read {n} frames, LeRobot lists {ds.num_frames}")
        return 1
    if max_pixel_diff > a.max_pixel_diff + 1e-6:
        print(f"FAIL: decoded frames differ from the episodes' own by up to {max_pixel_diff}")
        return 1
    dt = time.perf_counter() - t0
    print(f"ok: LeRobotDataset read {n} frames of {ds.num_episodes} episodes, {len(cams)} cameras "
          f"({', '.join(cams)}), fps {ds.fps:.4g}, every number equal to the HDF5 run's and every "
          f"frame within {max_pixel_diff:.3g} of the episodes' own videos; {dt:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
