"""Batched Earth-relative NED strapdown propagation on Warp devices (host API).

The local-level mechanization of Groves (2013) ch. 5 and NavToolKit; the kernel is
``fieldmap.kernels.strapdown.ned_kernel``. Quaternions are scalar-first ``q_b^n``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.nav.batch import prepare_batch


@dataclass(frozen=True)
class NedResult:
    """Output of :func:`propagate_ned` (every ``output_every``-th sample, initial state first).

    ``t`` (n_out,) s, on the time base of :class:`fieldmap.nav.strapdown.LciResult` (the time of
    each stored sample: ``t0`` of the first, default ``sample0 dt``); ``lat``, ``lon``
    (n_traj, n_out) degrees; ``h`` (n_traj, n_out) m;
    ``v_ned`` (n_traj, n_out, 3) m/s; ``q`` (n_traj, n_out, 4) scalar-first q_b^n.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    v_ned: np.ndarray
    q: np.ndarray
    gravity: tuple
    #: final Gauss–Markov states (n_traj, 3) of the accelerometers and gyros, the final
    #: baro-loop state (n_traj, 3: δa m/s², baro drift m, 0) and ``llh`` the last stored
    #: position (n_traj, 3: lat rad, lon rad, h m; the kernel's bits, for ``degrees=False``),
    #: to continue in the next block
    final: dict | None = None


@dataclass(frozen=True)
class Baro:
    """Third-order baro altitude loop and baro error model (see ``kernels.strapdown.BaroAiding``).

    Parameters
    ----------
    h_ref : array_like (n_samples,) or (n_sets, n_samples)
        True height at the start of each IMU sample (the baro senses it plus its errors). m.
    k1, k2, k3 : float
        Loop gains. Units: 1/s, 1/s², 1/s³. :func:`baro_gains` gives a triple pole.
    bias : float or array_like (n_traj,)
        Constant baro error per run. Units: m.
    noise : float or array_like (n_traj,)
        White noise per IMU sample. Units: m.
    gm_sigma, gm_tau : float or array_like (n_traj,)
        Gauss–Markov baro drift: stationary σ (m) and correlation time (s; 0: none).
    state : array_like (n_traj, 3), optional
        Loop state at the start (δa m/s², drift m, 0); default zeros.
    """

    h_ref: np.ndarray
    k1: float
    k2: float
    k3: float
    bias: object = 0.0
    noise: object = 0.0
    gm_sigma: object = 0.0
    gm_tau: object = 0.0
    state: object = None


def baro_gains(tau: float = 100.0, ellipsoid: Ellipsoid = WGS84) -> tuple[float, float, float]:
    r"""Gains of the third-order baro loop with a triple pole at s = −1/τ.

    The height error of the loop obeys s³ + k1 s² + (k2 − 2g/R) s + k3 = 0 (the 2g/R term is
    the vertical-channel instability, Titterton & Weston 2004 §5.3); matching (s + 1/τ)³ gives

    .. math:: k_1 = 3/\tau,\quad k_2 = 3/\tau^2 + 2 g/R,\quad k_3 = 1/\tau^3.

    Units: τ s; returns 1/s, 1/s², 1/s³.
    """
    if not np.isfinite(tau) or tau <= 0:
        raise InputError(f"baro loop time constant must be positive, got {tau}")
    g_over_r = 9.80665 / ellipsoid.a
    return 3.0 / tau, 3.0 / tau**2 + 2.0 * g_over_r, 1.0 / tau**3


