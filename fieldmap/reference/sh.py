r"""NumPy reference for the spherical-harmonic synthesis (independent of the Warp kernels).

Written for clarity. Differences from :mod:`fieldmap.kernels.sh` on purpose:

* the Legendre functions are built **row by row** (all orders of degree n at once, vectorised
  over points and orders) instead of column by column;
* the range problem near the poles is handled with **X-numbers** (Fukushima 2012, J. Geodesy
  86:271-285): every value is a float mantissa times 2^(400·k) with an integer k per point and
  order, and the powers u^m are carried the same way; nothing is scaled by a fixed 1e-280 and no
  Horner scheme in u is used. Along a column ``P̄nm/u^m`` does not decay (it grows, by at
  most ~sqrt(2n) per row, or oscillates), so one rescaling per row keeps it in range at any
  degree (checked against mpmath and the kernels up to degree 10,800, equator to poles); the
  cost is O(N·lmax²) NumPy work, ~6 s per point at degree 10,800;
* latitude derivatives come from the **m+1 identity**

  .. math::
      \frac{d\bar P_{nm}}{d\varphi} = -m\frac{t}{u}\bar P_{nm} + e_{nm}\bar P_{n,m+1},
      \quad e_{nm} = \sqrt{(n-m)(n+m+1)}\;(m \ge 1),\quad e_{n0} = \sqrt{n(n+1)/2},

  (from dP_n^m/dφ = −m (t/u) P_n^m + P_n^{m+1} for the unnormalised functions and the ratio of
  normalisation factors; the m = 0 factor carries 1/√2 because P̄_n0 has no factor √2);
* the powers q^n come from ``numpy.power`` and cos/sin(mλ) from ``numpy.cos``/``sin`` directly.

The potential and its spherical gradient follow Chen et al. (2022) eqs. 1-3:

.. math::
    V = \frac{GM}{r}\sum_n q^n\sum_m (C\cos m\lambda + S\sin m\lambda)\bar P_{nm},\quad
    \partial_r V = -\frac{GM}{r^2}\sum_n (n+1) q^n \sum_m(\dots)\bar P_{nm},

    \frac{1}{r}\partial_\varphi V = \frac{GM}{r^2}\sum_n q^n\sum_m(\dots)
        \frac{d\bar P_{nm}}{d\varphi},\quad
    \frac{1}{r\cos\varphi}\partial_\lambda V = \frac{GM}{r^2}\sum_n q^n\sum_m
        m(S\cos m\lambda - C\sin m\lambda)\frac{\bar P_{nm}}{u}.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.models.shmodel import SHModel

_STEP = 400  # X-number exponent step: values are mantissa * 2**(400 k)
_BIG = 2.0**_STEP


def _powers_x(u: np.ndarray, kmax: int) -> tuple[np.ndarray, np.ndarray]:
    """u^k for k = 0..kmax as X-numbers: ``(mant, exp2)`` arrays of shape (N, kmax+1)."""
    fu, eu = np.frexp(u)  # u = fu * 2**eu, fu in [0.5, 1) (or 0)
    mant = np.empty((u.size, kmax + 1))
    ex = np.empty((u.size, kmax + 1), dtype=np.int64)
    cur = np.ones_like(u)
    cur_e = np.zeros(u.size, dtype=np.int64)
    for k in range(kmax + 1):
        mant[:, k] = cur
        ex[:, k] = cur_e + k * eu
        cur = cur * fu
        small = (cur != 0.0) & (np.abs(cur) < 1.0 / _BIG)
        cur = np.where(small, cur * _BIG, cur)
        cur_e = cur_e - np.where(small, _STEP, 0)
    return mant, ex


def legendre_rows(
    t: np.ndarray, u: np.ndarray, lmax: int
) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Yield ``(n, P, PU)`` for n = 0..lmax.

    ``P[:, m]`` = P̄nm(t) and ``PU[:, m]`` = P̄nm(t)/u (m ≥ 1; column 0 set to 0), shapes
    (N, n+1), fully normalised without Condon-Shortley phase. ``PU`` stays finite at u = 0.

    Recursion (row-wise, over all m < n at once):
    ``Q_nm = a_nm t Q_{n-1,m} − b_nm Q_{n-2,m}`` with Q = P̄/u^m and the sectoral start
    ``Q_nn = sqrt(3) prod_{k=2}^{n} sqrt((2k+1)/(2k))`` (Q_00 = 1).
    """
    N = t.size
    umant, uex = _powers_x(u, lmax + 1)
    q1 = np.zeros((N, lmax + 1))  # row n-1 mantissas, per column exponent k
    q2 = np.zeros((N, lmax + 1))  # row n-2
    kx = np.zeros((N, lmax + 1), dtype=np.int64)
    sect = 1.0
    for n in range(lmax + 1):
        qn = np.zeros((N, lmax + 1))
        if n >= 1:
            m = np.arange(n, dtype=np.float64)
            a = np.sqrt((2 * n - 1) * (2 * n + 1) / ((n - m) * (n + m)))
            with np.errstate(invalid="ignore", divide="ignore"):
                b = np.sqrt(
                    (2 * n + 1) * (n + m - 1) * (n - m - 1) / ((n - m) * (n + m) * (2 * n - 3))
                )
            b = np.where(n - m >= 2, b, 0.0)
            qn[:, :n] = a * t[:, None] * q1[:, :n] - b * q2[:, :n]
            sect = np.sqrt(3.0) if n == 1 else sect * np.sqrt((2 * n + 1) / (2.0 * n))
        qn[:, n] = sect
        kx[:, n] = 0
        # keep mantissas in range: rescale a whole column (rows n and n-1 together)
        big = np.maximum(np.abs(qn), np.abs(q1)) > _BIG
        qn = np.where(big, qn / _BIG, qn)
        q1 = np.where(big, q1 / _BIG, q1)
        kx = kx + big
        cols = slice(0, n + 1)
        P = np.ldexp(qn[:, cols] * umant[:, cols], _STEP * kx[:, cols] + uex[:, cols])
        PU = np.zeros_like(P)
        if n >= 1:
            c1 = slice(1, n + 1)
            c0 = slice(0, n)
            PU[:, c1] = np.ldexp(qn[:, c1] * umant[:, c0], _STEP * kx[:, c1] + uex[:, c0])
        yield n, P, PU
        q2, q1 = q1, qn


