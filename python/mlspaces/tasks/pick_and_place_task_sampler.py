"""``PickAndPlaceTaskSampler`` and its variants (``molmo_spaces.tasks.pick_and_place_task_sampler``,
``pick_and_place_next_to_task_sampler``, ``pick_and_place_color_task_sampler``): the
pick-and-place samplers, for configs with ``task_type`` "pick_and_place",
"pick_and_place_next_to" or "pick_and_place_color" (docs/tasks.md).

``task_sampler_class=PickAndPlaceTaskSampler`` (or one of the variants) runs the engine's
sampler of that name in C++: receptacles added when the scene is built, one placed around the
pickup object each episode (next to: a scene object chosen as the target; colour: two coloured
copies). Its hooks cannot be overridden from Python yet: a subclass that overrides one is
refused when the run starts (``MlspacesError`` naming
``task_sampler_config.task_sampler_class``)."""

from __future__ import annotations

from .pick_task_sampler import BaseMujocoTaskSampler


class PickAndPlaceTaskSampler(BaseMujocoTaskSampler):
    """The engine's ``PickAndPlaceTaskSampler`` (see the module doc)."""

    _engine_sampler = "PickAndPlaceTaskSampler"


PickAndPlaceReceptacleTaskSampler = PickAndPlaceTaskSampler


class PickAndPlaceNextToTaskSampler(PickAndPlaceTaskSampler):
    """The engine's ``PickAndPlaceNextToTaskSampler`` (see the module doc)."""

    _engine_sampler = "PickAndPlaceNextToTaskSampler"


class PickAndPlaceColorTaskSampler(PickAndPlaceTaskSampler):
    """The engine's ``PickAndPlaceColorTaskSampler`` (see the module doc)."""

    _engine_sampler = "PickAndPlaceColorTaskSampler"



__all__ = ["PickAndPlaceColorTaskSampler", "PickAndPlaceNextToTaskSampler",
           "PickAndPlaceReceptacleTaskSampler", "PickAndPlaceTaskSampler"]
