"""``OpenTaskSampler`` (``molmo_spaces.tasks.opening_task_samplers``): the open / close task
sampler, for configs with ``task_type`` "open" or "close" (docs/tasks.md).

``task_sampler_class=OpenTaskSampler`` runs the engine's sampler of that name in C++: the
articulated object and its joint drawn per episode among those with joint grasps, the joint's
initial opened fraction (``target_initial_state_open_percentage``), the robot base noise.

A subclass may override the hooks of ``PickTaskSampler`` (``init_scene``,
``randomize_scene``, ``_on_candidate_selected``, ``_sample_and_place_robot``): the engine calls
the overridden ones in Python and runs the others in C++, as for pick. ``super()`` reaches the
engine's own: ``super()._sample_and_place_robot(env)`` chooses the joint, writes its initial
position, places the robot and sets ``task_config``'s three poses, which the override may then
change (an override that does not call it leaves no joint, and the run stops with an
``MlspacesError``: the sampler "chose no joint")."""

from __future__ import annotations

from typing import Any

from .pick_task_sampler import PickTaskSampler

_HOOKS = ("init_scene", "randomize_scene", "_on_candidate_selected", "_sample_and_place_robot")


class OpenTaskSampler(PickTaskSampler):
    """The engine's ``OpenTaskSampler`` (see the module doc)."""

    _engine_sampler = "OpenTaskSampler"


def _engine_class(cls: Any) -> type | None:
    # The engine class: OpenTaskSampler, or one of pick_and_place_task_sampler's (the nearest
    # class of the MRO that names an engine sampler).
    if not isinstance(cls, type):
        return None
    return next((c for c in cls.__mro__ if "_engine_sampler" in c.__dict__), None)


def engine_sampler_name(cls: Any) -> str | None:
    """The engine sampler that `cls` (a ``task_sampler_class``) stands for:
    ``"OpenTaskSampler"`` for ``OpenTaskSampler`` and its subclasses (likewise the
    pick-and-place classes), else None (``PickTaskSampler``: block_pickup)."""
    engine = _engine_class(cls)
    return None if engine is None else engine._engine_sampler


def overridden_hooks(cls: Any) -> list[str]:
    """The hooks `cls` overrides relative to its engine class (or ``PickTaskSampler``): those
    that run in Python."""
    if not isinstance(cls, type):
        return []
    base = _engine_class(cls) or PickTaskSampler
    return [h for h in _HOOKS if getattr(cls, h, None) is not getattr(base, h, None)]


def runs_in_python(cls: Any) -> bool:
    """Whether a ``task_sampler_class`` needs a Python sampler object: a class that stands
    for no engine sampler (a ``PickTaskSampler`` subclass) or overrides a hook. An engine
    class itself runs in C++ by name."""
    return isinstance(cls, type) and (engine_sampler_name(cls) is None or
                                      bool(overridden_hooks(cls)))


__all__ = ["OpenTaskSampler", "engine_sampler_name", "overridden_hooks", "runs_in_python"]