def spherical_gradient(
    model: SHModel, x: ArrayLike, y: ArrayLike, z: ArrayLike, lmax: int | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Potential and gravitation components in the geocentric spherical frame.

    Parameters
    ----------
    model : SHModel
        Gravity model.
    x, y, z : array_like
        ECEF coordinates (1-D, same length). Units: m.
    lmax : int, optional
        Truncation degree.

    Returns
    -------
    V, g_east, g_north, g_up : numpy.ndarray
        Units: m²/s², m/s² (geocentric east, north, radial up).
    """
    x, y, z = (np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in (x, y, z))
    L = model.lmax if lmax is None else int(lmax)
    rho = np.hypot(x, y)
    r = np.hypot(rho, z)
    t, u = z / r, rho / r
    lam = np.arctan2(y, x)
    q = model.radius / r
    mm = np.arange(L + 1, dtype=np.float64)
    cosm = np.cos(np.outer(lam, mm))
    sinm = np.sin(np.outer(lam, mm))
    V = np.zeros_like(r)
    d_r = np.zeros_like(r)
    d_phi = np.zeros_like(r)
    d_lam = np.zeros_like(r)
    for n, P, PU in legendre_rows(t, u, L):
        m = mm[: n + 1]
        e = np.sqrt((n - m) * (n + m + 1))
        e[0] = np.sqrt(n * (n + 1) / 2.0)
        P_next = np.zeros_like(P)
        P_next[:, :n] = P[:, 1 : n + 1]
        dP = -m * t[:, None] * PU + e * P_next
        C = model.C[n, : n + 1]
        S = model.S[n, : n + 1]
        A = C * cosm[:, : n + 1] + S * sinm[:, : n + 1]
        B = m * (S * cosm[:, : n + 1] - C * sinm[:, : n + 1])
        qn = np.power(q, n)
        V += qn * np.sum(A * P, axis=1)
        d_r += (n + 1) * qn * np.sum(A * P, axis=1)
        d_phi += qn * np.sum(A * dP, axis=1)
        d_lam += qn * np.sum(B * PU, axis=1)
    k = model.gm / r
    return k * V, k / r * d_lam, k / r * d_phi, -k / r * d_r


def gravitation_ecef(
    model: SHModel, x: ArrayLike, y: ArrayLike, z: ArrayLike, lmax: int | None = None
) -> np.ndarray:
    """Gravitation (no centrifugal) in ECEF, shape (N, 3). Units: m -> m/s²."""
    x, y, z = (np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in (x, y, z))
    _, ge, gn, gu = spherical_gradient(model, x, y, z, lmax)
    lam = np.arctan2(y, x)
    phi = np.arctan2(z, np.hypot(x, y))
    # columns: unit vectors east, north, up of the geocentric spherical frame in ECEF
    east = np.stack([-np.sin(lam), np.cos(lam), np.zeros_like(lam)], axis=-1)
    north = np.stack([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)], axis=-1)
    up = np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)
    return ge[:, None] * east + gn[:, None] * north + gu[:, None] * up


def potential(
    model: SHModel, x: ArrayLike, y: ArrayLike, z: ArrayLike, lmax: int | None = None
) -> np.ndarray:
    """Gravitational potential (Chen et al. 2022 eq. 1). Units: m -> m²/s²."""
    return spherical_gradient(model, x, y, z, lmax)[0]


def legendre_matrix(lat_rad: ArrayLike, lmax: int) -> np.ndarray:
    """Full matrix P̄nm(sin φ), shape (N, lmax+1, lmax+1) indexed [point, n, m] (for tests).

    Units: geocentric latitude in radians.
    """
    phi = np.atleast_1d(np.asarray(lat_rad, dtype=np.float64))
    out = np.zeros((phi.size, lmax + 1, lmax + 1))
    for n, P, _ in legendre_rows(np.sin(phi), np.cos(phi), lmax):
        out[:, n, : n + 1] = P
    return out
