"""Batched strapdown propagation on Warp devices: launch-centred inertial (LCI) mechanization.

One launch of :data:`fieldmap.kernels.strapdown.lci_kernel` propagates many trajectories
(Monte Carlo draws × navigation gravity models × IMU grades): each thread loops over its own
two-sample steps (Chen et al. 2022 eq. 14, Fig. 1). Quaternions in this API are scalar-first
``[w, x, y, z]`` (Hamilton), ``q_b^a`` rotating body vectors into the a-frame.

The validation and upload shared with the NED mechanization live in :mod:`fieldmap.nav.batch`,
the navigation gravity names in :mod:`fieldmap.nav.navgravity` (both re-exported here).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.nav.batch import per_trajectory as per_trajectory
from fieldmap.nav.batch import prepare_batch as prepare_batch
from fieldmap.nav.launch_frames import LaunchFrame
from fieldmap.nav.navgravity import GRAVITY_ALIASES as GRAVITY_ALIASES
from fieldmap.nav.navgravity import GRAVITY_KINDS as GRAVITY_KINDS
from fieldmap.nav.navgravity import NORMAL_MODELS as NORMAL_MODELS
from fieldmap.nav.navgravity import gravity_cost as gravity_cost
from fieldmap.nav.navgravity import gravity_names as gravity_names
from fieldmap.nav.navgravity import parse_gravity as parse_gravity
from fieldmap.nav.navgravity import sh_degree as sh_degree


@dataclass(frozen=True)
class LciResult:
    """Output of :func:`propagate_lci` (every ``output_every``-th step, initial state first).

    Attributes: ``t`` (n_out,) s since launch; ``P``, ``V`` (n_traj, n_out, 3) a-frame position
    (m) and inertial velocity (m/s); ``q`` (n_traj, n_out, 4) scalar-first q_b^a; ``gravity``
    the navigation gravity name of each trajectory.
    """

    t: np.ndarray
    P: np.ndarray
    V: np.ndarray
    q: np.ndarray
    gravity: tuple
    #: final Gauss–Markov states (n_traj, 3) ``acc_gm``, ``gyro_gm`` (to continue a flight)
    final: dict | None = None


def quat_to_dcm(q) -> np.ndarray:
    """Scalar-first quaternions ``(..., 4)`` -> rotation matrices ``(..., 3, 3)``."""
    q = np.asarray(q, dtype=np.float64)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if not np.all(np.isfinite(norm)) or np.any(norm < 1e-12):
        raise InputError("quat_to_dcm needs finite, non-zero quaternions")
    q = q / norm
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def dcm_to_quat(C) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` -> scalar-first quaternions with w >= 0."""
    from scipy.spatial.transform import Rotation

    C = np.asarray(C, dtype=np.float64)
    xyzw = Rotation.from_matrix(C.reshape(-1, 3, 3)).as_quat()
    q = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q.reshape(C.shape[:-2] + (4,))


def launch_params(frame: LaunchFrame):
    """Device struct of a launch frame (R_t^a of eq. 17, launch point, Earth rate)."""
    from fieldmap.kernels.launch_frames import LaunchParams

    lp = LaunchParams()
    lp.C_t_to_a = wp.mat33d(*frame.C_t_to_a.ravel())
    lp.r_launch = wp.vec3d(*frame.r_launch)
    lp.omega = wp.float64(frame.omega)
    return lp


