"""``PickTaskConfig`` (``molmo_spaces.configs.task_configs``): what the sampler fills per
episode. A sampler hook reads and writes it as ``self.config.task_config``."""

from __future__ import annotations

from typing import Any

from ._fields import engine_model

PickTaskConfig = engine_model(
    "PickTaskConfig", __name__, ("task_config",),
    "Per-episode task fields: pickup_obj_name (set before the hook), robot_base_pose, "
    "pickup_obj_start_pose and pickup_obj_goal_pose (7 floats each: x, y, z, qw, qx, qy, qz, "
    "world frame), receptacle_name, succ_pos_threshold, ...",
    task_cls=(Any, "pick"),
    referral_expressions=(Any, None),
)

__all__ = ["PickTaskConfig"]
