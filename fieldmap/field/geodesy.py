r"""The geodesist's quantities: disturbing potential, gravity anomaly, deflection, geoid height.

Definitions (as GeographicLib's ``Gravity -A`` and ``-H``, Karney's ``GravityModel``, which
reproduce NGA's synthesis programs):

* **Disturbing potential** :math:`T = W - U`, model gravity potential minus the normal potential
  of the level ellipsoid at the same point; the centrifugal parts are equal and cancel, so
  :math:`T = V_{model} - V_{normal}`. It is summed as one spherical-harmonic series whose
  coefficients are the model's minus the ellipsoid's even zonals
  :math:`\bar C^{ell}_{n0} = -(GM_e/GM)(a_e/R)^n J_n/\sqrt{2n+1}` (Heiskanen & Moritz 1967
  eq. 2-92 for :math:`J_n`), re-expressed with the model's GM and radius R; the ellipsoid's
  series is summed to degree 40 whatever the model's degree (its terms fall as
  :math:`e^n`, below 1e-30 of the central term there), so a truncated model is compared with the
  whole normal field.
* **Degree 0.** By default (``degree0=False``, GeographicLib's choice) the term
  :math:`(GM - GM_e)/r` is left out of T, so that T, Δg, ξ, η and N do not depend on the
  model's and ellipsoid's differing GM (for EGM2008 vs WGS84, 0.3 m²/s² in T, 3 cm in N).
  ``degree0=True`` keeps it (then T is exactly V − U).
* **Geoid height** by Bruns' formula (H&M eq. 2-144) :math:`N = T(\varphi, \lambda, 0)/\gamma_0
  + \zeta_0 + N_{corr}`, with T at the ellipsoid (h = 0) and γ0 Somigliana's normal gravity at
  the same latitude (H&M eq. 2-78). The difference :math:`W_0 - U_0` of the geoid's and the
  ellipsoid's potential is not modelled; the constant :math:`\zeta_0` (GeographicLib's
  ``HeightOffset``, −0.41 m for EGM96 and EGM2008, holding the degree-0 term of N) and the
  correction series :math:`N_{corr}` (EGM2008's ζ-to-N terms, summed on the unit sphere) are
  added when the model file has them (GeographicLib ``.egm`` files), and are zero otherwise.
* **Gravity anomaly and deflection of the vertical**, spherical approximation (H&M §2-14,
  eq. 2-151c; this is what ``Gravity -A`` prints and what NGA's programs compute):

  .. math::
      \Delta g = -\frac{\partial T}{\partial r} - \frac{2T}{r},\qquad
      \xi = -\frac{1}{\gamma}\,\frac{\partial T}{r\,\partial\psi},\qquad
      \eta = -\frac{1}{\gamma}\,\frac{\partial T}{r\cos\psi\,\partial\lambda}

  with the gradient of T in the geocentric spherical frame at the point P (ψ geocentric
  latitude, r geocentric radius) and γ the magnitude of normal gravity (with centrifugal) at P.
  ξ is the northerly, η the easterly component.

ICGEM's functionals (Barthelmes 2013, *Definition of functionals of the geopotential and their
calculation from spherical harmonic models*, GFZ Scientific Technical Report STR09/02, revised
edition; ICGEM's names in brackets), with the same T:

* **Height anomaly on the ellipsoid** [``height_anomaly_ell``] (Barthelmes 2013 §2.2 defines
  the height anomaly ζ of a point P by :math:`W(P) = U(Q)`, Q on P's ellipsoidal normal at
  height :math:`h_P - \zeta`; §3.2 and §4.3 approximate it by Bruns' formula):
  :math:`\zeta_{ell} = T(\varphi, \lambda, 0)/\gamma_0(\varphi)`, T on the ellipsoid over
  Somigliana's γ0. It is the geoid height above without GeographicLib's ζ0 and correction
  series (EGM2008's N − ζ terms): ``Gravity -H`` minus ζ is exactly that N − ζ term. The
  neglected second-order term :math:`\zeta^2 (\partial\gamma/\partial h)/(2\gamma)` is at
  most 2 mm (ζ = 110 m).
* **Classical (Molodensky) gravity anomaly** [``gravity_anomaly_cl``] (Barthelmes 2013 §2.4.1,
  §3.5.1, §4.5): :math:`\Delta g_{cl} = |\nabla W(P)| - |\nabla U(Q)|`, P at height h, Q on
  its ellipsoidal normal at height :math:`h - \zeta` with :math:`U(Q) = W(P)` (the normal
  height surface, the telluroid when P is on the topography). ζ is solved here from
  :math:`U(Q) = U(P) + T(P)` by Newton's method on the closed-form normal potential (Heiskanen
  & Moritz 1967 eqs. 2-61, 2-62 plus the centrifugal term), from Bruns' T/γ(P) until a step
  is below 1e-7 m (two steps for a real field, whose ζ Bruns gives to 2 mm).
  :math:`\nabla W(P) = \nabla U(P) + \nabla T(P)`, so the degree-0 choice of T applies here
  as well.
* **Gravity disturbance in spherical approximation** [``gravity_disturbance_sa``] (Barthelmes
  2013 §3.4, §4.4): :math:`\delta g_{sa} = -\partial T/\partial r`, the geocentric radial
  derivative at the point (the anomaly above without its :math:`-2T/r`).
* **Second radial derivative** [``second_r_derivative``] :math:`T_{rr} = \partial^2 T/
  \partial r^2` at the point, in Eötvös (1 E = 1e-9 s⁻²). From the series of T (Barthelmes
  2013 §4.1: each degree n of T is :math:`(R/r)^{n+1}` times a surface harmonic), exactly
  :math:`T_{rr} = r^{-2}\sum_n (n+1)(n+2)\,T_n(r, \psi, \lambda)`: one synthesis of the
  disturbing model with coefficients weighted by (n+1)(n+2), divided by r².

The series are summed by the engine of :mod:`fieldmap.field.sh` (Warp kernels), no new kernel.
On grids (:func:`grid_quantities`) every quantity is one Legendre pass of
:func:`fieldmap.grids.synthesis.synthesize` (the classical anomaly adds point evaluations of
normal gravity at h − ζ, which cost no harmonic synthesis).
"""

