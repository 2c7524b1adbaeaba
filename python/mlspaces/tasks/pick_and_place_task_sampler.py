"""``PickAndPlaceTaskSampler`` and its variants (``molmo_spaces.tasks.pick_and_place_task_sampler``,
``pick_and_place_next_to_task_sampler``, ``pick_and_place_color_task_sampler``): the
pick-and-place samplers, for configs with ``task_type`` "pick_and_place",
"pick_and_place_next_to" or "pick_and_place_color" (docs/tasks.md).

``task_sampler_class=PickAndPlaceTaskSampler`` (or one of the variants) runs the engine's
sampler of that name in C++: receptacles added when the scene is built, one placed around the
pickup object each episode (next to: a scene object chosen as the target; colour: two coloured
copies). A subclass may override the hooks of ``PickTaskSampler`` as for
``OpenTaskSampler`` (``opening_task_samplers``): the overridden ones run in Python, the others
in C++; ``super()._sample_and_place_robot(env)`` moves the robot and the object, places the
receptacle(s) and sets ``task_config``'s three poses, which the override may then change (an
override that does not call it leaves no place target, and the run stops with an
``MlspacesError``)."""

from __future__ import annotations

from .pick_task_sampler import PickTaskSampler


class PickAndPlaceTaskSampler(PickTaskSampler):
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
