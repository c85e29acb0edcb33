"""Truth gravitation along a trajectory at the cost of a few SH evaluations per minute.

A spherical-harmonic model of degree L holds no wavelength shorter than 2πR/L (167 km for
L = 240); a vehicle at speed v sees its disturbance change at most at the frequency
f = v L / (2π R). :class:`TrackGravitation` evaluates the *disturbance* δg = g_SH − γ_exact
(ECEF) on a uniform grid of times along the trajectory, spaced so that f is sampled many times
per period, interpolates it with six-point Lagrange polynomials (a local quintic: each point
depends on its six nearest grid nodes only, so the result does not depend on how the record is
cut into blocks), and adds the exact normal gravitation of the level ellipsoid at every point.

The error is bounded, not assumed: at construction the interpolant is compared with the full
evaluation at the midpoints of grid intervals spread over the whole trajectory; the spacing is
halved until the largest difference is below ``tol_mgal`` (default 1e-4 mGal), and that measured
maximum is reported (:attr:`TrackGravitation.max_error_mgal`).
"""

from __future__ import annotations

import math

import numpy as np

from fieldmap.errors import InputError

__all__ = ["TrackGravitation", "gravity_update_every", "highest_frequency"]

#: Grid spacing as a fraction of the shortest period of the disturbance seen along the path.
PERIOD_FRACTION = 0.02
#: Interval midpoints checked against the full evaluation (spread over the whole path).
CHECKS = 64
MGAL = 1e-5


def _path(traj, t: np.ndarray):
    """ECEF positions and velocities of ``traj`` at times ``t`` (m, m/s; Earth-fixed)."""
    try:
        r, v, _ = traj._ecef(t)
        return r, v
    except (AttributeError, NotImplementedError):
        r = traj.kinematics(t).r_e
        return r, np.gradient(r, t, axis=0)


def highest_frequency(traj, degree: int) -> float:
    """Highest frequency (Hz) of a degree-``degree`` field seen along ``traj``: v_max L / (2πR).

    The shortest wavelength of the field is 2πR/L (R the Earth's mean radius); the path's fastest
    Earth-relative speed v_max (from 2001 points along it) crosses it in 2πR/(L v_max) seconds.
    """
    t = np.linspace(0.0, float(traj.duration), 2001)
    speed = float(np.max(np.linalg.norm(_path(traj, t)[1], axis=1)))
    return max(speed, 1.0) * max(int(degree), 2) / (2.0 * math.pi * 6_371_000.0)


def _lagrange6(u: np.ndarray) -> np.ndarray:
    """Weights of the nodes -2..3 for a point at fraction ``u`` in [0, 1) of interval 0..1."""
    nodes = np.arange(-2, 4, dtype=np.float64)
    w = np.ones((u.size, 6))
    for j in range(6):
        for m in range(6):
            if m != j:
                w[:, j] *= (u - nodes[m]) / (nodes[j] - nodes[m])
    return w


