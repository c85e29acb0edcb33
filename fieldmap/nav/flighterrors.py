r"""Errors of a flight study: NED error vectors, the first-order prediction, the recommendation.

The reductions behind :func:`fieldmap.nav.flightsim.run_flight`: :func:`ned_errors` turns the
navigated states into north, east, down position, NED velocity and small-angle attitude errors
against the truth; :func:`gravity_error_along` gives each navigation model's gravity error along
the track and its double time integral (the first-order prediction of the horizontal error);
:func:`summarize` writes the JSON document with the final-error statistics and the recommended
model (the simplest, in :func:`simplicity_order`, whose added error stays small).
"""

from __future__ import annotations

import numpy as np

from fieldmap.nav.imu import Gravitation
from fieldmap.nav.navgravity import NORMAL_MODELS, sh_degree, table_file
from fieldmap.nav.propagator import final_stats


def simplicity_order(models) -> list[str]:
    """Models from the simplest to the most complete: j2, j4, j6, exact, tables, shN, sh.

    A compensation table (a look-up a flight computer interpolates) counts as simpler than
    real-time spherical harmonics; tables among themselves keep their order.
    """

    def key(m):
        if m in NORMAL_MODELS:
            return (0, NORMAL_MODELS.index(m))
        if table_file(m) is not None:
            return (1, 0)
        d = sh_degree(m)
        return (2, 10**9 if d is None else d)

    return sorted(models, key=key)


def ned_errors(lat, lon, h, v, C, truth, ell):
    """NED position, velocity and small-angle attitude errors against the truth tuple."""
    tl, tn, th, tv, tC = truth
    la = np.radians(tl)
    s = np.sin(la)
    w = 1.0 - ell.e2 * s * s
    R_E = ell.a / np.sqrt(w)
    R_N = ell.a * (1.0 - ell.e2) / w**1.5
    dlon = (lon - tn + 180.0) % 360.0 - 180.0
    dpos = np.stack(
        [
            np.radians(lat - tl) * (R_N + th),
            np.radians(dlon) * (R_E + th) * np.cos(la),
            -(h - th),
        ],
        -1,
    )
    dvel = v - tv
    E = C @ np.swapaxes(tC, -1, -2)  # ≈ I − [ψ×]
    datt = 0.5 * np.stack(
        [E[..., 2, 1] - E[..., 1, 2], E[..., 0, 2] - E[..., 2, 0], E[..., 1, 0] - E[..., 0, 1]], -1
    )
    return dpos, dvel, -datt


def gravity_error_along(track, t, names, model, ell, device=None):
    """δg = g_model − g_truth (NED, m/s²) at the track points and its double time integral.

    Returns two dicts keyed by model: δg (n, 3) and the predicted north/east position error
    (n, 2) in m (cumulative trapezoid twice, zero at t[0]).
    """
    from scipy.integrate import cumulative_trapezoid

    from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
    from fieldmap.nav.scenario import NORMAL_KINDS

    r = np.stack(geodetic_to_ecef(track[:, 0], track[:, 1], track[:, 2], ell), -1)
    enu = C_e_to_enu(track[:, 0], track[:, 1])
    to_ned = lambda g: np.einsum("nij,nj->ni", enu, g)[:, [1, 0, 2]] * [1, 1, -1]  # noqa: E731
    g_true = to_ned(Gravitation("sh", model=model, device=device, ellipsoid=ell)(r))
    dg, pred = {}, {}
    for m in names:
        if table_file(m) is not None:
            from fieldmap.nav.tablegravity import table_gravitation
            from fieldmap.products.tables.model import load_table

            tab = load_table(table_file(m))
            g_nav = table_gravitation(tab, *r.T, ellipsoid=ell, device=device)
        elif m in NORMAL_KINDS:
            g_nav = Gravitation(NORMAL_KINDS[m], device=device, ellipsoid=ell)(r)
        else:
            from fieldmap.nav.navgravity import parse_gravity

            lmax = parse_gravity(m, model)[1]
            g_nav = Gravitation("sh", model=model, lmax=lmax, device=device, ellipsoid=ell)(r)
        dg[m] = to_ned(g_nav) - g_true
        v = cumulative_trapezoid(dg[m][:, :2], t, axis=0, initial=0.0)
        pred[m] = cumulative_trapezoid(v, t, axis=0, initial=0.0)
    return dg, pred


