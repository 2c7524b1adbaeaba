"""The env and body views (``molmo_spaces.env``)."""

from .data_views import (MlSpacesBody, MlSpacesFreeJointBody, MlSpacesImmovableBody,
                         MlSpacesMocapBody, create_mlspaces_body)
from .env import CPUMujocoEnv

__all__ = ["CPUMujocoEnv", "MlSpacesBody", "MlSpacesFreeJointBody", "MlSpacesImmovableBody",
           "MlSpacesMocapBody", "create_mlspaces_body"]
