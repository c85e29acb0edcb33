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

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from fieldmap.errors import Advice, Message, Metavar, Pass
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
from fieldmap.nav.trajectory import FlightSamples
from fieldmap.units import STANDARD_GRAVITY as G0

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: a sample's fate: the codes of ``ConditionedFlight.raw["status"]``
KEPT, OUTLIER_H, OUTLIER_V, OUTLIER_HV, STALE, GROUND, DROPPED, GAP = range(8)
STATUS_NAMES = ("kept", "outlier_h", "outlier_v", "outlier_hv", "stale", "ground", "dropped", "gap")

#: outliers shown in the report's "worst" list
N_WORST = 10
METHOD = (
    "Hampel identifier on running-median trends, robust (bisquare) penalised cubic spline on a "
    "regular grid with λ from the discrepancy principle, softened to the vehicle limits"
)


@dataclass
class ConditionedFlight:
    """Result of :func:`~fieldmap.nav.logs.condition.condition`.

    Attributes
    ----------
    samples : FlightSamples
        The smooth path on a regular grid, times from 0 (``t_start`` the first, in the track's
        time scale); what :class:`~fieldmap.nav.trajectory.FlightTrajectory` takes.
    report : dict
        JSON-ready summary: ``samples``, ``order``, ``stale``, ``interpolated`` (positions
        interpolated between fixes: :func:`_interpolated`), ``outliers`` (every rejected
        sample with line, time and offset), ``fit`` (σ, residual RMS), ``gaps``, ``segments``,
        ``ground_trimmed`` (``airborne_only``), ``ground`` (the ground movement flown as such:
        :func:`_ground`), ``kinematics`` (:func:`kinematics`), ``options``, ``notes``.
    raw : dict
        The ordered raw samples (``t`` relative to ``samples.t_start``, ``lat``, ``lon``, ``h``,
        ``lines``), each one's ``status`` (codes :data:`STATUS_NAMES`) and offsets from the
        fitted path (``offset_h``, ``offset_v``, m; from the robust trend outside the flown
        segment) for :func:`plot_conditioning`.
    """

    samples: FlightSamples
    report: dict
    raw: dict = field(repr=False)

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


