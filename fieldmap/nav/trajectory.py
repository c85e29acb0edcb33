r"""Reference trajectories: closed-form position, velocity, acceleration, attitude, body rate.

Every trajectory is a C-infinity function of time. The translational motion is defined Earth-fixed
(ECEF position r_e(t) and its first two time derivatives in closed form) and carried into the
launch-centred inertial a-frame of Chen et al. (2022) §3.2 (eqs. 17, 19, 20) exactly:

.. math::
    P_a = R_t^a (R_e^t r_e - r_0),\quad
    V_a = R_e^a (\dot r_e + \omega\times r_e),\quad
    A_a = R_e^a (\ddot r_e + 2\omega\times\dot r_e + \omega\times(\omega\times r_e))

(Groves 2013 eq. 2.84 ff.: the a-frame is inertial, so ``A_a`` is the inertial acceleration that the
mechanization of eq. 14 integrates). Attitude is a smooth law: body x along the Earth-relative
velocity, y to the right (horizontal), z = x × y (down-ish) — a forward-right-down body frame with
zero roll — or, for the simple cases, NED-aligned or a closed-form coning motion. The body rate
``w_b`` is ω_ab^b (= ω_ib^b, the a-frame is inertial) in rad/s, from the exact derivative of the
body triad: for an orthonormal triad e_i(t), ω = ½ Σ e_i × ė_i.

Classes: :class:`BoostGlide` (Fig. 9 of Chen et al. 2022), :class:`Stationary`,
:class:`ConstantVelocity`, :class:`Coning`. All return :class:`Kinematics` from ``kinematics(t)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from fieldmap.errors import InputError
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic, geodetic_to_ecef
from fieldmap.nav.frames import LaunchFrame

_F64 = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Kinematics:
    """Exact state of a trajectory at times ``t`` (arrays of leading length N).

    Attributes
    ----------
    t : ndarray (N,)
        Units: s after launch.
    r_e, v_e, a_e : ndarray (N, 3)
        ECEF position, Earth-relative velocity and its ECEF time derivative. Units: m, m/s, m/s².
    P_a, V_a, A_a : ndarray (N, 3)
        A-frame position, inertial velocity and inertial acceleration. Units: m, m/s, m/s².
    C_b_to_a : ndarray (N, 3, 3)
        Body-to-a-frame rotation (columns: body axes in the a-frame).
    w_b : ndarray (N, 3)
        Body angular rate relative to the a-frame (inertial), resolved in body. Units: rad/s.
    """

    t: np.ndarray
    r_e: np.ndarray
    v_e: np.ndarray
    a_e: np.ndarray
    P_a: np.ndarray
    V_a: np.ndarray
    A_a: np.ndarray
    C_b_to_a: np.ndarray
    w_b: np.ndarray


def _number(value: Any, what: str) -> float:
    """Return ``value`` as a float; raise :class:`InputError` if it is not a real number."""
    try:
        if isinstance(value, (str, bytes, bool)):
            raise TypeError
        return float(value)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number, got {value!r}") from None


def _rows(M: _F64, v: _F64) -> _F64:
    """Apply matrices ``M`` (3,3) or (N,3,3) to row vectors ``v`` (N,3)."""
    return np.einsum("...ij,...j->...i", M, v)


def _unit_and_rate(w: _F64, wdot: _F64) -> tuple[_F64, _F64]:
    """Return the unit vector of ``w`` and its time derivative (ẇ − (ŵ·ẇ)ŵ)/|w|."""
    n = np.linalg.norm(w, axis=-1, keepdims=True)
    u = w / n
    return u, (wdot - np.sum(u * wdot, -1, keepdims=True) * u) / n


class Trajectory:
    """Base class: closed-form ECEF motion + attitude law, mapped into the a-frame.

    Subclasses implement :meth:`_ecef` and may override :meth:`_attitude`.

    Parameters
    ----------
    frame : LaunchFrame
        The launch-centred inertial frame (launch point, azimuth, ellipsoid).
    duration : float
        Length of the trajectory. Units: s.
    """

    name = "trajectory"

    def __init__(self, frame: LaunchFrame, duration: float) -> None:
        duration = _number(duration, "trajectory duration")
        if not np.isfinite(duration) or duration <= 0:
            raise InputError(
                f"trajectory duration must be a positive number of seconds, got {duration}"
            )
        self.frame = frame
        self.duration = float(duration)

    # -- to be provided by subclasses ---------------------------------------------------------
    def _ecef(self, t: _F64) -> tuple[_F64, _F64, _F64]:
        """Return ECEF ``r, ṙ, r̈`` at times ``t`` (each (N, 3)). Units: m, m/s, m/s²."""
        raise NotImplementedError

    def _attitude(self, t: _F64, r: _F64, v: _F64, a: _F64) -> tuple[_F64, _F64]:
        """Return ``(C_b_to_e, w_eb_e)``: body axes in ECEF and body rate w.r.t. ECEF in ECEF.

        Default: velocity-aligned forward-right-down frame, zero roll w.r.t. the geocentric up.
        """
        up, updot = _unit_and_rate(r, v)
        x, xd = _unit_and_rate(v, a)
        w = np.cross(x, up)
        wd = np.cross(xd, up) + np.cross(x, updot)
        y, yd = _unit_and_rate(w, wd)
        z = np.cross(x, y)
        zd = np.cross(xd, y) + np.cross(x, yd)
        omega = 0.5 * (np.cross(x, xd) + np.cross(y, yd) + np.cross(z, zd))
        return np.stack([x, y, z], axis=-1), omega

    # -- public -------------------------------------------------------------------------------
    def kinematics(self, t: npt.ArrayLike) -> Kinematics:
        """Exact state at times ``t`` (s after launch); see :class:`Kinematics`."""
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        fr = self.frame
        r, v, a = self._ecef(t)
        w_ie = np.array([0.0, 0.0, fr.omega])
        C_e_a = fr.C_e_to_a(t)
        v_in = v + np.cross(w_ie, r)
        a_in = a + 2.0 * np.cross(w_ie, v) + np.cross(w_ie, np.cross(w_ie, r))
        P_a = fr.ecef_to_a(r, t)
        C_b_e, w_eb_e = self._attitude(t, r, v, a)
        C_b_a, w_b = self._attitude_a(t, C_e_a, C_b_e, w_eb_e)
        return Kinematics(t, r, v, a, P_a, _rows(C_e_a, v_in), _rows(C_e_a, a_in), C_b_a, w_b)

    def _attitude_a(self, t: _F64, C_e_a: _F64, C_b_e: _F64, w_eb_e: _F64) -> tuple[_F64, _F64]:
        """C_b^a = C_e^a C_b^e and ω_ab^b = C_e^b (ω_eb^e + ω_ie^e)."""
        w_ib_e = w_eb_e + np.array([0.0, 0.0, self.frame.omega])
        w_b = np.einsum("...ji,...j->...i", C_b_e, w_ib_e)
        return C_e_a @ C_b_e, w_b

    def geodetic(self, t: npt.ArrayLike) -> tuple[_F64, _F64, _F64]:
        """Geodetic latitude, longitude (degrees) and height (m) at times ``t`` (s)."""
        r, _, _ = self._ecef(np.atleast_1d(np.asarray(t, dtype=np.float64)))
        return ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], self.frame.ellipsoid)

    def check_above_surface(self, n: int = 2001, min_height: float = 0.0) -> None:
        """Raise :class:`InputError` if the path dips below ``min_height`` (m) above ellipsoid."""
        _, _, h = self.geodetic(np.linspace(0.0, self.duration, n))
        if np.min(h) < min_height:
            raise InputError(
                f"trajectory {self.name!r} goes below the surface (min height {np.min(h):.1f} m)"
            )


# --- smooth building blocks --------------------------------------------------------------------
def _logcosh(x: _F64 | float) -> _F64:
    ax = np.abs(x)
    return ax + np.log1p(np.exp(-2.0 * ax)) - np.log(2.0)


def smooth_step(t: _F64 | float, t0: float, w: float) -> tuple[_F64, _F64, _F64, _F64]:
    """Logistic step S = ½(1 + tanh((t − t0)/w)), its first two derivatives and ∫₀ᵗ S.

    Units: t, t0, w in s. Returns ``(S, S', S'', I)``.
    """
    x = (t - t0) / w
    th = np.tanh(x)
    sech2 = 1.0 - th * th
    integral = 0.5 * (t + w * (_logcosh(x) - _logcosh(-t0 / w)))
    return 0.5 * (1.0 + th), 0.5 * sech2 / w, -sech2 * th / (w * w), integral


@dataclass(frozen=True)
class BoostGlideProfile:
    """Shape of the boost-glide path (heights in m, speeds in m/s, times and widths in s).

    Height above the ellipsoid (measured along the geocentric radius):
    ``h = h_start + h_boost·S(t_boost) − h_dive·S(t_dive)
    + h_skip·sin(2π(t − t_skip)/p_skip)·S(t_skip)``; ground speed along the track
    ``ṡ = v_start + (v_glide − v_start)·S(t_accel) − v_loss·S(t_decel)``;
    cross-range offset ``c = c_turn·S(t_turn)`` (to the left of the launch azimuth).
    """

    h_boost: float = 67_700.0
    t_boost: float = 60.0
    w_boost: float = 25.0
    h_dive: float = 37_700.0
    t_dive: float = 200.0
    w_dive: float = 25.0
    h_skip: float = 1_500.0
    t_skip: float = 320.0
    w_skip: float = 25.0
    p_skip: float = 220.0
    v_start: float = 30.0
    v_glide: float = 2_200.0
    t_accel: float = 70.0
    w_accel: float = 25.0
    v_loss: float = 700.0
    t_decel: float = 650.0
    w_decel: float = 150.0
    c_turn: float = 40_000.0
    t_turn: float = 450.0
    w_turn: float = 60.0
    mean_radius: float = 6_371_000.0


class BoostGlide(Trajectory):
    """Boost-glide reference path like Fig. 9 of Chen et al. (2022).

    Boost to about 67 km, dive, glide near 30 km with a gentle skip and a lateral turn, from the
    launch point (default 108.2°E, 34.0°N, azimuth 195°) to about 104.5°E, 21.5°N in 800 s, inside
    103–109°E, 20–35°N. The path is ``r_e = ρ(t) u(t)`` with the unit vector
    ``u = cos χ (cos σ e1 + sin σ e2) + sin χ e3`` (e1 geocentric up of the launch point, e2 the
    horizontal launch azimuth, e3 = e1 × e2), σ = s/R̄ and χ = c/R̄, and
    ``ρ = r_ell(u_z) + h`` with the ellipsoid's geocentric radius
    ``r_ell = ab/√(b² + (a²−b²)u_z²)``,
    so ``h`` is the height above the ellipsoid along the radius (within metres of geodetic height).
    """

    name = "boost-glide"

    def __init__(
        self,
        frame: LaunchFrame | None = None,
        duration: float = 800.0,
        profile: BoostGlideProfile = BoostGlideProfile(),
    ) -> None:
        super().__init__(frame or LaunchFrame(lon0=108.2, B0=34.0, A0=195.0, h0=400.0), duration)
        self.profile = profile
        fr = self.frame
        r0 = fr.r_launch
        e1 = r0 / np.linalg.norm(r0)
        east = np.array([-np.sin(np.radians(fr.lon0)), np.cos(np.radians(fr.lon0)), 0.0])
        north = np.cross(e1, east)
        A = np.radians(fr.A0)
        e2 = np.sin(A) * east + np.cos(A) * north
        self._e = (e1, e2, np.cross(e1, e2))
        # start exactly at the launch point: h(0) = launch radius − ellipsoid radius there
        self._h0 = 0.0
        h_start = float(np.linalg.norm(r0) - self._r_ell(e1[2])[0])
        self._h0 = h_start - float(self.height_profile(np.zeros(1))[0][0])

    def _r_ell(self, z: _F64 | float) -> tuple[_F64, _F64, _F64]:
        """Ellipsoid radius at sin(geocentric latitude) = z and its first two z-derivatives."""
        a, b = self.frame.ellipsoid.a, self.frame.ellipsoid.b
        k = a * a - b * b
        D = b * b + k * z * z
        f = a * b / np.sqrt(D)
        f1 = -a * b * k * z * D**-1.5
        f2 = -a * b * k * (D**-1.5 - 3.0 * k * z * z * D**-2.5)
        return f, f1, f2

    def height_profile(self, t: _F64) -> tuple[_F64, _F64, _F64]:
        """Height above the ellipsoid along the radius and its derivatives. Units: m, m/s, m/s²."""
        p = self.profile
        sb, sb1, sb2, _ = smooth_step(t, p.t_boost, p.w_boost)
        sd, sd1, sd2, _ = smooth_step(t, p.t_dive, p.w_dive)
        ss, ss1, ss2, _ = smooth_step(t, p.t_skip, p.w_skip)
        k = 2.0 * np.pi / p.p_skip
        sn, cs = np.sin(k * (t - p.t_skip)), np.cos(k * (t - p.t_skip))
        h = self._h0 + p.h_boost * sb - p.h_dive * sd + p.h_skip * sn * ss
        h1 = p.h_boost * sb1 - p.h_dive * sd1 + p.h_skip * (k * cs * ss + sn * ss1)
        h2 = (
            p.h_boost * sb2
            - p.h_dive * sd2
            + p.h_skip * (-k * k * sn * ss + 2 * k * cs * ss1 + sn * ss2)
        )
        return h, h1, h2

    def ground_profile(self, t: _F64) -> tuple[tuple[_F64, _F64, _F64], tuple[_F64, _F64, _F64]]:
        """Along-track ``s`` and cross-track ``c`` arc lengths (at R̄) with two derivatives each."""
        p = self.profile
        sa, sa1, _, ia = smooth_step(t, p.t_accel, p.w_accel)
        sd, sd1, _, idc = smooth_step(t, p.t_decel, p.w_decel)
        s = p.v_start * t + (p.v_glide - p.v_start) * ia - p.v_loss * idc
        s1 = p.v_start + (p.v_glide - p.v_start) * sa - p.v_loss * sd
        s2 = (p.v_glide - p.v_start) * sa1 - p.v_loss * sd1
        st, st1, st2, _ = smooth_step(t, p.t_turn, p.w_turn)
        st0 = smooth_step(0.0, p.t_turn, p.w_turn)[0]  # start on the launch point: c(0) = 0
        return (s, s1, s2), (p.c_turn * (st - st0), p.c_turn * st1, p.c_turn * st2)

    def _ecef(self, t: _F64) -> tuple[_F64, _F64, _F64]:
        e1, e2, e3 = self._e
        R = self.profile.mean_radius
        (s, s1, s2), (c, c1, c2) = self.ground_profile(t)
        sg, sg1, sg2 = s / R, s1 / R, s2 / R
        ch, ch1, ch2 = c / R, c1 / R, c2 / R
        col = lambda x: x[:, None]  # noqa: E731
        g = col(np.cos(sg)) * e1 + col(np.sin(sg)) * e2
        gp = -col(np.sin(sg)) * e1 + col(np.cos(sg)) * e2
        cc, sc = col(np.cos(ch)), col(np.sin(ch))
        u = cc * g + sc * e3
        u_s, u_c = cc * gp, -sc * g + cc * e3
        u_ss, u_sc, u_cc = -cc * g, -sc * gp, -u
        ud = col(sg1) * u_s + col(ch1) * u_c
        udd = (
            col(sg2) * u_s
            + col(ch2) * u_c
            + col(sg1**2) * u_ss
            + col(2 * sg1 * ch1) * u_sc
            + col(ch1**2) * u_cc
        )
        f, f1, f2 = self._r_ell(u[:, 2])
        h, h1, h2 = self.height_profile(t)
        rho = f + h
        rho1 = f1 * ud[:, 2] + h1
        rho2 = f2 * ud[:, 2] ** 2 + f1 * udd[:, 2] + h2
        r = col(rho) * u
        v = col(rho1) * u + col(rho) * ud
        a = col(rho2) * u + 2.0 * col(rho1) * ud + col(rho) * udd
        return r, v, a


class Stationary(Trajectory):
    """At rest on the Earth at the a-frame origin (or a given point), body axes = NED.

    Parameters
    ----------
    frame : LaunchFrame
    duration : float
        Units: s.
    lat, lon, h : float, optional
        Geodetic position (degrees, degrees, m); default the launch point.
    """

    name = "stationary"

    def __init__(
        self,
        frame: LaunchFrame,
        duration: float,
        lat: float | None = None,
        lon: float | None = None,
        h: float | None = None,
    ) -> None:
        super().__init__(frame, duration)
        lat = frame.B0 if lat is None else _number(lat, "latitude")
        lon = frame.lon0 if lon is None else _number(lon, "longitude")
        h = frame.h0 if h is None else _number(h, "height")
        if not (np.isfinite([lat, lon, h]).all() and abs(lat) <= 90.0):
            raise InputError(
                f"stationary point needs finite lat in [-90, 90], lon, h; got {lat}, {lon}, {h}"
            )
        self.r0 = np.array(geodetic_to_ecef(lat, lon, h, frame.ellipsoid))
        enu = C_e_to_enu(lat, lon)  # rows E, N, U in ECEF
        self.C_b_e = np.stack([enu[1], enu[0], -enu[2]], axis=-1)  # columns N, E, D

    def _ecef(self, t: _F64) -> tuple[_F64, _F64, _F64]:
        r = np.broadcast_to(self.r0, (t.size, 3)).copy()
        return r, np.zeros_like(r), np.zeros_like(r)

    def _attitude(self, t: _F64, r: _F64, v: _F64, a: _F64) -> tuple[_F64, _F64]:
        return np.broadcast_to(self.C_b_e, (t.size, 3, 3)).copy(), np.zeros_like(r)


class ConstantVelocity(Trajectory):
    """Straight line in ECEF at constant Earth-relative velocity from the launch point.

    Parameters
    ----------
    frame : LaunchFrame
    duration : float
        Units: s.
    v_enu : array_like (3,)
        Velocity in the east-north-up frame of the launch point (kept constant in ECEF). Units: m/s.

    Attitude: velocity-aligned forward-right-down (the default law).
    """

    name = "constant-velocity"

    def __init__(
        self, frame: LaunchFrame, duration: float, v_enu: npt.ArrayLike = (150.0, 200.0, 5.0)
    ) -> None:
        super().__init__(frame, duration)
        self.r0 = frame.r_launch
        self.v0 = C_e_to_enu(frame.B0, frame.lon0).T @ np.asarray(v_enu, dtype=np.float64)

    def _ecef(self, t: _F64) -> tuple[_F64, _F64, _F64]:
        r = self.r0 + t[:, None] * self.v0
        return r, np.broadcast_to(self.v0, r.shape).copy(), np.zeros_like(r)


class Coning(Trajectory):
    """Classical coning at rest on the Earth: ``C_b^a(t) = C0 Rz(Ωt) Rx(α) Rz(−Ωt)``.

    Closed-form body rate (derived from C^T Ċ, checked by finite differences in the tests):
    ``ω_ab^b = Ω (−sin α sin Ωt, sin α cos Ωt, cos α − 1)``; C0 is the NED attitude at the launch
    point at t = 0. Position: stationary at the launch point.

    Parameters
    ----------
    frame : LaunchFrame
    duration : float
        Units: s.
    half_angle : float
        Cone half-angle α. Units: rad.
    rate : float
        Coning frequency Ω. Units: rad/s.
    """

    name = "coning"

    def __init__(
        self,
        frame: LaunchFrame,
        duration: float,
        half_angle: float = 0.01,
        rate: float = 2.0 * np.pi,
    ) -> None:
        super().__init__(frame, duration)
        self.half_angle, self.rate = float(half_angle), float(rate)
        self._base = Stationary(frame, duration)
        self.C0 = frame.C_e_to_a(0.0) @ self._base.C_b_e

    def _ecef(self, t: _F64) -> tuple[_F64, _F64, _F64]:
        return self._base._ecef(t)

    def _attitude(self, t: _F64, r: _F64, v: _F64, a: _F64) -> tuple[_F64, _F64]:
        return self._base._attitude(t, r, v, a)

    def kinematics(self, t: npt.ArrayLike) -> Kinematics:
        """Exact state at times ``t``; attitude and body rate from the closed form above."""
        k = Trajectory.kinematics(self, t)
        wt, al, W = self.rate * k.t, self.half_angle, self.rate
        c, s = np.cos(wt), np.sin(wt)
        one, zero = np.ones_like(c), np.zeros_like(c)
        Rz = np.stack(
            [
                np.stack([c, -s, zero], -1),
                np.stack([s, c, zero], -1),
                np.stack([zero, zero, one], -1),
            ],
            -2,
        )
        Rx = np.array([[1, 0, 0], [0, np.cos(al), -np.sin(al)], [0, np.sin(al), np.cos(al)]])
        C = self.C0 @ Rz @ Rx @ np.swapaxes(Rz, -1, -2)
        w_b = W * np.stack([-np.sin(al) * s, np.sin(al) * c, (np.cos(al) - 1.0) * one], -1)
        return Kinematics(k.t, k.r_e, k.v_e, k.a_e, k.P_a, k.V_a, k.A_a, C, w_b)