def propagate_ned(
    dtheta,
    dv,
    dt,
    lat0,
    lon0,
    h0,
    v_ned0,
    q0,
    gravity="j4",
    *,
    sh_model=None,
    ellipsoid: Ellipsoid | str = WGS84,
    imu_set=None,
    errors=None,
    output_every=1,
    device=None,
    baro: Baro | None = None,
    sample0=0,
    degrees: bool = True,
    gravity_every=1,
    gravity_hold=None,
    t0=None,
) -> NedResult:
    """Propagate many trajectories with the Earth-relative NED mechanization.

    One update per IMU sample (see ``fieldmap.kernels.strapdown.ned_kernel``): specific force
    with the rotation correction of :func:`fieldmap.nav.forcened.calc_force_ned`, Coriolis and
    transport rate, navigation gravity plus centrifugal (Groves eq. 3.7.5), trapezoidal position.

    Parameters
    ----------
    dtheta, dv : array_like, shape (n_samples, 3) or (n_sets, n_samples, 3)
        Body-frame increments. Units: rad, m/s.
    dt : float
        Sample interval. Units: s.
    lat0, lon0, h0 : float or array_like (n_traj,)
        Initial geodetic position. Units: degrees (radians with ``degrees=False``), m.
    v_ned0 : array_like, shape (3,) or (n_traj, 3)
        Initial Earth-relative velocity in NED. Units: m/s.
    q0 : array_like, shape (4,) or (n_traj, 4)
        Initial q_b^n, scalar first.
    gravity, sh_model, ellipsoid, imu_set, errors, output_every, device
        As in :func:`fieldmap.nav.strapdown.propagate_lci`.
    baro : Baro, optional
        Altitude aiding of the vertical channel (default: free inertial).
    t0 : float, optional
        Time of the first sample, for ``t`` only (the mechanization does not depend on it).
        Default ``sample0 dt``. Units: s.
    sample0 : int
        Global index of the first sample, as in :func:`~fieldmap.nav.strapdown.propagate_lci`:
        the IMU and baro noise of sample j is keyed on (seed, ``sample0`` + j).
    degrees : bool
        False: ``lat0``, ``lon0`` in radians, e.g. ``final["llh"]`` of the previous piece of a
        flight (no degree round trip: the pieces give the bits of one propagation).

    Returns
    -------
    NedResult
    """
    llh = np.stack(
        np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (lat0, lon0, h0))), -1
    )
    lat_deg = llh[..., 0] if degrees else np.degrees(llh[..., 0])
    if llh.size and np.any(np.abs(lat_deg) >= 89.0):
        raise InputError("the NED mechanization is not valid within 1 degree of the poles")
    b = prepare_batch(
        dtheta,
        dv,
        dt,
        {"llh0": (llh, (3,)), "v_ned0": (v_ned0, (3,)), "q0": (q0, (4,))},
        gravity,
        sh_model,
        imu_set,
        errors,
        output_every,
        device,
        per_step=1,
        sample0=sample0,
        gravity_every=gravity_every,
        gravity_hold=gravity_hold,
    )
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import strapdown as ksd

    st = b.states
    llh_rad = st["llh0"].copy()
    if degrees:
        llh_rad[:, :2] = np.radians(llh_rad[:, :2])
    aid = _baro_struct(baro, b, ksd)
    L, v, q = b.launch(
        ksd.ned_kernel_for(b.has_errors or aid.enabled != 0, b.has_sh),
        (llh_rad, st["v_ned0"], st["q0"]),
        [normal_params(get_ellipsoid(ellipsoid)), aid],
    )
    se = b.sensor_errors
    final = {
        "acc_gm": se.acc_gm.numpy(),
        "gyro_gm": se.gyro_gm.numpy(),
        "baro": aid.state.numpy(),
        "llh": L[:, -1].copy(),
        "gravity_hold": b.grav_hold.numpy(),
    }
    return NedResult(
        # the time base of propagate_lci: t0 is the time of the first sample (default: the
        # global sample index times dt, so pieces of a record share one grid)
        t=(0.0 if t0 is None else float(t0) - b.dt * b.sample0)
        + b.dt * (b.sample0 + b.output_every * np.arange(b.n_out)),
        lat=np.degrees(L[..., 0]),
        lon=np.degrees(L[..., 1]),
        h=L[..., 2],
        v_ned=v,
        q=q,
        gravity=tuple(b.names),
        final=final,
    )


def _baro_struct(baro: Baro | None, b, ksd):
    """Device struct of the baro loop (disabled with placeholder arrays when ``baro`` is None)."""
    import warp as wp

    from fieldmap.nav.batch import per_trajectory

    dev, n = b.device, b.n
    aid = ksd.BaroAiding()

    def arr(a, t=wp.float64):
        return wp.array(a, dtype=t, device=dev)

    if baro is None:
        aid.enabled = 0
        aid.k1 = aid.k2 = aid.k3 = wp.float64(0.0)
        aid.h_ref = wp.zeros((1, 1), dtype=wp.float64, device=dev)
        for key in ("bias", "noise", "gm_sigma", "gm_tau"):
            setattr(aid, key, arr(np.zeros(n)))
        aid.state = arr(np.zeros((n, 3)), wp.vec3d)
        return aid
    h_ref = np.asarray(baro.h_ref, dtype=np.float64)
    h_ref = h_ref[None] if h_ref.ndim == 1 else h_ref
    n_sets, n_samples = b.inputs[0].shape
    if h_ref.shape != (n_sets, n_samples) or not np.all(np.isfinite(h_ref)):
        raise InputError(
            f"baro h_ref must be finite with shape ({n_samples},) or ({n_sets}, {n_samples}), "
            f"got {h_ref.shape}"
        )
    gains = np.array([baro.k1, baro.k2, baro.k3], dtype=np.float64)
    if not np.all(np.isfinite(gains)) or np.any(gains < 0):
        raise InputError(f"baro gains must be finite and >= 0, got {gains}")
    aid.enabled = 1
    aid.k1, aid.k2, aid.k3 = (wp.float64(x) for x in gains)
    aid.h_ref = arr(np.ascontiguousarray(h_ref))
    for key in ("bias", "noise", "gm_sigma", "gm_tau"):
        val = per_trajectory(f"baro {key}", getattr(baro, key), n, ())
        if key != "bias" and np.any(val < 0):
            raise InputError(f"baro {key} must be >= 0")
        setattr(aid, key, arr(val))
    state = np.zeros((n, 3)) if baro.state is None else baro.state
    aid.state = arr(per_trajectory("baro state", state, n, (3,)), wp.vec3d)
    return aid
