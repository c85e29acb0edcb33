"""Navigation frames: the launch frames of Chen et al. (2022) §3.2 and the NED specific force.

Launch frames of Chen et al. (2022) §3.2: t-, l- and launch-centred inertial a-frame (NumPy).

Frames (all right-handed):

* **e** — ECEF.
* **t** — launch Earth-centred inertial frame: coincides with ECEF at the launch epoch t = 0
  and stays fixed in inertial space, so ``r_t = R_e^t(t) r_e`` with ``R_e^t`` the rotation by
  +ω·t about the polar axis (eq. 19).
* **l** — local frame of the geocentric spherical coordinates (east, north, up along the
  coordinate lines of geocentric latitude φ and longitude λ) at the current point (eq. 16).
* **a** — launch-centred inertial frame: origin at the launch point (fixed in inertial space at
  its t = 0 position), y along the geodetic up of the launch point, x horizontal towards the
  launch azimuth A0 (clockwise from north), z = x × y (eq. 17).
  Positions: ``P_a = R_t^a (r_t − r_launch)``.

Misprints found in the printed equations (checked numerically in ``tests/test_launch_frames.py``):

* eq. (16) prints ``λ − ω t``; with eq. (19) (the Earth turns by +ω t eastwards after launch) the
  inertial longitude of an Earth-fixed point is ``λ + ω t``. Only with ``+`` does eq. (18) give the
  same g^a as eq. (20) for t ≠ 0 (the printed sign is wrong by 2ω t in azimuth).
* eq. (17) prints ``R11 = −sin A0 sin λ0 − cos A0 cos B0 cos λ0``; the x-axis
  ``sin A0·east + cos A0·north`` needs ``cos A0 sin B0 cos λ0`` (sin B0, as in R12). With the
  printed cos B0 the matrix is not orthonormal (tested).

Angles of the public API are in degrees; ω defaults to the WGS84 rotation rate.

Delta-velocity to NED specific force with the rotation correction ½ dθ×dv.

Same formula as NavToolKit's ``navtk::inertial::calc_force_ned`` (Titterton & Weston 2004,
eq. 11.64 without the high-rate sculling integral).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from fieldmap import limits
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef

#: Accepted launch longitudes and azimuths, half-open, as GeographicLib's angle range. Units: deg.
ANGLE_RANGE = (limits.LON_MIN, limits.LON_MAX)
#: Accepted launch heights: those of every point (:mod:`fieldmap.limits`, -10 km .. 1e8 m).
#: Units: m.
HEIGHT_RANGE = (limits.MIN_HEIGHT, limits.MAX_HEIGHT)


def _checked(name: str, value: Any, lo: float, hi: float, closed: bool, unit: str) -> float:
    """``value`` as a float within [lo, hi] (``closed``) or [lo, hi), else :class:`InputError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number, got {value!r}") from None
    inside = lo <= v <= hi if closed else lo <= v < hi
    if not inside:  # NaN fails both comparisons
        end = "]" if closed else ")"
        raise InputError(
            f"{name} must be a finite number within [{lo:g}, {hi:g}{end} {unit}, got {value!r}"
        )
    return v


def C_e_to_t(t: npt.ArrayLike, omega: float = WGS84.omega) -> npt.NDArray[np.float64]:
    r"""Rotation ECEF -> launch Earth-centred inertial t-frame at time t after launch, eq. (19).

    Units: t in s, omega in rad/s. Returns shape ``(..., 3, 3)``.

    .. math:: R_e^t = \\begin{bmatrix}\\cos(-\\omega t) & \\sin(-\\omega t) & 0\\\\
              -\\sin(-\\omega t) & \\cos(-\\omega t) & 0\\\\ 0 & 0 & 1\\end{bmatrix}
    """
    wt = omega * np.asarray(t, dtype=np.float64)
    c, s = np.cos(-wt), np.sin(-wt)
    one, zero = np.ones_like(c), np.zeros_like(c)
    return np.stack(
        [np.stack([c, s, zero], -1), np.stack([-s, c, zero], -1), np.stack([zero, zero, one], -1)],
        -2,
    )


def C_l_to_t(
    lat_gc_deg: npt.ArrayLike, lon_deg: npt.ArrayLike, t: npt.ArrayLike, omega: float = WGS84.omega
) -> npt.NDArray[np.float64]:
    """Rotation l-frame (geocentric east, north, up) -> t-frame, eq. (16) with the sign corrected.

    Units: geocentric latitude and longitude in degrees, t in s, omega in rad/s.
    The printed ``λ − ω t`` is replaced by ``λ + ω t`` (see module docstring).
    """
    phi = np.radians(np.asarray(lat_gc_deg, dtype=np.float64))
    lam = np.radians(np.asarray(lon_deg, dtype=np.float64)) + omega * np.asarray(t, np.float64)
    sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
    sp, cp, sl, cl = np.broadcast_arrays(sp, cp, sl, cl)
    zero = np.zeros_like(sp)
    return np.stack(
        [
            np.stack([-sl, -sp * cl, cp * cl], -1),
            np.stack([cl, -sp * sl, cp * sl], -1),
            np.stack([zero, cp, sp], -1),
        ],
        -2,
    )


def C_t_to_a(
    lon0_deg: float, B0_deg: float, A0_deg: float, *, printed: bool = False
) -> npt.NDArray[np.float64]:
    """Rotation t-frame -> launch-centred inertial a-frame, eq. (17) (R11 corrected).

    Units: launch longitude λ0, geodetic latitude B0 and azimuth A0 (from north, clockwise) in
    degrees. ``printed=True`` returns the matrix exactly as printed (for the misprint test only).
    Rows: x = sin A0·east + cos A0·north, y = geodetic up, z = x × y (at the launch point).
    """
    lam, B, A = np.radians([lon0_deg, B0_deg, A0_deg])
    sA, cA, sB, cB, sl, cl = np.sin(A), np.cos(A), np.sin(B), np.cos(B), np.sin(lam), np.cos(lam)
    R11 = -sA * sl - cA * (cB if printed else sB) * cl
    R12 = sA * cl - cA * sB * sl
    R31 = -cA * sl + sA * sB * cl
    R32 = cA * cl + sA * sB * sl
    return np.array(
        [[R11, R12, cA * cB], [cB * cl, cB * sl, sB], [R31, R32, -sA * cB]], dtype=np.float64
    )


def C_l_to_a(
    lat_gc_deg: npt.ArrayLike,
    lon_deg: npt.ArrayLike,
    t: npt.ArrayLike,
    lon0_deg: float,
    B0_deg: float,
    A0_deg: float,
    omega: float = WGS84.omega,
) -> npt.NDArray[np.float64]:
    """Rotation l-frame -> a-frame, eq. (18): ``R_l^a = R_t^a R_l^t``."""
    return C_t_to_a(lon0_deg, B0_deg, A0_deg) @ C_l_to_t(lat_gc_deg, lon_deg, t, omega)


def C_e_to_a(
    t: npt.ArrayLike, lon0_deg: float, B0_deg: float, A0_deg: float, omega: float = WGS84.omega
) -> npt.NDArray[np.float64]:
    """Rotation ECEF -> a-frame at time t, eq. (20): ``R_e^a = R_t^a R_e^t``."""
    return C_t_to_a(lon0_deg, B0_deg, A0_deg) @ C_e_to_t(t, omega)


def C_n_to_e(lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Columns north, east, down of the local-level (NED) frame in ECEF, shape (..., 3, 3).

    Parameters
    ----------
    lat_deg, lon_deg : array_like
        Geodetic latitude and longitude. Units: degrees.
    """
    enu = C_e_to_enu(lat_deg, lon_deg)
    return np.stack([enu[..., 1, :], enu[..., 0, :], -enu[..., 2, :]], axis=-1)


@dataclass(frozen=True)
class LaunchFrame:
    """A launch-centred inertial a-frame defined by its launch point and azimuth.

    Parameters
    ----------
    lon0, B0 : float
        Launch longitude in [-540, 540) and geodetic latitude in [-90, 90]. Units: degrees.
    A0 : float
        Launch azimuth, clockwise from north, in [-540, 540). Units: degrees.
    h0 : float
        Launch height above the ellipsoid (origin of the a-frame), -10 km .. 1e8 m. Units: m.
    ellipsoid : Ellipsoid or str
        Reference ellipsoid (its ``a``, ``e2`` and rotation rate ``omega`` are used).

    Raises
    ------
    InputError
        A non-numeric, non-finite or out-of-range field, or an unknown ellipsoid.
    """

    lon0: float
    B0: float
    A0: float
    h0: float = 0.0
    ellipsoid: Ellipsoid = WGS84

    def __post_init__(self) -> None:
        """Validate and normalise the fields (floats, an :class:`Ellipsoid`); InputError if bad."""
        checks: tuple[tuple[str, str, float, float, bool, str], ...] = (
            ("lon0", "launch longitude lon0", *ANGLE_RANGE, False, "degrees"),
            ("B0", "launch latitude B0", -90.0, 90.0, True, "degrees"),
            ("A0", "launch azimuth A0", *ANGLE_RANGE, False, "degrees"),
            ("h0", "launch height h0", *HEIGHT_RANGE, True, "m"),
        )
        for field, name, lo, hi, closed, unit in checks:
            object.__setattr__(
                self, field, _checked(name, getattr(self, field), lo, hi, closed, unit)
            )
        object.__setattr__(self, "ellipsoid", get_ellipsoid(self.ellipsoid))

    @property
    def omega(self) -> float:
        """Earth rotation rate. Units: rad/s."""
        return self.ellipsoid.omega

    @property
    def r_launch(self) -> npt.NDArray[np.float64]:
        """Launch point in the t-frame (= ECEF at t = 0). Units: m."""
        return np.array(geodetic_to_ecef(self.B0, self.lon0, self.h0, self.ellipsoid))

    @property
    def C_t_to_a(self) -> npt.NDArray[np.float64]:
        """Eq. (17), corrected."""
        return C_t_to_a(self.lon0, self.B0, self.A0)

    def C_e_to_a(self, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Eq. (20) at time(s) t after launch. Units: s."""
        return C_e_to_a(t, self.lon0, self.B0, self.A0, self.omega)

    def ecef_to_a(self, r_ecef: npt.ArrayLike, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """ECEF positions ``(..., 3)`` at times t -> a-frame positions ``P_a``. Units: m, s."""
        r_t = np.einsum("...ij,...j->...i", C_e_to_t(t, self.omega), np.asarray(r_ecef, float))
        return (r_t - self.r_launch) @ self.C_t_to_a.T

    def a_to_ecef(self, P_a: npt.ArrayLike, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """A-frame positions ``(..., 3)`` at times t -> ECEF positions. Units: m, s."""
        r_t = np.asarray(P_a, float) @ self.C_t_to_a + self.r_launch
        return np.einsum("...ji,...j->...i", C_e_to_t(t, self.omega), r_t)

    def vector_e_to_a(self, v_ecef: npt.ArrayLike, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Rotate ECEF vectors (e.g. gravitation) into the a-frame at times t, eq. (20)."""
        return np.einsum("...ij,...j->...i", self.C_e_to_a(t), np.asarray(v_ecef, float))

    def vector_a_to_e(self, v_a: npt.ArrayLike, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Rotate a-frame vectors into ECEF at times t (transpose of eq. 20)."""
        return np.einsum("...ji,...j->...i", self.C_e_to_a(t), np.asarray(v_a, float))

    def ecef_state_to_a(
        self, r_ecef: npt.ArrayLike, v_ecef: npt.ArrayLike, t: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """ECEF position and Earth-relative velocity -> a-frame position and inertial velocity.

        ``V_a = R_e^a (v_e + ω × r_e)`` (the a-frame is inertial). Units: m, m/s, s.
        """
        r = np.asarray(r_ecef, float)
        w = np.array([0.0, 0.0, self.omega])
        v_inertial_e = np.asarray(v_ecef, float) + np.cross(w, r)
        return self.ecef_to_a(r, t), self.vector_e_to_a(v_inertial_e, t)

    def a_state_to_ecef(
        self, P_a: npt.ArrayLike, V_a: npt.ArrayLike, t: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Inverse of :meth:`ecef_state_to_a`. Units: m, m/s, s."""
        r = self.a_to_ecef(P_a, t)
        w = np.array([0.0, 0.0, self.omega])
        return r, self.vector_a_to_e(V_a, t) - np.cross(w, r)


def calc_force_ned(
    C_s_to_n: npt.ArrayLike, dt: npt.ArrayLike, dth: npt.ArrayLike, dv: npt.ArrayLike
) -> npt.NDArray[np.float64]:
    r"""Specific force in NED from one delta-velocity / delta-rotation sample.

    .. math:: f^n = C_s^n\left(\delta v + \tfrac12\,\delta\theta \times \delta v\right)/\delta t

    Parameters
    ----------
    C_s_to_n : array_like, shape (..., 3, 3)
        DCM rotating sensor-frame vectors into NED.
    dt : float or array_like
        Interval over which ``dv`` and ``dth`` were collected. Units: s.
    dth : array_like, shape (..., 3)
        Delta rotation in the sensor frame. Units: rad.
    dv : array_like, shape (..., 3)
        Delta velocity in the sensor frame. Units: m/s.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        Specific force in NED. Units: m/s².
    """
    C = np.asarray(C_s_to_n, dtype=np.float64)
    dth = np.asarray(dth, dtype=np.float64)
    dv = np.asarray(dv, dtype=np.float64)
    dt = np.asarray(dt, dtype=np.float64)
    corrected = dv + 0.5 * np.cross(dth, dv)
    return np.einsum("...ij,...j->...i", C, corrected) / dt[..., None]
