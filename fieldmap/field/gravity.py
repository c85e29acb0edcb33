"""Gravitation, gravity and gravity disturbance of a spherical-harmonic model at geodetic points.

Public API (degrees and metres in, NumPy out):

* :func:`gravitation` — gradient of the model potential (Chen et al. 2022 eqs. 1-3);
* :func:`gravity` — gravitation plus the centrifugal acceleration ω²(x, y, 0) (Groves 2013
  eq. 3.7.5), ω of the ellipsoid;
* :func:`disturbance` — δg = g_model − γ at the same point (Chen et al. 2022 §2.3). Both gravity
  vectors carry the same centrifugal term, so δg is the difference of the *gravitations*: the
  spherical-harmonic one with the model's own GM and radius, the exact level-ellipsoid one
  (Heiskanen & Moritz 1967 §2-7…2-9, :mod:`fieldmap.field.normal`) with the ellipsoid's GM and a.
  Nothing is rescaled: the degree-0 difference (GM_model − GM_ell)/r² (≈ 0.0007 mGal for
  EIGEN-6S vs WGS84) and the differing zonal terms are part of δg.

Points are ``latitude, longitude, height``: geodetic degrees and metres above the ellipsoid,
positional; every other argument is keyword-only. The local frames are the geodetic ENU/NED
frames at the point (``fieldmap.field.frames``). Output units of the disturbance: ``units=``,
looked up in :mod:`fieldmap.units`. A truncation degree and an epoch belong to the model:
``model=load_model(name, lmax=..., epoch=...)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike

from fieldmap import limits
from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.field.sh import sh_gravitation
from fieldmap.models.shmodel import SHModel
from fieldmap.units import Unit, from_si

if TYPE_CHECKING:
    from fieldmap.products.tables.model import CompensationTable

#: Accepted heights above the ellipsoid (:mod:`fieldmap.limits`, one rule for points and grids).
#: Units: m.
MIN_HEIGHT = limits.MIN_HEIGHT
MAX_HEIGHT = limits.MAX_HEIGHT

__all__ = ["disturbance", "gravitation", "gravity"]

FRAMES = ("enu", "ned", "ecef")


def _model(model: object) -> SHModel:
    if isinstance(model, SHModel):
        return model
    from fieldmap.models.registry import load_model

    return load_model(cast(Any, model))


def _inputs(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    frame: str,
    ellipsoid: Ellipsoid | str,
) -> tuple[str, Ellipsoid, np.ndarray, np.ndarray, np.ndarray]:
    """Return the validated (frame, ellipsoid, lat, lon, h) of the public calls."""
    f = str(frame).lower()
    if f not in FRAMES:
        raise InputError(f"frame must be one of {', '.join(FRAMES)}, got {frame!r}")
    return (f, get_ellipsoid(ellipsoid), *limits.check_geodetic(latitude, longitude, height))


def _to_frame(v_ecef: np.ndarray, lat: ArrayLike, lon: ArrayLike, frame: str) -> np.ndarray:
    if frame == "ecef":
        return v_ecef
    v_enu = frames.ecef_to_enu_vector(v_ecef, lat, lon)
    return v_enu if frame == "enu" else frames.enu_to_ned(v_enu)


def _gravitation_ecef(
    model: object,
    lat: np.ndarray,
    lon: np.ndarray,
    h: np.ndarray,
    ellipsoid: Ellipsoid,
    device: str | None,
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    m = _model(model)
    x, y, z = frames.geodetic_to_ecef(lat, lon, h, ellipsoid)
    return sh_gravitation(m, x, y, z, device=device), (x, y, z)


def gravitation(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    frame: str = "enu",
    device: str | None = None,
) -> np.ndarray:
    """Gravitational acceleration of a spherical-harmonic model (no centrifugal term).

    Chen et al. (2022) eqs. 1-3, evaluated by the Warp kernel of :mod:`fieldmap.kernels.sh`.

    Parameters
    ----------
    latitude : array_like
        Geodetic latitude in [-90, 90], broadcast with ``longitude`` and ``height``.
        Units: degrees.
    longitude : array_like
        Longitude in [-540, 540) (GeographicLib's range). Units: degrees.
    height : array_like
        Height above ``ellipsoid``, ``MIN_HEIGHT`` ≤ h ≤ ``MAX_HEIGHT`` (-10 km to 1e8 m).
        Units: m.
    model : SHModel or str
        A model (:func:`fieldmap.models.registry.load_model`, which applies a truncation
        degree ``lmax=`` and an ``epoch=`` of time-variable terms; or ``model.truncated(lmax)``),
        a bundled model name or the path of a model file (at its full degree and reference
        epoch).
    ellipsoid : Ellipsoid or str
        Ellipsoid of the geodetic coordinates (default WGS84).
    frame : {"enu", "ned", "ecef"}
        Output frame (local geodetic ENU/NED at the point, or ECEF).
    device : str, optional
        Warp device (default: first CUDA device, else CPU).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(latitude, longitude, height).shape + (3,)``. Units: m/s².

    Examples
    --------
    The gravitation 1 km above 45° N, 10° E (no centrifugal term), east-north-up:

    >>> import fieldmap
    >>> model = fieldmap.load_model("eigen-6s", lmax=12)
    >>> g = fieldmap.gravitation(45.0, 10.0, 1000.0, model=model)
    >>> g.shape, round(float(g[2]), 2)  # up. Units: m/s²
    ((3,), -9.82)
    """
    f, ell, lat, lon, h = _inputs(latitude, longitude, height, frame, ellipsoid)
    g, _ = _gravitation_ecef(model, lat, lon, h, ell, device)
    return _to_frame(g, lat, lon, f)


def gravity(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    frame: str = "enu",
    device: str | None = None,
) -> np.ndarray:
    """Gravity = model gravitation + centrifugal ω²(x, y, 0), ω of ``ellipsoid``.

    Groves (2013) eq. 3.7.5. Parameters as :func:`gravitation`.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(latitude, longitude, height).shape + (3,)``. Units: m/s².

    Examples
    --------
    East, north, up at 45° N, 10° E, 1 km, EIGEN-6S to degree 36:

    >>> import numpy as np
    >>> from fieldmap.field.gravity import gravity
    >>> from fieldmap.models.registry import load_model
    >>> g = gravity(45.0, 10.0, 1000.0, model=load_model("eigen-6s", lmax=36))
    >>> g.shape
    (3,)
    >>> round(float(g[2]), 4)  # up; m/s²
    -9.8034
    """
    f, ell, lat, lon, h = _inputs(latitude, longitude, height, frame, ellipsoid)
    g, (x, y, z) = _gravitation_ecef(model, lat, lon, h, ell, device)
    g = g + frames.centrifugal_ecef(x, y, z, ell.omega)
    return _to_frame(g, lat, lon, f)


def disturbance(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | CompensationTable | str = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    units: str | Unit = "mGal",
    frame: str = "enu",
    device: str | None = None,
) -> np.ndarray:
    """Gravity disturbance vector δg = g_model − γ_exact at the same point.

    The centrifugal terms cancel, so this is the model gravitation (model GM and radius) minus
    the exact normal gravitation of the level ellipsoid (its own GM and a; Heiskanen & Moritz
    1967 §2-7…2-9), Chen et al. (2022) eq. 14 with the exact normal field.

    Parameters
    ----------
    latitude, longitude, height : array_like
        As in :func:`gravitation`. Units: degrees, degrees, m.
    model : SHModel, CompensationTable or str
        A model, a bundled model name or the path of an ICGEM file; or a gravity compensation
        table, ``"table:FILE"`` (``fieldmap table``'s table.nc or table.bin) or a
        :class:`fieldmap.products.tables.model.CompensationTable`: its interpolated δg (WGS84
        only; NumPy, ``device`` unused; a point outside the table is an :class:`InputError`).
        A truncation degree and an epoch belong to the model:
        ``load_model(name, lmax=, epoch=)``.
    ellipsoid : Ellipsoid or str
        Level ellipsoid of the normal field and of the coordinates (default WGS84).
    units : {"mGal", "mg", "m/s2"}
        Output unit (1 mGal = 1e-5 m/s², 1 mg = 9.80665e-3 m/s²), any case, aliases of
        :mod:`fieldmap.units` (``"m s-2"``...).
    frame : {"enu", "ned", "ecef"}
        Output frame.
    device : str, optional
        Warp device.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(latitude, longitude, height).shape + (3,)``. Units: ``units``.

    Examples
    --------
    δg at two points on the ellipsoid (EIGEN-6S to degree 36), in mGal and in mg:

    >>> import numpy as np
    >>> from fieldmap.field.gravity import disturbance
    >>> from fieldmap.models.registry import load_model
    >>> m36 = load_model("eigen-6s", lmax=36)
    >>> d = disturbance([45.0, -30.0], [10.0, 150.0], 0.0, model=m36)
    >>> d.shape
    (2, 3)
    >>> np.round(d, 1)  # east, north, up; mGal
    array([[ -1.3,   5. , -32.1],
           [  8.3,  26.1, -28.8]])
    >>> np.round(disturbance(45.0, 10.0, 0.0, model=m36, units="mg"), 4)
    array([-0.0013,  0.0051, -0.0327])
    """
    from fieldmap.field.normal import normal_gravity
    from fieldmap.units import get_unit

    unit = get_unit(units)
    if _table_model(model) is not None:
        return _table_disturbance(latitude, longitude, height, model, ellipsoid, unit, frame)
    f, ell, lat, lon, h = _inputs(latitude, longitude, height, frame, ellipsoid)
    g, _ = _gravitation_ecef(model, lat, lon, h, ell, device)
    gamma = normal_gravity(
        lat, lon, h, normal="exact", ellipsoid=ell, centrifugal=False, frame="ecef", device=device
    )
    return _to_frame(from_si(g - gamma, unit), lat, lon, f)


def _table_model(model: object) -> CompensationTable | None:
    """Return the table of ``model`` (``"table:FILE"`` or a table object), else None."""
    from fieldmap.models.registry import table_path
    from fieldmap.products.tables.model import CompensationTable, load_table

    if isinstance(model, CompensationTable):
        return model
    path = table_path(model)
    return None if path is None else load_table(path)


def _table_disturbance(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    model: object,
    ellipsoid: Ellipsoid | str,
    unit: str | Unit,
    frame: str,
) -> np.ndarray:
    """δg interpolated from a compensation table, in ``frame`` and ``unit``."""
    tab = _table_model(model)
    f, ell, lat, lon, h = _inputs(latitude, longitude, height, frame, ellipsoid)
    if ell.name != WGS84.name:
        raise InputError(f"a compensation table holds δg of WGS84, not of {ell.name}")
    assert tab is not None  # _table_disturbance serves table models only
    ned = tab.interpolate(lat, lon, h).reshape(lat.shape + (3,)) * 1e-5  # mGal -> m/s²
    enu = np.stack([ned[..., 1], ned[..., 0], -ned[..., 2]], axis=-1)
    if f == "enu":
        v = enu
    elif f == "ned":
        v = ned
    else:
        v = np.einsum("...ji,...j->...i", frames.C_e_to_enu(lat, lon), enu)
    return from_si(v, unit)
