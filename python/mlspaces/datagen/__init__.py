"""The data engine from Python: register configs, run them (``python -m mlspaces.datagen``)."""

from .config_registry import get_config_class, list_available_configs, register_config
from .run import main, native_config_text, run_config

__all__ = ["get_config_class", "list_available_configs", "main", "native_config_text",
           "register_config", "run_config"]
