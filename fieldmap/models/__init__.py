"""Gravity-field models: readers, the SH model type, bundled and synthetic models.

``icgem`` reads ICGEM ``.gfc`` files (``nga`` NGA coefficient files, ``egm`` GeographicLib's
``.egm`` models), ``shmodel`` holds :class:`SHModel`, ``registry`` resolves a name or path to a
model (bundled EIGEN-6S, Kaula-rule synthetics) with an in-process cache, and ``geographiclib``
writes a model in GeographicLib's ``.egm`` format and runs its ``Gravity`` tool.
"""

from __future__ import annotations

import importlib
from typing import Any

# fieldmap 0.1 had ``fieldmap.models`` as the module now called ``fieldmap.models.registry``;
# its names stay importable from here.
_REGISTRY = ("load_model", "kaula_model", "clear_cache", "BUNDLED", "DEFAULT_MODEL")


def __getattr__(name: str) -> Any:
    if name in _REGISTRY:
        return getattr(importlib.import_module("fieldmap.models.registry"), name)
    raise AttributeError(f"module 'fieldmap.models' has no attribute {name!r}")
