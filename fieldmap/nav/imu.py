r"""Exact IMU synthesis: gyro and accelerometer increments from a reference trajectory.

For each IMU sample ``[t_i, t_i + dt]`` the increments the two-sample mechanization of Chen et al.
(2022) Fig. 1 expects are (Savage 1998 §2; Titterton & Weston 2004 §11.2):

.. math::
    \Delta\theta_i = \int_{t_i}^{t_i+dt} \omega_{ib}^b(t)\,dt, \qquad
    \Delta v_i = \int_{t_i}^{t_i+dt} f^b(t)\,dt, \qquad
    f^b = C_a^b\,(A_a - \gamma^a(P_a, t))

with f = a − γ the specific force (Groves 2013 eq. 3.7.1: accelerometers sense the non-gravitational
force, so at rest the sensed force points up) and γ the gravitation of the *truth* model (no
centrifugal term: the a-frame is inertial). Both integrals are evaluated by Gauss–Legendre
quadrature with ``n_gauss`` nodes per sample (exact for polynomials of degree 2·n_gauss − 1); the
trajectory is analytic (:mod:`fieldmap.nav.trajectory`), so the quadrature error is far below the
mechanization's own truncation error. The truth gravitation is evaluated in batches of many
quadrature points per Warp launch (:func:`fieldmap.field.sh.sh_gravitation`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.nav.trajectory import Trajectory

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

#: The bundled truth model.
DEFAULT_TRUTH = "eigen-6s"


@dataclass(frozen=True)
class ImuIncrements:
    """Gyro and accelerometer increments of one IMU.

    Attributes
    ----------
    dtheta : ndarray (n, 3)
        Rotation increments ∫ω_ib^b dt. Units: rad.
    dv : ndarray (n, 3)
        Velocity increments ∫f^b dt. Units: m/s.
    dt : float
        Sample interval. Units: s.
    t0 : float
        Start time of the first sample (s after launch).
    meta : dict
        Provenance (trajectory, truth gravity, quadrature).
    """

    dtheta: np.ndarray
    dv: np.ndarray
    dt: float
    t0: float = 0.0
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        validate_increments(self.dtheta, self.dv, self.dt)

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return self.dtheta.shape[0]

    @property
    def rate_hz(self) -> float:
        """Sample rate. Units: Hz."""
        return 1.0 / self.dt

    @property
    def duration(self) -> float:
        """Covered time. Units: s."""
        return self.n_samples * self.dt


def validate_increments(dtheta: Any, dv: Any, dt: Any) -> None:
    """Raise :class:`InputError` for mismatched or non-finite increments or a bad interval."""
    try:
        dt_value = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"IMU sample interval dt must be a number, got {dt!r}") from None
    if not np.isfinite(dt_value) or dt_value <= 0:
        raise InputError(f"IMU sample interval dt must be positive and finite, got {dt}")
    try:
        dtheta, dv = np.asarray(dtheta, dtype=np.float64), np.asarray(dv, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("IMU increments must be numeric arrays of shape (n, 3)") from None
    if dtheta.ndim != 2 or dtheta.shape[-1] != 3 or dv.ndim != 2 or dv.shape[-1] != 3:
        raise InputError(
            f"IMU increments must have shape (n, 3), got {dtheta.shape} and {dv.shape}"
        )
    if dtheta.shape != dv.shape:
        raise InputError(
            f"gyro and accelerometer increments differ in length: {dtheta.shape} vs {dv.shape}"
        )
    if dtheta.shape[0] < 2 or dtheta.shape[0] % 2:
        raise InputError(
            "the two-sample mechanization needs an even number (>= 2) of samples, "
            f"got {dtheta.shape[0]}"
        )
    if not (np.all(np.isfinite(dtheta)) and np.all(np.isfinite(dv))):
        raise InputError("IMU increments contain NaN or inf")


# --- truth gravitation --------------------------------------------------------------------------
def load_truth_model(name: str | SHModel = DEFAULT_TRUTH, lmax: int | None = None) -> SHModel:
    """Load a gravity model by name or path via :func:`fieldmap.models.registry.load_model`."""
    from fieldmap.models.registry import load_model

    return load_model(name, lmax=lmax)


class Gravitation:
    """ECEF gravitation ``γ_e(r_e)`` of a named model, evaluated in Warp launches.

    Parameters
    ----------
    kind : str
        ``"sh"`` (spherical harmonics), or a normal kind ``"exact"``, ``"j2"``, ``"j4"``, ``"j6"``.
    model : SHModel, optional
        For ``"sh"``: the coefficients (default: bundled EIGEN-6S).
    lmax : int, optional
        For ``"sh"``: truncation degree (default: the model's).
    device : str, optional
        Warp device.
    ellipsoid : Ellipsoid or str
        Level ellipsoid of the normal kinds (default WGS84): a trajectory's
        ``frame.ellipsoid``, the one its navigator uses (unused by ``"sh"``).
    """

    def __init__(
        self,
        kind: str = "sh",
        model: SHModel | None = None,
        lmax: int | None = None,
        device: str | None = None,
        *,
        ellipsoid: Ellipsoid | str = WGS84,
    ) -> None:
        from fieldmap._warp import resolve_device
        from fieldmap.models.icgem import as_degree

        self.ellipsoid = get_ellipsoid(ellipsoid)
        self.kind = str(kind).lower()
        self.model: SHModel | None  # None for the normal kinds, as the degree:
        self.lmax: Any  # an int for "sh" (callers read it as one)
        # a DeviceError is an InputError already (one line, exit 2 in the CLI)
        self.device = None if device is None else resolve_device(device)
        if self.kind == "sh":
            sh = self.model = model if model is not None else load_truth_model()
            lmax = as_degree(lmax)
            self.lmax = degree = sh.lmax if lmax is None else lmax
            if not 0 <= degree <= sh.lmax:
                raise InputError(f"degree {lmax} is beyond the model {sh.name} (max {sh.lmax})")
            self.name = f"{sh.name} (degree {degree})"
        elif self.kind in ("exact", "j2", "j4", "j6"):
            self.model, self.lmax = None, None
            self.name = f"normal {self.kind} ({self.ellipsoid.name})"
        else:
            raise InputError(f"unknown gravity model kind {kind!r}")

    def __call__(self, r_e: np.ndarray) -> np.ndarray:
        """Gravitation at ECEF points ``(N, 3)`` (m) -> ``(N, 3)`` ECEF (m/s²)."""
        x, y, z = r_e[:, 0], r_e[:, 1], r_e[:, 2]
        if self.kind == "sh":
            from fieldmap.field.sh import sh_gravitation

            assert self.model is not None  # set with kind "sh"
            return sh_gravitation(self.model, x, y, z, lmax=self.lmax, device=self.device)
        from fieldmap.field.normal import normal_gravitation_ecef

        return normal_gravitation_ecef(
            x, y, z, normal=self.kind, ellipsoid=self.ellipsoid, device=self.device
        )


# --- synthesis ------------------------------------------------------------------------------------
def gauss_legendre01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [0, 1] (1 ≤ n ≤ 64)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= 64:
        raise InputError(f"number of Gauss-Legendre nodes must be an integer in 1..64, got {n!r}")
    x, w = np.polynomial.legendre.leggauss(int(n))
    return 0.5 * (x + 1.0), 0.5 * w


#: most IMU samples of one synthesis (the paper's 800 s at 200 Hz is 160 000; this allows
#: 12.5x that and keeps the Gauss-node gravity evaluations within a few GiB)
MAX_SAMPLES = 2_000_000


def sample_count(duration: float, rate_hz: float) -> int:
    """Even number of samples covering ``duration`` at ``rate_hz`` (two samples per nav step).

    Units: ``duration`` s, ``rate_hz`` Hz. Raises :class:`InputError` for a non-positive or
    non-finite value, fewer than 2 samples, or more than :data:`MAX_SAMPLES`.
    """
    if not np.isfinite(rate_hz) or rate_hz <= 0:
        raise InputError(f"IMU rate must be positive, got {rate_hz}")
    if not np.isfinite(duration) or duration <= 0:
        raise InputError(f"duration must be positive, got {duration}")
    n = duration * rate_hz
    if n > MAX_SAMPLES:
        raise InputError(
            f"duration {duration:g} s at {rate_hz:g} Hz gives {n:.3g} IMU samples, more than "
            f"{MAX_SAMPLES}"
        )
    n = int(round(n / 2.0)) * 2
    if n < 2:
        raise InputError(f"duration {duration} s at {rate_hz} Hz gives fewer than 2 samples")
    return n


@dataclass(frozen=True)
class ImuSampling:
    """How the IMU samples its increments: the rate and the quadrature nodes per sample.

    Parameters
    ----------
    rate_hz : float
        IMU sample rate (a navigation step is two samples). Units: Hz.
    n_gauss : int
        Gauss–Legendre nodes per sample (1..64).

    Raises
    ------
    InputError
        A rate that is no positive number, or a node count out of 1..64 (on construction).
    """

    rate_hz: float = 200.0
    n_gauss: int = 3

    def __post_init__(self) -> None:
        r = self.rate_hz
        if isinstance(r, (str, bytes, bool)) or not isinstance(r, (int, float, np.number)):
            raise InputError(f"rate must be a positive number, got {r!r}", param="rate_hz")
        if not np.isfinite(r) or r <= 0:
            raise InputError(f"rate must be a positive number, got {r!r}", param="rate_hz")
        gauss_legendre01(self.n_gauss)


def synthesize(
    traj: Trajectory,
    sampling: ImuSampling | None = None,
    gravity: Any = None,
    *,
    duration: float | None = None,
    t0: float = 0.0,
    batch: int = 200_000,
    progress: bool = False,
    sample0: int = 0,
) -> ImuIncrements | list[ImuIncrements]:
    """Exact gyro and accelerometer increments of ``traj`` under the ``gravity`` truth.

    Parameters
    ----------
    traj : Trajectory
        Reference trajectory (closed form).
    sampling : ImuSampling, optional
        IMU rate and Gauss–Legendre nodes per sample (default ``ImuSampling()``: 200 Hz, 3
        nodes).
    gravity : callable or list of callables, optional
        ECEF gravitation ``γ_e(r_e)`` (N, 3) -> (N, 3), e.g. :class:`Gravitation`; default
        EIGEN-6S at full degree. A list gives one increment set per model from one evaluation
        of the kinematics (the gyro increments are shared).
    duration : float, optional
        Covered time (default: the trajectory's). Units: s.
    t0 : float
        Start time of sample 0. Units: s.
    batch : int
        Quadrature points per gravity launch.
    progress : bool
        Show a tqdm progress bar.
    sample0 : int
        Index of the first sample on the grid ``t0 + dt k``: the record starts at
        ``t0 + dt sample0`` (a piece of a longer record: its times, hence its increments, are
        the bits of that record's).

    Returns
    -------
    ImuIncrements, or a list of them for a list of gravities
    """
    sampling = ImuSampling() if sampling is None else sampling
    rate_hz, n_gauss = sampling.rate_hz, sampling.n_gauss
    gravity = Gravitation() if gravity is None else gravity
    many = isinstance(gravity, (list, tuple))
    gravities = list(gravity) if many else [gravity]
    if not gravities:
        raise InputError("synthesize needs at least one gravity model")
    duration = traj.duration if duration is None else float(duration)
    if isinstance(sample0, (bool, np.bool_)) or not isinstance(sample0, (int, np.integer)):
        raise InputError(f"sample0 must be an integer sample index, got {sample0!r}")
    if sample0 < 0:
        raise InputError(f"sample0 must be >= 0, got {sample0}")
    dt = 1.0 / float(rate_hz) if np.isfinite(rate_hz) and rate_hz > 0 else 0.0
    start = t0 + dt * int(sample0)
    if not np.isfinite(duration) or duration <= 0 or start + duration > traj.duration * (1 + 1e-12):
        raise InputError(f"duration {duration} s does not fit the trajectory ({traj.duration} s)")
    n = sample_count(duration, rate_hz)
    traj.check_above_surface()
    xg, wg = gauss_legendre01(n_gauss)
    # trajectories that keep the base-class kinematics: rotation-invariant ECEF path (no a-frame)
    direct = type(traj).kinematics is Trajectory.kinematics
    dtheta = np.empty((n, 3))
    dvs = [np.empty((n, 3)) for _ in gravities]
    per = max(1, batch // n_gauss)
    starts = range(0, n, per)
    if progress:
        from tqdm import tqdm

        starts = tqdm(starts, desc="IMU synthesis", unit="batch")
    for s0 in starts:
        s1 = min(n, s0 + per)
        ts = t0 + dt * np.arange(sample0 + s0, sample0 + s1, dtype=np.float64)
        tq = (ts[:, None] + dt * xg[None, :]).ravel()
        if direct:
            w_b, f_bs = _body_ecef(traj, tq, gravities)  # (_evaluate: at times where it can)
        else:
            k = traj.kinematics(tq)
            f_bs = []
            for g in gravities:
                g_a = traj.frame.vector_e_to_a(_evaluate(g, tq, k.r_e), tq)
                f_bs.append(np.einsum("nji,nj->ni", k.C_b_to_a, k.A_a - g_a))
            w_b = k.w_b
        wq = (dt * wg)[None, :, None]
        dtheta[s0:s1] = np.sum(w_b.reshape(s1 - s0, n_gauss, 3) * wq, axis=1)
        for dv, f_b in zip(dvs, f_bs):
            dv[s0:s1] = np.sum(f_b.reshape(s1 - s0, n_gauss, 3) * wq, axis=1)
    out = [
        ImuIncrements(
            dtheta if j == 0 else dtheta.copy(),
            dv,
            dt,
            float(start),
            {
                "trajectory": traj.name,
                "truth_gravity": getattr(g, "name", repr(g)),
                "n_gauss": int(n_gauss),
                "rate_hz": float(rate_hz),
            },
        )
        for j, (g, dv) in enumerate(zip(gravities, dvs))
    ]
    return out if many else out[0]


def _evaluate(g: Any, t: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Gravitation ``g`` on the path: by time where it interpolates along it, else by position."""
    if hasattr(g, "at_times"):  # fieldmap.nav.gravity.TrackGravitation
        return g.at_times(t, r)
    return np.asarray(g(r), dtype=np.float64)


def _body_ecef(
    traj: Trajectory, t: np.ndarray, gravities: list[Any]
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Body rate ω_ib^b and specific forces f^b (one per gravity) at times ``t`` from ECEF.

    f^b = C_e^b (r̈ + 2ω×ṙ + ω×(ω×r) − γ(r)) and ω_ib^b = C_e^b (ω_eb^e + ω_ie^e): the same
    vectors as through the a-frame (a rotation of both sides, Groves 2013 eq. 2.84 ff.), without
    the a-frame's rotation matrices.
    """
    r, v, a = traj._ecef(t)
    C_b_e, w_eb_e = traj._attitude(t, r, v, a)
    w = np.array([0.0, 0.0, traj.frame.omega])
    a_in = a + 2.0 * np.cross(w, v) + np.cross(w, np.cross(w, r))
    vecs = [w_eb_e + w] + [a_in - _evaluate(g, t, r) for g in gravities]
    body = np.einsum("nji,nkj->nki", C_b_e, np.stack(vecs, 1))
    return body[:, 0], [body[:, 1 + j] for j in range(len(gravities))]
