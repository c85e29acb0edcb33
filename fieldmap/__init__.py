"""fieldmap: Earth gravity-field maps and strapdown inertial navigation with NVIDIA Warp.

Public API (see the README): models are read with :func:`fieldmap.models.icgem.read_icgem` or
:func:`fieldmap.models.registry.load_model`; ellipsoids live in :mod:`fieldmap.field.ellipsoid`.
"""

__version__ = "0.1.0"

from fieldmap.field.ellipsoid import GRS80, WGS84, Ellipsoid  # noqa: F401

# Lazy exports: importing fieldmap stays light (no Warp, xarray, matplotlib until used).
_LAZY = {
    "disturbance_map": "fieldmap.products.maps",
    "truncation_map": "fieldmap.products.maps",
    "altitude_sweep": "fieldmap.products.maps",
}


def __getattr__(name):
    """Import lazily exported functions on first use (PEP 562)."""
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'fieldmap' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(mod), name)
    globals()[name] = value
    return value
