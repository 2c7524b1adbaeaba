"""Camera systems (``molmo_spaces.configs.camera_configs``)."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from ._base import default
from ._fields import engine_model

def _camera_fields() -> dict[str, Any]:
    cams = default("camera_config", "cameras")
    keys: dict[str, Any] = {}
    for cam in cams:
        keys.update(cam)
    return keys


def _make_camera_config():
    from pydantic import create_model

    from ._base import Config
    from ._fields import _annotation, _copy
    fields: dict[str, Any] = {}
    template = {**_camera_fields(), "mjcf_name": "", "robot_namespace": "",
                "reference_body_names": [], "camera_offset": [0.0, 0.0, 0.0],
                "camera_quaternion": [1.0, 0.0, 0.0, 0.0], "fov": 45.0,
                "visibility_constraints": {}}
    for key, value in template.items():
        if key == "name":
            fields[key] = (str, ...)
        elif isinstance(value, (list, dict)):
            fields[key] = (_annotation(value), Field(default_factory=lambda v=value: _copy(v)))
        elif key == "type":
            fields[key] = (str, "mjcf")
        else:
            fields[key] = (_annotation(value), value)
    return create_model("CameraConfig", __base__=Config, __module__=__name__,
                        __doc__="One camera: an MJCF camera of the robot (type 'mjcf') or a "
                                "camera mounted on a body (type 'robot_mounted'); fov is the "
                                "vertical field of view in degrees.", **fields)


CameraConfig = _make_camera_config()


def _droid_cameras() -> list[Any]:
    return [CameraConfig(**cam) for cam in default("camera_config", "cameras")]


CameraSystemConfig = engine_model(
    "CameraSystemConfig", __name__, ("camera_config",),
    "A camera system: img_resolution (width, height), cameras, video settings.",
    cameras=(list[CameraConfig], Field(default_factory=list)),
    img_resolution=(Any, tuple(default("camera_config", "img_resolution"))),
)

FrankaDroidCameraSystem = engine_model(
    "FrankaDroidCameraSystem", __name__, ("camera_config",),
    "FrankaDroidCameraSystem(): wrist_camera and exo_camera_1 at 640x368.",
    base=CameraSystemConfig,
    cameras=(list[CameraConfig], Field(default_factory=_droid_cameras)),
    img_resolution=(Any, tuple(default("camera_config", "img_resolution"))),
)

class RobotCameraSystem(CameraSystemConfig):
    """The robot's own cameras (robot.yaml ``cameras``, docs/robots.md) at ``img_resolution``;
    ``cameras`` stays empty here (the engine takes them from the robot)."""

    name: str = "RobotCameraSystem"


__all__ = ["CameraConfig", "CameraSystemConfig", "FrankaDroidCameraSystem", "RobotCameraSystem"]
