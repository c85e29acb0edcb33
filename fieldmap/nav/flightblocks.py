"""One time block of every run of a flight study, here or on a Dask cluster.

:func:`fieldmap.nav.flightsim.run_flight` synthesises a block's exact IMU increments once and
hands them, with the per-run start states, to :func:`propagate_block` (NED or LCI
mechanization for every run), or, within :func:`blocks_propagated_by`, to another propagator:
:func:`fieldmap.nav.distributed.flight_block_on` splits the runs over Dask workers.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator

import numpy as np

from fieldmap.nav.strapdown import dcm_to_quat, quat_to_dcm

__all__ = [
    "PER_RUN_ARGS",
    "block_propagator",
    "blocks_propagated_by",
    "initial_state",
    "propagate_block",
]


def initial_state(traj, frame, lat0, lon0, h0, v0, C0, n) -> dict:
    """Start state of ``n`` runs at the truth's first epoch (NED: llh (rad), v, q; LCI: P, V, q)."""
    st: dict = {"acc_gm": None, "gyro_gm": None}
    if frame == "ned":
        st.update(
            llh=np.tile([np.radians(lat0[0]), np.radians(lon0[0]), h0[0]], (n, 1)),  # rad, m
            v=np.tile(v0[0], (n, 1)),
            q=np.tile(dcm_to_quat(C0[0]), (n, 1)),
        )
    else:
        k = traj.kinematics([0.0])
        st.update(
            P=np.tile(k.P_a[0], (n, 1)),
            V=np.tile(k.V_a[0], (n, 1)),
            q=np.tile(dcm_to_quat(k.C_b_to_a[0]), (n, 1)),
        )
    return st


#: Who propagates a time block of the flight study (None: here; see blocks_propagated_by).
_BLOCK_PROPAGATOR: contextvars.ContextVar = contextvars.ContextVar(
    "fieldmap_flight_block_propagator", default=None
)


def block_propagator():
    """Return the function that propagates a time block now (:func:`propagate_block` here)."""
    return _BLOCK_PROPAGATOR.get() or propagate_block


@contextlib.contextmanager
def blocks_propagated_by(fn) -> Iterator[None]:
    """Within the block, :func:`fieldmap.nav.flightsim.run_flight` hands each time block to ``fn``.

    ``fn`` takes the arguments of :func:`propagate_block` and returns its result;
    :func:`fieldmap.nav.distributed.on_cluster` uses it to split the runs of every time block
    over Dask workers (each run depends on no other run: the same bits). ``fn=None``: here.
    """
    token = _BLOCK_PROPAGATOR.set(fn)
    try:
        yield
    finally:
        _BLOCK_PROPAGATOR.reset(token)


#: Arguments of propagate_block that hold one row per run (split by run groups on a cluster).
PER_RUN_ARGS = ("state", "grav", "imu_set", "kerr", "baro_bias", "baro_state")


def propagate_block(
    traj, frame, sets, tb, nb, dt, every, state, grav, model, imu_set, kerr, aiding, baro,
    baro_bias, baro_state, rate_hz, device, sample0=0,
):  # fmt: skip
    """Propagate one time block of every run; return the stored states and the next start state.

    ``state``, ``kerr`` (dicts of per-run arrays), ``grav``, ``imu_set``, ``baro_bias`` and
    ``baro_state`` hold one row per run (:data:`PER_RUN_ARGS`); ``sets`` are the exact IMU
    increments of the block (truth, reference), shared by all runs. ``sample0`` is the global
    index of the block's first IMU sample (``tb = sample0 dt``): the sensor and baro noise of
    every sample is keyed on (run seed, global index), the same whatever the blocking.
    """
    dth = np.stack([s.dtheta for s in sets])
    dv = np.stack([s.dv for s in sets])
    n = len(grav)
    if frame == "ned":
        from fieldmap.nav.strapdown_ned import Baro, baro_gains, propagate_ned

        aid = None
        if aiding == "baro":
            # the times of the whole record's grid (tb + dt k rounds differently per blocking)
            _, _, h_ref = traj.geodetic(dt * np.arange(sample0, sample0 + nb))
            k1, k2, k3 = baro_gains(baro.loop_tau_s, traj.frame.ellipsoid)
            noise = baro.noise_m * np.sqrt(rate_hz / baro.rate_hz)
            aid = Baro(
                np.stack([h_ref, h_ref]), k1, k2, k3, bias=baro_bias, noise=noise,
                gm_sigma=baro.drift_m, gm_tau=baro.drift_tau_s, state=baro_state,
            )  # fmt: skip
        res = propagate_ned(
            dth, dv, dt, state["llh"][:, 0], state["llh"][:, 1], state["llh"][:, 2], state["v"],
            state["q"], grav, sh_model=model, ellipsoid=traj.frame.ellipsoid, imu_set=imu_set,
            errors=kerr, output_every=every, device=device, baro=aid, sample0=sample0,
            degrees=False,
        )  # fmt: skip
        C = quat_to_dcm(res.q)
        nxt = {
            "llh": res.final["llh"],
            "v": res.v_ned[:, -1],
            "q": res.q[:, -1],
            "acc_gm": res.final["acc_gm"],
            "gyro_gm": res.final["gyro_gm"],
            "baro": res.final["baro"],
        }
        return {"lat": res.lat, "lon": res.lon, "h": res.h, "v": res.v_ned, "C": C}, nxt
    from fieldmap.field.frames import ecef_to_geodetic
    from fieldmap.nav.flight import _C_n_to_e
    from fieldmap.nav.strapdown import propagate_lci

    fr = traj.frame
    res = propagate_lci(
        dth, dv, dt, state["P"], state["V"], state["q"], fr, grav, sh_model=model,
        imu_set=imu_set, errors=kerr, t0=tb, output_every=every // 2, device=device,
        sample0=sample0,
    )  # fmt: skip
    t = res.t
    r_e, v_in = fr.a_state_to_ecef(res.P.reshape(-1, 3), res.V.reshape(-1, 3), np.tile(t, n))
    lat, lon, h = ecef_to_geodetic(r_e[:, 0], r_e[:, 1], r_e[:, 2], fr.ellipsoid)
    v_e = v_in - np.cross([0.0, 0.0, fr.omega], r_e)
    C_n_e = _C_n_to_e(lat, lon)
    v_ned = np.einsum("nji,nj->ni", C_n_e, v_e)
    C_b_a = quat_to_dcm(res.q).reshape(-1, 3, 3)
    C_a_e = np.swapaxes(fr.C_e_to_a(np.tile(t, n)), -1, -2)
    C_b_n = np.swapaxes(C_n_e, -1, -2) @ C_a_e @ C_b_a
    shp = (n, t.size)
    nxt = {
        "P": res.P[:, -1],
        "V": res.V[:, -1],
        "q": res.q[:, -1],
        "acc_gm": res.final["acc_gm"],
        "gyro_gm": res.final["gyro_gm"],
    }
    out = {
        "lat": lat.reshape(shp),
        "lon": lon.reshape(shp),
        "h": h.reshape(shp),
        "v": v_ned.reshape(shp + (3,)),
        "C": C_b_n.reshape(shp + (3, 3)),
    }
    return out, nxt
