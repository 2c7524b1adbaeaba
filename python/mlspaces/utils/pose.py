"""Pose helpers (``molmo_spaces.utils.pose``): 4x4 matrices and ``[x, y, z, qw, qx, qy, qz]``.

Quaternions are scalar-first (MuJoCo's order) and come out exactly as scipy's
``Rotation.from_matrix(R).as_quat(scalar_first=True)`` gives them: the same branch choice
(the largest of the diagonal and the trace) and no sign canonicalisation, so a pose written by
MolmoSpaces code and by this module is the same bytes. scipy is not needed.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as _v


def _as_matrix(pose_matrix, what: str = "pose_matrix", func: str = "pose_mat_to_7d"
               ) -> np.ndarray:
    """A finite (4, 4) float64 matrix; ``TypeError`` / ``ValueError`` naming ``what``."""
    if type(pose_matrix) is np.ndarray and pose_matrix.shape == (4, 4) \
            and pose_matrix.dtype == np.float64 and np.isfinite(pose_matrix).all():
        return pose_matrix
    return _v.array(pose_matrix, what, func, (4, 4))


def _quat_from_rotation(r: np.ndarray) -> np.ndarray:
    """scipy's from_matrix for one 3x3 matrix, as [w, x, y, z]."""
    decision = (r[0, 0], r[1, 1], r[2, 2], r[0, 0] + r[1, 1] + r[2, 2])
    choice = int(np.argmax(decision))
    q = np.empty(4)  # x, y, z, w (scipy's internal order)
    if choice != 3:
        i = choice
        j = (i + 1) % 3
        k = (j + 1) % 3
        q[i] = 1 - decision[3] + 2 * r[i, i]
        q[j] = r[j, i] + r[i, j]
        q[k] = r[k, i] + r[i, k]
        q[3] = r[k, j] - r[j, k]
    else:
        q[0] = r[2, 1] - r[1, 2]
        q[1] = r[0, 2] - r[2, 0]
        q[2] = r[1, 0] - r[0, 1]
        q[3] = 1 + decision[3]
    q /= np.sqrt(q @ q)
    return np.array([q[3], q[0], q[1], q[2]])


def _rotation_from_quat(quat) -> np.ndarray:
    w, x, y, z = np.asarray(quat, dtype=np.float64) / np.linalg.norm(quat)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def pose_mat_to_7d(pose_matrix) -> np.ndarray:
    """``[x, y, z, qw, qx, qy, qz]`` of a 4x4 pose: a fresh, writable float64 array.
    Raises ``ValueError`` for another shape (MolmoSpaces asserts)."""
    m = _as_matrix(pose_matrix)
    out = np.empty(7)
    out[:3] = m[:3, 3]
    out[3:] = _quat_from_rotation(m[:3, :3])
    return out


def pos_quat_to_pose_mat(pos, quat=None) -> np.ndarray:
    """A 4x4 pose from a position and a ``[w, x, y, z]`` quaternion, or from one 7-vector
    when ``quat`` is ``None``."""
    func = "pos_quat_to_pose_mat"
    if quat is None:
        pos = _v.array(pos, "pos", func).reshape(-1)
        if pos.shape != (7,):
            raise _v.value_error(func, "pos", f"expected 7 values (xyz + wxyz) when quat is "
                                              f"None, got {pos.shape[0]}")
        pos, quat = pos[:3], pos[3:]
    else:
        pos = _v.array(pos, "pos", func, (3,))
        quat = _v.array(quat, "quat", func, (4,))
    if not np.any(quat):
        raise _v.value_error(func, "quat", "expected a non-zero quaternion, got [0, 0, 0, 0]")
    out = np.eye(4)
    out[:3, :3] = _rotation_from_quat(quat)
    out[:3, 3] = pos
    return out


def pose_mat_to_pos_quat(pose) -> tuple[np.ndarray, np.ndarray]:
    """``(pos, quat)`` of a 4x4 pose; ``pos`` is a view into ``pose`` (as MolmoSpaces)."""
    m = (pose if isinstance(pose, np.ndarray) and pose.shape == (4, 4)
         and pose.dtype.kind == "f" and np.isfinite(pose).all()
         else _as_matrix(pose, "pose", "pose_mat_to_pos_quat"))
    return m[:3, 3], _quat_from_rotation(np.asarray(m[:3, :3], dtype=np.float64))


__all__ = ["pose_mat_to_7d", "pos_quat_to_pose_mat", "pose_mat_to_pos_quat"]
