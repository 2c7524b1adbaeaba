"""``molmo_spaces.data_generation.config_registry``."""

from ..datagen.config_registry import get_config_class, list_available_configs, register_config

__all__ = ["get_config_class", "list_available_configs", "register_config"]
