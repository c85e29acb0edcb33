r"""The linear error model of an inertial navigator: its position error driven by a gravity error.

An INS integrates the specific force it measures plus the gravity its model computes. With a
perfect IMU and a gravity model in error by δg(t) along the true path, the navigated position
r + δr obeys, to first order in δr (in the Earth-fixed frame, ω the Earth's rotation rate,
Γ = ∂g/∂r the gravitation gradient at the true position; Groves 2013 §14.2, Titterton & Weston
2004 §12.2)

.. math::
    \delta\dot r = \delta v,\qquad
    \delta\dot v = \Gamma\,\delta r - 2\omega\times\delta v - \omega\times(\omega\times\delta r)
        + \delta g .

Γ δr carries the Schuler feedback (the horizontal −g/r, period 84 min) and the vertical
instability (+2g/r); the Coriolis term the Foucault and 24-hour modes. The position error is a
physical vector, so the same equation holds for an Earth-relative (NED) and an inertial (LCI)
mechanization: the frames differ in coordinates, not in the error they make. With the baro
loop of :func:`fieldmap.nav.mechanize.baro_gains` (NED), e_u = û·δr the height error,

.. math::
    \delta\dot r \mathrel{+}= -k_1 e_u \hat u,\qquad
    \delta\dot v \mathrel{+}= -(k_2 e_u + a)\,\hat u,\qquad \dot a = k_3 e_u .

(baro errors are the sensor's, not gravity's: the loop compares with the true height here).

Γ is the point mass's GM/r³ (3 r̂r̂ᵀ − I): the J2 part changes it by 1e-3, a relative 1e-3 of a
first-order term. The equation is linear in δg, so a model's gravity contribution is exactly
zero when its δg is, the contributions of independent error sources add, and one pass
propagates many inputs (models, draws) as columns of one state.

Integration: one fourth-order Runge–Kutta step per interval of the input's time grid, the input
linear in time within it; the step's transition and input matrices are built for all intervals
at once, leaving a short recursion x_{i+1} = Φ_i x_i + w_i. Schuler (ω_s ≈ 1.2e-3 rad/s) and
the vertical mode (√(2g/r) ≈ 1.8e-3 rad/s) are resolved to (ωh)⁵ ≈ 1e-12 at h = 3 s.

This module shares no code with the strapdown mechanizations
(:mod:`fieldmap.nav.mechanize`): tests compare the two on the same δg.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.field.ellipsoid import Ellipsoid
from fieldmap.field.frames import geodetic_to_ecef
from fieldmap.nav.frames import C_n_to_e

__all__ = ["CORE_STATES", "core_dynamics", "position_response", "rk4_transition"]

#: the core error state: δr (3, ECEF, m), δv (3, ECEF, m/s), the baro loop's acceleration
#: correction a (1, m/s²)
CORE_STATES = 7
_NS = CORE_STATES


def core_dynamics(
    r: np.ndarray, up: np.ndarray, gm: float, omega: float, gains: tuple[float, float, float]
) -> np.ndarray:
    """Return F(t) of the core error state at ECEF points r (n, 3), geodetic up û (n, 3).

    ``gm`` and ``omega`` the ellipsoid's GM (m³/s²) and rotation rate (rad/s), ``gains`` the
    baro loop's (k1, k2, k3) or zeros. Shape (n, 7, 7).
    """
    n = r.shape[0]
    rn = np.linalg.norm(r, axis=1)
    rh = r / rn[:, None]
    gam = (gm / rn**3)[:, None, None] * (3.0 * rh[:, :, None] * rh[:, None, :] - np.eye(3))
    W = np.array([[0.0, -omega, 0.0], [omega, 0.0, 0.0], [0.0, 0.0, 0.0]])  # ω× (ω along z)
    F = np.zeros((n, _NS, _NS))
    F[:, 0:3, 3:6] = np.eye(3)
    F[:, 3:6, 0:3] = gam - W @ W
    F[:, 3:6, 3:6] = -2.0 * W
    k1, k2, k3 = gains
    uu = up[:, :, None] * up[:, None, :]
    F[:, 0:3, 0:3] -= k1 * uu
    F[:, 3:6, 0:3] -= k2 * uu
    F[:, 3:6, 6] = -up if (k1 or k2 or k3) else 0.0
    F[:, 6, 0:3] = k3 * up
    return F


def rk4_transition(F0: np.ndarray, Fm: np.ndarray, F1: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Return the transition matrices of one RK4 step of x' = F(t) x per interval.

    ``F0``, ``Fm``, ``F1`` (n, k, k): F at the start, middle and end of each of the n
    intervals, ``h`` (n,) their lengths (s). Exact to fifth order in h‖F‖.
    """
    hs = np.asarray(h, dtype=np.float64)[:, None, None]
    eye = np.eye(F0.shape[-1])
    K1 = F0
    K2 = Fm @ (eye + 0.5 * hs * K1)
    K3 = Fm @ (eye + 0.5 * hs * K2)
    K4 = F1 @ (eye + hs * K3)
    return np.asarray(eye + hs / 6.0 * (K1 + 2.0 * K2 + 2.0 * K3 + K4))


