"""Flight studies' start state and stored states in geodetic terms.

:func:`fieldmap.nav.flightsim.run_flight` starts a :class:`fieldmap.nav.propagator.Propagator`
from :func:`initial_state` (the truth at t = 0) and turns each block's stored states into
latitude, longitude, height, NED velocity and attitude with :func:`geodetic_outputs`.
"""

from __future__ import annotations

import numpy as np

from fieldmap.nav.strapdown import dcm_to_quat, quat_to_dcm

__all__ = ["geodetic_outputs", "initial_state"]


def initial_state(traj, frame, lat0, lon0, h0, v0, C0, n) -> dict:
    """Start state of ``n`` runs at the truth's first epoch (NED: llh (rad), v, q; LCI: P, V, q)."""
    st: dict = {}
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


def geodetic_outputs(launch, out: dict) -> dict:
    """Turn the stored states of :meth:`~fieldmap.nav.propagator.Propagator.propagate` into NED.

    Returns ``lat``, ``lon`` (degrees), ``h`` (m), ``v`` (NED, m/s) and ``C`` (C_b^n), one row
    per run; LCI states are carried from the a-frame (``launch``) to the Earth.
    """
    if "llh" not in out and "lat" in out:
        return {
            "lat": out["lat"], "lon": out["lon"], "h": out["h"], "v": out["v"],
            "C": quat_to_dcm(out["q"]),
        }  # fmt: skip
    from fieldmap.field.frames import ecef_to_geodetic
    from fieldmap.nav.flight import _C_n_to_e

    fr = launch
    t = out["t"]
    n = out["P"].shape[0]
    r_e, v_in = fr.a_state_to_ecef(out["P"].reshape(-1, 3), out["V"].reshape(-1, 3), np.tile(t, n))
    lat, lon, h = ecef_to_geodetic(r_e[:, 0], r_e[:, 1], r_e[:, 2], fr.ellipsoid)
    v_e = v_in - np.cross([0.0, 0.0, fr.omega], r_e)
    C_n_e = _C_n_to_e(lat, lon)
    v_ned = np.einsum("nji,nj->ni", C_n_e, v_e)
    C_b_a = quat_to_dcm(out["q"]).reshape(-1, 3, 3)
    C_a_e = np.swapaxes(fr.C_e_to_a(np.tile(t, n)), -1, -2)
    C_b_n = np.swapaxes(C_n_e, -1, -2) @ C_a_e @ C_b_a
    shp = (n, t.size)
    return {
        "lat": lat.reshape(shp),
        "lon": lon.reshape(shp),
        "h": h.reshape(shp),
        "v": v_ned.reshape(shp + (3,)),
        "C": C_b_n.reshape(shp + (3, 3)),
    }
