r"""Commission error: standard deviations of field quantities propagated from coefficient σ.

ICGEM files give a (calibrated) standard deviation for every coefficient,
:attr:`SHModel.sigma_c` and :attr:`SHModel.sigma_s`. Every quantity f computed here is linear in
the coefficients, so with **uncorrelated coefficient errors** (diagonal propagation: the full
covariance matrix of the solution is not distributed with the model and is not used)

.. math::
    \sigma^2(f) = \sum_{n,m} \left(\frac{\partial f}{\partial \bar C_{nm}}\right)^2
        \sigma^2_{C,nm} + \left(\frac{\partial f}{\partial \bar S_{nm}}\right)^2\sigma^2_{S,nm}.

Each partial derivative is the coefficient's basis function; with q = R/r, ψ the geocentric
latitude, t = sin ψ, u = cos ψ and P̄nm fully normalised (no Condon-Shortley phase):

* geoid height N (Bruns, at h = 0, γ0 Somigliana's normal gravity):
  :math:`\partial N/\partial \bar C_{nm} = \frac{GM}{r\gamma_0} q^n \bar P_{nm}\cos m\lambda`
  (sin mλ for S);
* gravity anomaly (spherical approximation, :mod:`fieldmap.field.geodesy`):
  :math:`\partial\Delta g/\partial \bar C_{nm} = \frac{GM}{r^2}(n-1) q^n \bar P_{nm}\cos m\lambda`;
* gravity disturbance δg in the local geodetic east-north-up frame: the geocentric radial
  :math:`-\frac{GM}{r^2}(n+1)q^n\bar P_{nm}`, north :math:`\frac{GM}{r^2}q^n d\bar P_{nm}/d\psi`
  and east :math:`\frac{GM}{r^2}q^n m \bar P_{nm}/u` (times ∓sin/cos mλ) basis values, turned by
  the angle φ − ψ between the geodetic and the geocentric vertical.

The normal field and the correction terms of N do not depend on the coefficients and drop out.
For a time-variable model the σ are those of the static part (the ``gfct`` lines; the σ of
trend and periodic terms are not propagated).

The Legendre functions come from the row recursion of :func:`fieldmap.field.legendre.legendre_rows`
(extended range, finite at the poles); the sums are NumPy, vectorised over points and orders,
in chunks of points (a degree-240 model at a few thousand points takes seconds).
"""

from __future__ import annotations

import os

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.field.legendre import legendre_rows
from fieldmap.limits import check_geodetic
from fieldmap.models.shmodel import SHModel

#: quantities of :func:`commission_sigma` and their units
QUANTITIES = {"disturbance": "mGal", "anomaly": "mGal", "geoid": "m"}
MGAL = 1.0e5  # mGal per m/s²
_CHUNK = 2048  # points per pass (memory: a few (chunk, lmax+1) float arrays)


def _sigma_model(
    model: SHModel | str | os.PathLike[str], lmax: int | None, epoch: float | str | None
) -> SHModel:
    from fieldmap.models.registry import load_model

    m = load_model(model, lmax=lmax, epoch=epoch)
    if m.sigma_c is None or m.sigma_s is None:
        raise InputError(
            f"model {m.name} carries no coefficient standard deviations (sigma C, sigma S):"
            " the commission error needs an ICGEM file with sigma columns"
        )
    return m


