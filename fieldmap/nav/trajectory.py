r"""Trajectories a study can fly, closed-form or sampled, each with its exact kinematics.

A trajectory is a smooth function of time: ECEF position r_e(t) and its first two time
derivatives, and an attitude law C_b^e(t) with its body rate. :class:`Trajectory` carries them
into the launch-centred inertial a-frame of Chen et al. (2022) §3.2 (eqs. 17, 19, 20) exactly:

.. math::
    P_a = R_t^a (R_e^t r_e - r_0),\quad
    V_a = R_e^a (\dot r_e + \omega\times r_e),\quad
    A_a = R_e^a (\ddot r_e + 2\omega\times\dot r_e + \omega\times(\omega\times r_e))

(Groves 2013 eq. 2.84 ff.: the a-frame is inertial, so ``A_a`` is the inertial acceleration that the
mechanization of eq. 14 integrates). ``kinematics(t)`` returns them as :class:`Kinematics`; the
body rate ``w_b`` is ω_ab^b (= ω_ib^b, the a-frame is inertial) in rad/s. :func:`geodetic_state`
gives the same truth in navigation terms (latitude, longitude, height, NED velocity, C_b^n).

Closed-form trajectories are C-infinity functions of time: :class:`BoostGlide` (Fig. 9 of Chen et
al. 2022), :class:`Stationary`, :class:`ConstantVelocity`, :class:`Coning`. Their default attitude
is a smooth law: body x along the Earth-relative velocity, y to the right (horizontal),
z = x × y (down-ish) — a forward-right-down body frame with zero roll — or, for the simple cases,
NED-aligned or a closed-form coning motion; the body rate comes from the exact derivative of the
body triad: for an orthonormal triad e_i(t), ω = ½ Σ e_i × ė_i.

Sampled trajectories: :class:`FlightTrajectory`, a user's flight through samples. Input: times
(s), geodetic latitude, longitude (degrees) and height above the ellipsoid (m), optionally roll,
pitch and heading (degrees), from a CSV file (header row, ``#`` comment lines), a NetCDF file, a
pandas ``DataFrame``, an xarray ``Dataset`` or plain arrays (:func:`read_flight`), a GNSS, ADS-B
or vehicle log read and conditioned by :func:`fieldmap.nav.logs.load_flight`, or a route of
waypoints flown along geodesics (:func:`route_flight`, :func:`parse_route`); each gives
:class:`FlightSamples`. Sampling may be irregular (a 1 Hz GNSS log is typical).

Interpolation. Positions are carried to ECEF and interpolated by a quintic B-spline in time
(``scipy.interpolate.make_interp_spline``, k = 5: C⁴, so the acceleration the IMU senses is
twice continuously differentiable); velocity and acceleration are its exact derivatives. Attitude
is a :class:`scipy.spatial.transform.RotationSpline` of ``C_b^e`` through the knots (C² in
rotation, its body rate continuous). Without attitude columns the flight is *coordinated*: heading
along the ground track, pitch along the flight path, roll ``atan(V ψ̇ / g)`` from the turn rate
(Etkin & Reid 1996 §6.4: no side force in a balanced turn; :func:`coordinated_attitude`). IMU
increments are then synthesized exactly from the interpolated path by
:func:`fieldmap.nav.imu.synthesize`, as for the closed-form trajectories.

A flight is refused with one :class:`fieldmap.errors.InputError` naming the source, line and
column when a column is missing, a value is not a finite number, times do not increase, there
are fewer than 6 points (a quintic spline's minimum), latitude/longitude look like radians,
the path jumps (> 8 km/s between samples) or the spline's acceleration exceeds 100 g.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic, geodetic_to_ecef
from fieldmap.limits import MAX_HEIGHT, MIN_HEIGHT, number_text
from fieldmap.nav.frames import C_n_to_e, LaunchFrame
from fieldmap.units import STANDARD_GRAVITY

if TYPE_CHECKING:
    import xarray as xr

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
    """Base class: exact ECEF motion (closed-form or a spline) + attitude law, into the a-frame.

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


# --- sampled trajectories: a user's flight from a log, a file or a route -----------------------
REQUIRED = ("time_s", "lat_deg", "lon_deg", "height_m")
ATTITUDE = ("roll_deg", "pitch_deg", "heading_deg")
#: accelerations beyond this are refused (m/s²)
MAX_ACCEL = 100.0 * STANDARD_GRAVITY
#: speeds between consecutive samples beyond this are a position jump (m/s)
MAX_SPEED = 8000.0
#: the quintic spline needs at least k + 1 points
MIN_POINTS = 6


