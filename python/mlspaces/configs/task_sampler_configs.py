"""``PickTaskSamplerConfig`` (``molmo_spaces.configs.task_sampler_configs``)."""

from __future__ import annotations

import math
from typing import Any

from ._fields import engine_model

PickTaskSamplerConfig = engine_model(
    "PickTaskSamplerConfig", __name__, ("task_sampler_config",),
    "Scenes and sampling: task_sampler_class (a PickTaskSampler subclass, or the name of an "
    "engine sampler such as 'block_pickup'), scene_xml_paths, house_inds, samples_per_house, "
    "house_variant, episodes_per_batch, max_tasks, pickup_types, grasp_libraries, ...",
    task_sampler_class=(Any, None),
    scene_xml_paths=(Any, None),
    max_tasks=(Any, math.inf),
    pickup_types=(Any, None),
)

__all__ = ["PickTaskSamplerConfig"]
