"""The report of a conditioned flight: flown kinematics, a JSON-ready summary, text and a figure.

The kinematics are those of the path :class:`~fieldmap.nav.trajectory.FlightTrajectory` will fly:
the quintic interpolating spline (``make_interp_spline``, k = 5) of the conditioned samples in
ECEF, evaluated at the samples and half-way between them. Acceleration and jerk are relative to
the Earth (derivatives of the ECEF path, gravity not included); the specific force (what an
accelerometer senses, in g) is ``a + 2 Ω × v − γ`` with normal gravity ``γ`` along the ellipsoidal
normal (Somigliana, Heiskanen & Moritz 1967 eqs. 2-78, 2-124); the turn rate is the rate of the
track angle, ``(v_N a_E − v_E a_N) / v_H²``, where the ground speed exceeds 10 m/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import PurePath
from typing import TYPE_CHECKING, Any

import numpy as np

from fieldmap.errors import Advice, Message, Metavar, Pass
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
from fieldmap.nav.logs.vehicles import GROUND_CHANNEL, SURFACE_WIND_MAX
from fieldmap.nav.trajectory import FlightSamples
from fieldmap.units import STANDARD_GRAVITY as G0

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: a sample's fate: the codes of ``ConditionedFlight.raw["status"]``
KEPT, OUTLIER_H, OUTLIER_V, OUTLIER_HV, NOT_MEASURED, TRIMMED = range(6)
STATUS_NAMES = ("kept", "outlier_h", "outlier_v", "outlier_hv", "not_measured", "trimmed")

#: faults shown in the text report
N_WORST = 8
METHOD = (
    "Singer manoeuvre model per axis (white jerk, vehicle-class bounds), robust smoother over "
    "the whole log (banded normal equations = RTS smoother; EM weights of an inlier/fault "
    "mixture), noise levels by marginal likelihood"
)


@dataclass(frozen=True)
class ConditionedFlight:
    """Result of :func:`~fieldmap.nav.logs.condition.condition`.

    Attributes
    ----------
    samples : FlightSamples
        The smooth path on a regular grid, times from 0 (``t_start`` the first, in the track's
        time scale); what :class:`~fieldmap.nav.trajectory.FlightTrajectory` takes.
    report : dict
        JSON-ready summary (:func:`build_report`): ``samples``, ``order``, ``vehicle`` (class,
        how chosen, evidence), ``model`` (the motion model's noise levels), ``channels`` (each
        measurement channel: noise σ, its search bounds and the one it stopped at, if any,
        fault rate, residual RMS and largest, rejected samples),
        ``fit`` (the horizontal and vertical noise and residuals in one place), ``faults``
        (every run of rejected samples, with lines and what it is), ``gaps`` (longer than
        ``max_gap_s``, with the path's σ), ``ground``, ``kinematics`` (:func:`kinematics`),
        ``velocity`` (the flown path against the log's velocities), ``options``, ``notes``.
    raw : dict
        The ordered raw samples (``t`` relative to ``samples.t_start``, ``lat``, ``lon``, ``h``,
        ``lines``; ``h`` and ``offset_v`` NaN at a sample without a height of its own), each
        one's ``status`` (codes :data:`STATUS_NAMES`) and distances from the flown path
        (``offset_h``, ``offset_v``, m; NaN on a frozen end's rows, where no path is flown)
        for :func:`plot_conditioning`.
    conditioned : Conditioned
        The typed result the report is built from
        (:class:`~fieldmap.nav.logs.condition.Conditioned`).
    """

    samples: FlightSamples
    report: dict
    raw: dict = field(repr=False)
    conditioned: Any = field(default=None, repr=False)

    def format_report(self) -> str:
        """Return the report as text (see :func:`format_report`)."""
        return format_report(self.report)


def _normal_gravity(lat_deg: np.ndarray, h: np.ndarray, ell: Ellipsoid) -> np.ndarray:
    """Compute normal gravity (m/s²) at geodetic latitude and height (2nd order in h/a)."""
    phi = np.radians(lat_deg)
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    a, b = ell.a, ell.b
    g0 = (a * ell.gamma_a * c2 + b * ell.gamma_b * s2) / np.sqrt(a * a * c2 + b * b * s2)
    return g0 * (1.0 - 2.0 * h / a * (1.0 + ell.f + ell.m - 2.0 * ell.f * s2) + 3.0 * (h / a) ** 2)


def flown_velocity(
    samples: FlightSamples, t: np.ndarray, ellipsoid: Ellipsoid = WGS84
) -> np.ndarray:
    """Return the east, north, up velocity (m/s) of the flown path at times ``t``, (m, 3).

    The path is the quintic through ``samples``; ``t`` in the samples' time scale (s).
    """
    from scipy.interpolate import make_interp_spline

    s = samples
    r = np.stack(geodetic_to_ecef(s.lat, s.lon, s.h, ellipsoid), -1)
    v = make_interp_spline(s.t, r, k=5)(t, 1)
    C = C_e_to_enu(np.interp(t, s.t, s.lat), np.interp(t, s.t, s.lon))
    return np.einsum("nij,nj->ni", C, v)


def kinematics(samples: FlightSamples, ellipsoid: Ellipsoid = WGS84) -> dict:
    """Peaks of the path a :class:`FlightTrajectory` interpolates through ``samples``.

    Returns a dict: ``duration_s``, ``max_speed_m_s``, ``max_ground_speed_m_s`` (horizontal),
    ``peak_acceleration_g`` (and its
    ``peak_acceleration_t_s``, ``peak_acceleration_line``), ``peak_specific_force_g``,
    ``min_specific_force_g``, ``peak_jerk_m_s3``, ``peak_turn_rate_deg_s``,
    ``peak_climb_rate_m_s``, ``peak_descent_rate_m_s``.
    """
    from scipy.interpolate import make_interp_spline

    s = samples
    r = np.stack(geodetic_to_ecef(s.lat, s.lon, s.h, ellipsoid), -1)
    sp = make_interp_spline(s.t, r, k=5)
    tt = np.sort(np.concatenate([s.t, 0.5 * (s.t[1:] + s.t[:-1])]))
    v, a, j = sp(tt, 1), sp(tt, 2), sp(tt, 3)
    lat, lon, h = (np.interp(tt, s.t, x) for x in (s.lat, s.lon, s.h))
    C = C_e_to_enu(lat, lon)
    v_enu, a_enu = np.einsum("nij,nj->ni", C, v), np.einsum("nij,nj->ni", C, a)
    w = np.array([0.0, 0.0, ellipsoid.omega])
    f = a + 2.0 * np.cross(w, v) + _normal_gravity(lat, h, ellipsoid)[:, None] * C[:, 2, :]
    acc, fs = np.linalg.norm(a, axis=1), np.linalg.norm(f, axis=1)
    vh = np.hypot(v_enu[:, 0], v_enu[:, 1])
    fast = vh > 10.0
    turn = np.zeros_like(vh)
    turn[fast] = (v_enu[fast, 1] * a_enu[fast, 0] - v_enu[fast, 0] * a_enu[fast, 1]) / vh[fast] ** 2
    i = int(np.argmax(acc))
    near = int(np.clip(np.searchsorted(s.t, tt[i]), 0, s.t.size - 1))
    return {
        "duration_s": float(s.t[-1] - s.t[0]),
        "max_speed_m_s": float(np.linalg.norm(v, axis=1).max()),
        "max_ground_speed_m_s": float(np.hypot(v_enu[:, 0], v_enu[:, 1]).max()),
        "peak_acceleration_g": float(acc[i] / G0),
        "peak_acceleration_t_s": float(tt[i]),
        "peak_acceleration_line": int(s.lines[near]),
        "peak_specific_force_g": float(fs.max() / G0),
        "min_specific_force_g": float(fs.min() / G0),
        "peak_jerk_m_s3": float(np.linalg.norm(j, axis=1).max()),
        "peak_turn_rate_deg_s": float(np.degrees(np.abs(turn).max())),
        "peak_climb_rate_m_s": float(max(v_enu[:, 2].max(), 0.0)),
        "peak_descent_rate_m_s": float(max(-v_enu[:, 2].min(), 0.0)),
    }


def _stats(x: np.ndarray) -> tuple[float, float, int]:
    """RMS, largest and the index of the largest of ``x`` (0, 0, -1 when empty)."""
    if x.size == 0:
        return 0.0, 0.0, -1
    i = int(np.argmax(x))
    return float(np.sqrt(np.mean(x * x))), float(x[i]), i


def _velocity_residuals(c: Any, t0: float) -> dict[str, Any] | None:
    """Return the flown path's ground speed, track and vertical rate against the log's own."""
    m = c.measurements
    if m is None or (m.velocities is None and m.climbs is None):
        return None
    log, s = c.log, c.samples
    out: dict[str, Any] = {"columns": list(m.velocity_columns)}
    lo, hi = s.t_start, s.t_start + s.t[-1]
    for name in ("velocity", "vertical rate"):
        if name not in m.index:
            continue
        idx = m.index[name]
        inside = (log.t[idx] >= lo) & (log.t[idx] <= hi)
        idx = idx[inside]
        if idx.size == 0:
            continue
        v = flown_velocity(s, log.t[idx] - lo, c.options.ellipsoid)
        used = name in c.residuals
        rej = c.rejected[name][inside] if used else np.zeros(idx.size, bool)
        if name == "velocity":
            vel_e = m.velocities
            assert vel_e is not None
            gs_flown = np.hypot(v[:, 0], v[:, 1])
            ch = np.degrees(np.arctan2(v[:, 0], v[:, 1]))
            # the log's own values, as given
            from_track = c.velocity_log
            gs_log, tr_log = from_track[0][idx], from_track[1][idx]
            dgs = np.abs(gs_flown - gs_log)
            dtr = np.abs((ch - tr_log + 180.0) % 360.0 - 180.0)
            fast = gs_log > 10.0
            for key, x in (("groundspeed", dgs), ("track", dtr[fast])):
                unit = "deg" if key == "track" else "m_s"
                r_all, m_all, _ = _stats(x)
                keep = x[~(rej[fast] if key == "track" else rej)]
                r_in, m_in, _ = _stats(keep)
                out[f"{key}_rms_{unit}"], out[f"{key}_max_{unit}"] = r_in, m_in
                out[f"{key}_all_rms_{unit}"], out[f"{key}_all_max_{unit}"] = r_all, m_all
            out["velocity_used"] = used
            out["velocity_rejected"] = int(rej.sum())
        else:
            climb_log = c.velocity_log[2][idx]
            d = np.abs(v[:, 2] - climb_log)
            r_in, m_in, _ = _stats(d[~rej])
            r_all, m_all, _ = _stats(d)
            out["vertical_rate_rms_m_s"], out["vertical_rate_max_m_s"] = r_in, m_in
            out["vertical_rate_all_rms_m_s"], out["vertical_rate_all_max_m_s"] = r_all, m_all
            out["vertical_rate_used"] = used
            out["vertical_rate_rejected"] = int(rej.sum())
    return out


def build_report(c: Any) -> dict[str, Any]:
    """Return the JSON-ready report of a :class:`~fieldmap.nav.logs.condition.Conditioned`."""
    log, s, m, est, veh = c.log, c.samples, c.measurements, c.estimate, c.vehicle
    t0 = s.t_start
    report: dict[str, Any] = {
        "source": log.source,
        "height_ref": c.height_ref,
        "t0_utc": c.t0_utc,
        "t_start_s": float(t0),
        "method": METHOD if est is not None else "exact: the ordered samples, no smoothing",
        "options": c.options.as_dict(),
        "samples": {
            "in": int(log.n_in),
            "invalid": int(log.n_invalid),
            "first_invalid_line": log.first_invalid_line,
            "ordered": int(log.t.size),
            "out": int(s.t.size),
            "dt_out_s": None if c.grid is None else float(c.grid.dt),
            "repeated_positions": 0 if m is None else int(m.repeated.sum()),
            "interpolated_positions": 0 if m is None else int(m.interpolated.sum()),
        },
        "order": {
            "reordered": log.n_reordered,
            "first_reordered_line": log.first_reordered_line,
            "duplicates": log.n_duplicates,
            "first_duplicate_line": log.first_duplicate_line,
            "apart": [
                {"samples": a.samples, "lines": list(a.lines), "gap_s": a.gap_s} for a in log.apart
            ],
        },
        "vehicle": {
            "class": veh.name,
            "how": c.vehicle_how,
            "evidence": None
            if c.evidence is None
            else {
                "speed_m_s": c.evidence.speed,
                "climb_m_s": c.evidence.climb,
                "climb_reported_m_s": c.evidence.climb_reported,
                "turn_rate_deg_s": c.evidence.turn_rate,
                "height_band_m": c.evidence.height_band,
                "slow_airborne_fraction": c.evidence.slow_airborne,
                "category": c.evidence.category,
                "file_format": c.evidence.file_format,
            },
            "load_factor_g": [veh.n_min, veh.n_max],
            "max_speed_m_s": veh.speed,
            "max_climb_m_s": veh.climb,
            "max_accel_h_m_s2": veh.accel_h,
            "max_accel_v_m_s2": veh.accel_v,
            "stall_speed_m_s": veh.stall,
        },
        "kinematics": kinematics(s, c.options.ellipsoid),
        "notes": [*c.track_notes, *c.notes]
        + (
            [
                Message(
                    f"vehicle: {veh.name} ({c.vehicle_how})",
                    Advice("; ", Pass("vehicle", Metavar("CLASS")), " to choose"),
                )
            ]
            if c.vehicle_how.startswith("guessed")
            else []
        ),
    }
    if est is None:
        return report
    assert m is not None
    sig = {}
    chans: dict[str, Any] = {}
    for name, (ch, axis, i) in est.channels.items():
        res, rej = c.residuals[name], c.rejected[name]
        idx = est.samples_of(name, m)
        r_in, m_in, _ = _stats(res[~rej])
        r_all, m_all, j = _stats(res)
        per_axis = 1.0 / math.sqrt(ch.dof) if ch.dof == 2 else 1.0
        chans[name] = {
            "samples": int(ch.t.size),
            "noise_sigma": float(axis.scales[i]),
            # "floor" or "ceiling" where the estimate stopped at a bound of its search
            "noise_sigma_at_bound": axis.scale_at_bound(i),
            "noise_sigma_bounds": [float(b) for b in axis.scale_bounds[i]],
            "fault_rate": float(axis.fault_rate[i]),
            "rejected": int(rej.sum()),
            "copies": axis.copies(i),
            "residual_rms": r_in * per_axis,
            "residual_max": m_in,
            "residual_all_max": m_all,
            "residual_all_max_line": int(log.lines[idx[j]]) if j >= 0 else None,
        }
        sig[name] = float(axis.scales[i])
    hz, vt = est.horizontal, est.vertical
    pos, hgt = chans["position"], chans["height"]
    report["model"] = {
        "horizontal": {
            "jerk_intensity_m2_s5": hz.q,
            "sigma_accel_m_s2": hz.model.sigma_accel(hz.q),
            "tau_s": hz.model.tau_s,
            "q_bounds": list(veh.q_bounds(False)),
            # the speed bound (the log's top ground speed) and how long it holds the path
            "top_speed_m_s": hz.top_speed,
            "speed_bound_held_s": hz.speed_held * hz.grid.dt,
            "speed_bound_holds": hz.speed_bound_holds,
        },
        "vertical": {
            "jerk_intensity_m2_s5": vt.q,
            "sigma_accel_m_s2": vt.model.sigma_accel(vt.q),
            "tau_s": vt.model.tau_s,
            "tau_climb_s": 1.0 / vt.model.beta,
            "q_bounds": list(veh.q_bounds(True)),
        },
    }
    report["channels"] = chans
    report["fit"] = {
        "sigma_h_m": sig["position"],
        "sigma_v_m": sig["height"],
        # the σ of the time errors a height carries from its row's stamp (0: none; motion
        # module docstring, "Time errors"): its σ at the stamped time is √(s² + (ż σ_τ)²)
        "height_time_sigma_s": est.height_time_sigma_s,
        "sigma_estimated": c.options.noise_m() is None,
        "height_quantum_m": float(m.height_quantum),
        "residual_rms_h_m": pos["residual_rms"],
        "residual_rms_v_m": hgt["residual_rms"],
        "residual_max_h_m": pos["residual_max"],
        "residual_max_v_m": hgt["residual_max"],
        "residual_all_max_h_m": pos["residual_all_max"],
        "residual_all_max_v_m": hgt["residual_all_max"],
    }
    report["faults"] = {
        "runs": len(c.faults),
        "samples": {k: int(v.sum()) for k, v in c.rejected.items()},
        "list": [
            {
                "channel": f.channel,
                "kind": f.kind,
                "lines": list(f.lines),
                "t_start_s": f.t_start_s - t0,
                "t_end_s": f.t_end_s - t0,
                "samples": f.samples,
                "offset": f.offset_m,
                "time_shift_s": f.time_shift_s,
                "text": f.text(t0),
            }
            for f in c.faults
        ],
    }
    report["gaps"] = {
        "limit_s": float(c.options.max_gap_s),
        "count": len(c.gaps),
        "longest_s": max((g.t_to_s - g.t_from_s for g in c.gaps), default=0.0),
        "list": [
            {
                "t_from_s": g.t_from_s - t0,
                "t_to_s": g.t_to_s - t0,
                "duration_s": g.t_to_s - g.t_from_s,
                "lines": list(g.lines),
                "sigma_h_m": g.sigma_h_m,
                "sigma_v_m": g.sigma_v_m,
                "fixes": g.fixes,
                "edge": g.edge,
            }
            for g in c.gaps
        ],
    }
    report["timing"] = _timing(est)
    report["ground"] = _ground(c)
    report["velocity"] = _velocity_residuals(c, t0)
    return report


def _gap_text(gp: dict[str, Any]) -> str:
    """One line of the report on a stretch flown without fixes (``report["gaps"]["list"]``)."""
    where = f"lines {gp['lines'][0]}..{gp['lines'][1]} ({gp['duration_s']:.0f} s, t = "
    where += f"{gp['t_from_s']:.0f}..{gp['t_to_s']:.0f} s)"
    sigma = f"σ {gp['sigma_h_m']:.0f} m per horizontal axis, {gp['sigma_v_m']:.0f} m vertical"
    both = gp["fixes"] == "positions and heights"
    if gp["edge"] is None:
        what = "gap" if both else f"gap in the {gp['fixes']}"
        return f"{what}: {where}: flown as the model predicts, {sigma} at mid-gap"
    side = "after" if gp["edge"] == "start" else "before"
    what = "no fix" if both else f"no {gp['fixes'][:-1]} kept"
    return (
        f"{gp['edge']} of the flight with {what}: {where}: flown as the model predicts from "
        f"the fixes {side} it, {sigma} at its {gp['edge']}"
    )


def _timing(est: Any) -> dict[str, Any] | None:
    """Return the time errors of the fixes (the position channel's), when the log shows them."""
    _, axis, i = est.channels["position"]
    sig = axis.sigma_tau[i] if axis.sigma_tau else 0.0
    if sig <= 0.0:
        return None
    tau = axis.tau[i]
    return {
        "sigma_s": float(sig),
        "shift_rms_s": float(np.sqrt(np.mean(tau**2))),
        "shift_max_s": float(np.max(np.abs(tau))),
        "fixes": int(tau.size),
    }


def _ground(c: Any) -> dict[str, Any]:
    """Time at the ends of the flown path slower than the vehicle's stall speed (on the ground)."""
    veh, s = c.vehicle, c.samples
    if veh.stall <= 0.0 or s.t.size < 2:
        return {
            "duration_s": 0.0,
            "fraction_of_flight": 0.0,
            "stall_speed_m_s": veh.stall,
            "level_fixes": 0,
        }
    hz = c.estimate.horizontal
    a, b = c.flown
    speed = np.linalg.norm(hz.x[a : b + 1, 1, :], axis=1)
    fast = np.flatnonzero(speed >= veh.stall)
    dt = float(s.t[1] - s.t[0])
    if fast.size == 0:
        dur = float(s.t[-1])
    else:
        dur = float((fast[0] + (speed.size - 1 - fast[-1])) * dt)
    span = float(s.t[-1]) or 1.0
    level = c.estimate.channels.get(GROUND_CHANNEL)
    held = 0 if level is None else int(np.sum(level[1].fault_prob[level[2]] <= 0.5))
    return {
        "duration_s": dur,
        "fraction_of_flight": dur / span,
        "stall_speed_m_s": veh.stall,
        "level_fixes": held,
    }


def conditioned_flight(c: Any) -> ConditionedFlight:
    """Return the :class:`ConditionedFlight` of a conditioning result ``c`` (a ``Conditioned``)."""
    log, s = c.log, c.samples
    n = log.t.size
    report = build_report(c)
    status = np.full(n, KEPT, np.int64)
    off_h, off_v = np.zeros(n), np.zeros(n)
    m = c.measurements
    if m is not None:
        status[m.repeated | m.interpolated] = NOT_MEASURED
        ip, ih = m.index["position"], m.index["height"]
        off_h[ip], off_v[ih] = c.residuals["position"], c.residuals["height"]
        # the positions not measured: their distance from the path all the same
        other = np.setdiff1d(np.arange(n), ip)
        if other.size and c.estimate is not None:
            p = (
                np.stack(
                    geodetic_to_ecef(
                        log.lat[other], log.lon[other], np.zeros(other.size), c.options.ellipsoid
                    ),
                    -1,
                )
                - m.origin
            )
            off_h[other] = np.linalg.norm(p - c.estimate.horizontal.value_at(log.t[other]), axis=1)
        bad_h = np.zeros(n, bool)
        bad_v = np.zeros(n, bool)
        bad_h[ip[c.rejected["position"]]] = True
        bad_v[ih[c.rejected["height"]]] = True
        status[bad_h] = OUTLIER_H
        status[bad_v] = OUTLIER_V
        status[bad_h & bad_v] = OUTLIER_HV
    lo, hi = s.t_start, s.t_start + s.t[-1]
    status[(log.t < lo - 1e-9) | (log.t > hi + 1e-9)] = TRIMMED
    h = log.h
    end = n if m is None else m.t.size  # the rows after are a frozen end: no path there
    if m is not None and m.index["height"].size < end:  # samples without a height of their own
        own = np.zeros(n, bool)
        own[m.index["height"]] = True
        own[end:] = own[end - 1]  # a frozen end's rows repeat the last measured one
        h = np.where(own, log.h, np.nan)
        off_v[~own] = np.nan
    off_h[end:], off_v[end:] = np.nan, np.nan
    raw = {
        "t": log.t - s.t_start,
        "lat": log.lat,
        "lon": log.lon,
        "h": h,
        "lines": log.lines,
        "status": status,
        "offset_h": off_h,
        "offset_v": off_v,
    }
    return ConditionedFlight(s, report, raw, c)


def _duration(seconds: float) -> str:
    """Return a duration as a person reads it: seconds, minutes, hours, days or years."""
    for unit, size in (("years", 365.25 * 86400.0), ("days", 86400.0), ("h", 3600.0)):
        if seconds >= 2.0 * size:
            return f"{seconds / size:.0f} {unit}"
    return f"{seconds / 60.0:.0f} min" if seconds >= 120.0 else f"{seconds:.0f} s"


def format_report(rep: dict) -> str:
    """Text of a conditioning report (:attr:`ConditionedFlight.report`), one item a line."""
    s, o, k, v = rep["samples"], rep["order"], rep["kinematics"], rep["vehicle"]
    lines = [f"Conditioned flight: {rep['source']}"]
    extra = []
    if s["invalid"]:
        extra.append(f"{s['invalid']} not finite (first line {s['first_invalid_line']})")
    if o["reordered"]:
        extra.append(
            f"{o['reordered']} out of order, sorted (first line {o['first_reordered_line']})"
        )
    if o["duplicates"]:
        extra.append(
            f"{o['duplicates']} repeated times dropped (first line {o['first_duplicate_line']})"
        )
    for a in o.get("apart", []):
        at = (
            f"line {a['lines'][0]}"
            if a["samples"] == 1
            else f"lines {a['lines'][0]}..{a['lines'][1]} (the first and last in time order)"
        )
        extra.append(
            f"{a['samples']} dropped at {at}, {_duration(a['gap_s'])} from the rest of the "
            "log: a recording apart (a time tag from another day, or another flight), not flown"
        )
    if s.get("repeated_positions"):
        extra.append(f"{s['repeated_positions']} repeated positions (the fix before, resent)")
    if s.get("interpolated_positions"):
        extra.append(
            f"{s['interpolated_positions']} positions interpolated between fixes or "
            "extrapolated from one (no measurements)"
        )
    dt = f" every {s['dt_out_s']:g} s" if s["dt_out_s"] else ""
    lines.append(f"  samples: {s['in']} in, {s['out']} out{dt}" + "".join("; " + e for e in extra))
    lines.append(f"  method: {rep['method']}")
    lines.append(
        f"  vehicle: {v['class']} ({v['how']}): load factor {v['load_factor_g'][0]:g}.."
        f"{v['load_factor_g'][1]:g} g, speed to {v['max_speed_m_s']:g} m/s"
    )
    if "model" in rep:
        mh, mv = rep["model"]["horizontal"], rep["model"]["vertical"]
        lines.append(
            f"  motion model: acceleration σ {mh['sigma_accel_m_s2']:.2f} m/s² horizontally "
            f"({mh['tau_s']:g} s manoeuvres), {mv['sigma_accel_m_s2']:.2f} m/s² vertically "
            "(estimated within the class's bounds)"
            + (
                f"; speed within the log's top ground speed, {mh['top_speed_m_s']:.0f} m/s "
                f"(held there for {mh['speed_bound_held_s']:.0f} s)"
                if mh["top_speed_m_s"] is not None and mh["speed_bound_holds"]
                else ""
            )
            + (
                f"; the log's top ground speed, {mh['top_speed_m_s']:.0f} m/s, could not be "
                f"held ({mh['speed_bound_held_s']:.0f} s faster): fixes the vehicle could not "
                "have reached are kept, and the path flies them"
                if mh["top_speed_m_s"] is not None and not mh["speed_bound_holds"]
                else ""
            )
        )
        units = {"position": "m", "height": "m", "velocity": "m/s", "vertical rate": "m/s"}
        for name, ch in rep["channels"].items():
            if name == GROUND_CHANNEL:
                continue  # the model's (the ground line above), not the log's
            u = units.get(name, "")
            per = " per axis" if name in ("position", "velocity") else ""
            bound = ch["noise_sigma_at_bound"]
            at = (
                f" (the estimate stopped at its {bound}, "
                f"{ch['noise_sigma_bounds'][bound == 'ceiling']:.4g} {u})"
                if bound
                else ""
            )
            lines.append(
                f"  {name}: {ch['samples']} measured, "
                f"noise σ {ch['noise_sigma']:.2f} {u}{per}{at}; "
                f"residual RMS {ch['residual_rms']:.2f} {u}{per}, largest {ch['residual_max']:.1f}"
                f" {u} (kept), {ch['residual_all_max']:.0f} {u} (all, line "
                f"{ch['residual_all_max_line']}); {ch['rejected']} rejected"
                + (f", {ch['copies']} copies of the value before" if ch["copies"] else "")
            )
        fl = rep["faults"]["list"]
        if fl:
            # the largest first: samples × distance, a re-timed run by its time error at 100 m/s
            worst = sorted(
                fl,
                key=lambda f: -f["samples"] * (f["offset"] + 100.0 * abs(f["time_shift_s"] or 0)),
            )[:N_WORST]
            lines.append(f"  faults: {len(fl)} runs of rejected samples; the largest:")
            lines += [f"    {f['text']}" for f in worst]
        g = rep["gaps"]
        for gp in g["list"]:
            lines.append("  " + _gap_text(gp))
        tm = rep.get("timing")
        if tm:
            lines.append(
                f"  time errors of the fixes: σ {tm['sigma_s']:.2f} s (the along-track spread "
                f"beyond the across-track one); each fix re-timed, {tm['shift_rms_s']:.2f} s RMS,"
                f" largest {tm['shift_max_s']:.1f} s"
            )
        gr = rep["ground"]
        if gr["duration_s"] > 0.0:
            lines.append(
                f"  on the ground (slower than the stall speed, {gr['stall_speed_m_s']:g} m/s, "
                f"at the ends): {gr['duration_s']:.0f} s, "
                f"{100 * gr['fraction_of_flight']:.1f} % of the flown span"
            )
        if gr["level_fixes"]:
            lines.append(
                f"  held level at {gr['level_fixes']} fixes slower than the vehicle flies "
                f"({gr['stall_speed_m_s']:g} m/s less {SURFACE_WIND_MAX:g} m/s of wind): on "
                "the ground, whatever the heights say"
            )
    lines.append(
        f"  flown: {k['duration_s']:.0f} s, max speed {k['max_speed_m_s']:.0f} m/s; peak "
        f"acceleration {k['peak_acceleration_g']:.2f} g (t = {k['peak_acceleration_t_s']:.0f} s, "
        f"line {k['peak_acceleration_line']}), specific force {k['min_specific_force_g']:.2f}.."
        f"{k['peak_specific_force_g']:.2f} g, jerk {k['peak_jerk_m_s3']:.2f} m/s³, turn rate "
        f"{k['peak_turn_rate_deg_s']:.1f} °/s, climb {k['peak_climb_rate_m_s']:.1f} m/s, "
        f"descent {k['peak_descent_rate_m_s']:.1f} m/s"
    )
    vr = rep.get("velocity")
    if vr:
        parts = []
        if "groundspeed_rms_m_s" in vr:
            parts.append(
                f"ground speed {vr['groundspeed_rms_m_s']:.2f} m/s RMS (max "
                f"{vr['groundspeed_max_m_s']:.1f}; all {vr['groundspeed_all_max_m_s']:.1f}), "
                f"track {vr['track_rms_deg']:.2f}° RMS (max {vr['track_max_deg']:.1f}°)"
            )
        if "vertical_rate_rms_m_s" in vr:
            parts.append(
                f"vertical rate {vr['vertical_rate_rms_m_s']:.2f} m/s RMS (max "
                f"{vr['vertical_rate_max_m_s']:.1f}; all {vr['vertical_rate_all_max_m_s']:.1f})"
            )
        if parts:
            lines.append(
                f"  flown − log's velocities ({', '.join(vr['columns'])}): " + "; ".join(parts)
            )
    lines += [f"  note: {n}" for n in rep["notes"]]
    return "\n".join(lines)


def plot_conditioning(cf: ConditionedFlight) -> Figure:
    """Raw samples against the conditioned path: map, height, distances; a matplotlib Figure.

    Rejected samples are marked (red x), samples that are no measurement (repeated or
    interpolated positions) grey, samples the path does not fly past (a frozen end, the slow
    ends ``airborne_only`` trims) light grey circles; distances are from the flown path.
    """
    from matplotlib.figure import Figure

    raw, s = cf.raw, cf.samples
    st = raw["status"]
    bad_h = np.isin(st, (OUTLIER_H, OUTLIER_HV))
    bad_v = np.isin(st, (OUTLIER_V, OUTLIER_HV))
    used = st == KEPT
    off = st == TRIMMED
    fig = Figure(figsize=(12, 8), layout="constrained")
    ax = fig.subplots(2, 2)
    a = ax[0, 0]
    a.plot(
        raw["lon"][~bad_h & ~off], raw["lat"][~bad_h & ~off], ".", ms=2, color="0.6", label="log"
    )
    a.plot(raw["lon"][bad_h], raw["lat"][bad_h], "x", color="r", label="rejected")
    if off.any():
        a.plot(raw["lon"][off], raw["lat"][off], "o", ms=3, mfc="none", color="0.75",
               label="not flown")  # fmt: skip
    a.plot(s.lon, s.lat, "-", lw=1, color="C0", label="flown")
    a.set_xlabel("longitude (°)")
    a.set_ylabel("latitude (°)")
    a.legend(fontsize=8)
    a = ax[0, 1]
    a.plot(raw["t"][~bad_v & ~off] / 60, raw["h"][~bad_v & ~off], ".", ms=2, color="0.6",
           label="log")  # fmt: skip
    a.plot(raw["t"][bad_v] / 60, raw["h"][bad_v], "x", color="r", label="rejected")
    if off.any():
        a.plot(raw["t"][off] / 60, raw["h"][off], "o", ms=3, mfc="none", color="0.75",
               label="not flown")  # fmt: skip
    a.plot(s.t / 60, s.h, "-", lw=1, color="C0", label="flown")
    a.set_xlabel("time (min)")
    a.set_ylabel("height above the ellipsoid (m)")
    a.legend(fontsize=8)
    for a, key, bad, what in (
        (ax[1, 0], "offset_h", bad_h, "horizontal"),
        (ax[1, 1], "offset_v", bad_v, "vertical"),
    ):
        a.semilogy(raw["t"][used] / 60, np.maximum(raw[key][used], 1e-2), ".", ms=2, color="C0")
        a.semilogy(raw["t"][bad] / 60, np.maximum(raw[key][bad], 1e-2), "x", color="r")
        a.set_xlabel("time (min)")
        a.set_ylabel(f"{what} distance from the path (m)")
        a.grid(True, which="both", alpha=0.3)
    for a in ax.flat:
        a.grid(True, alpha=0.3)
    name = PurePath(str(cf.report["source"])).name  # the file, not the folder it was read in
    title = f"{name}: {int(used.sum())} kept, {int((bad_h | bad_v).sum())} rejected"
    fig.suptitle(title + (f", {int(off.sum())} not flown" if off.any() else ""))
    return fig
