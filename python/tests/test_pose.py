"""Pose helpers against scipy, which MolmoSpaces' pose code calls."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mlspaces.utils.pose import pos_quat_to_pose_mat, pose_mat_to_7d, pose_mat_to_pos_quat

from conftest import random_poses


def test_pose_mat_to_7d_equals_scipy_on_1000_rotations_sign_included():
    poses = random_poses(1000, 42)
    # Rotations near each branch of the quaternion extraction (half turns about x, y, z).
    for axis in range(3):
        p = np.eye(4)
        p[:3, :3] = Rotation.from_rotvec(np.eye(3)[axis] * (np.pi - 1e-3)).as_matrix()
        poses = np.concatenate([poses, p[None]])
    for pose in poses:
        got = pose_mat_to_7d(pose)
        want = Rotation.from_matrix(pose[:3, :3]).as_quat(scalar_first=True)
        np.testing.assert_array_equal(got[:3], pose[:3, 3])
        np.testing.assert_allclose(got[3:], want, rtol=0, atol=1e-15)
        assert np.sign(got[3:][np.argmax(np.abs(want))]) == np.sign(want[np.argmax(np.abs(want))])


def test_7d_is_fresh_and_writable_and_round_trips():
    pose = random_poses(1, 9)[0]
    seven = pose_mat_to_7d(pose)
    seven[2] += 0.05  # the tutorial edits the goal in place
    assert seven.flags.writeable and not np.shares_memory(seven, pose)
    back = pos_quat_to_pose_mat(pose_mat_to_7d(pose))
    np.testing.assert_allclose(back, pose, atol=1e-14)
    pos, quat = pose_mat_to_pos_quat(pose)
    assert np.shares_memory(pos, pose)  # a view, as the original
    np.testing.assert_allclose(pos_quat_to_pose_mat(pos, quat), pose, atol=1e-14)


def test_bad_shapes_are_value_errors():
    for bad in (np.zeros((3, 3)), np.zeros(16), [[1, 2], [3, 4]], None):
        with pytest.raises(ValueError):
            pose_mat_to_7d(bad)
    with pytest.raises(ValueError, match="7 values"):
        pos_quat_to_pose_mat([1, 2, 3])
