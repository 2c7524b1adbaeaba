"""``PickPlannerPolicyConfig`` (``molmo_spaces.configs.policy_configs``): the scripted pick
planner's parameters (lengths in metres, speeds in m/s, durations in seconds)."""

from __future__ import annotations

from typing import Any

from ._fields import engine_model

PickPlannerPolicyConfig = engine_model(
    "PickPlannerPolicyConfig", __name__, ("policy_config",),
    "The pick planner: approach offsets, speeds, gripper timings, retries, grasp filtering "
    "and ranking.",
    grasp_libraries=(Any, None),
)

__all__ = ["PickPlannerPolicyConfig"]
