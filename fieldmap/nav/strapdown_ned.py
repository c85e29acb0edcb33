"""Batched Earth-relative NED strapdown propagation on Warp devices (host API).

The local-level mechanization of Groves (2013) ch. 5 and NavToolKit; the kernel is
``fieldmap.kernels.strapdown.ned_kernel``. Quaternions are scalar-first ``q_b^n``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.nav.strapdown import _prepare


@dataclass(frozen=True)
class NedResult:
    """Output of :func:`propagate_ned` (every ``output_every``-th sample, initial state first).

    ``t`` (n_out,) s; ``lat``, ``lon`` (n_traj, n_out) degrees; ``h`` (n_traj, n_out) m;
    ``v_ned`` (n_traj, n_out, 3) m/s; ``q`` (n_traj, n_out, 4) scalar-first q_b^n.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    v_ned: np.ndarray
    q: np.ndarray
    gravity: tuple


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
        Initial geodetic position. Units: degrees, degrees, m.
    v_ned0 : array_like, shape (3,) or (n_traj, 3)
        Initial Earth-relative velocity in NED. Units: m/s.
    q0 : array_like, shape (4,) or (n_traj, 4)
        Initial q_b^n, scalar first.
    gravity, sh_model, ellipsoid, imu_set, errors, output_every, device
        As in :func:`fieldmap.nav.strapdown.propagate_lci`.

    Returns
    -------
    NedResult
    """
    llh = np.stack(
        np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (lat0, lon0, h0))), -1
    )
    if llh.size and np.any(np.abs(llh[..., 0]) >= 89.0):
        raise InputError("the NED mechanization is not valid within 1 degree of the poles")
    b = _prepare(
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
    )
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import strapdown as ksd

    st = b.states
    llh_rad = st["llh0"].copy()
    llh_rad[:, :2] = np.radians(llh_rad[:, :2])
    L, v, q = b.launch(
        ksd.ned_kernel, (llh_rad, st["v_ned0"], st["q0"]), [normal_params(get_ellipsoid(ellipsoid))]
    )
    return NedResult(
        t=b.dt * b.output_every * np.arange(b.n_out),
        lat=np.degrees(L[..., 0]),
        lon=np.degrees(L[..., 1]),
        h=L[..., 2],
        v_ned=v,
        q=q,
        gravity=tuple(b.names),
    )
