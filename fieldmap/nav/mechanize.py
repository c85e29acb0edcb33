"""Strapdown mechanizations on Warp devices: LCI and Earth-relative NED (with baro aiding).

Validation and upload of a batch of trajectories, shared by the LCI and NED mechanizations.

:func:`_prepare_batch` checks the IMU increments, initial states, navigation gravity names and
sensor errors of many trajectories and uploads them to a Warp device as a ``_Batch``,
whose ``launch`` runs :func:`fieldmap.nav.mechanize.propagate_lci`'s or
:func:`fieldmap.nav.mechanize.propagate_ned`'s kernel. Quaternions are scalar-first
``[w, x, y, z]`` here and ``(x, y, z, w)`` on the device.

Batched strapdown propagation on Warp devices: launch-centred inertial (LCI) mechanization.

One launch of :data:`fieldmap.kernels.strapdown.lci_kernel` propagates many trajectories
(Monte Carlo draws × navigation gravity models × IMU grades): each thread loops over its own
two-sample steps (Chen et al. 2022 eq. 14, Fig. 1). Quaternions in this API are scalar-first
``[w, x, y, z]`` (Hamilton), ``q_b^a`` rotating body vectors into the a-frame.

The validation and upload shared with the NED mechanization live in :mod:`fieldmap.nav.mechanize`,
the navigation gravity names in :mod:`fieldmap.nav.gravity` (both re-exported here).

Batched Earth-relative NED strapdown propagation on Warp devices (host API).

The local-level mechanization of Groves (2013) ch. 5 and NavToolKit; the kernel is
``fieldmap.kernels.strapdown.ned_kernel``. Quaternions are scalar-first ``q_b^n``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt
import warp as wp

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.nav.frames import LaunchFrame
from fieldmap.nav.gravity import parse_gravity, table_file
from fieldmap.units import STANDARD_GRAVITY

if TYPE_CHECKING:
    from fieldmap.kernels.frames import LaunchParams
    from fieldmap.kernels.sh import SHKernelModel
    from fieldmap.kernels.strapdown import BaroAiding, SensorErrors
    from fieldmap.models.shmodel import SHModel


def _finite(name: str, a: npt.ArrayLike, shape_tail: tuple[int, ...] | None = None) -> np.ndarray:
    try:
        a = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be numeric") from None
    if shape_tail and a.shape[-len(shape_tail) :] != shape_tail:
        raise InputError(f"{name} must have trailing shape {shape_tail}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains non-finite values")
    return a


def _per_trajectory(name: str, a: npt.ArrayLike, n: int, tail: tuple[int, ...]) -> np.ndarray:
    """Broadcast the finite ``a`` to one value per trajectory: shape ``(n, *tail)``."""
    a = _finite(name, a, tail)
    if a.ndim == len(tail):
        a = np.broadcast_to(a, (n,) + tail)
    if a.shape != (n,) + tail:
        raise InputError(f"{name} must have shape {tail} or {(n,) + tail}, got {a.shape}")
    return np.ascontiguousarray(a)


class _DummyTable:
    """Lattice of a launch without a table (the kernels take the struct in any case)."""

    lat0 = dlat = lon0 = dlon = h0 = dh = 1.0
    data = np.zeros((2, 4, 4, 3))


_DUMMY_TABLE = _DummyTable()


def _dummy_sh(device: str) -> SHKernelModel:
    from fieldmap.kernels import sh as ksh

    km = ksh.SHKernelModel()
    one = np.ones((1, 1))
    km.cnm, km.snm, km.anm, km.bnm, km.fnm = (
        wp.array(one, dtype=wp.float64, device=device) for _ in range(5)
    )
    km.sect = wp.array(np.ones(1), dtype=wp.float64, device=device)
    km.lmax = 0
    km.gm = wp.float64(WGS84.GM)
    km.radius = wp.float64(WGS84.a)
    return km


_ERROR_KEYS = {
    "acc_bias": (3,),
    "gyro_bias": (3,),
    "acc_M": (3, 3),
    "gyro_M": (3, 3),
    "acc_noise": (),
    "gyro_noise": (),
    "seed": (),
    "acc_gm_sigma": (),
    "acc_gm_tau": (),
    "gyro_gm_sigma": (),
    "gyro_gm_tau": (),
    "acc_gm": (3,),
    "gyro_gm": (3,),
}
_ERROR_DEFAULTS = {
    "acc_bias": np.zeros(3),
    "gyro_bias": np.zeros(3),
    "acc_M": np.eye(3),
    "gyro_M": np.eye(3),
    "acc_noise": 0.0,
    "gyro_noise": 0.0,
    "acc_gm_sigma": 0.0,
    "acc_gm_tau": 0.0,
    "gyro_gm_sigma": 0.0,
    "gyro_gm_tau": 0.0,
    "acc_gm": np.zeros(3),
    "gyro_gm": np.zeros(3),
}


@dataclass
class _Batch:
    n: int
    names: list
    inputs: list  # increments, imu_set, sensor errors
    states: dict
    kinds: list  # kind, lmax arrays
    shk: object
    tab: object  # the compensation table of the table:FILE trajectories (or a dummy)
    dt: float
    n_steps: int
    output_every: int
    n_out: int
    device: str
    #: global index (in the flight) of the first IMU sample: keys the noise draws
    sample0: int = 0
    #: samples between SH disturbance updates (1: full SH every step; see held_gravitation_ecef)
    grav_every: int = 1
    #: per trajectory (disturbance, slope, (last index, started, 0)), read and written back
    grav_hold: Any = None
    #: some trajectory has a sensor error (bias, scale/misalignment, noise, Gauss–Markov)
    has_errors: bool = True
    #: some trajectory navigates with an SH model or a compensation table
    has_sh: bool = True

    @property
    def sensor_errors(self) -> SensorErrors:
        """Uploaded :class:`fieldmap.kernels.strapdown.SensorErrors` (final GM states after use)."""
        return self.inputs[3]

    def launch(
        self,
        kernel: wp.Kernel,
        start: tuple[np.ndarray, np.ndarray, np.ndarray],
        params: list,
        times: Sequence[object] = (),
    ) -> tuple:
        """Run ``kernel`` for every trajectory; return its stored states (NumPy).

        ``start`` = (position, velocity, scalar-first quaternion) per trajectory; ``params`` are
        the frame structs and ``times`` the float64 inputs after ``dt``, in the kernel's order;
        the noise is keyed on the global sample indices from :attr:`sample0` on.
        Returns (position, velocity, scalar-first quaternion), each (n, n_out, ...).
        """
        dev = self.device
        types = (wp.vec3d, wp.vec3d, wp.quatd)
        pos, vel, q = start
        start_d: Any = [
            wp.array(a, dtype=t, device=dev) for a, t in zip((pos, vel, _quat_in(q)), types)
        ]
        outs = [wp.zeros((self.n, self.n_out), dtype=t, device=dev) for t in types]
        inputs = [
            *self.inputs,
            *start_d,
            *self.kinds,
            *params,
            self.shk,
            self.tab,
            wp.float64(self.dt),
            *times,
            self.n_steps,
            self.output_every,
            self.sample0,
            self.grav_every,
            self.grav_hold,
            *outs,
        ]
        _warp.launch_chunked(kernel, self.n, inputs, dev)
        return outs[0].numpy(), outs[1].numpy(), _quat_out(outs[2])


def _prepare_batch(
    dtheta: npt.ArrayLike, dv: npt.ArrayLike, dt: float, states: dict[str, Any],
    cfg: NavConfig, device: str | None, per_step: int,
) -> _Batch:  # fmt: skip
    """Validate and upload everything the LCI and NED kernels share (one row per trajectory).

    Used by :func:`fieldmap.nav.mechanize.propagate_lci` and
    :func:`fieldmap.nav.mechanize.propagate_ned`; ``cfg.sample0`` is the global index of the
    first sample (see :func:`~fieldmap.nav.mechanize.propagate_lci`).
    """
    gravity, sh_model, imu_set, errors = cfg.gravity, cfg.sh_model, cfg.imu_set, cfg.errors
    output_every, sample0 = cfg.output_every, cfg.sample0
    gravity_every, gravity_hold = cfg.gravity_every, cfg.gravity_hold
    _warp.init()
    dtheta = _finite("dtheta", dtheta, (3,))
    dv = _finite("dv", dv, (3,))
    if dtheta.ndim == 2:
        dtheta, dv = dtheta[None], (dv[None] if dv.ndim == 2 else dv)
    if dtheta.ndim != 3 or dv.shape != dtheta.shape:
        raise InputError(
            f"dtheta {dtheta.shape} and dv {dv.shape} must match (n_sets, n_samples, 3)"
        )
    n_sets, n_samples = dtheta.shape[:2]
    if n_samples < per_step or n_samples % per_step:
        raise InputError(
            f"need a multiple of {per_step} IMU samples (even for LCI), got {n_samples}"
        )
    sample0 = _sample_index(sample0, n_samples)
    dt = float(_finite("dt", dt))
    if not dt > 0:
        raise InputError(f"dt must be > 0, got {dt}")
    output_every = int(output_every)
    if output_every < 1:
        raise InputError("output_every must be >= 1")
    err = dict(errors or {})
    unknown = set(err) - set(_ERROR_KEYS)
    if unknown:
        raise InputError(f"unknown sensor error keys: {sorted(unknown)}")
    names = [gravity] if isinstance(gravity, str) else list(gravity)
    # with imu_set given, the number of sets says nothing about the number of trajectories
    lens = [
        len(names),
        n_sets if imu_set is None else 1,
        1 if imu_set is None else np.size(imu_set),
    ]
    for a, tail in list(states.values()) + [(v, _ERROR_KEYS[k]) for k, v in err.items()]:
        a = np.asarray(a)
        lens.append(a.shape[0] if a.ndim > len(tail) else 1)
    n = max(lens)
    if len(names) == 1:
        names = names * n
    if len(names) != n:
        raise InputError(f"{len(names)} gravity names for {n} trajectories")
    # once per distinct name (a table name reads or stats its file; runs repeat names per draw)
    parsed = {g: parse_gravity(g, sh_model) for g in dict.fromkeys(names)}
    kl = np.array([parsed[g] for g in names], dtype=np.int32).reshape(n, 2)
    if imu_set is None:
        if n_sets not in (1, n):
            raise InputError(
                f"{n_sets} increment sets for {n} trajectories: give imu_set= (the set of each "
                "trajectory) or one set per trajectory"
            )
        imu_set = np.arange(n) if n_sets == n else np.zeros(n, dtype=np.int32)
    imu_set = np.broadcast_to(np.asarray(imu_set, dtype=np.int64), (n,))
    if imu_set.min() < 0 or imu_set.max() >= n_sets:
        raise InputError(f"imu_set indices must lie in 0..{n_sets - 1}")
    states = {k: _per_trajectory(k, a, n, tail) for k, (a, tail) in states.items()}
    device = _warp.resolve_device(device)
    from fieldmap.kernels import strapdown as ksd

    arr: Callable[[np.ndarray, type], wp.array] = lambda a, dtype: wp.array(  # noqa: E731
        a, dtype=dtype, device=device
    )
    se = ksd.SensorErrors()
    types = {(3,): wp.vec3d, (3, 3): wp.mat33d, (): wp.float64}
    has_errors = False
    for key, tail in _ERROR_KEYS.items():
        if key == "seed":
            seed = _per_trajectory("seed", err.get("seed", np.arange(n)), n, ()).astype(np.int32)
            se.seed = arr(seed, wp.int32)
        else:
            a = _per_trajectory(key, err.get(key, _ERROR_DEFAULTS[key]), n, tail)
            has_errors = has_errors or bool(np.any(a != _ERROR_DEFAULTS[key]))
            setattr(se, key, arr(a, types[tail]))
    sh_lmax = int(kl[:, 1].max())
    if sh_lmax > 0:
        from fieldmap.field.sh import kernel_model

        shk = kernel_model(cast("SHModel", sh_model), device, sh_lmax)  # parse_gravity checked it
    else:
        shk = _dummy_sh(device)
    tables = sorted({f for f in (table_file(g) for g in names) if f is not None})
    if len(tables) > 1:
        raise InputError(
            f"one compensation table per launch, got {len(tables)}: {', '.join(tables)}"
        )
    from fieldmap.nav.gravity import kernel_table

    if tables:
        from fieldmap.products.tables.model import load_table

        tab = kernel_table(load_table(tables[0]), device)
    else:
        tab = kernel_table(_DUMMY_TABLE, device)
    wp.load_module(ksd, device=device)
    n_steps = n_samples // per_step
    if (
        isinstance(gravity_every, (bool, np.bool_))
        or not isinstance(gravity_every, (int, np.integer))
        or gravity_every < 1
    ):
        raise InputError(f"gravity_every must be an integer >= 1 (samples), got {gravity_every!r}")
    hold = np.zeros((n, 3, 3)) if gravity_hold is None else gravity_hold
    hold = _per_trajectory("gravity_hold", hold, n, (3, 3))
    return _Batch(
        has_errors=has_errors,
        has_sh=sh_lmax > 0 or bool(tables),
        tab=tab,
        sample0=sample0,
        grav_every=int(gravity_every),
        grav_hold=wp.array(np.ascontiguousarray(hold), dtype=wp.vec3d, device=device),
        n=n,
        names=names,
        device=device,
        shk=shk,
        dt=dt,
        n_steps=n_steps,
        output_every=output_every,
        n_out=n_steps // output_every + 1,
        states=states,
        inputs=[
            arr(dtheta, wp.vec3d),
            arr(dv, wp.vec3d),
            arr(imu_set.astype(np.int32), wp.int32),
            se,
        ],
        kinds=[
            arr(np.ascontiguousarray(kl[:, 0]), wp.int32),
            arr(np.ascontiguousarray(kl[:, 1]), wp.int32),
        ],
    )


def _sample_index(sample0: object, n_samples: int) -> int:
    """Check the global index of a record's first sample: an integer, >= 0, the record in int32."""
    if isinstance(sample0, (bool, np.bool_)) or not isinstance(sample0, (int, np.integer)):
        raise InputError(f"sample0 must be an integer sample index, got {sample0!r}")
    sample0 = int(sample0)
    if sample0 < 0 or sample0 + n_samples > 2**31 - 1:
        raise InputError(
            f"sample0 must lie in 0..{2**31 - 1 - n_samples} for {n_samples} samples, got {sample0}"
        )
    return sample0