#: most track points at which the truth's commission σ is evaluated (linear in time between)
SIGMA_POINTS = 2000


def truth_sigma_along(track, t, model, ell):
    """Commission σ of the truth's gravity along the track, NED (n, 3) in m/s², or None.

    From the truth model's coefficient σ (:func:`fieldmap.field.commission.commission_sigma`,
    diagonal propagation); None for a model without σ. At most :data:`SIGMA_POINTS` points
    are evaluated, evenly spaced in the output index, and interpolated linearly in time
    between them (σ varies on the scale of the model's shortest wavelength, tens of km).
    """
    if model.sigma_c is None or model.sigma_s is None:
        return None
    from fieldmap.field.commission import MGAL, commission_sigma

    n = len(t)
    idx = np.unique(np.linspace(0, n - 1, min(n, SIGMA_POINTS)).round().astype(int))
    s = commission_sigma(
        track[idx, 0], track[idx, 1], track[idx, 2], model=model, quantity="disturbance",
        ellipsoid=ell,
    )  # fmt: skip
    ned = s[:, [1, 0, 2]] / MGAL  # east, north, up -> north, east, down (σ has no sign)
    if idx.size == n:
        return ned
    return np.stack([np.interp(t, t[idx], ned[:, k]) for k in range(3)], axis=-1)


def summarize(dpos, dvel, run_models, rows, n_draws, fraction, diverged, meta) -> dict:
    """Build the JSON document: final-error statistics per row, added errors, recommendation."""
    run_models = np.array(run_models)
    fin = dpos[:, -1]
    doc = {"meta": meta, "models": {}, "fraction": fraction}
    ref = fin[run_models == "imu_only"]
    imu_h = float(np.sqrt(np.mean(np.sum(ref[:, :2] ** 2, -1))))
    bad_models = {d["model"] for d in diverged}
    for r in rows:
        sel = run_models == r
        f = fin[sel]
        entry = {
            "final_position_error_m": final_stats(np.linalg.norm(f, axis=-1)),
            "final_horizontal_error_m": final_stats(np.hypot(f[:, 0], f[:, 1])),
            "final_vertical_error_m": final_stats(np.abs(f[:, 2])),
            "final_north_error_m": final_stats(f[:, 0]),
            "final_east_error_m": final_stats(f[:, 1]),
            "final_down_error_m": final_stats(f[:, 2]),
            "final_velocity_error_m_s": final_stats(np.linalg.norm(dvel[sel, -1], axis=-1)),
            "diverged": r in bad_models,
        }
        if r != "imu_only":
            d = f - ref  # same draws, same order
            entry["added_horizontal_error_m"] = float(np.sqrt(np.mean(np.sum(d[:, :2] ** 2, -1))))
            entry["added_vertical_error_m"] = float(np.sqrt(np.mean(d[:, 2] ** 2)))
        doc["models"][r] = entry
    doc["imu_only_horizontal_error_m"] = imu_h
    order = simplicity_order([r for r in rows if r != "imu_only"])
    ok = [
        m for m in order
        if not doc["models"][m]["diverged"]
        and doc["models"][m]["added_horizontal_error_m"] <= fraction * imu_h
    ]  # fmt: skip
    if ok:
        doc["recommended_model"] = ok[0]
        doc["recommendation"] = (
            f"{ok[0]}: adds {doc['models'][ok[0]]['added_horizontal_error_m']:.3g} m horizontal "
            f"error, below {fraction:.0%} of the IMU-only {imu_h:.3g} m"
        )
    else:
        best = min(order, key=lambda m: doc["models"][m]["added_horizontal_error_m"])
        doc["recommended_model"] = None
        doc["recommendation"] = (
            f"no model stays below {fraction:.0%} of the IMU-only error ({imu_h:.3g} m); the "
            f"smallest added error is {best}'s "
            f"({doc['models'][best]['added_horizontal_error_m']:.3g} m)"
        )
    doc["diverged"] = list(diverged)
    return doc
