r"""NumPy reference for the spherical-harmonic synthesis (independent of the Warp kernels).

Written for clarity. Differences from :mod:`fieldmap.kernels.sh` on purpose:

* the Legendre functions are built **row by row** in **X-numbers**
  (:func:`fieldmap.field.legendre.legendre_rows`: all orders of degree n at once, vectorised
  over points and orders, instead of column by column; every value a float mantissa times
  2^(400·k), in range at any degree, finite at the poles; no fixed 1e-280 scaling, no Horner
  scheme in u); O(N·lmax²) NumPy work, ~6 s per point at degree 10,800;
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

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.field import legendre
from fieldmap.models.shmodel import SHModel


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
    for n, P, PU in legendre.legendre_rows(t, u, L):
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
    for n, P, _ in legendre.legendre_rows(np.sin(phi), np.cos(phi), lmax):
        out[:, n, : n + 1] = P
    return out