def position_response(
    t: ArrayLike,
    track: ArrayLike,
    dg_ned: ArrayLike,
    ellipsoid: Ellipsoid,
    baro_gains: tuple[float, float, float] | None = None,
) -> np.ndarray:
    """NED position errors of navigators whose only error is the gravity error ``dg_ned``.

    Parameters
    ----------
    t : array_like
        Times of the track points, increasing, shape (n,). Units: s.
    track : array_like
        True geodetic latitude, longitude, height at ``t``, shape (n, 3). Units: deg, deg, m.
    dg_ned : array_like
        Gravity error g_model − g_true at the track points, north/east/down, shape (k, n, 3)
        for k inputs (models, draws) or (n, 3). Units: m/s².
    ellipsoid : Ellipsoid
        Of the coordinates; its GM and rotation rate enter the dynamics.
    baro_gains : (k1, k2, k3), optional
        The baro loop's gains (:func:`fieldmap.nav.mechanize.baro_gains`); None: free inertial.

    Returns
    -------
    numpy.ndarray
        δr north, east, down at ``t`` (zero at ``t[0]``), the shape of ``dg_ned``. Units: m.
    """
    t = np.asarray(t, dtype=np.float64)
    trk = np.asarray(track, dtype=np.float64)
    dg = np.asarray(dg_ned, dtype=np.float64)
    single = dg.ndim == 2
    if single:
        dg = dg[None]
    n = t.size
    k = dg.shape[0]
    lat, lon, h = trk[:, 0], trk[:, 1], trk[:, 2]
    r = np.stack(geodetic_to_ecef(lat, lon, h, ellipsoid), -1)
    ned = np.swapaxes(C_n_to_e(lat, lon), -1, -2)  # (n, 3, 3): rows north, east, down in ECEF
    up = -ned[:, 2, :]
    k1, k2, k3 = (0.0, 0.0, 0.0) if baro_gains is None else baro_gains
    gains = (float(k1), float(k2), float(k3))
    # inputs in ECEF (velocity rows of the state): u = C_ecef<-ned δg
    u = np.einsum("nji,knj->kni", ned, dg)
    # midpoints: the track and the input linear in time within an interval
    F = core_dynamics(r, up, ellipsoid.GM, ellipsoid.omega, gains)
    rm = 0.5 * (r[1:] + r[:-1])
    um_dir = up[1:] + up[:-1]
    um_dir /= np.linalg.norm(um_dir, axis=1)[:, None]
    Fm = core_dynamics(rm, um_dir, ellipsoid.GM, ellipsoid.omega, gains)
    F0, F1 = F[:-1], F[1:]
    hs = np.diff(t)[:, None, None]
    # RK4 for x' = F x + B u (B selects the velocity rows): x+ = Φ x + P0 u0 + Pm um + P1 u1
    Phi = rk4_transition(F0, Fm, F1, np.diff(t))
    B = np.zeros((_NS, 3))
    B[3:6] = np.eye(3)
    # the stage inputs: k1 = F0 x + B u0; k2 = Fm(x + h/2 k1) + B um; k3 = Fm(x + h/2 k2) + B um;
    # k4 = F1(x + h k3) + B u1 — their u-parts, as matrices on u0, um, u1
    a1_0 = B
    a2_0, a2_m = 0.5 * hs * (Fm @ a1_0), B
    a3_0, a3_m = 0.5 * hs * (Fm @ a2_0), 0.5 * hs * (Fm @ a2_m) + B
    a4_0, a4_m, a4_1 = hs * (F1 @ a3_0), hs * (F1 @ a3_m), B
    P0 = hs / 6.0 * (a1_0 + 2.0 * a2_0 + 2.0 * a3_0 + a4_0)
    Pm = hs / 6.0 * (2.0 * a2_m + 2.0 * a3_m + a4_m)
    P1 = hs / 6.0 * a4_1
    um = 0.5 * (u[:, 1:] + u[:, :-1])
    w = (
        np.einsum("iab,kib->ika", P0, u[:, :-1])
        + np.einsum("iab,kib->ika", Pm, um)
        + np.einsum("iab,kib->ika", P1, u[:, 1:])
    )  # (n-1, k, 7)
    x = np.zeros((k, _NS))
    dr = np.empty((n, k, 3))
    dr[0] = 0.0
    for i in range(n - 1):
        x = x @ Phi[i].T + w[i]
        dr[i + 1] = x[:, 0:3]
    out = np.einsum("nij,nkj->kni", ned, dr)
    return out[0] if single else out