from __future__ import annotations

import math
import os
import threading
import weakref
from dataclasses import replace
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.limits import check_geodetic as _points
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec
    from fieldmap.units import Unit

#: Highest degree of the ellipsoid's zonal series subtracted from the model. |J_n| falls like
#: e^n (e² = 0.0067 for WGS84): J_40 ~ 1e-44, far below the float64 rounding of the central term.
NORMAL_DEGREE = 40
ARCSEC_PER_RAD = 180.0 / math.pi * 3600.0
MGAL = 1.0e5  # mGal per m/s²

_memo_lock = threading.Lock()
_memo: dict = {}  # (id(model), ellipsoid, degree0) -> (weakref(model), SHModel)


def _height_offset(model: SHModel) -> float:
    """GeographicLib ``HeightOffset`` ζ0 of a model read from a ``.egm`` file (else 0). Units: m."""
    return float(model.header.get("HeightOffset", 0.0) or 0.0)


def disturbing_model(
    model: SHModel, ellipsoid: Ellipsoid | str = WGS84, *, degree0: bool = False
) -> SHModel:
    r"""Coefficients of the disturbing potential T = V_model − V_ellipsoid.

    Parameters
    ----------
    model : SHModel
        Fully normalised model (its GM and radius R are kept).
    ellipsoid : Ellipsoid or str
        Level ellipsoid of the normal field (default WGS84).
    degree0 : bool
        Keep the degree-0 term 1 − GM_e/GM (False: C̄00 = 0, as GeographicLib).

    Returns
    -------
    SHModel
        Degree ``max(model.lmax, 40)`` (the normal series is never truncated with the model);
        :math:`\bar C_{n0} - \bar C^{ell}_{n0}` for even n, with
        :math:`\bar C^{ell}_{n0} = -(GM_e/GM)(a_e/R)^n J_n/\sqrt{2n+1}`
        (Heiskanen & Moritz 1967 eq. 2-92, full normalisation of :math:`P_n`).
    """
    ell = get_ellipsoid(ellipsoid)
    key = (id(model), ell, bool(degree0))
    with _memo_lock:
        hit = _memo.get(key)
        if hit is not None and hit[0]() is model:
            return hit[1]
    L = max(model.lmax, NORMAL_DEGREE)
    C = np.zeros((L + 1, L + 1))
    S = np.zeros((L + 1, L + 1))
    C[: model.lmax + 1, : model.lmax + 1] = model.C
    S[: model.lmax + 1, : model.lmax + 1] = model.S
    mult = ell.GM / model.gm
    # (GM − GM_e)/GM, not 1 − GM_e/GM: the difference of the constants is exact, the ratio's
    # rounding would be 1e-7 of this 7e-10 term
    C[0, 0] = (C[0, 0] - 1.0 + (model.gm - ell.GM) / model.gm) if degree0 else 0.0
    amult = (ell.a / model.radius) ** 2
    for k in range(1, NORMAL_DEGREE // 2 + 1):
        n = 2 * k
        mult *= amult
        C[n, 0] -= -mult * ell.J2n(k) / math.sqrt(2 * n + 1)
    out = replace(
        model,
        name=f"{model.name} - {ell.name}",
        C=C,
        S=S,
        sigma_c=None,  # the synthesis model; σ stay on ``model`` (fieldmap.field.commission)
        sigma_s=None,
        source=f"{model.source} minus the {ell.name} normal potential",
    )
    with _memo_lock:
        while len(_memo) >= 4:
            _memo.pop(next(iter(_memo)))
        _memo[key] = (weakref.ref(model), out)
    return out


def _resolve(model: SHModel | str | os.PathLike[str]) -> SHModel:
    from fieldmap.models.registry import load_model

    return load_model(model)


def _t_and_gradient(
    m: SHModel,
    ell: Ellipsoid,
    lat: NDArray[np.float64],
    lon: NDArray[np.float64],
    h: NDArray[np.float64],
    degree0: bool,
    device: str | None,
    grad: bool = True,
) -> tuple[np.ndarray, np.ndarray | None, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """T (m²/s²), its ECEF gradient (m/s², None unless ``grad``) and the ECEF position."""
    from fieldmap.field.sh import sh_gravitation, sh_potential

    dm = disturbing_model(m, ell, degree0=degree0)
    x, y, z = frames.geodetic_to_ecef(lat, lon, h, ell)
    t = sh_potential(dm, x, y, z, device=device)
    g = sh_gravitation(dm, x, y, z, device=device) if grad else None
    return t, g, (x, y, z)


def disturbing_potential(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
) -> np.ndarray:
    """Disturbing potential T = W − U at geodetic points (see the module docstring).

    Parameters
    ----------
    latitude, longitude : array_like
        Geodetic latitude in [-90, 90] and longitude in [-540, 540). Units: degrees.
    height : array_like
        Height above ``ellipsoid``, −10 km ≤ h ≤ 1e8 m. Units: m.
    model : SHModel or str
        A model, a bundled model name or a model file path. A truncation degree and an epoch
        of time-variable terms belong to the model: ``load_model(name, lmax=, epoch=)`` or
        ``model.truncated(lmax)`` (the normal field is never truncated).
    ellipsoid : Ellipsoid or str
        Level ellipsoid of the normal field and of the coordinates (default WGS84).
    degree0 : bool
        Keep the term (GM − GM_e)/r (default False, as GeographicLib).
    device : str, optional
        Warp device.

    Returns
    -------
    numpy.ndarray
        Broadcast shape of the inputs. Units: m²/s².

    Examples
    --------
    >>> import numpy as np
    >>> import fieldmap
    >>> model = fieldmap.load_model("eigen-6s", lmax=36)
    >>> T = fieldmap.disturbing_potential([45.0, -30.0], [10.0, 150.0], 0.0, model=model)
    >>> np.round(T, 1)  # m²/s²
    array([479.3, 316. ])
    """
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = _points(latitude, longitude, height)
    m = _resolve(model)
    t, _, _ = _t_and_gradient(m, ell, lat, lon, h, degree0, device, grad=False)
    return t


class _AnomalyFields(NamedTuple):
    #: Δg, gravity anomaly (spherical approximation). Units: :attr:`SphericalAnomaly.units`.
    anomaly: np.ndarray
    #: ξ, northerly deflection of the vertical. Units: arcsec.
    xi_arcsec: np.ndarray
    #: η, easterly deflection of the vertical. Units: arcsec.
    eta_arcsec: np.ndarray


class SphericalAnomaly(_AnomalyFields):
    """What :func:`gravity_anomaly` returns: three arrays of the points' shape, one unit each.

    Unpack it (``dg, xi, eta = gravity_anomaly(...)``) or use the names: ``anomaly`` (Δg in
    :attr:`units`, the ``units=`` of the call, mGal by default), ``xi_arcsec``, ``eta_arcsec``;
    ``anomaly_mgal`` is Δg in mGal whatever the unit asked.
    """

    #: Canonical name of the unit of ``anomaly`` (:mod:`fieldmap.units`).
    units: str

    def __new__(
        cls, anomaly: np.ndarray, xi_arcsec: np.ndarray, eta_arcsec: np.ndarray, units: str = "mGal"
    ) -> SphericalAnomaly:
        """Make the tuple; ``units``: unit of ``anomaly`` (:func:`fieldmap.units.get_unit`)."""
        from fieldmap.units import get_unit

        self = super().__new__(cls, anomaly, xi_arcsec, eta_arcsec)
        self.units = get_unit(units).name
        return self

    def __getnewargs__(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
        return (*self, self.units)

    def _replace(self, **changes: Any) -> SphericalAnomaly:
        units = changes.pop("units", self.units)
        return SphericalAnomaly(*super()._replace(**changes), units=units)

    @property
    def anomaly_mgal(self) -> np.ndarray:
        """Δg in mGal (``anomaly`` itself when the unit asked is mGal)."""
        from fieldmap.units import from_si, get_unit

        if self.units == "mGal":
            return self.anomaly
        return from_si(self.anomaly * get_unit(self.units).si, "mGal")


def anomaly_from_t(
    t: np.ndarray,
    grad_ecef: np.ndarray,
    xyz: tuple[np.ndarray, np.ndarray, np.ndarray],
    lon_deg: ArrayLike,
    gamma: ArrayLike,
    units: str | Unit = "mGal",
) -> np.ndarray:
    """Spherical-approximation anomaly and deflection from T and its ECEF gradient.

    Heiskanen & Moritz (1967) eq. 2-151c for Δg; ξ, η from the horizontal gradient in the
    geocentric frame (module docstring). Longitudes are the input ones, so that the local
    frame at a pole is the one of the given longitude (as GeographicLib).

    Parameters
    ----------
    t : numpy.ndarray
        Disturbing potential. Units: m²/s².
    grad_ecef : numpy.ndarray
        Shape ``t.shape + (3,)``, gradient of T. Units: m/s².
    xyz : tuple of numpy.ndarray
        ECEF position. Units: m.
    lon_deg : numpy.ndarray
        Longitude. Units: degrees.
    gamma : numpy.ndarray
        Normal gravity magnitude at the point. Units: m/s².
    units : str or fieldmap.units.Unit
        Unit of Δg (:func:`fieldmap.units.get_unit`; default mGal).

    Returns
    -------
    numpy.ndarray
        Shape ``t.shape + (3,)``: Δg (``units``), ξ (arcsec), η (arcsec).
    """
    from fieldmap.units import from_si, get_unit

    unit = get_unit(units)
    x, y, z = xyz
    p = np.hypot(x, y)
    r = np.hypot(p, z)
    cpsi, spsi = p / r, z / r
    lam = np.radians(lon_deg)
    cl, sl = np.cos(lam), np.sin(lam)
    gx, gy, gz = grad_ecef[..., 0], grad_ecef[..., 1], grad_ecef[..., 2]
    d_east = -sl * gx + cl * gy
    d_north = -spsi * (cl * gx + sl * gy) + cpsi * gz
    d_up = cpsi * (cl * gx + sl * gy) + spsi * gz
    dg = -d_up - 2.0 * t / r
    xi = -d_north / gamma
    eta = -d_east / gamma
    # mGal as x 1e5 (the bits of fieldmap 0.1), any other unit as fieldmap.units.from_si
    dg = dg * MGAL if unit.name == "mGal" else from_si(dg, unit)
    return np.stack([dg, xi * ARCSEC_PER_RAD, eta * ARCSEC_PER_RAD], axis=-1)


def gravity_anomaly(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
    units: str = "mGal",
) -> SphericalAnomaly:
    """Gravity anomaly Δg and deflection of the vertical ξ, η (spherical approximation).

    As GeographicLib's ``Gravity -A`` (``GravityModel::SphericalAnomaly``); definitions in the
    module docstring. Parameters as :func:`disturbing_potential`, and:

    Parameters
    ----------
    units : {"mGal", "mg", "m/s2"}
        Unit of Δg, as ``units=`` of :func:`fieldmap.field.gravity.disturbance` (any case,
        aliases of :mod:`fieldmap.units`). Default mGal. ξ and η are in arcsec.

    Returns
    -------
    SphericalAnomaly
        ``(anomaly, xi_arcsec, eta_arcsec)``, each of shape ``broadcast(lat, lon, h).shape``:
        Δg (``units``), ξ north (arcsec), η east (arcsec).

    Examples
    --------
    >>> import numpy as np
    >>> from fieldmap.field.geodesy import gravity_anomaly
    >>> from fieldmap.models.registry import load_model
    >>> m36 = load_model("eigen-6s", lmax=36)
    >>> dg, xi, eta = gravity_anomaly([45.0], [10.0], [0.0], model=m36)
    >>> np.round(dg, 2), np.round(xi, 2)  # mGal, arcsec
    (array([17.03]), array([-1.02]))
    >>> a = gravity_anomaly([45.0], [10.0], [0.0], model=m36, units="m/s2")
    >>> a.units, np.round(a.anomaly * 1e5, 2)
    ('m/s2', array([17.03]))
    """
    from fieldmap.field.normal import normal_gravity
    from fieldmap.units import get_unit

    unit = get_unit(units)
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = _points(latitude, longitude, height)
    m = _resolve(model)
    t, grad, xyz = _t_and_gradient(m, ell, lat, lon, h, degree0, device)
    gam = normal_gravity(
        lat, lon, h, ellipsoid=ell, normal="exact", centrifugal=True, frame="ecef", device=device
    )
    assert grad is not None  # asked for (grad=True)
    a = anomaly_from_t(t, grad, xyz, lon, np.linalg.norm(gam, axis=-1), unit)
    return SphericalAnomaly(a[..., 0], a[..., 1], a[..., 2], units=unit.name)


def correction_height(
    model: SHModel,
    lat: ArrayLike,
    lon: ArrayLike,
    *,
    lmax: int | None = None,
    ellipsoid: Ellipsoid | str = WGS84,
    device: str | None = None,
) -> np.ndarray:
    """ζ0 + the correction series of a GeographicLib model at geodetic points (m; 0 if none).

    GeographicLib sums the correction (EGM2008's ζ-to-N terms) as a fully normalised series on
    the unit sphere at the point's geocentric direction, times ``CorrectionMultiplier``.
    """
    from fieldmap.field.sh import sh_potential

    out = np.full(np.shape(lat), _height_offset(model), dtype=np.float64)
    corr = model.header.get("correction")
    if isinstance(corr, SHModel) and (np.any(corr.C) or np.any(corr.S)):
        if lmax is not None and lmax < corr.lmax:
            corr = corr.truncated(lmax)
        x, y, z = frames.geodetic_to_ecef(lat, lon, np.zeros_like(lat), get_ellipsoid(ellipsoid))
        r = np.sqrt(x * x + y * y + z * z)
        # gm = radius = 1 at r = 1: the sum itself
        unit = replace(corr, gm=1.0, radius=1.0)
        mult = float(model.header.get("CorrectionMultiplier", 1.0) or 1.0)
        out = out + mult * sh_potential(unit, x / r, y / r, z / r, device=device)
    return out


def geoid_height(
    latitude: ArrayLike,
    longitude: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    lmax: int | None = None,
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
    epoch: float | str | None = None,
) -> np.ndarray:
    """Geoid height N above the ellipsoid by Bruns' formula, as GeographicLib's ``Gravity -H``.

    N = T(φ, λ, 0)/γ0(φ) + ζ0 + N_corr (module docstring; Heiskanen & Moritz 1967 eq. 2-144):
    T on the ellipsoid, γ0 Somigliana's normal gravity there.

    Parameters
    ----------
    latitude, longitude : array_like
        Geodetic latitude and longitude. Units: degrees.
    model, ellipsoid, degree0, device
        As :func:`disturbing_potential`.
    lmax : int, optional
        Truncation degree of the model and of its correction series N_corr (a
        ``model.truncated(lmax)`` keeps the whole correction series).
    epoch : float or str, optional
        Epoch of time-variable terms when ``model`` is a name or file. Units: decimal year.

    Returns
    -------
    numpy.ndarray
        Broadcast shape of ``latitude``, ``longitude``. Units: m.

    Examples
    --------
    >>> import numpy as np
    >>> from fieldmap.field.geodesy import geoid_height
    >>> np.round(geoid_height([45.0, -30.0], [10.0, 150.0], lmax=36), 2)  # m
    array([48.87, 32.27])
    """
    from fieldmap.field.normal import somigliana
    from fieldmap.models.registry import load_model

    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = _points(latitude, longitude, 0.0)
    m = load_model(model, lmax=lmax, epoch=epoch)
    t, _, _ = _t_and_gradient(m, ell, lat, lon, h, degree0, device, grad=False)
    n = t / somigliana(lat, ellipsoid=ell)
    return n + correction_height(m, lat, lon, lmax=lmax, ellipsoid=ell, device=device)


def height_anomaly(
    latitude: ArrayLike,
    longitude: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
) -> np.ndarray:
    """Height anomaly on the ellipsoid ζ = T(φ, λ, 0)/γ0(φ) (ICGEM's ``height_anomaly_ell``).

    Barthelmes (2013) §2.2 (definition), §4.3 (Bruns' formula on the ellipsoid); module
    docstring. GeographicLib's ``Gravity -H`` (and :func:`geoid_height`) is ζ plus the model's
    N − ζ terms (``HeightOffset`` and correction series); for a model without them both agree.

    Parameters
    ----------
    latitude, longitude : array_like
        Geodetic latitude and longitude. Units: degrees.
    model, ellipsoid, degree0, device
        As :func:`disturbing_potential`.

    Returns
    -------
    numpy.ndarray
        Broadcast shape of ``latitude``, ``longitude``. Units: m.
    """
    from fieldmap.field.normal import somigliana

    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = _points(latitude, longitude, 0.0)
    m = _resolve(model)
    t, _, _ = _t_and_gradient(m, ell, lat, lon, h, degree0, device, grad=False)
    return t / somigliana(lat, ellipsoid=ell)


def _radial(grad_ecef: np.ndarray, xyz: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Geocentric radial component r̂·∇ of an ECEF gradient (the ``d_up`` of anomaly_from_t)."""
    x, y, z = xyz
    p = np.hypot(x, y)
    r = np.hypot(p, z)
    cpsi, spsi = p / r, z / r
    lam = np.arctan2(y, x)
    gx, gy, gz = grad_ecef[..., 0], grad_ecef[..., 1], grad_ecef[..., 2]
    return cpsi * (np.cos(lam) * gx + np.sin(lam) * gy) + spsi * gz


def disturbance_sa(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
) -> np.ndarray:
    """Gravity disturbance in spherical approximation δg_sa = −∂T/∂r (``gravity_disturbance_sa``).

    Barthelmes (2013) §3.4, §4.4: the geocentric radial derivative of T at the point (module
    docstring). Parameters as :func:`disturbing_potential`.

    Returns
    -------
    numpy.ndarray
        Broadcast shape of the inputs. Units: mGal.
    """
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = _points(latitude, longitude, height)
    m = _resolve(model)
    _, grad, xyz = _t_and_gradient(m, ell, lat, lon, h, degree0, device)
    assert grad is not None  # asked for (grad=True)
    return -_radial(grad, xyz) * MGAL


def radial_weighted_model(model: SHModel, weights: np.ndarray) -> SHModel:
    """``model`` with the coefficients of each degree n multiplied by ``weights[n]``.

    A functional that is a per-degree weighting of a series is one synthesis of this model
    (module docstring: T_rr; :mod:`fieldmap.field.water`: equivalent water height).
    """
    w = np.asarray(weights, dtype=np.float64)[: model.lmax + 1, None]
    return replace(
        model,
        name=f"{model.name} (weighted per degree)",
        C=model.C * w,
        S=model.S * w,
        sigma_c=None,
        sigma_s=None,
    )


def _trr_model(dm: SHModel) -> SHModel:
    n = np.arange(dm.lmax + 1, dtype=np.float64)
    return radial_weighted_model(dm, (n + 1.0) * (n + 2.0))


def second_radial_derivative(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
) -> np.ndarray:
    r"""Second radial derivative :math:`T_{rr}` of T (ICGEM's ``second_r_derivative``).

    .. math::
        T_{rr} = \frac{1}{r^2}\sum_{n}(n+1)(n+2)\,T_n(r,\psi,\lambda)

    (each degree of T falls as :math:`r^{-(n+1)}`, Barthelmes 2013 §4.1), r the geocentric
    radius. Parameters as :func:`disturbing_potential`.

    Returns
    -------
    numpy.ndarray
        Broadcast shape of the inputs. Units: E (1e-9 s⁻²).
    """
    from fieldmap.field.sh import sh_potential

    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = _points(latitude, longitude, height)
    m = _resolve(model)
    wm = _trr_model(disturbing_model(m, ell, degree0=degree0))
    x, y, z = frames.geodetic_to_ecef(lat, lon, h, ell)
    r2 = x * x + y * y + z * z
    return sh_potential(wm, x, y, z, device=device) / r2 * 1e9


def _normal_potential(x: np.ndarray, y: np.ndarray, z: np.ndarray, ell: Ellipsoid) -> np.ndarray:
    r"""Return the normal gravity potential U (gravitational + centrifugal), closed form. m²/s².

    Heiskanen & Moritz (1967) eqs. 2-61, 2-62 (:func:`fieldmap.reference.normal.exact_potential`)
    plus :math:`\omega^2 (x^2 + y^2)/2`.
    """
    from fieldmap.reference.normal import exact_potential

    return exact_potential(x, y, z, ell) + 0.5 * ell.omega**2 * (x * x + y * y)


#: Newton on the classical anomaly's ζ stops at the first step below this, well above the
#: rounding of the steps (U ~ 6e7 m²/s² to 1e-8, over γ: 1e-9 m), and small enough that |γ(Q)|,
#: taken at the ζ before that step, is off by at most 3e-8 mGal (∂γ/∂h = 3e-6 s⁻²). From
#: Bruns' T/γ a real field (ζ < 110 m, Bruns off by < 2 mm) needs 2 steps, a point mass far
#: from the ellipsoid (ζ of kilometres) 3. Units: m.
_ZETA_TOL = 1e-7
#: most Newton steps (the tolerance is judged on the finite steps only)
_ZETA_STEPS = 8


def _normal_height_point(
    t: np.ndarray,
    gamma_p: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    h: np.ndarray,
    ell: Ellipsoid,
    device: str | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Height anomaly ζ at P (m) and |∇U(Q)| (m/s²), Q at h − ζ with U(Q) = U(P) + T(P).

    Newton's method on ζ from Bruns' ζ = T/|γ(P)| (``gamma_p``, m/s²); module docstring.
    """
    from fieldmap.field.normal import normal_gravity

    x, y, z = frames.geodetic_to_ecef(lat, lon, h, ell)
    target = _normal_potential(x, y, z, ell) + t
    zeta = t / gamma_p
    for _ in range(_ZETA_STEPS):
        gam_q = normal_gravity(
            lat,
            lon,
            h - zeta,
            ellipsoid=ell,
            normal="exact",
            centrifugal=True,
            frame="enu",
            device=device,
        )
        xq, yq, zq = frames.geodetic_to_ecef(lat, lon, h - zeta, ell)
        # dU/dh along the ellipsoidal normal is the up component of normal gravity (< 0)
        step = (_normal_potential(xq, yq, zq, ell) - target) / gam_q[..., 2]
        zeta = zeta + step
        if not np.abs(step[np.isfinite(step)]).max(initial=0.0) > _ZETA_TOL:
            break
    # |γ| at the ζ before the last step: it moved Q by at most 1e-7 m (_ZETA_TOL)
    return zeta, np.linalg.norm(gam_q, axis=-1)


def classical_anomaly(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
) -> np.ndarray:
    r"""Classical (Molodensky) gravity anomaly (ICGEM's ``gravity_anomaly_cl``).

    .. math::
        \Delta g_{cl} = |\nabla W(P)| - |\nabla U(Q)|,\qquad U(Q) = W(P)

    with Q on P's ellipsoidal normal at height h − ζ (Barthelmes 2013 §2.4.1, §4.5; module
    docstring). Parameters as :func:`disturbing_potential`.

    Returns
    -------
    numpy.ndarray
        Broadcast shape of the inputs. Units: mGal.
    """
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = _points(latitude, longitude, height)
    m = _resolve(model)
    t, grad, _ = _t_and_gradient(m, ell, lat, lon, h, degree0, device)
    assert grad is not None  # asked for (grad=True)
    from fieldmap.field.normal import normal_gravity

    gam_p = normal_gravity(
        lat, lon, h, ellipsoid=ell, normal="exact", centrifugal=True, frame="ecef", device=device
    )
    _, gam_q = _normal_height_point(t, np.linalg.norm(gam_p, axis=-1), lat, lon, h, ell, device)
    return (np.linalg.norm(gam_p + grad, axis=-1) - gam_q) * MGAL


#: quantities of :func:`grid_quantities`
GRID_QUANTITIES = (
    "potential",
    "anomaly",
    "deflection",
    "geoid",
    "height-anomaly",
    "anomaly-classical",
    "disturbance-sa",
    "trr",
)
#: those of them defined on the ellipsoid's surface (h = 0 whatever the grid's heights)
_SURFACE = ("geoid", "height-anomaly")


def grid_quantities(
    model: SHModel,
    grid: GridSpec,
    quantity: str,
    *,
    ellipsoid: Ellipsoid | str = WGS84,
    degree0: bool = False,
    device: str | None = None,
    progress: bool | None = None,
) -> dict[str, np.ndarray]:
    """T, Δg, ξ, η, N or an ICGEM functional on every node of a grid, one Legendre pass per row.

    The disturbing model (:func:`disturbing_model`) is synthesised with
    :func:`fieldmap.grids.synthesis.synthesize` (potential and gradient in geodetic ENU); the
    gradient is turned back into the geocentric frame of each row (rotation by φ − ψ) and
    combined as in :func:`anomaly_from_t`. The geoid height and the height anomaly are computed
    at h = 0 whatever the grid's heights (properties of the surface). T_rr is the potential of
    the disturbing model weighted per degree by (n+1)(n+2), over r² (module docstring); the
    classical anomaly adds ζ and normal gravity at h − ζ, node by node
    (:func:`classical_anomaly`).

    Parameters
    ----------
    model : SHModel
        Model (already truncated).
    grid : fieldmap.grids.spec.GridSpec
        Nodes.
    quantity : str
        What to compute, one of :data:`GRID_QUANTITIES`.
    ellipsoid, degree0, device
        As :func:`disturbing_potential`.
    progress : bool, optional
        Progress bar of the synthesis.

    Returns
    -------
    dict of numpy.ndarray
        Arrays of shape ``grid.shape`` (``(1, nlat, nlon)`` for the geoid and the height
        anomaly): ``potential`` (m²/s²); ``anomaly`` (mGal); ``xi``, ``eta`` (arcsec, with
        ``deflection``); ``geoid`` (m); ``height_anomaly`` (m); ``anomaly_classical``,
        ``disturbance_sa`` (mGal); ``trr`` (E).
    """
    from fieldmap.field.normal import somigliana
    from fieldmap.grids.synthesis import centrifugal_rows, normal_rows, synthesize

    if quantity not in GRID_QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(GRID_QUANTITIES)}, got {quantity!r}")
    ell = get_ellipsoid(ellipsoid)
    if quantity in _SURFACE and np.any(grid.heights != 0.0):
        grid = replace(grid, heights=np.zeros(1))
    dm = disturbing_model(model, ell, degree0=degree0)
    if quantity == "trr":
        dm = _trr_model(dm)
    out = synthesize(
        dm, grid, ell, quantity="gravitation", device=device, progress=progress, potential=True
    )
    t = out[..., 3]
    if quantity == "potential":
        return {"potential": t}
    if quantity == "height-anomaly":
        return {"height_anomaly": t / somigliana(grid.lat, ellipsoid=ell)[None, :, None]}
    if quantity == "geoid":
        gam0 = somigliana(grid.lat, ellipsoid=ell)[None, :, None]
        n = t / gam0
        lat2, lon2 = np.meshgrid(grid.lat, grid.lon, indexing="ij")
        corr = correction_height(model, lat2, lon2, ellipsoid=ell, device=device)
        return {"geoid": n + corr[None]}
    # geocentric latitude ψ and radius r of each (height, row)
    phi = np.radians(grid.lat)[None, :]
    h = grid.heights[:, None]
    nrad = ell.a / np.sqrt(1.0 - ell.e2 * np.sin(phi) ** 2)
    p = (nrad + h) * np.cos(phi)
    z = (nrad * (1.0 - ell.e2) + h) * np.sin(phi)
    r = np.hypot(p, z)
    psi = np.arctan2(z, p)
    cd, sd = np.cos(phi - psi)[..., None], np.sin(phi - psi)[..., None]
    if quantity == "trr":  # the weighted series' potential over r²
        return {"trr": t / (r * r)[..., None] * 1e9}
    g_e, g_n, g_u = out[..., 0], out[..., 1], out[..., 2]
    d_north = cd * g_n + sd * g_u  # geodetic -> geocentric (north, up)
    d_up = -sd * g_n + cd * g_u
    if quantity == "disturbance-sa":
        return {"disturbance_sa": -d_up * MGAL}
    gam_enu = normal_rows(grid, ell, device=device) + centrifugal_rows(grid, ell)
    gam = np.linalg.norm(gam_enu, axis=-1)
    if quantity == "anomaly-classical":
        return {"anomaly_classical": _grid_classical(grid, ell, out, gam_enu, gam, device)}
    gam = gam[..., None]
    if quantity == "anomaly":
        return {"anomaly": (-d_up - 2.0 * t / r[..., None]) * MGAL}
    return {
        "xi": -d_north / gam * ARCSEC_PER_RAD,
        "eta": -g_e / gam * ARCSEC_PER_RAD,
    }


def _grid_classical(
    grid: GridSpec,
    ell: Ellipsoid,
    out: np.ndarray,
    gam_enu: np.ndarray,
    gam: np.ndarray,
    device: str | None,
) -> np.ndarray:
    """Classical anomaly (mGal) of every node from the synthesis ``out`` (∇T in ENU, T).

    ``gam_enu`` (nh, nlat, 3) and ``gam`` (nh, nlat): normal gravity at the rows (ENU, with
    centrifugal) and its magnitude. |∇W(P)| = |γ(P) + ∇T(P)| (geodetic ENU, as the
    synthesis); ζ and |γ(Q)| node by node (:func:`classical_anomaly`); the normal field is
    axisymmetric, so the nodes' longitude does not enter it.
    """
    g_p = np.linalg.norm(gam_enu[:, :, None, :] + out[..., :3], axis=-1)
    shape = g_p.shape
    lat = np.broadcast_to(grid.lat[None, :, None], shape).ravel()
    h = np.broadcast_to(grid.heights[:, None, None], shape).ravel()
    gp = np.broadcast_to(gam[..., None], shape).ravel()
    _, gam_q = _normal_height_point(
        out[..., 3].ravel(), gp, lat, np.zeros_like(lat), h, ell, device
    )
    return (g_p - gam_q.reshape(shape)) * MGAL
