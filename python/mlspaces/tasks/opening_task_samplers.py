"""``OpenTaskSampler`` (``molmo_spaces.tasks.opening_task_samplers``): the open / close task
sampler, for configs with ``task_type`` "open" or "close" (docs/tasks.md).

``task_sampler_class=OpenTaskSampler`` runs the engine's sampler of that name in C++: the
articulated object and its joint drawn per episode among those with joint grasps, the joint's
initial opened fraction (``target_initial_state_open_percentage``), the robot base noise. Its
hooks cannot be overridden from Python yet: a subclass that overrides one is refused when the
run starts (``MlspacesError`` naming ``task_sampler_config.task_sampler_class``)."""

from __future__ import annotations

from typing import Any

from ..errors import MlspacesError
from .pick_task_sampler import BaseMujocoTaskSampler

_HOOKS = ("init_scene", "randomize_scene", "_on_candidate_selected", "_sample_and_place_robot")


class OpenTaskSampler(BaseMujocoTaskSampler):
    """The engine's ``OpenTaskSampler`` (see the module doc)."""

    _engine_sampler = "OpenTaskSampler"


def engine_sampler_name(cls: Any) -> str | None:
    """The engine sampler that runs for ``task_sampler_class`` `cls`: ``"OpenTaskSampler"`` for
    ``OpenTaskSampler`` and its subclasses, else None. Raises ``MlspacesError`` for a subclass
    that overrides a hook."""
    if not isinstance(cls, type):
        return None
    # The engine class: OpenTaskSampler, or one of pick_and_place_task_sampler's (the nearest
    # class of the MRO that names an engine sampler).
    engine = next((c for c in cls.__mro__ if "_engine_sampler" in c.__dict__), None)
    if engine is None:
        return None
    overridden = [h for h in _HOOKS
                  if getattr(cls, h, None) is not getattr(engine, h, None)]
    if overridden:
        raise MlspacesError(
            f"task_sampler_config.task_sampler_class: {cls.__qualname__} overrides "
            f"{', '.join(overridden)}; {engine.__name__}'s hooks run in the engine and cannot be "
            "overridden from Python yet (docs/tasks.md)")
    return engine._engine_sampler


__all__ = ["OpenTaskSampler", "engine_sampler_name"]
