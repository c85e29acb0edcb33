"""fieldmap: Earth gravity-field maps and strapdown inertial navigation with NVIDIA Warp.

The package is layered the way the data flows (model file → coefficients → field → grid →
product → file), with navigation apart:

- :mod:`fieldmap.models`: model file readers, the :class:`SHModel` type, bundled models;
- :mod:`fieldmap.field`: ellipsoids, normal gravity, SH synthesis, gravity and its gradient
  tensor at points, frames;
- :mod:`fieldmap.grids`: grid specifications, row-wise synthesis, longitude sums;
- :mod:`fieldmap.products`: map requests, the block engine, variables and statistics,
  sinks and writers, plots, compensation tables;
- :mod:`fieldmap.nav`: launch frames, trajectories, IMU synthesis and errors, mechanizations,
  navigation studies;
- :mod:`fieldmap.cli`: the ``fieldmap`` command;
- ``fieldmap.kernels``: the Warp kernels (top-level folder ``kernels/`` of the repository).

What a user calls (models, the field at points, maps, flights and flight studies) is
importable from the top level (see ``__all__``); the building blocks stay in their modules.
The names are resolved lazily, so ``import fieldmap`` loads neither Warp, xarray nor
matplotlib.
"""

from __future__ import annotations

import importlib
import typing

from fieldmap.errors import FieldmapError as FieldmapError
from fieldmap.errors import InputError as InputError
from fieldmap.errors import ModelFileError as ModelFileError
from fieldmap.field.ellipsoid import GRS80 as GRS80
from fieldmap.field.ellipsoid import WGS84 as WGS84
from fieldmap.field.ellipsoid import Ellipsoid as Ellipsoid

#: the version of fieldmap: the one place it is written (pyproject.toml reads it from here)
__version__ = "0.2.0"

#: Public name -> module that defines it (imported on first use, PEP 562). The top level holds
#: what a user calls: models, the field at points, maps, flights and flight studies; the
#: building blocks (frames, mechanizations, IMU synthesis, normal-field pieces, units) stay in
#: their modules (``fieldmap.nav.frames.calc_force_ned``, ``fieldmap.field.normal.somigliana``).
_LAZY = {
    # models
    "SHModel": "fieldmap.models.shmodel",
    "load_model": "fieldmap.models.registry",
    # the field at points
    "gravitation": "fieldmap.field.gravity",
    "gravity": "fieldmap.field.gravity",
    "disturbance": "fieldmap.field.gravity",
    "gradient_tensor": "fieldmap.field.gradient",
    "normal_gravity": "fieldmap.field.normal",
    "disturbing_potential": "fieldmap.field.geodesy",
    "gravity_anomaly": "fieldmap.field.geodesy",
    "geoid_height": "fieldmap.field.geodesy",
    "commission_sigma": "fieldmap.field.commission",
    # maps and compensation tables
    "disturbance_map": "fieldmap.products.maps",
    "altitude_sweep": "fieldmap.products.maps",
    "truncation_map": "fieldmap.products.maps",
    "component_maps": "fieldmap.products.maps",
    "quantity_map": "fieldmap.products.maps",
    "MapRequest": "fieldmap.products.request",
    "build_table": "fieldmap.products.tables.build",
    # flights and flight studies
    "route_flight": "fieldmap.nav.trajectory",
    "FlightTrajectory": "fieldmap.nav.trajectory",
    "load_flight": "fieldmap.nav.logs",
    "load_imu": "fieldmap.nav.sensors",
    "ImuErrorSpec": "fieldmap.nav.sensors",
    "FlightStudy": "fieldmap.nav.study",
    "BaroSpec": "fieldmap.nav.study",
    "GnssSpec": "fieldmap.nav.aiding",
    "run_flight": "fieldmap.nav.study",
}

__all__ = sorted(
    [
        "__version__",
        "FieldmapError",
        "InputError",
        "ModelFileError",
        "Ellipsoid",
        "WGS84",
        "GRS80",
        *_LAZY,
    ]
)


def __getattr__(name: str) -> typing.Any:
    """Resolve the lazily exported names on first use (PEP 562)."""
    target = _LAZY.get(name)
    if target is None:
        raise AttributeError(f"module 'fieldmap' has no attribute {name!r}")
    value = getattr(importlib.import_module(target), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