def disturbance_basis(
    n: int,
    P: NDArray[np.float64],
    PU: NDArray[np.float64],
    t: NDArray[np.float64],
    m: NDArray[np.float64],
    cd: NDArray[np.float64],
    sd: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Basis values of δg at degree n, orders m = 0..n: (east factor m P̄/u, north, up).

    ``P``, ``PU``: P̄nm and P̄nm/u, shape (N, n+1) (:func:`fieldmap.field.legendre.legendre_rows`);
    ``t`` sin ψ (N,); ``m`` the orders; ``cd``, ``sd`` cos/sin of φ − ψ, shape (N, 1). North and
    up are the geodetic components of the geocentric radial −(n+1) P̄ and dP̄/dψ (the factor
    GM/r² q^n and cos/sin mλ left out); the east basis is ∓ m P̄/u sin/cos mλ.
    """
    e = np.sqrt((n - m) * (n + m + 1))
    e[0] = np.sqrt(n * (n + 1) / 2.0)
    P_next = np.zeros_like(P)
    P_next[:, :n] = P[:, 1 : n + 1]
    dP = -m * t[:, None] * PU + e * P_next
    radial = -(n + 1.0) * P
    return m * PU, -radial * sd + dP * cd, radial * cd + dP * sd


def _variances(
    model: SHModel,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
    lat_geod: NDArray[np.float64],
    quantity: str,
) -> np.ndarray:
    """Σ basis² σ² at ECEF points (1-D), shape (N,) or (N, 3) for the disturbance; SI units."""
    rho = np.hypot(x, y)
    r = np.hypot(rho, z)
    t, u = z / r, rho / r
    lam = np.arctan2(y, x)
    q2 = (model.radius / r) ** 2
    L = model.lmax
    mm = np.arange(L + 1, dtype=np.float64)
    cos2 = np.cos(np.outer(lam, mm)) ** 2
    sin2 = 1.0 - cos2
    sc2, ss2 = np.asarray(model.sigma_c) ** 2, np.asarray(model.sigma_s) ** 2
    disturbance = quantity == "disturbance"
    acc = np.zeros((r.size, 3 if disturbance else 1))
    if disturbance:
        delta = np.radians(lat_geod) - np.arctan2(z, rho)  # geodetic minus geocentric latitude
        cd, sd = np.cos(delta)[:, None], np.sin(delta)[:, None]
    qn2 = np.ones_like(r)
    for n, P, PU in legendre_rows(t, u, L):
        k = slice(0, n + 1)
        w = cos2[:, k] * sc2[n, k] + sin2[:, k] * ss2[n, k]  # weight of a cos-type basis
        if not disturbance:
            f = (n - 1.0) if quantity == "anomaly" else 1.0
            acc[:, 0] += qn2 * f * f * np.sum(P * P * w, axis=1)
        else:
            east, north, up = disturbance_basis(n, P, PU, t, mm[k], cd, sd)
            we = sin2[:, k] * sc2[n, k] + cos2[:, k] * ss2[n, k]  # east: the λ-derivative
            acc[:, 0] += qn2 * np.sum(east**2 * we, axis=1)
            acc[:, 1] += qn2 * np.sum(north * north * w, axis=1)
            acc[:, 2] += qn2 * np.sum(up * up * w, axis=1)
        qn2 = qn2 * q2
    if quantity == "geoid":
        return acc[:, 0] * (model.gm / r) ** 2
    scale = (model.gm / r**2) ** 2
    return acc * scale[:, None] if disturbance else acc[:, 0] * scale


def commission_sigma(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike = 0.0,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    quantity: str = "disturbance",
    lmax: int | None = None,
    ellipsoid: Ellipsoid | str = WGS84,
    epoch: float | str | None = None,
) -> np.ndarray:
    """Propagated standard deviation (commission error) of a quantity at geodetic points.

    Parameters
    ----------
    latitude, longitude : array_like
        Geodetic latitude and longitude. Units: degrees.
    height : array_like
        Height above ``ellipsoid`` (ignored for ``"geoid"``, which is at h = 0). Units: m.
    model : SHModel or str
        A model with ``sigma_c``/``sigma_s`` (an ICGEM file with σ columns; the bundled
        EIGEN-6S has them), a bundled model name or a model file path.
    quantity : {"disturbance", "anomaly", "geoid"}
        Gravity disturbance δg (east, north, up), gravity anomaly Δg or geoid height N.
    lmax : int, optional
        Truncation degree (the σ of the omitted degrees are not counted: that is the omission
        error's part).
    ellipsoid : Ellipsoid or str
        Ellipsoid of the coordinates and of the normal gravity (default WGS84).
    epoch : float or str, optional
        Epoch of the model's time-variable terms (the σ are the static part's in any case).

    Returns
    -------
    numpy.ndarray
        Broadcast shape of the inputs (``+ (3,)`` for ``"disturbance"``: σ east, north, up).
        Units: mGal for δg and Δg, m for N.

    Raises
    ------
    InputError
        Unknown quantity, or a model without coefficient standard deviations.

    Examples
    --------
    The standard deviation of EIGEN-6S's disturbance from its coefficients' sigma, at one point:

    >>> import numpy as np
    >>> import fieldmap
    >>> sigma = fieldmap.commission_sigma([45.0], [10.0], 0.0)
    >>> np.round(sigma, 2)  # east, north, up. Units: mGal
    array([[3.77, 3.33, 5.04]])
    """
    if quantity not in QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    ell = get_ellipsoid(ellipsoid)
    geoid = quantity == "geoid"
    lat, lon, h = check_geodetic(latitude, longitude, 0.0 if geoid else height)
    m = _sigma_model(model, lmax, epoch)
    x, y, z = (np.ravel(v) for v in frames.geodetic_to_ecef(lat, lon, h, ell))
    flat_lat = np.ravel(lat)
    var = np.zeros((x.size, 3) if quantity == "disturbance" else x.size)
    for i in range(0, x.size, _CHUNK):
        k = slice(i, i + _CHUNK)
        var[k] = _variances(m, x[k], y[k], z[k], flat_lat[k], quantity)
    if geoid:
        from fieldmap.field.normal import somigliana

        gamma0 = np.asarray(somigliana(lat, ellipsoid=ell), dtype=np.float64).ravel()
        return (np.sqrt(var) / gamma0).reshape(lat.shape)
    sig = np.sqrt(var) * MGAL
    return sig.reshape(lat.shape + ((3,) if quantity == "disturbance" else ()))


def commission_draws(
    model: SHModel,
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    draws: int,
    seed: int,
    ellipsoid: Ellipsoid = WGS84,
    device: str | None = None,
) -> np.ndarray:
    """Random realisations of the model's commission error of δg, north/east/down, in m/s².

    Each draw is a set of coefficient errors δC̄nm ~ N(0, σ²_C,nm), δS̄nm ~ N(0, σ²_S,nm)
    (uncorrelated, as :func:`commission_sigma` assumes), synthesised as a gravitational field
    by the point engine (:func:`fieldmap.field.sh.sh_gravitation`): a realisation is a field
    consistent in 3-D, and its σ over draws at a point is :func:`commission_sigma`'s.

    Parameters
    ----------
    model : SHModel
        A model with ``sigma_c`` and ``sigma_s`` (its degree: the degrees realised).
    latitude, longitude, height : array_like
        Geodetic points (1-D, same length). Units: degrees, degrees, m.
    draws : int
        Number of realisations (>= 1).
    seed : int
        Seed of ``numpy.random.default_rng``: the same seed gives the same fields.
    ellipsoid : Ellipsoid
        Of the coordinates.
    device : str, optional
        Warp device.

    Returns
    -------
    numpy.ndarray
        Shape (draws, n, 3): δg north, east, down. Units: m/s².
    """
    from fieldmap.field.sh import sh_gravitation

    if model.sigma_c is None or model.sigma_s is None:
        raise InputError(
            f"model {model.name} carries no coefficient standard deviations: no commission error"
        )
    lat, lon, h = (np.asarray(v, dtype=np.float64).ravel() for v in (latitude, longitude, height))
    x, y, z = frames.geodetic_to_ecef(lat, lon, h, ellipsoid)
    enu = frames.C_e_to_enu(lat, lon)
    rng = np.random.default_rng(seed)
    sc, ss = np.asarray(model.sigma_c), np.asarray(model.sigma_s)
    out = np.empty((int(draws), lat.size, 3))
    for k in range(int(draws)):
        dC = sc * rng.standard_normal(sc.shape)
        dS = ss * rng.standard_normal(ss.shape)
        err = SHModel(
            f"{model.name} commission draw {k}", model.gm, model.radius, dC, dS, model.lmax,
            tide_system=model.tide_system, source="synthetic",
        )  # fmt: skip
        g = np.asarray(sh_gravitation(err, x, y, z, device=device))
        e_n_u = np.einsum("nij,nj->ni", enu, g)
        out[k] = e_n_u[:, [1, 0, 2]] * np.array([1.0, 1.0, -1.0])
    return out
