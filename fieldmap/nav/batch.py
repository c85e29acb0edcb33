"""Validation and upload of a batch of trajectories, shared by the LCI and NED mechanizations.

:func:`prepare_batch` checks the IMU increments, initial states, navigation gravity names and
sensor errors of many trajectories and uploads them to a Warp device as a ``_Batch``,
whose ``launch`` runs :func:`fieldmap.nav.strapdown.propagate_lci`'s or
:func:`fieldmap.nav.strapdown_ned.propagate_ned`'s kernel. Quaternions are scalar-first
``[w, x, y, z]`` here and ``(x, y, z, w)`` on the device.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import warp as wp

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84
from fieldmap.nav.navgravity import gravity_names, parse_gravity, table_file


def _finite(name, a, shape_tail=None) -> np.ndarray:
    try:
        a = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be numeric") from None
    if shape_tail and a.shape[-len(shape_tail) :] != shape_tail:
        raise InputError(f"{name} must have trailing shape {shape_tail}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains non-finite values")
    return a


def per_trajectory(name, a, n, tail) -> np.ndarray:
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


def _dummy_sh(device: str):
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
    def sensor_errors(self):
        """Uploaded :class:`fieldmap.kernels.strapdown.SensorErrors` (final GM states after use)."""
        return self.inputs[3]

    def launch(self, kernel, start, params: list, times=()) -> tuple:
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


def prepare_batch(
    dtheta, dv, dt, states, gravity, sh_model, imu_set, errors, output_every, device, per_step,
    sample0=0, gravity_every=1, gravity_hold=None,
):  # fmt: skip
    """Validate and upload everything the LCI and NED kernels share (one row per trajectory).

    Used by :func:`fieldmap.nav.strapdown.propagate_lci` and
    :func:`fieldmap.nav.strapdown_ned.propagate_ned`; ``sample0`` is the global index of the first
    sample (see :func:`~fieldmap.nav.strapdown.propagate_lci`).
    """
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
    names = gravity_names([gravity] if isinstance(gravity, str) else list(gravity), 5)
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
    states = {k: per_trajectory(k, a, n, tail) for k, (a, tail) in states.items()}
    device = _warp.resolve_device(device)
    from fieldmap.kernels import strapdown as ksd

    arr = lambda a, dtype: wp.array(a, dtype=dtype, device=device)  # noqa: E731
    se = ksd.SensorErrors()
    types = {(3,): wp.vec3d, (3, 3): wp.mat33d, (): wp.float64}
    has_errors = False
    for key, tail in _ERROR_KEYS.items():
        if key == "seed":
            seed = per_trajectory("seed", err.get("seed", np.arange(n)), n, ()).astype(np.int32)
            se.seed = arr(seed, wp.int32)
        else:
            a = per_trajectory(key, err.get(key, _ERROR_DEFAULTS[key]), n, tail)
            has_errors = has_errors or bool(np.any(a != _ERROR_DEFAULTS[key]))
            setattr(se, key, arr(a, types[tail]))
    sh_lmax = int(kl[:, 1].max())
    if sh_lmax > 0:
        from fieldmap.field.sh import kernel_model

        shk = kernel_model(sh_model, device, sh_lmax)
    else:
        shk = _dummy_sh(device)
    tables = sorted({f for f in (table_file(g) for g in names) if f is not None})
    if len(tables) > 1:
        raise InputError(
            f"one compensation table per launch, got {len(tables)}: {', '.join(tables)}"
        )
    from fieldmap.nav.tablegravity import kernel_table

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
    hold = per_trajectory("gravity_hold", hold, n, (3, 3))
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


def _sample_index(sample0, n_samples: int) -> int:
    """Check the global index of a record's first sample: an integer, >= 0, the record in int32."""
    if isinstance(sample0, (bool, np.bool_)) or not isinstance(sample0, (int, np.integer)):
        raise InputError(f"sample0 must be an integer sample index, got {sample0!r}")
    sample0 = int(sample0)
    if sample0 < 0 or sample0 + n_samples > 2**31 - 1:
        raise InputError(
            f"sample0 must lie in 0..{2**31 - 1 - n_samples} for {n_samples} samples, got {sample0}"
        )
    return sample0


def _quat_in(q0) -> np.ndarray:
    """Scalar-first unit quaternions -> the kernels' (x, y, z, w), normalized.

    One that is unit to rounding (a kernel's output) is taken as is, so that a propagation
    continued from the previous one's final attitude gives the bits of one propagation.
    """
    norms = np.linalg.norm(q0, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-6):
        raise InputError("q0 must be unit quaternions")
    norms = np.where(np.abs(norms - 1.0) <= 4 * np.finfo(np.float64).eps, 1.0, norms)
    return np.ascontiguousarray(np.concatenate([q0[:, 1:], q0[:, :1]], axis=1) / norms[:, None])


def _quat_out(q) -> np.ndarray:
    q = q.numpy()
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)
