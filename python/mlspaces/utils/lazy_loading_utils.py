"""UID lookup (``molmo_spaces.utils.lazy_loading_utils``), on the process-default registry."""

from __future__ import annotations

from .._registry import install_uid, locate_uid_package

__all__ = ["install_uid", "locate_uid_package"]