@dataclass(frozen=True)
class FlightSamples:
    """Validated samples of one flight (times relative to the first sample).

    ``t`` (n,) s; ``lat``, ``lon`` (n,) degrees (longitude unwrapped); ``h`` (n,) m;
    ``attitude`` (n, 3) roll, pitch, heading in degrees or None; ``source`` and ``lines`` (the
    line, or record, of each sample in the source) for messages; ``t_start`` the first time.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    attitude: np.ndarray | None
    source: str
    lines: np.ndarray
    t_start: float = 0.0


def _where(source: str, lines: npt.NDArray[np.int64], i: int, column: str) -> str:
    return f"{source} line {int(lines[i])} column {column}"


def _columns_from_csv(
    path: Path,
) -> tuple[dict[str, npt.NDArray[np.float64]], npt.NDArray[np.int64], str, list[str]]:
    """Columns of a CSV file as float arrays plus the line number of each row."""
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the flight file ({exc})") from None
    rows, lines, header, hline = [], [], None, 0
    for lineno, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        cells = next(csv.reader([s]))
        if header is None:
            header, hline = [c.strip() for c in cells], lineno
            continue
        if len(cells) != len(header):
            raise InputError(
                f"{path} line {lineno}: {len(cells)} fields, the header (line {hline}) has "
                f"{len(header)}"
            )
        rows.append(cells)
        lines.append(lineno)
    if header is None:
        raise InputError(f"{path}: empty flight file (no header, no samples)")
    cols = {}
    for j, name in enumerate(header):
        if name not in REQUIRED + ATTITUDE:
            continue
        vals = np.empty(len(rows))
        for i, r in enumerate(rows):
            try:
                vals[i] = float(r[j])
            except ValueError:
                raise InputError(
                    f"{path} line {lines[i]} column {name}: {r[j].strip()!r} is not a number"
                ) from None
        cols[name] = vals
    return cols, np.array(lines, dtype=np.int64), str(path), header


def _columns_from_mapping(
    data: Mapping[str, Any], source: str
) -> tuple[dict[str, npt.NDArray[np.float64]], npt.NDArray[np.int64], str, list[str]]:
    names = list(data.keys()) if hasattr(data, "keys") else []
    cols = {}
    for name in names:
        if name in REQUIRED + ATTITUDE:
            try:
                cols[name] = np.asarray(data[name], dtype=np.float64).ravel()
            except (TypeError, ValueError):
                raise InputError(f"{source} column {name}: values are not numbers") from None
    n = max((c.size for c in cols.values()), default=0)
    for name, c in cols.items():
        if c.size != n:
            raise InputError(f"{source} column {name}: {c.size} values, other columns have {n}")
    return cols, np.arange(1, n + 1), source, names


def read_flight(
    source: str | Path | xr.Dataset | Mapping[str, npt.ArrayLike],
    *,
    ellipsoid: Ellipsoid = WGS84,
) -> FlightSamples:
    """Read and validate a flight from a file, DataFrame, Dataset or mapping of arrays.

    Parameters
    ----------
    source : str, Path, pandas.DataFrame, xarray.Dataset or dict
        CSV (``.csv``/``.txt``: header row, ``#`` comments) or NetCDF (``.nc``) file, or
        columns ``time_s, lat_deg, lon_deg, height_m`` [``roll_deg, pitch_deg, heading_deg``].
        Units: s, degrees, degrees, m, degrees.
    ellipsoid : Ellipsoid
        Ellipsoid of the geodetic coordinates (for the speed and acceleration checks).

    Returns
    -------
    FlightSamples

    Raises
    ------
    InputError
        Naming the source, the line (file rows; record number for arrays) and the column.
    """
    if isinstance(source, (str, Path)):
        path = Path(source)
        if not path.is_file():
            raise InputError(f"{path}: flight file not found")
        if path.suffix.lower() in (".nc", ".nc4", ".cdf"):
            import xarray as xr

            try:
                with xr.open_dataset(path) as ds:
                    cols, lines, name, header = _columns_from_mapping(
                        {k: ds[k].values for k in ds.variables}, str(path)
                    )
            except (OSError, ValueError) as exc:
                raise InputError(f"{path}: not a readable NetCDF file ({exc})") from None
            name = f"{path} (record)"
        else:
            cols, lines, name, header = _columns_from_csv(path)
    else:
        kind = type(source).__name__
        mapping: Any = source  # a DataFrame, a Dataset or a mapping of columns
        if kind == "Dataset":
            mapping = {k: mapping[k].values for k in mapping.variables}
        cols, lines, name, header = _columns_from_mapping(mapping, f"flight {kind} (record)")
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        raise InputError(
            f"{name}: missing column(s) {', '.join(missing)} (have: {', '.join(map(str, header))})"
        )
    att = [c for c in ATTITUDE if c in cols]
    if att and len(att) != 3:
        raise InputError(
            f"{name}: give all of {', '.join(ATTITUDE)} or none (coordinated flight), got "
            f"{', '.join(att)}"
        )
    n = cols["time_s"].size
    if n == 0:
        raise InputError(f"{name}: no samples")
    for c in REQUIRED + (ATTITUDE if att else ()):
        bad = np.flatnonzero(~np.isfinite(cols[c]))
        if bad.size:
            raise InputError(f"{_where(name, lines, bad[0], c)}: {cols[c][bad[0]]} is not finite")
    if n < MIN_POINTS:
        raise InputError(f"{name}: {n} samples, the quintic spline needs at least {MIN_POINTS}")
    t = cols["time_s"]
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = bad[0] + 1
        what = "repeats" if dt[bad[0]] == 0 else "goes back from"
        raise InputError(
            f"{_where(name, lines, i, 'time_s')}: time {t[i]:g} s {what} the previous "
            f"{t[i - 1]:g} s (times must increase)"
        )
    lat, lon, h = cols["lat_deg"], cols["lon_deg"], cols["height_m"]
    for c, v, lim in (("lat_deg", lat, 90.0), ("lon_deg", lon, 540.0)):
        bad = np.flatnonzero(np.abs(v) > lim)
        if bad.size:
            raise InputError(f"{_where(name, lines, bad[0], c)}: {v[bad[0]]:g} is beyond ±{lim:g}")
    bad = np.flatnonzero((h < MIN_HEIGHT) | (h > MAX_HEIGHT))
    if bad.size:
        raise InputError(
            f"{_where(name, lines, bad[0], 'height_m')}: {number_text(h[bad[0]])} m is outside "
            "-11 km..1e8 m"
        )
    lon = np.degrees(np.unwrap(np.radians(lon)))
    r = np.stack(geodetic_to_ecef(lat, lon, h, ellipsoid), -1)
    speed = np.linalg.norm(np.diff(r, axis=0), axis=1) / dt
    _check_radians(name, lines, lat, lon, speed)
    bad = np.flatnonzero(speed > MAX_SPEED)
    if bad.size:
        i = bad[0] + 1
        raise InputError(
            f"{_where(name, lines, i, 'lat_deg')}: position jump ({speed[bad[0]]:.0f} m/s from "
            f"the previous sample, more than {MAX_SPEED:g} m/s)"
        )
    attitude = None
    if att:
        attitude = np.stack([cols[c] for c in ATTITUDE], -1)
        attitude[:, 2] = np.degrees(np.unwrap(np.radians(attitude[:, 2])))
        bad = np.flatnonzero(np.abs(cols["pitch_deg"]) > 90.0)
        if bad.size:
            raise InputError(f"{_where(name, lines, bad[0], 'pitch_deg')}: beyond ±90 degrees")
    return FlightSamples(t - t[0], lat, lon, h, attitude, name, lines, float(t[0]))


def _check_radians(
    name: str,
    lines: npt.NDArray[np.int64],
    lat: npt.NDArray[np.float64],
    lon: npt.NDArray[np.float64],
    speed: npt.NDArray[np.float64],
) -> None:
    """Refuse latitudes/longitudes that look like radians.

    All values inside ±π/2, ±π and a path that would be an aircraft's speed (1..1000 m/s) only if
    the numbers were radians (57.3× the distance), i.e. at most 17 m/s read as degrees.
    """
    v_deg = float(np.median(speed))
    if (
        np.all(np.abs(lat) <= np.pi / 2)
        and np.all(np.abs(lon) <= np.pi)
        and 1.0 <= np.degrees(v_deg) <= 1000.0
        and v_deg < 17.5
    ):
        raise InputError(
            f"{_where(name, lines, 0, 'lat_deg')}: latitudes and longitudes look like radians "
            f"(all within ±π/2, ±π; median speed {v_deg:.2f} m/s read as degrees, "
            f"{np.degrees(v_deg):.0f} m/s as radians): give degrees"
        )


class FlightTrajectory(Trajectory):
    """Smooth trajectory through flight samples (see the module docstring).

    Parameters
    ----------
    samples : FlightSamples or anything :func:`read_flight` accepts
    ellipsoid : Ellipsoid

    The launch-centred frame (for ``--frame lci``) sits at the first sample, azimuth = the
    first heading. Time 0 is the first sample.
    """

    name = "flight"

    def __init__(
        self,
        samples: FlightSamples | str | Path | xr.Dataset | Mapping[str, npt.ArrayLike],
        *,
        ellipsoid: Ellipsoid = WGS84,
    ) -> None:
        from scipy.interpolate import make_interp_spline
        from scipy.spatial.transform import Rotation, RotationSpline

        s = samples if isinstance(samples, FlightSamples) else read_flight(samples)
        self.samples = s
        self.name = Path(s.source.split(" (")[0]).name if s.source != "route" else "route"
        r = np.stack(geodetic_to_ecef(s.lat, s.lon, s.h, ellipsoid), -1)
        self._spline = make_interp_spline(s.t, r, k=5)
        self._d1 = self._spline.derivative(1)
        self._d2 = self._spline.derivative(2)
        v, a = self._d1(s.t), self._d2(s.t)
        C_n_e = C_n_to_e(s.lat, s.lon)
        v_n = np.einsum("nji,nj->ni", C_n_e, v)
        if s.attitude is None:
            att = coordinated_attitude(v_n, np.einsum("nji,nj->ni", C_n_e, a))
        else:
            att = np.radians(s.attitude)
        self.attitude_knots_deg = np.degrees(att)
        C_b_n = Rotation.from_euler("ZYX", att[:, ::-1]).as_matrix()
        self._rot = RotationSpline(s.t, Rotation.from_matrix(C_n_e @ C_b_n))
        self._rot_d1 = self._rot.interpolator.derivative()
        self._knot_C = self._rot.rotations.as_matrix()
        frame = LaunchFrame(
            lon0=float((s.lon[0] + 180.0) % 360.0 - 180.0),
            B0=float(s.lat[0]),
            A0=float(np.degrees(att[0, 2]) % 360.0),
            h0=float(s.h[0]),
            ellipsoid=ellipsoid,
        )
        super().__init__(frame, float(s.t[-1]))
        self._check_acceleration()
        self._check_between(ellipsoid)

    def _check_acceleration(self) -> None:
        s = self.samples
        tt = np.concatenate([s.t, 0.5 * (s.t[1:] + s.t[:-1])])
        acc = np.linalg.norm(self._d2(tt), axis=1)
        if acc.max() > MAX_ACCEL:
            j = int(np.argmax(acc))
            acc_g = acc[j] / STANDARD_GRAVITY
            i = j if j < s.t.size else j - s.t.size + 1
            if s.source == "route":  # no file: the speed flown is what the user chose
                raise InputError(
                    f"route: the path accelerates at {acc_g:.0f} g near t = {tt[j]:g} s "
                    f"(more than 100 g): a ground speed of {_speed(s):.0f} m/s is too fast for "
                    "its turns and the Earth's curvature"
                )
            raise InputError(
                f"{_where(s.source, s.lines, i, 'lat_deg')}: the interpolated path accelerates at "
                f"{acc_g:.0f} g near t = {tt[j]:g} s (more than 100 g: a position jump?)"
            )

    def _check_between(self, ellipsoid: Ellipsoid) -> None:
        """Refuse a path that leaves the heights of a flight between two samples.

        The samples themselves are checked where they are read; the quintic through them can
        still overshoot by kilometres where samples are far apart (a gap of hours in a log flown
        with ``smooth=False``). Checked at a quarter, half and three quarters of every interval.
        """
        s = self.samples
        frac = np.array([0.25, 0.5, 0.75])
        tt = (s.t[:-1, None] + np.diff(s.t)[:, None] * frac).ravel()
        r = self._spline(tt)
        _, _, h = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], ellipsoid)
        bad = np.flatnonzero((h < MIN_HEIGHT) | (h > MAX_HEIGHT))
        if bad.size:
            j = int(bad[0])
            i = j // frac.size
            where = (
                "route"
                if s.source == "route"
                else f"{s.source} lines {s.lines[i]}..{s.lines[i + 1]}"
            )
            raise InputError(
                f"{where}: the interpolated path reaches a height of {number_text(h[j])} m between "
                f"t = {s.t[i]:g} s and {s.t[i + 1]:g} s ({s.t[i + 1] - s.t[i]:g} s without "
                f"samples), outside {MIN_HEIGHT / 1e3:g} km .. {MAX_HEIGHT:g} m"
            )

    def _ecef(
        self, t: npt.NDArray[np.float64]
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        return self._spline(t), self._d1(t), self._d2(t)

    def _attitude(
        self,
        t: npt.NDArray[np.float64],
        r: npt.NDArray[np.float64],
        v: npt.NDArray[np.float64],
        a: npt.NDArray[np.float64],
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """C_b^e and ω_eb^e from the rotation spline, evaluated in NumPy.

        :class:`~scipy.spatial.transform.RotationSpline` stores, per interval i, a cubic
        rotation vector φ(t) with C(t) = C_i exp([φ×]); its body rate is
        ω = φ̇ − k1 φ×φ̇ + k2 φ×(φ×φ̇), k1 = (1 − cos θ)/θ², k2 = (θ − sin θ)/θ³, θ = |φ|
        (Bortz 1971; the same formula as scipy's). Evaluated here with vectorised cross products
        (3× faster than ``RotationSpline.__call__``; equal to it to 1e-15, checked in the tests).
        """
        t = np.asarray(t, dtype=np.float64)
        knots = self._rot.times
        i = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, knots.size - 2)
        phi = self._rot.interpolator(t)
        phid = self._rot_d1(t)
        th2 = np.sum(phi * phi, -1)
        th = np.sqrt(th2)
        small = th < 1e-4
        safe = np.where(small, 1.0, th)
        k1 = np.where(small, 0.5 - th2 / 24.0, (1.0 - np.cos(safe)) / safe**2)
        k2 = np.where(small, 1.0 / 6.0 - th2 / 120.0, (safe - np.sin(safe)) / safe**3)
        c = _cross(phi, phid)
        w_b = phid - k1[:, None] * c + k2[:, None] * _cross(phi, c)
        s1 = np.where(small, 1.0 - th2 / 6.0, np.sin(safe) / safe)
        # Rodrigues with [φ×]² = φφᵀ − θ² I: E = (1 − k1 θ²) I + s1 [φ×] + k1 φφᵀ
        sk = s1[:, None] * phi
        E = (k1[:, None, None] * phi[:, :, None]) * phi[:, None, :]
        diag = 1.0 - k1 * th2
        for j in range(3):
            E[:, j, j] += diag
        E[:, 0, 1] -= sk[:, 2]
        E[:, 1, 0] += sk[:, 2]
        E[:, 0, 2] += sk[:, 1]
        E[:, 2, 0] -= sk[:, 1]
        E[:, 1, 2] -= sk[:, 0]
        E[:, 2, 1] += sk[:, 0]
        C = np.matmul(self._knot_C[i], E)
        return C, np.matmul(C, w_b[:, :, None])[:, :, 0]

    def check_above_surface(self, n: int = 2001, min_height: float = MIN_HEIGHT) -> None:
        """Refuse paths deeper than ``min_height`` (m; default :data:`fieldmap.limits.MIN_HEIGHT`).

        Ellipsoidal heights at sea level reach -106 m; the base class's 0 m is for rockets.
        """
        super().check_above_surface(n, min_height)


def _speed(s: FlightSamples) -> float:
    """Median ground speed between samples (m/s; on a sphere of 6371 km)."""
    from fieldmap.nav.logs.read import speeds

    return float(np.median(speeds(s.lat, s.lon, s.t)))


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (n, 3) arrays (``np.cross`` without its generic set-up)."""
    out = np.empty_like(u)
    out[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    out[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    out[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return out


def coordinated_attitude(
    v_ned: npt.NDArray[np.float64], a_ned: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """Roll, pitch, heading (rad, (n, 3)) of a coordinated flight from NED velocity and accel.

    Heading ψ = atan2(v_E, v_N), pitch θ = atan2(−v_D, v_H), roll φ = atan(v_H ψ̇ / g0) with the
    turn rate ψ̇ = (v_N a_E − v_E a_N)/v_H². Below 0.5 m/s ground speed the heading is held.
    """
    vN, vE, vD = v_ned.T
    vh = np.hypot(vN, vE)
    psi = np.arctan2(vE, vN)
    slow = vh < 0.5
    if np.all(slow):
        psi = np.zeros_like(psi)
    elif np.any(slow):
        idx = np.flatnonzero(~slow)
        psi = np.interp(np.arange(psi.size), idx, np.unwrap(psi[idx]))
    psi = np.unwrap(psi)
    theta = np.arctan2(-vD, vh)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(slow, 0.0, (vN * a_ned[:, 1] - vE * a_ned[:, 0]) / np.maximum(vh, 0.5) ** 2)
    phi = np.arctan(vh * rate / STANDARD_GRAVITY)
    return np.stack([phi, theta, psi], -1)


def route_flight(
    waypoints: str | Sequence[Sequence[float]] | npt.ArrayLike,
    speed_mps: float,
    *,
    max_accel: float = 2.0,
    sample_dt: float = 1.0,
    ellipsoid: Ellipsoid = WGS84,
) -> FlightSamples:
    """Build a study flight along geodesics between waypoints at constant ground speed.

    Parameters
    ----------
    waypoints : sequence of (lat, lon, h) or str ``"lat,lon,h;lat,lon,h;..."``
        Units: degrees, degrees, m.
    speed_mps : float
        Ground speed. Units: m/s.
    max_accel : float
        Bound on the turn and climb accelerations. Units: m/s².
    sample_dt : float
        Spacing of the generated samples. Units: s.

    Each leg is a geodesic (Karney 2013, via ``geographiclib``) with the height linear in the
    distance flown. The heading and climb-rate steps at the corners are smoothed by a Gaussian
    filter in time of width σ = max(Δψ v, Δḣ)/(a_max √(2π)) (a smoothed step Δ has the peak
    slope Δ/(σ√(2π)), so turn and climb accelerations stay at ``max_accel``) and flown at
    constant ground speed from the first waypoint by geodesic steps; the turns cut the corners,
    so the later waypoints are passed within about σ v.

    Examples
    --------
    Two waypoints (lat, lon, h) at 200 m/s, climbing from 500 to 3000 m:

    >>> import fieldmap
    >>> samples = fieldmap.route_flight("47,8,500;47.5,9,3000", speed_mps=200.0)
    >>> float(samples.t[-1]), samples.t.size  # s, samples
    (469.0, 470)
    """
    from geographiclib.geodesic import Geodesic
    from scipy.ndimage import gaussian_filter1d

    pts = parse_route(waypoints) if isinstance(waypoints, str) else np.asarray(waypoints, float)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 2:
        raise InputError("a route needs at least two waypoints 'lat,lon,h'")
    if not np.all(np.isfinite(pts)) or np.any(np.abs(pts[:, 0]) > 89.0):
        raise InputError("route waypoints need finite values and |lat| <= 89 degrees")
    bad = np.flatnonzero((pts[:, 2] < MIN_HEIGHT) | (pts[:, 2] > MAX_HEIGHT))
    if bad.size:
        raise InputError(
            f"route waypoint {bad[0] + 1}: height {number_text(pts[bad[0], 2])} m is outside the "
            "heights of "
            f"a flight ({MIN_HEIGHT / 1e3:g} km .. {MAX_HEIGHT:g} m)"
        )
    for name, v in (("--speed-mps", speed_mps), ("max_accel", max_accel), ("dt", sample_dt)):
        if not np.isfinite(v) or v <= 0:
            raise InputError(f"{name} must be a positive number, got {v}")
    geod = Geodesic(ellipsoid.a, ellipsoid.f)
    lat, lon, h, az = [], [], [], []
    d_done = 0.0
    for k in range(len(pts) - 1):
        line = geod.InverseLine(pts[k, 0], pts[k, 1], pts[k + 1, 0], pts[k + 1, 1])
        if line.s13 < 1.0:
            if pts[k, 2] == pts[k + 1, 2]:
                raise InputError(f"route waypoints {k + 1} and {k + 2} coincide")
            raise InputError(
                f"route waypoints {k + 1} and {k + 2} are above the same point (heights "
                f"{pts[k, 2]:g} m and {pts[k + 1, 2]:g} m): a route is flown at a constant ground "
                "speed, so each leg needs a horizontal distance (climb along a leg instead)"
            )
        s = np.arange(d_done, line.s13, speed_mps * sample_dt)
        d_done = (s[-1] + speed_mps * sample_dt - line.s13) if s.size else d_done - line.s13
        for si in s:
            g = line.Position(si)
            lat.append(g["lat2"])
            lon.append(g["lon2"])
            az.append(g["azi2"])
            h.append(pts[k, 2] + (pts[k + 1, 2] - pts[k, 2]) * si / line.s13)
    lat_a, lon_a, h_a = np.array(lat), np.degrees(np.unwrap(np.radians(lon))), np.array(h)
    az_a = np.unwrap(np.radians(az))
    if lat_a.size < MIN_POINTS:
        raise InputError("the route is shorter than 6 samples: add distance or lower the speed")
    hdot = np.gradient(h_a, sample_dt)
    turn = np.max(np.abs(np.diff(az_a)), initial=0.0) * speed_mps  # V Δψ, m/s
    climb = np.ptp(hdot)  # largest change of climb rate, m/s (bound)
    # a step of size Δ smoothed by a Gaussian of σ seconds has a peak slope Δ/(σ√(2π))
    sigma_s = max(turn, climb) / (max_accel * np.sqrt(2.0 * np.pi))
    sigma = max(sigma_s / sample_dt, 3.0)  # in samples
    az_s = gaussian_filter1d(az_a, sigma, mode="nearest")
    hdot_s = gaussian_filter1d(hdot, sigma, mode="nearest")
    # fly the smoothed heading and climb rate at constant ground speed (geodesic steps)
    lat_f, lon_f, h_f = [lat_a[0]], [lon_a[0]], [h_a[0]]
    for k in range(lat_a.size - 1):
        g = geod.Direct(lat_f[-1], lon_f[-1], np.degrees(0.5 * (az_s[k] + az_s[k + 1])),
                        speed_mps * sample_dt)  # fmt: skip
        lat_f.append(g["lat2"])
        lon_f.append(g["lon2"])
        h_f.append(h_f[-1] + 0.5 * (hdot_s[k] + hdot_s[k + 1]) * sample_dt)
    lat_r, lon_r = np.array(lat_f), np.degrees(np.unwrap(np.radians(lon_f)))
    h_r = np.array(h_f)
    t = sample_dt * np.arange(lat_r.size)
    return FlightSamples(t, lat_r, lon_r, h_r, None, "route", np.arange(1, t.size + 1))


def parse_route(text: str) -> np.ndarray:
    """``"lat,lon,h;lat,lon,h;..."`` -> (n, 3) array; :class:`InputError` naming the waypoint."""
    out = []
    for k, part in enumerate(p for p in str(text).split(";") if p.strip()):
        vals = part.replace(" ", ",").split(",")
        vals = [v for v in vals if v]
        try:
            if len(vals) != 3:
                raise ValueError
            out.append([float(v) for v in vals])
        except ValueError:
            raise InputError(
                f"--route waypoint {k + 1} {part.strip()!r}: need 'lat,lon,h' (degrees, degrees, m)"
            ) from None
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def geodetic_state(
    traj: Trajectory, t: npt.ArrayLike
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
]:
    """Truth in navigation terms at times ``t``: lat, lon (deg), h (m), v_ned (m/s), C_b^n.

    Derived from :meth:`Trajectory.kinematics` (ECEF state and C_b^a) for any trajectory.
    """
    k = traj.kinematics(t)
    lat, lon, h = ecef_to_geodetic(k.r_e[:, 0], k.r_e[:, 1], k.r_e[:, 2], traj.frame.ellipsoid)
    C_n_e = C_n_to_e(lat, lon)
    C_a_e = np.swapaxes(traj.frame.C_e_to_a(k.t), -1, -2)
    C_b_e = C_a_e @ k.C_b_to_a
    v_ned = np.einsum("nji,nj->ni", C_n_e, k.v_e)
    C_b_n = np.swapaxes(C_n_e, -1, -2) @ C_b_e
    return lat, lon, h, v_ned, C_b_n