def _runs(mask: np.ndarray, t: np.ndarray, lines: np.ndarray) -> list[dict]:
    """Contiguous runs of ``mask`` as dicts of times, lines and sample counts."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    out = []
    for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1):
        out.append(
            {
                "t_start_s": float(t[a]),
                "t_end_s": float(t[b]),
                "lines": [int(lines[a]), int(lines[b])],
                "samples": int(b - a + 1),
            }
        )
    return out


def _intervals(t: np.ndarray, dtm: float) -> tuple[int, float]:
    """Intervals of ``t`` longer than 2.5 median intervals: count and the longest (s)."""
    if t.size < 2:
        return 0, 0.0
    d = np.diff(t)
    return int(np.sum(d > 2.5 * dtm)), float(d.max())


def _ground(st: Any, t0: float) -> dict[str, Any]:
    """Return the ground movement flown as such (``st.ground_pieces``), JSON-ready.

    ``flown``: each piece (before or after the flight) with its times (relative to ``t0``),
    lines, samples, level height and where it came from, noise σ, fit residual RMS and
    samples softened; ``duration_s`` and ``fraction_of_log``: their time against the log's
    span (first to last sample); ``envelope``: the ground envelope they keep within.
    """
    log = st.log
    pieces = list(getattr(st, "ground_pieces", []))
    env = getattr(st, "ground_envelope", None)
    span = float(log.t[-1] - log.t[0]) if log.t.size > 1 else 0.0
    duration = float(sum(p["t_end"] - p["t_start"] for p in pieces))
    flown = []
    for p in pieces:
        d = {k: v for k, v in p.items() if k not in ("t_start", "t_end")}
        flown.append(dict(d, t_start_s=p["t_start"] - t0, t_end_s=p["t_end"] - t0))
    return {
        "flown": flown,
        "samples": int(sum(p["samples"] for p in pieces)),
        "duration_s": duration,
        "fraction_of_log": duration / span if span > 0.0 else 0.0,
        "envelope": None
        if env is None
        else {"load_factor_g": [env.n_min, env.n_max], "max_jerk_m_s3": env.jerk},
    }


def _interpolated(st: Any) -> dict[str, Any]:
    """Return the positions interpolated between fixes (JSON-ready; ``st.interpolated``)."""
    L = np.asarray(getattr(st, "interpolated", np.zeros(0)))
    first = (L > 0.0) & (np.concatenate([[0.0], L[:-1]]) == 0.0)
    return {
        "positions": int(np.sum(L > 0.0)),
        "runs": int(np.sum(first)),
        "tolerance_deg": float(getattr(st, "interpolated_tol", 0.0)),
        "use": "each run of L weighted 1/L: one observation; not in the noise estimates",
    }


def finish(st: Any, fr: dict[str, Any]) -> ConditionedFlight:
    """Assemble the :class:`ConditionedFlight` of a fitted segment ``fr`` of the stages ``st``.

    ``st``: a :class:`fieldmap.nav.logs.condition.Stages` (not imported: condition imports this
    module).
    """
    log, o, track = st.log, st.opts, st.track
    samples, status = fr["samples"], st.status()
    t0 = samples.t_start
    rej: list[dict] = []
    for i in np.flatnonzero((status >= OUTLIER_H) & (status <= OUTLIER_HV)):
        c = int(status[i])
        offset = {OUTLIER_H: st.off_h[i], OUTLIER_V: st.off_v[i]}.get(
            c, float(np.hypot(st.off_h[i], st.off_v[i]))
        )
        rej.append(
            {
                "line": int(log.lines[i]),
                "t_s": float(log.t[i] - t0),
                "component": {OUTLIER_H: "horizontal", OUTLIER_V: "vertical"}.get(c, "both"),
                "offset_m": float(abs(offset)),
            }
        )
    hi, vi = fr["hi"], fr["vi"]
    dtm = float(np.median(np.diff(log.t[hi]))) if hi.size > 1 else 0.0
    nb_h, long_h = _intervals(log.t[hi], dtm)
    nb_v, long_v = _intervals(log.t[vi], dtm)
    sig = fr["sigma"]
    flown = (log.t >= fr["t_lo"]) & (log.t <= fr["t_hi"])
    notes = list(getattr(track, "notes", ()) or ())
    if st.dropped:
        notes.append(f"flew the longest of {len(st.dropped) + 1} segments (breaks: gaps, jumps)")
    veh, lim = st.vehicle, st.lim
    if o["smooth"]:
        notes.append(
            Message(
                f"vehicle: {veh.name} ({st.vehicle_why}",
                Advice("; ", Pass("vehicle", Metavar("CLASS")), " to choose"),
                f"): load factor {veh.n_min:g}..{veh.n_max:g} g, jerk {lim['max_jerk']:g} m/s³, "
                f"speed {veh.speed:g} m/s",
            )
        )
    if fr["softened"]:
        limits = [f"load factor {veh.n_min:g}..{veh.n_max:g} g"]
        limits += [
            f"{lim[k]:g} {u}" for k, u in (("max_accel_g", "g"), ("max_jerk", "m/s³")) if lim[k]
        ]
        notes.append(
            f"the path was softened near {fr['softened']} samples to keep within the vehicle "
            f"limits ({', '.join(limits)})"
        )

    interp = _interpolated(st)
    if interp["positions"]:
        notes.append(
            f"{interp['positions']} positions in {interp['runs']} runs interpolated between "
            f"fixes (collinear at equal time steps within {interp['tolerance_deg']:.1g}°, the "
            "rounding of the printed digits): each run one observation in the fit, left out "
            "of the noise and timing-jitter estimates"
        )

    def rel(d: dict) -> dict:
        return dict(d, t_start_s=d["t_start_s"] - t0, t_end_s=d["t_end_s"] - t0)

    report = {
        "source": log.source,
        "height_ref": getattr(track, "height_ref", None),
        "t0_utc": getattr(track, "t0_utc", None),
        "t_start_s": float(t0),
        "method": METHOD if o["smooth"] else "exact: the ordered samples, no smoothing",
        "options": dict(o),
        "samples": {
            "in": int(log.n_in),
            "invalid": int(log.n_invalid),
            "first_invalid_line": log.first_invalid_line,
            "out": int(samples.t.size),
            "used_horizontal": int(hi.size),
            "used_vertical": int(vi.size),
            "dt_out_s": fr["dt_out"],
        },
        "order": {
            "reordered": log.n_reordered,
            "first_reordered_line": log.first_reordered_line,
            "duplicates": log.n_duplicates,
            "first_duplicate_line": log.first_duplicate_line,
        },
        "stale": {"positions": int(np.sum(st.stale)), "heights": int(np.sum(st.stale_v))},
        "interpolated": interp,
        "outliers": {
            "count": len(rej),
            "horizontal": int(np.sum(st.out_h)),
            "vertical": int(np.sum(st.out_v)),
            "in_flown_segment": int(
                np.sum(((status >= OUTLIER_H) & (status <= OUTLIER_HV))[flown])
            ),
            "worst": sorted(rej, key=lambda r: -float(r["offset_m"]))[:N_WORST],
            "samples": rej,
        },
        "fit": {
            "sigma_h_m": None if sig is None else float(sig[0]),
            "sigma_v_m": None if sig is None else float(sig[1]),
            "sigma_estimated": bool(fr["sigma_estimated"]),
            "height_quantum_m": float(st.quantum),
            "residual_rms_h_m": float(fr["rms"][0]),
            "residual_rms_v_m": float(fr["rms"][1]),
            "lambda_h": float(fr["lam"][0]),
            "lambda_v": float(fr["lam"][1]),
            "edf_h": float(fr["edf"][0]),
            "edf_v": float(fr["edf"][1]),
            "softened_samples": int(fr["softened"]),
        },
        "gaps": {
            "limit_s": o["max_gap_s"],
            "bridged": nb_h,
            "bridged_vertical": nb_v,
            "longest_bridged_s": max(long_h, long_v),
            "breaks": [
                {
                    "kind": kind,
                    "t_from_s": float(log.t[a] - t0),
                    "t_to_s": float(log.t[b] - t0),
                    "duration_s": float(log.t[b] - log.t[a]),
                    "lines": [int(log.lines[a]), int(log.lines[b])],
                }
                for a, b, kind in st.breaks
            ],
            "samples_in_breaks": int(np.sum(status == GAP)),
            "long_bridged": [
                {
                    "t_from_s": b["t_from"] - t0,
                    "t_to_s": b["t_to"] - t0,
                    "duration_s": b["t_to"] - b["t_from"],
                    "lines": b["lines"],
                    "sigma_h_m": b["sigma_h_m"],
                    "sigma_v_m": b["sigma_v_m"],
                }
                for b in fr["bridges"]
            ],
        },
        "segments": {
            "flown": {
                "t_start_s": 0.0,
                "t_end_s": float(samples.t[-1]),
                "lines": [int(samples.lines[0]), int(samples.lines[-1])],
            },
            "dropped": [rel(d) for d in st.dropped],
        },
        "vehicle": {
            "class": veh.name,
            "how": st.vehicle_why,
            "load_factor_g": [veh.n_min, veh.n_max],
            "max_jerk_m_s3": lim["max_jerk"],
            "max_speed_m_s": veh.speed,
            "max_climb_m_s": veh.climb,
        },
        "ground_trimmed": [rel(g) for g in _runs(st.ground, log.t, log.lines)],
        "ground": _ground(st, t0),
        "kinematics": kinematics(samples, log.ellipsoid),
        "velocity": fr.get("velocity"),
        "timing": fr.get("timing"),
        "notes": notes,
    }
    raw = {
        "t": log.t - t0,
        "lat": log.lat,
        "lon": log.lon,
        "h": log.h,
        "lines": log.lines,
        "status": status,
        "offset_h": np.abs(st.off_h),
        "offset_v": np.abs(st.off_v),
    }
    return ConditionedFlight(samples, report, raw)


def format_report(rep: dict) -> str:
    """Text of a conditioning report (:attr:`ConditionedFlight.report`), one item a line."""
    s, o, f, g, k = rep["samples"], rep["order"], rep["fit"], rep["gaps"], rep["kinematics"]
    out = rep["outliers"]
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
    st = rep["stale"]
    if st["positions"] or st["heights"]:
        extra.append(f"{st['positions']} stale positions, {st['heights']} stale heights")
    dt = f" every {s['dt_out_s']:g} s" if s["dt_out_s"] else ""
    lines.append(f"  samples: {s['in']} in, {s['out']} out{dt}" + "".join("; " + e for e in extra))
    lines.append(f"  method: {rep['method']}")
    if f["sigma_h_m"] is not None:
        how = "estimated" if f["sigma_estimated"] else "given"
        q = f"; heights quantised in {f['height_quantum_m']:.2f} m" if f["height_quantum_m"] else ""
        lines.append(
            f"  noise σ ({how}): {f['sigma_h_m']:.2f} m horizontal, {f['sigma_v_m']:.2f} m "
            f"vertical{q}; fit residual RMS {f['residual_rms_h_m']:.2f} m, "
            f"{f['residual_rms_v_m']:.2f} m ({s['used_horizontal']} positions, "
            f"{s['used_vertical']} heights)"
        )
        worst = ", ".join(
            f"line {w['line']} (t = {w['t_s']:.1f} s, {w['offset_m']:.0f} m {w['component']})"
            for w in out["worst"][:5]
        )
        lines.append(
            f"  outliers rejected: {out['count']} ({out['horizontal']} horizontal, "
            f"{out['vertical']} vertical)" + (f"; worst: {worst}" if worst else "")
        )
        lines.append(
            f"  gaps bridged: {g['bridged']} (longest {g['longest_bridged_s']:.1f} s); breaks "
            f"(gaps over {g['limit_s']:g} s, jumps): {len(g['breaks'])}"
        )
        for b in g.get("long_bridged", []):
            lines.append(
                f"  long gap bridged: lines {b['lines'][0]}..{b['lines'][1]} "
                f"({b['duration_s']:.0f} s, t = {b['t_from_s']:.0f}..{b['t_to_s']:.0f} s): "
                f"a path the vehicle could fly, σ {b['sigma_h_m']:.0f} m per horizontal axis, "
                f"{b['sigma_v_m']:.0f} m vertical at mid-gap"
            )
    for d in rep["segments"]["dropped"]:
        lines.append(
            f"  segment dropped: lines {d['lines'][0]}..{d['lines'][1]} ({d['samples']} samples, "
            f"t = {d['t_start_s']:.0f}..{d['t_end_s']:.0f} s)"
        )
    gr = rep.get("ground") or {}
    for d in gr.get("flown", []):
        env = gr["envelope"]
        lines.append(
            f"  ground movement flown as such ({d['side']} the flight): lines "
            f"{d['lines'][0]}..{d['lines'][1]} ({d['samples']} samples, "
            f"{d['t_end_s'] - d['t_start_s']:.0f} s), level at {d['height_m']:.0f} m "
            f"({d['height_from']}), noise σ {d['sigma_h_m']:.1f} m, fit residual RMS "
            f"{d['residual_rms_h_m']:.1f} m, within {env['load_factor_g'][0]:g}.."
            f"{env['load_factor_g'][1]:g} g and {env['max_jerk_m_s3']:g} m/s³"
            + (f" (softened near {d['softened_samples']} samples)" if d["softened_samples"] else "")
        )
    if gr.get("flown"):
        lines.append(
            f"  on the ground: {gr['duration_s']:.0f} s, {100 * gr['fraction_of_log']:.1f} % "
            "of the log's span, flown as an aircraft on the ground"
        )
    for d in rep["ground_trimmed"]:
        lines.append(
            f"  ground trimmed: lines {d['lines'][0]}..{d['lines'][1]} ({d['samples']} samples, "
            f"{d['t_end_s'] - d['t_start_s']:.0f} s)"
        )
    lines.append(
        f"  flown: {k['duration_s']:.0f} s, max speed {k['max_speed_m_s']:.0f} m/s; peak "
        f"acceleration {k['peak_acceleration_g']:.2f} g (t = {k['peak_acceleration_t_s']:.0f} s, "
        f"line {k['peak_acceleration_line']}), specific force {k['min_specific_force_g']:.2f}.."
        f"{k['peak_specific_force_g']:.2f} g, jerk {k['peak_jerk_m_s3']:.2f} m/s³, turn rate "
        f"{k['peak_turn_rate_deg_s']:.1f} °/s, climb {k['peak_climb_rate_m_s']:.1f} m/s, "
        f"descent {k['peak_descent_rate_m_s']:.1f} m/s"
    )
    tm = rep.get("timing")
    if tm:
        lines.append(
            f"  timing jitter of the fixes: σ {tm['jitter_s']:.2f} s ({tm['sigma_along_m']:.0f} m "
            f"along the track at {tm['speed_m_s']:.0f} m/s, {tm['sigma_across_m']:.1f} m across):"
            f" modelled as a time error per fix, {tm['fixes_retimed']} fixes moved by "
            f"{tm['time_shift_rms_s']:.2f} s RMS (max {tm['time_shift_max_s']:.1f} s)"
        )
    vr = rep.get("velocity")
    if vr:
        parts = []
        if "groundspeed_rms_m_s" in vr:
            parts.append(
                f"ground speed {vr['groundspeed_rms_m_s']:.2f} m/s RMS (max "
                f"{vr['groundspeed_max_m_s']:.1f}), track {vr['track_rms_deg']:.2f}° RMS (max "
                f"{vr['track_max_deg']:.1f}°)"
            )
        if "vertical_rate_rms_m_s" in vr:
            parts.append(
                f"vertical rate {vr['vertical_rate_rms_m_s']:.2f} m/s RMS (max "
                f"{vr['vertical_rate_max_m_s']:.1f})"
            )
        lines.append(
            f"  velocity residuals, flown − log ({', '.join(vr['columns'])}; fitted with σ "
            f"{vr['sigma_h_m_s']:.2f} m/s per horizontal axis, {vr['sigma_v_m_s']:.2f} m/s "
            f"vertical; {vr['outliers']} outliers left out): " + "; ".join(parts)
        )
        every = []
        if "groundspeed_all_rms_m_s" in vr:
            every.append(
                f"ground speed {vr['groundspeed_all_rms_m_s']:.2f} m/s RMS (max "
                f"{vr['groundspeed_all_max_m_s']:.1f}), track {vr['track_all_rms_deg']:.2f}° "
                f"RMS (max {vr['track_all_max_deg']:.1f}°)"
            )
        if "vertical_rate_all_rms_m_s" in vr:
            every.append(
                f"vertical rate {vr['vertical_rate_all_rms_m_s']:.2f} m/s RMS (max "
                f"{vr['vertical_rate_all_max_m_s']:.1f})"
            )
        if every:
            lines.append(
                "  against every velocity of the log, the outliers included: " + "; ".join(every)
            )
    lines += [f"  note: {n}" for n in rep["notes"]]
    return "\n".join(lines)


def plot_conditioning(cf: ConditionedFlight) -> Figure:
    """Raw samples against the conditioned path: map, height, offsets; a matplotlib Figure.

    Rejected samples are marked (red), stale positions grey; offsets are from the fitted path
    (from the robust trend outside the flown segment).
    """
    from matplotlib.figure import Figure

    raw, s = cf.raw, cf.samples
    st = raw["status"]
    bad_h = np.isin(st, (OUTLIER_H, OUTLIER_HV))
    bad_v = np.isin(st, (OUTLIER_V, OUTLIER_HV))
    used = st == KEPT
    fig = Figure(figsize=(12, 8), layout="constrained")
    ax = fig.subplots(2, 2)
    a = ax[0, 0]
    a.plot(raw["lon"][~bad_h], raw["lat"][~bad_h], ".", ms=2, color="0.6", label="raw")
    a.plot(raw["lon"][bad_h], raw["lat"][bad_h], "x", color="r", label="rejected")
    a.plot(s.lon, s.lat, "-", lw=1, color="C0", label="conditioned")
    a.set_xlabel("longitude (°)")
    a.set_ylabel("latitude (°)")
    a.legend(fontsize=8)
    a = ax[0, 1]
    a.plot(raw["t"][~bad_v] / 60, raw["h"][~bad_v], ".", ms=2, color="0.6", label="raw")
    a.plot(raw["t"][bad_v] / 60, raw["h"][bad_v], "x", color="r", label="rejected")
    a.plot(s.t / 60, s.h, "-", lw=1, color="C0", label="conditioned")
    a.set_xlabel("time (min)")
    a.set_ylabel(f"height (m, {cf.report.get('height_ref') or 'ellipsoid'})")
    a.legend(fontsize=8)
    for a, key, bad, what in (
        (ax[1, 0], "offset_h", bad_h, "horizontal"),
        (ax[1, 1], "offset_v", bad_v, "vertical"),
    ):
        a.semilogy(raw["t"][used] / 60, np.maximum(raw[key][used], 1e-2), ".", ms=2, color="C0")
        a.semilogy(raw["t"][bad] / 60, np.maximum(raw[key][bad], 1e-2), "x", color="r")
        a.set_xlabel("time (min)")
        a.set_ylabel(f"{what} offset from the path (m)")
        a.grid(True, which="both", alpha=0.3)
    for a in ax.flat:
        a.grid(True, alpha=0.3)
    fig.suptitle(
        f"{cf.report['source']}: {STATUS_NAMES[KEPT]} {int(used.sum())}, rejected "
        f"{int((bad_h | bad_v).sum())}"
    )
    return fig
