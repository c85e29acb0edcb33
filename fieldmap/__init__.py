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

Everything a user needs is importable from the top level (see ``__all__``); the names are
resolved lazily, so ``import fieldmap`` loads neither Warp, xarray nor matplotlib.
"""

from __future__ import annotations

import importlib
import sys
import types
import typing

from fieldmap import _compat
from fieldmap.errors import FieldmapError as FieldmapError
from fieldmap.errors import InputError as InputError
from fieldmap.errors import ModelFileError as ModelFileError
from fieldmap.field.ellipsoid import GRS80 as GRS80
from fieldmap.field.ellipsoid import WGS84 as WGS84
from fieldmap.field.ellipsoid import Ellipsoid as Ellipsoid

#: the version of fieldmap: the one place it is written (pyproject.toml reads it from here)
__version__ = "0.2.0"

#: Public name -> module that defines it (imported on first use, PEP 562).
_LAZY = {
    # models
    "SHModel": "fieldmap.models.shmodel",
    "load_model": "fieldmap.models.registry",
    "kaula_model": "fieldmap.models.registry",
    "read_icgem": "fieldmap.models.icgem",
    # the field at points
    "gravitation": "fieldmap.field.gravity",
    "gravity": "fieldmap.field.gravity",
    "disturbance": "fieldmap.field.gravity",
    "gradient_tensor": "fieldmap.field.gradient",
    "normal_gravity": "fieldmap.field.normal",
    "normal_gravitation_ecef": "fieldmap.field.normal",
    "normal_model": "fieldmap.field.normal",
    "NORMAL_MODELS": "fieldmap.field.normal",
    "somigliana": "fieldmap.field.normal",
    "get_ellipsoid": "fieldmap.field.ellipsoid",
    "geodetic_to_ecef": "fieldmap.field.frames",
    "ecef_to_geodetic": "fieldmap.field.frames",
    # geodetic quantities
    "disturbing_potential": "fieldmap.field.geodesy",
    "gravity_anomaly": "fieldmap.field.geodesy",
    "SphericalAnomaly": "fieldmap.field.geodesy",
    "geoid_height": "fieldmap.field.geodesy",
    "commission_sigma": "fieldmap.field.commission",
    # units and accepted ranges
    "Unit": "fieldmap.units",
    "UNITS": "fieldmap.units",
    "get_unit": "fieldmap.units",
    "MIN_HEIGHT": "fieldmap.limits",
    "MAX_HEIGHT": "fieldmap.limits",
    # products
    "disturbance_map": "fieldmap.products.maps",
    "altitude_sweep": "fieldmap.products.maps",
    "truncation_map": "fieldmap.products.maps",
    "component_maps": "fieldmap.products.maps",
    "quantity_map": "fieldmap.products.maps",
    "MapRequest": "fieldmap.products.request",
    "write_netcdf": "fieldmap.products.io",
    # navigation
    "LaunchFrame": "fieldmap.nav.frames",
    "Trajectory": "fieldmap.nav.trajectory",
    "BoostGlide": "fieldmap.nav.trajectory",
    "synthesize_imu": ("fieldmap.nav.imu", "synthesize"),
    "ImuErrorSpec": "fieldmap.nav.sensors",
    "propagate_lci": "fieldmap.nav.mechanize",
    "propagate_ned": "fieldmap.nav.mechanize",
    "calc_force_ned": "fieldmap.nav.frames",
    # your own flight and IMU
    "FlightTrajectory": "fieldmap.nav.trajectory",
    "route_flight": "fieldmap.nav.trajectory",
    "load_imu": "fieldmap.nav.sensors",
    "run_flight": "fieldmap.nav.study",
    "FlightStudy": "fieldmap.nav.study",
    "load_flight": "fieldmap.nav.logs",
    "GnssSpec": "fieldmap.nav.aiding",
    "BaroSpec": "fieldmap.nav.study",
    "build_table": "fieldmap.products.tables.build",
    "allan_deviation": "fieldmap.nav.sensors",
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

#: Old module paths -> where their names live now (the deprecation map, kept in
#: :mod:`fieldmap._compat`); importing an old path warns and gives the new module.
_MOVED = _compat.MOVED


def __getattr__(name: str) -> typing.Any:
    """Resolve the lazily exported names on first use (PEP 562)."""
    target = _LAZY.get(name)
    if target is None:
        raise AttributeError(f"module 'fieldmap' has no attribute {name!r}")
    module, attr = target if isinstance(target, tuple) else (target, name)
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """The ``fieldmap`` module: an old module path never shadows a public function.

    ``from fieldmap.gravity import disturbance`` (0.1 layout) makes the import system set
    ``fieldmap.gravity`` to the module; the public function of that name is kept instead.
    """

    def __setattr__(self, name: str, value: object) -> None:
        if isinstance(value, types.ModuleType) and name in _compat.MOVED and name in _LAZY:
            return
        super().__setattr__(name, value)


_compat.install_moved_finder()
sys.modules[__name__].__class__ = _Package
