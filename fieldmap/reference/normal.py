"""NumPy reference implementations of normal gravity, independent of ``kernels/normal.py``.

Written for clarity, not speed; each follows a different route than the Warp code:

* :func:`exact_gravitation_ecef` differentiates the level-ellipsoid potential directly in Cartesian
  coordinates, V(x, y, z) = f(u) + g(u)(z²/u² − 1/3), with ∇u from the implicit equation
  u⁴ − (r² − E²)u² − E²z² = 0 (the kernel uses the (u, β) metric instead), and q'(x) from
  Heiskanen & Moritz's q' (eq. 2-67 form) with its own series.
* :func:`zonal_series_gravitation` sums the J2n series (H&M eq. 2-92 coefficients) with Legendre
  recursions in spherical coordinates, to any degree (converges for r > E, i.e. everywhere on
  and above the ellipsoid).
* :func:`jn_gravitation` takes complex-step derivatives of the truncated potential, Chen et al.
  (2022) eq. (7) with P2, P4, P6 of eq. (8).
* :func:`groves_j2_gravitation` and :func:`groves_gravity_ned` type Groves (2013) eqs. 3.7.7 and
  3.7.6 as printed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from numpy.typing import ArrayLike

from fieldmap.field.ellipsoid import Ellipsoid

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

#: a NumPy array (float64; complex128 in the complex-step derivatives)
_Array = npt.NDArray[Any]

# ---------------------------------------------------------------------------------------------
# exact closed form, Cartesian route


def _one_minus_atan_over_x(x: ArrayLike) -> _Array:
    """1 − arctan(x)/x, by its Taylor series for small x (no cancellation), else directly."""
    x = np.asarray(x, dtype=np.float64)
    small = x < 0.5
    xs = np.where(small, x, 0.0)
    total = np.zeros_like(xs)
    power = np.ones_like(xs)
    for k in range(1, 60):  # 0.5^(2·60) is far below double precision
        power = power * xs * xs
        total += (-1) ** (k + 1) * power / (2 * k + 1)
    xl = np.where(small, 1.0, x)
    return np.where(small, total, 1.0 - np.arctan(xl) / xl)


def q_function(x: ArrayLike) -> _Array:
    r"""q(x) = ½[(1 + 3/x²) arctan x − 3/x] (H&M eq. 2-58), x = E/u, written via 1 − arctan(x)/x.

    With arctan x = x(1 − w), w = 1 − arctan(x)/x:  q = ½[x(1 − w) − 3w/x]. The O(x) parts
    cancel; with T = w − x²/3 (its own series, no cancellation) q = −½[x³/3 + T(x + 3/x)].
    """
    x = np.asarray(x, dtype=np.float64)
    w = _one_minus_atan_over_x(x)
    # w − x²/3 = Σ_{k≥2} (−1)^(k+1) x^(2k)/(2k+1), again by series for small x
    small = x < 0.5
    xs = np.where(small, x, 0.0)
    tail = np.zeros_like(xs)
    power = xs * xs
    for k in range(2, 60):
        power = power * xs * xs
        tail += (-1) ** (k + 1) * power / (2 * k + 1)
    tail = np.where(small, tail, w - x * x / 3.0)
    return -0.5 * (x**3 / 3.0 + tail * (x + 3.0 / x))


def q_prime_hm(x: ArrayLike) -> _Array:
    r"""Heiskanen & Moritz's q' = 3(1 + 1/x²)(1 − arctan(x)/x) − 1 (eq. 2-67 with x = E/u).

    It relates to the derivative of q(E/u) by dq/du = −E q'/(u² + E²) (checked numerically in
    the tests against finite differences of :func:`q_function`).
    """
    x = np.asarray(x, dtype=np.float64)
    return 3.0 * (1.0 + 1.0 / (x * x)) * _one_minus_atan_over_x(x) - 1.0


def ellipsoidal_u(x: _Array, y: _Array, z: _Array, E: float) -> _Array:
    """Ellipsoidal coordinate u (semi-minor axis of the confocal ellipsoid through the point). m."""
    r2 = x * x + y * y + z * z
    d = r2 - E * E
    return np.sqrt(0.5 * (d + np.sqrt(d * d + 4.0 * E * E * z * z)))


def exact_potential(x: _Array, y: _Array, z: _Array, ell: Ellipsoid) -> _Array:
    r"""Gravitational potential of the level ellipsoid (H&M eqs. 2-61, 2-62, without Φ). m²/s²."""
    E = ell.E
    u = ellipsoidal_u(x, y, z, E)
    sin2beta = z * z / (u * u)
    return ell.GM / E * np.arctan(E / u) + 0.5 * ell.omega**2 * ell.a**2 * q_function(
        E / u
    ) / ell.q0 * (sin2beta - 1.0 / 3.0)


def exact_gravitation_ecef(x: ArrayLike, y: ArrayLike, z: ArrayLike, ell: Ellipsoid) -> _Array:
    r"""Gradient of :func:`exact_potential` in Cartesian coordinates. Returns (..., 3), m/s².

    V = f(u) + g(u)·(z²/u² − 1/3) with f = (GM/E) arctan(E/u), g = ½ω²a² q(E/u)/q0, so

    .. math::
        \nabla V = \Big[f'(u) + g'(u)\big(\tfrac{z^2}{u^2}-\tfrac13\big)
                   - 2g(u)\tfrac{z^2}{u^3}\Big]\nabla u + g(u)\,\frac{2z}{u^2}\hat z,

        \nabla u = \frac{(u x,\; u y,\; z(u^2+E^2)/u)}{2u^2 - r^2 + E^2}.
    """
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    E = ell.E
    u = ellipsoidal_u(x, y, z, E)
    r2 = x * x + y * y + z * z
    denom = 2.0 * u * u - r2 + E * E
    grad_u = np.stack([u * x, u * y, z * (u * u + E * E) / u], axis=-1) / denom[..., None]
    c = 0.5 * ell.omega**2 * ell.a**2 / ell.q0
    g = c * q_function(E / u)
    fp = -ell.GM / (u * u + E * E)
    gp = -c * E * q_prime_hm(E / u) / (u * u + E * E)
    s2 = z * z / (u * u)
    coef = fp + gp * (s2 - 1.0 / 3.0) - 2.0 * g * z * z / u**3
    out = coef[..., None] * grad_u
    out[..., 2] += g * 2.0 * z / (u * u)
    return out


# ---------------------------------------------------------------------------------------------
# zonal series


def legendre_and_derivative(nmax: int, t: ArrayLike) -> tuple[_Array, _Array]:
    """Legendre polynomials P_n(t) and P_n'(t), n = 0..nmax, shape (nmax+1, ...).

    Bonnet's recursion n P_n = (2n−1) t P_{n−1} − (n−1) P_{n−2}, and
    P_n' = P_{n−2}' + (2n−1) P_{n−1}
    (valid at t = ±1, unlike the (1 − t²) form).
    """
    t = np.asarray(t, dtype=np.float64)
    P = np.zeros((nmax + 1,) + t.shape)
    dP = np.zeros_like(P)
    P[0] = 1.0
    if nmax >= 1:
        P[1] = t
        dP[1] = 1.0
    for n in range(2, nmax + 1):
        P[n] = ((2 * n - 1) * t * P[n - 1] - (n - 1) * P[n - 2]) / n
        dP[n] = dP[n - 2] + (2 * n - 1) * P[n - 1]
    return P, dP


def zonal_series_gravitation(
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    ell: Ellipsoid,
    nmax: int = 40,
    radius: float | None = None,
) -> _Array:
    r"""Gradient of V = (GM/r)[1 − Σ_{n=1}^{nmax} J_{2n} (R/r)^{2n} P_{2n}(z/r)]. (..., 3), m/s².

    Chen et al. (2022) eq. (6)/(7); J_{2n} from :meth:`Ellipsoid.J2n` (H&M eq. 2-92), R = a by
    default. With t = z/r: ∇V = (∂V/∂r) r̂ + (∂V/∂t)(ẑ − t r̂)/r.
    """
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    R = ell.a if radius is None else radius
    r = np.sqrt(x * x + y * y + z * z)
    t = z / r
    P, dP = legendre_and_derivative(2 * nmax, t)
    dV_dr = -ell.GM / r**2 * np.ones_like(r)
    dV_dt = np.zeros_like(r)
    for n in range(1, nmax + 1):
        J = ell.J2n(n)
        ratio = (R / r) ** (2 * n)
        dV_dr += ell.GM / r**2 * (2 * n + 1) * J * ratio * P[2 * n]
        dV_dt += -ell.GM / r * J * ratio * dP[2 * n]
    rhat = np.stack([x, y, z], axis=-1) / r[..., None]
    zhat = np.zeros_like(rhat)
    zhat[..., 2] = 1.0
    return dV_dr[..., None] * rhat + (dV_dt / r)[..., None] * (zhat - t[..., None] * rhat)


def zonal_sh_model(
    ell: Ellipsoid, nmax: int = 12, gm: float | None = None, radius: float | None = None
) -> SHModel:
    r"""Return the normal gravitational potential as a zonal SH model of degree 2 nmax.

    Fully normalised coefficients of the J2n series (Heiskanen & Moritz 1967 eq. 2-92),
    re-expressed with the model constants ``gm``, ``radius`` (default: the ellipsoid's GM, a):

    .. math::
        \bar C_{00} = GM/gm,\qquad
        \bar C_{2k,0} = -\frac{J_{2k}}{\sqrt{4k+1}}\,\frac{GM}{gm}\Big(\frac{a}{R}\Big)^{2k}.

    Units: gm m³/s², radius m.
    """
    from fieldmap.models.shmodel import SHModel

    gm = ell.GM if gm is None else gm
    radius = ell.a if radius is None else radius
    L = 2 * nmax
    C = np.zeros((L + 1, L + 1))
    C[0, 0] = ell.GM / gm
    for k in range(1, nmax + 1):
        C[2 * k, 0] = -ell.J2n(k) / np.sqrt(4 * k + 1) * (ell.GM / gm) * (ell.a / radius) ** (2 * k)
    return SHModel(f"zonal-{ell.name}", gm, radius, C, np.zeros_like(C), L)


# ---------------------------------------------------------------------------------------------
# truncated J2/J4/J6 (Chen et al. 2022 eqs. 7-8) by complex-step differentiation


def _p2n(n: int, s: _Array) -> _Array:
    """P2, P4, P6 of Chen et al. (2022) eq. (8) (works on complex arrays)."""
    if n == 1:
        return 1.5 * s**2 - 0.5
    if n == 2:
        return 35.0 / 8.0 * s**4 - 30.0 / 8.0 * s**2 + 3.0 / 8.0
    if n == 3:
        return 231.0 / 16.0 * s**6 - 315.0 / 16.0 * s**4 + 105.0 / 16.0 * s**2 - 5.0 / 16.0
    raise ValueError("n must be 1, 2 or 3")


def jn_potential(
    x: _Array, y: _Array, z: _Array, ell: Ellipsoid, order: int, j2: float | None = None
) -> _Array:
    """Return the zonal potential of Chen et al. (2022) eq. (7) up to J_order (2, 4, 6). m²/s²."""
    rho = np.sqrt(x * x + y * y + z * z)
    s = z / rho
    J = {1: ell.J2 if j2 is None else j2, 2: ell.J4, 3: ell.J6}
    total = 1.0
    for n in range(1, order // 2 + 1):
        total = total - J[n] * (ell.a / rho) ** (2 * n) * _p2n(n, s)
    return ell.GM / rho * total


def jn_gravitation(
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    ell: Ellipsoid,
    order: int,
    j2: float | None = None,
    step: float = 1e-20,
) -> _Array:
    """Gradient of :func:`jn_potential` by complex-step derivatives (exact to rounding). m/s²."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.complex128) for v in (x, y, z)))
    out = []
    for k in range(3):
        pts = [x, y, z]
        pts[k] = pts[k] + 1j * step
        out.append(np.imag(jn_potential(pts[0], pts[1], pts[2], ell, order, j2)) / step)
    return np.stack(out, axis=-1)


# ---------------------------------------------------------------------------------------------
# Groves (2013) as printed


def groves_j2_gravitation(
    x: ArrayLike, y: ArrayLike, z: ArrayLike, mu: float, J2: float, R0: float
) -> _Array:
    """Groves (2013) eq. 3.7.7, ECEF J2 gravitation, typed as printed. m/s²."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    r = np.sqrt(x * x + y * y + z * z)
    zr2 = (z / r) ** 2
    k = 1.5 * J2 * R0**2 / r**2
    vec = np.stack(
        [x + k * (1 - 5 * zr2) * x, y + k * (1 - 5 * zr2) * y, z + k * (3 - 5 * zr2) * z]
    )
    return np.moveaxis(-mu / r**3 * vec, 0, -1)


def groves_centrifugal_ned(lat_rad: ArrayLike, r_ned: _Array, omega: float) -> _Array:
    """Centrifugal term of Groves (2013) eq. 3.7.6 in NED, typed as printed. m/s²."""
    sL, cL = np.sin(lat_rad), np.cos(lat_rad)
    rn, re, rd = r_ned[..., 0], r_ned[..., 1], r_ned[..., 2]
    return omega**2 * np.stack([sL * sL * rn + cL * sL * rd, re, cL * sL * rn + cL * cL * rd], -1)


# ---------------------------------------------------------------------------------------------
# assembly at geodetic points


def _geodetic_to_ecef(
    lat: _Array, lon: _Array, h: _Array, ell: Ellipsoid
) -> tuple[_Array, _Array, _Array]:
    N = ell.a / np.sqrt(1.0 - ell.e2 * np.sin(lat) ** 2)
    return (
        (N + h) * np.cos(lat) * np.cos(lon),
        (N + h) * np.cos(lat) * np.sin(lon),
        (N * (1.0 - ell.e2) + h) * np.sin(lat),
    )


def _ned_basis(lat: ArrayLike, lon: ArrayLike) -> _Array:
    """Rows: north, east, down unit vectors in ECEF, shape (..., 3, 3)."""
    sL, cL, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    north = np.stack([-sL * co, -sL * so, cL], -1)
    east = np.stack([-so, co, 0.0 * so], -1)
    down = np.stack([-cL * co, -cL * so, -sL], -1)
    return np.stack([north, east, down], -2)


def normal_gravity(
    lat_deg: ArrayLike,
    lon_deg: ArrayLike,
    h: ArrayLike,
    ell: Ellipsoid,
    kind: str = "exact",
    centrifugal: bool = True,
    frame: str = "enu",
    groves_j2: float | None = 1.082627e-3,
) -> _Array:
    """Compute normal gravity at geodetic points (reference).

    Conventions of ``fieldmap.field.normal``.
    """
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    lat, lon, h = np.broadcast_arrays(lat, lon, np.asarray(h, dtype=np.float64))
    x, y, z = _geodetic_to_ecef(lat, lon, h, ell)
    if kind == "exact":
        g = exact_gravitation_ecef(x, y, z, ell)
    elif kind in ("j2", "j4", "j6"):
        g = jn_gravitation(x, y, z, ell, int(kind[1]))
    elif kind == "groves_j2":
        g = groves_j2_gravitation(
            x, y, z, ell.GM, ell.J2 if groves_j2 is None else groves_j2, ell.a
        )
    else:
        raise ValueError(kind)
    C = _ned_basis(lat, lon)
    g_ned = np.einsum("...ij,...j->...i", C, g)
    if centrifugal:
        r_ned = np.einsum("...ij,...j->...i", C, np.stack([x, y, z], -1))
        g_ned = g_ned + groves_centrifugal_ned(lat, r_ned, ell.omega)
    if frame == "ned":
        return g_ned
    if frame == "enu":
        return np.stack([g_ned[..., 1], g_ned[..., 0], -g_ned[..., 2]], -1)
    return np.einsum("...ji,...j->...i", C, g_ned)  # ECEF