def propagate_lci(
    dtheta,
    dv,
    dt,
    P0,
    V0,
    q0,
    launch,
    gravity="j4",
    *,
    sh_model=None,
    ellipsoid: Ellipsoid | str | None = None,
    imu_set=None,
    errors=None,
    t0=0.0,
    output_every=1,
    device=None,
    sample0=0,
    gravity_every=1,
    gravity_hold=None,
) -> LciResult:
    """Propagate many trajectories in the launch-centred inertial frame (eqs. 14-15, 20).

    Parameters
    ----------
    dtheta, dv : array_like, shape (n_samples, 3) or (n_sets, n_samples, 3)
        Gyro and accelerometer increments per IMU sample, body frame; n_samples even (two
        samples per navigation step). Units: rad, m/s.
    dt : float
        IMU sample interval; the navigation step is T = 2 dt. Units: s.
    P0, V0 : array_like, shape (3,) or (n_traj, 3)
        Initial a-frame position and inertial velocity. Units: m, m/s.
    q0 : array_like, shape (4,) or (n_traj, 4)
        Initial attitude q_b^a, scalar first.
    launch : LaunchFrame or tuple
        The a-frame, or ``(lon0, B0, A0[, h0])`` in degrees (h0 in m).
    gravity : str or sequence of str
        Navigation gravity per trajectory: ``j2``, ``j4``, ``j6``, ``exact`` (closed-form level
        ellipsoid; ``normal`` is its deprecated 0.1 name), ``sh`` (full ``sh_model``) or ``shN``
        (degree N).
    sh_model : SHModel, optional
        Spherical-harmonic model for the ``sh`` kinds.
    ellipsoid : Ellipsoid or str, optional
        Level ellipsoid of the frame and of the normal kinds (default: the frame's, WGS84 for a
        tuple). Given with a :class:`LaunchFrame` of another ellipsoid: :class:`InputError`.
    imu_set : array_like of int, optional
        Increment set of each trajectory (default: trajectory i uses set i, or set 0 if one set;
        several sets for a different number of trajectories need ``imu_set``).
    errors : dict, optional
        Per-trajectory sensor errors (shape (3,) or (n_traj, ...)): ``acc_bias`` m/s²,
        ``gyro_bias`` rad/s, ``acc_M``, ``gyro_M`` (3×3, I + scale + misalignment),
        ``acc_noise`` m/s/√s, ``gyro_noise`` rad/√s, ``seed`` int; first-order Gauss–Markov
        bias instability ``acc_gm_sigma`` m/s², ``gyro_gm_sigma`` rad/s with correlation times
        ``acc_gm_tau``, ``gyro_gm_tau`` s (0: none) and initial states ``acc_gm`` m/s²,
        ``gyro_gm`` rad/s (n_traj, 3). The normals of sample j are drawn from Warp's RNG keyed
        on (``seed``, ``sample0`` + j) (``fieldmap.kernels.strapdown.sample_rng``).
    t0 : float
        Time of the first sample after launch (Earth rotation angle ω t0). Units: s. With
        ``sample0``, the times are taken on the grid ``t0 − sample0 dt + dt j`` of the global
        sample indices j (a piece of a flight at ``t0 = sample0 dt`` has the whole record's times).
    output_every : int
        Decimation of the stored states (in navigation steps).
    device : str, optional
        Warp device (default: CUDA if present, else CPU using every core).
    sample0 : int
        Global index (in the whole flight) of the first sample: a flight propagated in pieces,
        each from the previous one's final state (``final``) with ``sample0`` = the samples
        before it, draws the noise of one propagation over the whole record.
    gravity_every : int
        For the ``sh`` kinds: evaluate the SH disturbance (model minus exact normal
        gravitation) every this many samples and extrapolate it linearly in between, the exact
        normal field every step (``fieldmap.kernels.navgravity.held_gravitation_ecef``, a
        flight computer's gravity rate); 1 (default): the full model every step.
    gravity_hold : array_like (n_traj, 3, 3), optional
        State of that update (``final["gravity_hold"]`` of the previous piece); default: none yet.

    Returns
    -------
    LciResult
    """
    if isinstance(launch, LaunchFrame):
        frame = launch
        if ellipsoid is not None and get_ellipsoid(ellipsoid) != frame.ellipsoid:
            raise InputError(
                f"ellipsoid {get_ellipsoid(ellipsoid).name} differs from the launch frame's "
                f"{frame.ellipsoid.name}: give it to the LaunchFrame"
            )
    else:
        parts = tuple(launch)
        if not 3 <= len(parts) <= 4:
            raise InputError(
                f"launch must be a LaunchFrame or (lon0, B0, A0[, h0]), got {len(parts)} values"
            )
        frame = LaunchFrame(
            parts[0],
            parts[1],
            parts[2],
            parts[3] if len(parts) == 4 else 0.0,
            ellipsoid=get_ellipsoid(WGS84 if ellipsoid is None else ellipsoid),
        )
    b = prepare_batch(
        dtheta,
        dv,
        dt,
        {"P0": (P0, (3,)), "V0": (V0, (3,)), "q0": (q0, (4,))},
        gravity,
        sh_model,
        imu_set,
        errors,
        output_every,
        device,
        per_step=2,
        sample0=sample0,
        gravity_every=gravity_every,
        gravity_hold=gravity_hold,
    )
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import strapdown as ksd

    st = b.states
    # the kernel's time origin is global sample 0: t0 − sample0 dt (0 exactly when t0 =
    # sample0 dt, as for the blocks of a flight: the times of one grid whatever the blocking)
    t_base = float(t0) - b.dt * b.sample0
    P, V, q = b.launch(
        ksd.lci_kernel_for(b.has_errors, b.has_sh),
        (st["P0"], st["V0"], st["q0"]),
        [launch_params(frame), normal_params(frame.ellipsoid)],
        [wp.float64(t_base)],
    )
    t = t_base + b.dt * (b.sample0 + 2 * b.output_every * np.arange(b.n_out))
    se = b.sensor_errors
    final = {
        "acc_gm": se.acc_gm.numpy(),
        "gyro_gm": se.gyro_gm.numpy(),
        "gravity_hold": b.grav_hold.numpy(),
    }
    return LciResult(t=t, P=P, V=V, q=q, gravity=tuple(b.names), final=final)