def _quat_in(q0: np.ndarray) -> np.ndarray:
    """Scalar-first unit quaternions -> the kernels' (x, y, z, w), normalized.

    One that is unit to rounding (a kernel's output) is taken as is, so that a propagation
    continued from the previous one's final attitude gives the bits of one propagation.
    """
    norms = np.linalg.norm(q0, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-6):
        raise InputError("q0 must be unit quaternions")
    norms = np.where(np.abs(norms - 1.0) <= 4 * np.finfo(np.float64).eps, 1.0, norms)
    return np.ascontiguousarray(np.concatenate([q0[:, 1:], q0[:, :1]], axis=1) / norms[:, None])


def _quat_out(q: wp.array) -> np.ndarray:
    q = q.numpy()
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


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


def quat_to_dcm(q: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Scalar-first quaternions ``(..., 4)`` -> rotation matrices ``(..., 3, 3)``."""
    q = np.asarray(q, dtype=np.float64)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if not np.all(np.isfinite(norm)) or np.any(norm < 1e-12):
        raise InputError("quat_to_dcm needs finite, non-zero quaternions")
    q = np.asarray(q / norm)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def dcm_to_quat(C: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Rotation matrices ``(..., 3, 3)`` -> scalar-first quaternions with w >= 0."""
    from scipy.spatial.transform import Rotation

    C = np.asarray(C, dtype=np.float64)
    xyzw = Rotation.from_matrix(C.reshape(-1, 3, 3)).as_quat()
    q = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q.reshape(C.shape[:-2] + (4,))


def launch_params(frame: LaunchFrame) -> LaunchParams:
    """Device struct of a launch frame (R_t^a of eq. 17, launch point, Earth rate)."""
    from fieldmap.kernels.frames import LaunchParams

    lp = LaunchParams()
    lp.C_t_to_a = wp.mat33d(*frame.C_t_to_a.ravel())
    lp.r_launch = wp.vec3d(*frame.r_launch)
    lp.omega = wp.float64(frame.omega)
    return lp


@dataclass(frozen=True)
class NavConfig:
    """How the runs of :func:`propagate_lci` / :func:`propagate_ned` navigate.

    Everything of a propagation but the increments, the start state and the device: one
    object that the studies build once and pass down.

    Parameters
    ----------
    gravity : str or sequence of str
        Navigation gravity per trajectory: ``j2``, ``j4``, ``j6``, ``exact`` (closed-form level
        ellipsoid; ``normal`` is its deprecated 0.1 name), ``sh`` (full ``sh_model``), ``shN``
        (degree N) or ``table:FILE``.
    sh_model : SHModel, optional
        Spherical-harmonic model for the ``sh`` kinds.
    ellipsoid : Ellipsoid or str, optional
        Level ellipsoid of the normal kinds (LCI: default the frame's, WGS84 for a tuple; given
        with a :class:`LaunchFrame` of another ellipsoid: :class:`InputError`. NED: default
        WGS84).
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
    output_every : int
        Decimation of the stored states (LCI: in navigation steps of two samples; NED: in
        samples).
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
    t0 : float, optional
        Time of the first sample. LCI: after launch (Earth rotation angle ω t0; default 0);
        with ``sample0``, the times are taken on the grid ``t0 − sample0 dt + dt j`` of the
        global sample indices j (a piece of a flight at ``t0 = sample0 dt`` has the whole
        record's times). NED: for ``t`` only (the mechanization does not depend on it; default
        ``sample0 dt``). Units: s.
    baro : Baro, optional
        NED only: altitude aiding of the vertical channel (default: free inertial).
    """

    gravity: Any = "j4"
    sh_model: Any = None
    ellipsoid: Any = None
    imu_set: Any = None
    errors: dict | None = None
    output_every: int = 1
    sample0: int = 0
    gravity_every: int = 1
    gravity_hold: Any = None
    t0: float | None = None
    baro: Baro | None = None


@dataclass(frozen=True)
class LciStart:
    """Start state of :func:`propagate_lci`: a-frame ``P`` (m), inertial ``V`` (m/s), ``q`` q_b^a.

    Each (3,) / (4,) for all trajectories or (n_traj, 3) / (n_traj, 4), q scalar first, in
    the a-frame ``launch``: a :class:`LaunchFrame`, or ``(lon0, B0, A0[, h0])`` in degrees
    (h0 in m).
    """

    P: Any
    V: Any
    q: Any
    launch: Any


@dataclass(frozen=True)
class NedStart:
    """Start state of :func:`propagate_ned`: geodetic position, NED velocity, attitude q_b^n.

    ``lat``, ``lon`` (degrees; radians with ``degrees=False``, e.g. ``final["llh"]`` of the
    previous piece of a flight: no degree round trip, the pieces give the bits of one
    propagation), ``h`` (m): floats or (n_traj,); ``v_ned`` (3,) or (n_traj, 3) m/s; ``q``
    (4,) or (n_traj, 4), scalar first.
    """

    lat: Any
    lon: Any
    h: Any
    v_ned: Any
    q: Any
    degrees: bool = True


def propagate_lci(
    dtheta: npt.ArrayLike,
    dv: npt.ArrayLike,
    dt: float,
    start: LciStart,
    config: NavConfig | None = None,
    *,
    device: str | None = None,
) -> LciResult:
    """Propagate many trajectories in the launch-centred inertial frame (eqs. 14-15, 20).

    Parameters
    ----------
    dtheta, dv : array_like, shape (n_samples, 3) or (n_sets, n_samples, 3)
        Gyro and accelerometer increments per IMU sample, body frame; n_samples even (two
        samples per navigation step). Units: rad, m/s.
    dt : float
        IMU sample interval; the navigation step is T = 2 dt. Units: s.
    start : LciStart
        Initial a-frame position, inertial velocity and attitude q_b^a, and the a-frame.
    config : NavConfig, optional
        Navigation gravity, sensor errors, decimation, continuation (default ``NavConfig()``:
        J4, no errors, every step).
    device : str, optional
        Warp device (default: CUDA if present, else CPU using every core).

    Returns
    -------
    LciResult
    """
    if not isinstance(start, LciStart):
        raise TypeError(f"start must be an LciStart, got {type(start).__name__}")
    launch = start.launch
    cfg = NavConfig() if config is None else config
    ellipsoid = cfg.ellipsoid
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
    b = _prepare_batch(
        dtheta,
        dv,
        dt,
        {"P0": (start.P, (3,)), "V0": (start.V, (3,)), "q0": (start.q, (4,))},
        cfg,
        device,
        per_step=2,
    )
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import strapdown as ksd

    st = b.states
    # the kernel's time origin is global sample 0: t0 − sample0 dt (0 exactly when t0 =
    # sample0 dt, as for the blocks of a flight: the times of one grid whatever the blocking)
    t_base = float(0.0 if cfg.t0 is None else cfg.t0) - b.dt * b.sample0
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


@dataclass(frozen=True)
class NedResult:
    """Output of :func:`propagate_ned` (every ``output_every``-th sample, initial state first).

    ``t`` (n_out,) s, on the time base of :class:`fieldmap.nav.mechanize.LciResult` (the time of
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
    bias: npt.ArrayLike = 0.0
    noise: npt.ArrayLike = 0.0
    gm_sigma: npt.ArrayLike = 0.0
    gm_tau: npt.ArrayLike = 0.0
    state: npt.ArrayLike | None = None


def baro_gains(tau: float = 100.0, ellipsoid: Ellipsoid = WGS84) -> tuple[float, float, float]:
    r"""Gains of the third-order baro loop with a triple pole at s = −1/τ.

    The height error of the loop obeys s³ + k1 s² + (k2 − 2g/R) s + k3 = 0 (the 2g/R term is
    the vertical-channel instability, Titterton & Weston 2004 §5.3); matching (s + 1/τ)³ gives

    .. math:: k_1 = 3/\tau,\quad k_2 = 3/\tau^2 + 2 g/R,\quad k_3 = 1/\tau^3.

    Units: τ s; returns 1/s, 1/s², 1/s³.
    """
    if not np.isfinite(tau) or tau <= 0:
        raise InputError(f"baro loop time constant must be positive, got {tau}")
    g_over_r = STANDARD_GRAVITY / ellipsoid.a
    return 3.0 / tau, 3.0 / tau**2 + 2.0 * g_over_r, 1.0 / tau**3


def propagate_ned(
    dtheta: npt.ArrayLike,
    dv: npt.ArrayLike,
    dt: float,
    start: NedStart,
    config: NavConfig | None = None,
    *,
    device: str | None = None,
) -> NedResult:
    """Propagate many trajectories with the Earth-relative NED mechanization.

    One update per IMU sample (see ``fieldmap.kernels.strapdown.ned_kernel``): specific force
    with the rotation correction of :func:`fieldmap.nav.frames.calc_force_ned`, Coriolis and
    transport rate, navigation gravity plus centrifugal (Groves eq. 3.7.5), trapezoidal position.

    Parameters
    ----------
    dtheta, dv : array_like, shape (n_samples, 3) or (n_sets, n_samples, 3)
        Body-frame increments. Units: rad, m/s.
    dt : float
        Sample interval. Units: s.
    start : NedStart
        Initial geodetic position, Earth-relative NED velocity and attitude q_b^n.
    config : NavConfig, optional
        Navigation gravity, sensor errors, baro aiding, decimation, continuation (default
        ``NavConfig()``: J4, free inertial, no errors, every sample). Its ``sample0`` keys the
        IMU and baro noise of sample j on (seed, ``sample0`` + j), as in :func:`propagate_lci`.
    device : str, optional
        Warp device (default: CUDA if present, else CPU using every core).

    Returns
    -------
    NedResult
    """
    if not isinstance(start, NedStart):
        raise TypeError(f"start must be a NedStart, got {type(start).__name__}")
    cfg = NavConfig() if config is None else config
    degrees = start.degrees
    ellipsoid = WGS84 if cfg.ellipsoid is None else cfg.ellipsoid
    pos = (start.lat, start.lon, start.h)
    llh = np.stack(np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in pos)), -1)
    lat_deg = llh[..., 0] if degrees else np.degrees(llh[..., 0])
    if llh.size and np.any(np.abs(lat_deg) >= 89.0):
        raise InputError("the NED mechanization is not valid within 1 degree of the poles")
    b = _prepare_batch(
        dtheta,
        dv,
        dt,
        {"llh0": (llh, (3,)), "v_ned0": (start.v_ned, (3,)), "q0": (start.q, (4,))},
        cfg,
        device,
        per_step=1,
    )
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import strapdown as ksd

    st = b.states
    llh_rad = st["llh0"].copy()
    if degrees:
        llh_rad[:, :2] = np.radians(llh_rad[:, :2])
    aid = _baro_struct(cfg.baro, b, ksd)
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
        t=(0.0 if cfg.t0 is None else float(cfg.t0) - b.dt * b.sample0)
        + b.dt * (b.sample0 + b.output_every * np.arange(b.n_out)),
        lat=np.degrees(L[..., 0]),
        lon=np.degrees(L[..., 1]),
        h=L[..., 2],
        v_ned=v,
        q=q,
        gravity=tuple(b.names),
        final=final,
    )


def _baro_struct(baro: Baro | None, b: _Batch, ksd: ModuleType) -> BaroAiding:
    """Device struct of the baro loop (disabled with placeholder arrays when ``baro`` is None)."""
    import warp as wp

    dev, n = b.device, b.n
    aid = ksd.BaroAiding()

    def arr(a: np.ndarray, t: type = wp.float64) -> wp.array:
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
        val = _per_trajectory(f"baro {key}", getattr(baro, key), n, ())
        if key != "bias" and np.any(val < 0):
            raise InputError(f"baro {key} must be >= 0")
        setattr(aid, key, arr(val))
    state = np.zeros((n, 3)) if baro.state is None else baro.state
    aid.state = arr(_per_trajectory("baro state", state, n, (3,)), wp.vec3d)
    return aid
