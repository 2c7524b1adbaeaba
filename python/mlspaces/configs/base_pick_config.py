"""``PickBaseConfig`` (``molmo_spaces.configs.base_pick_config``): the whole pick datagen
config. Subclass it and annotate class attributes to change defaults, as the tutorial does."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import Field

from ._base import DEFAULTS, Config, native_value
from ._fields import engine_model
from .camera_configs import CameraSystemConfig, FrankaDroidCameraSystem
from .policy_configs import PickPlannerPolicyConfig
from .robot_configs import BaseRobotConfig, FrankaRobotConfig
from .task_configs import PickTaskConfig
from .task_sampler_configs import PickTaskSamplerConfig

_NESTED = ("libraries", "task_config", "task_sampler_config", "robot_config", "camera_config",
           "policy_config")
_TOP = {k: v for k, v in DEFAULTS.items() if k not in _NESTED and k != "tag"}


class MlSpacesExpConfig(Config):
    """Base of experiment configs (MolmoSpaces' name)."""

    def model_post_init(self, __context: Any) -> None:  # noqa: D401 - pydantic hook
        for name in ("policy_dt_ms", "ctrl_dt_ms"):
            a, b = getattr(self, name, None), getattr(self, "sim_dt_ms", None)
            if a is not None and b and abs(a / b - round(a / b)) > 1e-9:
                raise ValueError(f"{name} ({a}) must be a whole multiple of sim_dt_ms ({b})")

    @property
    def tag(self) -> str:
        """The run's tag (the folder name when output_dir is None); subclasses override it."""
        return DEFAULTS["tag"]


PickBaseConfig = engine_model(
    "PickBaseConfig", __name__, (),
    "The pick datagen config (PickBaseConfig's fields and defaults). Libraries come from the "
    "registrations (register_user_asset_library / register_user_grasp_library).",
    base=MlSpacesExpConfig,
    libraries=(Any, None),
    tag=None,
    seed=(Any, None),
    output_dir=(Any, None),
    task_config=(PickTaskConfig, Field(default_factory=PickTaskConfig)),
    task_sampler_config=(PickTaskSamplerConfig, Field(default_factory=PickTaskSamplerConfig)),
    robot_config=(BaseRobotConfig, Field(default_factory=FrankaRobotConfig)),
    camera_config=(CameraSystemConfig, Field(default_factory=FrankaDroidCameraSystem)),
    policy_config=(PickPlannerPolicyConfig, Field(default_factory=PickPlannerPolicyConfig)),
)


def to_native(config: Config, registry: Any = None) -> dict[str, Any]:
    """The engine's config dict of a config object: every field the engine knows, in its
    layout (classes as ``module:qualname``, paths as str, ``inf`` as null), ``tag`` from the
    (possibly overridden) property, and ``libraries`` from ``config.libraries`` or else the
    registrations of `registry` (default: the process-default registry)."""
    out: dict[str, Any] = {}
    for key, template in DEFAULTS.items():
        if key == "tag":
            tag = getattr(config, "tag", None)
            out["tag"] = tag if isinstance(tag, str) else DEFAULTS["tag"]
            continue
        if key == "libraries":
            libs = getattr(config, "libraries", None)
            if libs is None:
                from .._registry import default_registry
                libs = (registry or default_registry()).library_config()
            out["libraries"] = native_value(libs, template)
            continue
        if not hasattr(config, key):
            continue
        out[key] = native_value(getattr(config, key), template)
    task = out.get("task_config")
    if task is not None and not isinstance(getattr(config.task_config, "task_cls", "pick"), str):
        task["task_cls"] = "pick"
    sampler = out.get("task_sampler_config", {})
    if sampler.get("task_sampler_class") is None:
        sampler["task_sampler_class"] = DEFAULTS["task_sampler_config"]["task_sampler_class"]
    from ..tasks.opening_task_samplers import engine_sampler_name  # late: tasks imports configs
    engine = engine_sampler_name(getattr(config.task_sampler_config, "task_sampler_class", None))
    if engine is not None:
        sampler["task_sampler_class"] = engine
    for key in ("scene_xml_paths", "pickup_types"):
        if sampler.get(key) is None:
            sampler[key] = []
    if out.get("output_dir") is not None:
        out["output_dir"] = str(Path(out["output_dir"]))
    return out


__all__ = ["MlSpacesExpConfig", "PickBaseConfig", "to_native"]
