"""Pose helpers (canonical name; ``mlspaces.utils.pose`` mirrors MolmoSpaces' path)."""

from .utils.pose import pos_quat_to_pose_mat, pose_mat_to_7d, pose_mat_to_pos_quat

__all__ = ["pos_quat_to_pose_mat", "pose_mat_to_7d", "pose_mat_to_pos_quat"]