class TrackGravitation:
    """ECEF gravitation of an SH model along ``traj``: exact normal field + interpolated δg.

    Parameters
    ----------
    model : SHModel
        Truth model (its own GM and radius).
    traj : Trajectory
        The path (its closed-form positions place the grid nodes).
    lmax : int, optional
        Degree (default: the model's).
    ellipsoid : Ellipsoid or str
        Level ellipsoid of the exact normal part.
    device : str, optional
        Warp device.
    step_s : float, optional
        Grid spacing (default: :data:`PERIOD_FRACTION` of the shortest period, from L and the
        fastest speed of the path). Units: s.
    tol_mgal : float
        Largest interpolation error allowed at the checked midpoints. Units: mGal.
    """

    def __init__(
        self, model, traj, *, lmax=None, ellipsoid="WGS84", device=None, step_s=None,
        tol_mgal: float = 1e-4,
    ):  # fmt: skip
        from fieldmap.nav.imu import Gravitation

        self.sh = Gravitation("sh", model=model, lmax=lmax, device=device)
        self.normal = Gravitation("exact", device=device, ellipsoid=ellipsoid)
        self.traj = traj
        self.duration = float(traj.duration)
        if step_s is None:
            step_s = PERIOD_FRACTION / highest_frequency(traj, self.sh.lmax)
        step_s = float(step_s)
        if not (math.isfinite(step_s) and step_s > 0):
            raise InputError(
                f"truth gravity step must be a positive number of seconds, got {step_s}"
            )
        self._cache: dict[int, np.ndarray] = {}
        for _ in range(12):
            self._set_step(step_s)
            self.max_error_mgal = self._check()
            if self.max_error_mgal <= tol_mgal:
                break
            step_s /= 2.0
        else:
            raise InputError(
                f"the truth disturbance cannot be interpolated to {tol_mgal:g} mGal along this "
                "path: use the full evaluation"
            )
        self.name = f"{self.sh.name}, disturbance every {self.step_s:.3g} s + exact normal"

    def _set_step(self, step_s: float) -> None:
        # nodes on both ends of the path: an integer number of intervals
        self.n_int = max(5, math.ceil(self.duration / step_s))
        self.step_s = self.duration / self.n_int
        self._cache = {}

    def _positions(self, t) -> np.ndarray:
        return _path(self.traj, np.asarray(t, dtype=np.float64))[0]

    def _disturbance(self, r: np.ndarray) -> np.ndarray:
        return np.asarray(self.sh(r), dtype=np.float64) - np.asarray(self.normal(r), np.float64)

    def _nodes(self, ks: np.ndarray) -> np.ndarray:
        """δg at grid nodes ``ks`` (ECEF, m/s²), evaluated once each."""
        missing = np.array(sorted({int(k) for k in ks} - set(self._cache)), dtype=np.int64)
        if missing.size:
            vals = self._disturbance(self._positions(missing * self.step_s))
            for k, v in zip(missing, vals):
                self._cache[int(k)] = v
        return np.stack([self._cache[int(k)] for k in ks])

    def disturbance_at(self, t) -> np.ndarray:
        """Interpolated δg (ECEF, m/s²) at times ``t`` (s) within the path."""
        t = np.asarray(t, dtype=np.float64)
        x = np.clip(t / self.step_s, 0.0, float(self.n_int))
        i = np.floor(x).astype(np.int64)
        first = np.clip(i - 2, 0, self.n_int - 5)  # the six nodes, shifted inside at the ends
        u = x - (first + 2)
        w = _lagrange6(u)
        idx = first[:, None] + np.arange(6)[None, :]
        uniq, inv = np.unique(idx, return_inverse=True)
        vals = self._nodes(uniq)[inv.reshape(idx.shape)]  # (n, 6, 3)
        return np.einsum("nj,njc->nc", w, vals)

    def at_times(self, t, r_e) -> np.ndarray:
        """Gravitation at ECEF points ``r_e`` (on the path at times ``t``): γ_exact + δg(t)."""
        return np.asarray(self.normal(r_e), dtype=np.float64) + self.disturbance_at(t)

    def __call__(self, r_e: np.ndarray) -> np.ndarray:
        """Full evaluation at arbitrary points (no interpolation)."""
        return np.asarray(self.sh(r_e), dtype=np.float64)

    def _check(self) -> float:
        """Largest |interpolated − full| δg (mGal) at interval midpoints along the path."""
        k = np.unique(np.linspace(0, self.n_int - 1, min(CHECKS, self.n_int)).round().astype(int))
        t = (k + 0.5) * self.step_s
        full = self._disturbance(self._positions(t))
        err = np.linalg.norm(self.disturbance_at(t) - full, axis=1)
        return float(err.max() / MGAL)


#: Default gravity rate: (2π f T)² ≤ this, f the highest frequency of the navigation model along
#: the path and T the update interval (the linear extrapolation's relative error is of that order).
GRAVITY_RATE_ERROR = 1e-3


def gravity_update_every(traj, degree: int, rate_hz: float, gravity_rate_hz=None) -> int:
    """IMU samples between SH disturbance updates of an SH navigation model of ``degree``.

    ``gravity_rate_hz`` None: the slowest rate whose linear extrapolation error stays below
    :data:`GRAVITY_RATE_ERROR` of the disturbance (0.1 %, well below 1 % of the model's own
    effect); ``"full"`` or 0: every sample; a number: that rate (Hz).
    """
    if gravity_rate_hz in ("full", 0, 0.0):
        return 1
    if gravity_rate_hz is None:
        f = highest_frequency(traj, degree)
        interval = math.sqrt(GRAVITY_RATE_ERROR) / (2.0 * math.pi * f)
    else:
        try:
            g = float(gravity_rate_hz)
        except (TypeError, ValueError):
            g = math.nan
        if not (math.isfinite(g) and g > 0):
            raise InputError(
                f"gravity rate must be a positive number of Hz, got {gravity_rate_hz!r}"
            )
        interval = 1.0 / g
    return max(1, int(math.floor(interval * float(rate_hz) + 1e-9)))
