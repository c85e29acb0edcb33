r"""A log's own velocities as observations of the path: their weights, a check, their residuals.

ADS-B messages carry the aircraft's velocity (ground speed, track, vertical rate, from the
airborne velocity message: DO-260B §2.2.3.2.6), NMEA RMC sentences the speed and course over
the ground, GPX files a speed: a measurement of the velocity at the fix, independent of the
positions, whose noise it does not share. They enter the smoothing fit of
:mod:`fieldmap.nav.logs.fit` as rows of the path's time derivative (:class:`~.fit.Rates`):

- **Horizontal**: east and north components ``v_E = s sin χ``, ``v_N = s cos χ`` (ground speed
  s, track χ) carried to the rate of the surface point the horizontal fit follows (its ECEF
  position on the ellipsoid): east × ``N / (N + h)``, north × ``M / (M + h)`` (N, M the prime
  vertical and meridian radii of curvature; Heiskanen & Moritz 1967 eqs. 2-81, 5-58).
- **Vertical**: the vertical rate, up positive.
- **σ** (:func:`observations`): the larger of the quantisation (a rounding error of step q has
  σ = q/√12: 1 kt and 1° horizontally, the track's error scaled by the speed, 64 ft/min
  vertically) and the noise of the velocity series itself, from the same leave-one-out cubic
  predictions as the positions' (:func:`~fieldmap.nav.logs.fit.loo_noise`): the velocities
  change smoothly, their noise does not. A run of L equal values (steady flight: the same
  rounded speed and track for minutes) carries one rounding error, not L: each of its values
  has the weight 1/(L σ²), so that the rounding does not integrate into a drift along the
  track.
- **Outliers**: a horizontal velocity further than ``OUTLIER_K`` robust σ (and over
  ``OUTLIER_FLOOR``) from the positions-only fit's, or not within the contradiction bound of
  it (stale, or another source), is left out; a vertical rate further than ``OUTLIER_K``
  robust σ from the cubic through its neighbours (barometric heights, not the rates, are what
  goes wrong for minutes).
- **Contradiction** (:func:`check`): where the log's ground speeds or tracks disagree with its
  positions by more than ``CONTRADICTION`` of the speed (and ``CONTRADICTION_MIN`` m/s) for
  the median sample, one of the two is wrong for the whole log (a unit, a column, a
  convention): an :class:`~fieldmap.errors.InputError` in one line, nothing flown.

The report (:func:`residuals`) gives the flown path's ground speed, track and vertical rate
against the log's: RMS, largest, and the σ the fit gave them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.nav.logs import fit as cfit

#: a velocity beyond OUTLIER_K robust σ of its residual from the positions-only fit, and over
#: OUTLIER_FLOOR m/s, is an outlier
OUTLIER_K, OUTLIER_FLOOR = 5.0, 5.0
#: velocities that disagree with the positions by more than CONTRADICTION × the speed and
#: CONTRADICTION_MIN m/s for the median sample contradict them
CONTRADICTION, CONTRADICTION_MIN = 0.25, 15.0
#: vertical: by more than half the rate and CONTRADICTION_V m/s
CONTRADICTION_V = 5.0
#: fewer than this fraction of the velocities agreeing with the positions: the log's
#: velocities contradict them (refused); else the others are left out (stale, wrong)
AGREE_MIN = 0.1
#: tracks are compared where the ground speed exceeds this (m/s)
MOVING = 10.0


@dataclass(frozen=True)
class Observed:
    """The velocities of one flown segment, as observations of the horizontal and height fits.

    ``ih``, ``iv``: indices (into the ordered log) of the samples with a horizontal, a vertical
    velocity; ``h``, ``v``: the :class:`~fieldmap.nav.logs.fit.Rates` of each (None when
    none); ``sigma``: the σ (m/s) of each, per horizontal axis and vertical; ``east_north``
    (m, 2) and ``up`` (m,): the observed values (m/s) for the residuals.
    """

    ih: np.ndarray
    iv: np.ndarray
    h: cfit.Rates | None
    v: cfit.Rates | None
    sigma: tuple[float, float]
    east_north: np.ndarray
    up: np.ndarray
    names: tuple[str, ...]
    outliers: int = 0


def _radii(lat_deg: np.ndarray, ell: Any) -> tuple[np.ndarray, np.ndarray]:
    """Prime vertical and meridian radii of curvature (m) at geodetic latitudes."""
    e2 = ell.f * (2.0 - ell.f)
    w2 = 1.0 - e2 * np.sin(np.radians(lat_deg)) ** 2
    return ell.a / np.sqrt(w2), ell.a * (1.0 - e2) / w2**1.5


def _run_lengths(x: np.ndarray) -> np.ndarray:
    """Length of the run of equal rows each row of ``x`` (m, k) is in, (m,)."""
    if x.shape[0] == 0:
        return np.ones(0)
    same = np.all(x[1:] == x[:-1], axis=1)
    start = np.concatenate([[True], ~same])
    ident = np.cumsum(start) - 1
    return np.bincount(ident)[ident].astype(np.float64)


def _loo_sigma(t: np.ndarray, v: np.ndarray) -> float:
    z = cfit.loo_noise(t, v)
    return cfit.noise_sigma(z)[0] if z.size else 0.0


def observations(log: Any, track: Any, idx: np.ndarray) -> Observed | None:
    """Return the velocities of the ordered samples ``idx`` of ``log`` (an ``OrderedLog``).

    ``track``: the :class:`~fieldmap.nav.logs.track.RawTrack` whose ``velocity`` the ordered
    samples index (``log.index``). Only finite values are used.
    """
    vel = getattr(track, "velocity", None)
    if vel is None or idx.size == 0:
        return None
    src = log.index[idx]
    speed, course = vel.speed[src], vel.track[src]
    climb = vel.climb[src] if vel.climb is not None else np.full(idx.size, np.nan)
    okh = np.isfinite(speed) & np.isfinite(course) & (speed >= 0.0)
    okv = np.isfinite(climb)
    if okh.sum() < cfit.ORDER + 3 and okv.sum() < cfit.ORDER + 3:
        return None
    chi = np.radians(course)
    en = np.stack([speed * np.sin(chi), speed * np.cos(chi)], -1)
    q_s, q_c, q_v = (r / np.sqrt(12.0) for r in vel.resolution)
    ih, iv = idx[okh], idx[okv]
    # per horizontal axis: half the variance of the speed's and the track's rounding
    s_q = np.sqrt(0.5 * (q_s**2 + (np.nanmedian(speed[okh]) * np.radians(q_c)) ** 2))
    s_h = max(float(s_q), _loo_sigma(log.t[ih], en[okh]))
    s_v = max(float(q_v), _loo_sigma(log.t[iv], climb[okv, None])) if iv.size else 0.0
    rh = rv = None
    run_h = _run_lengths(np.stack([speed[okh], course[okh]], -1))
    run_v = _run_lengths(climb[okv, None])
    if ih.size:
        n_rad, m_rad = _radii(log.lat[ih], log.ellipsoid)
        hh = log.h[ih]
        e = en[okh, 0] * n_rad / (n_rad + hh)
        n = en[okh, 1] * m_rad / (m_rad + hh)
        v_ecef = e[:, None] * log.en[ih, 0, :] + n[:, None] * log.en[ih, 1, :]
        rh = cfit.Rates(log.t[ih], v_ecef, 1.0 / (s_h**2 * run_h))
    if iv.size:
        rv = cfit.Rates(log.t[iv], climb[okv, None], 1.0 / (s_v**2 * run_v))
    return Observed(ih, iv, rh, rv, (s_h, s_v), en[okh], climb[okv], tuple(vel.names))


def fitted_rates(grid: tuple[float, float, int], g: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rates (m, d) at the times ``t`` of the grid values ``g`` (cubic Lagrange derivative)."""
    t0, dt, ng = grid
    return cfit.on_grid(g, cfit.lagrange_rate_rows(t0, dt, ng, t))


def check(
    obs: Observed, rate_h: np.ndarray, rate_v: np.ndarray, source: str, lines: np.ndarray
) -> Observed:
    """Refuse velocities that contradict the positions; leave out outliers (module docstring).

    ``rate_h`` (m, 3), ``rate_v`` (m, 1): the positions-only fit's rates at the observations.
    ``lines``: the line of each ordered sample, for the message. Returns the observations
    without their outliers.
    """
    keep_h = np.ones(obs.ih.size, bool)
    keep_v = np.ones(obs.iv.size, bool)
    s_h, s_v = obs.sigma
    if obs.h is not None and obs.ih.size:
        d = obs.h.v - rate_h
        r = np.linalg.norm(d, axis=1)
        speed = np.linalg.norm(rate_h, axis=1)
        agree = r <= np.maximum(CONTRADICTION * speed, CONTRADICTION_MIN)
        if agree.mean() < AGREE_MIN:
            names = "/".join(obs.names[:2])
            raise InputError(
                f"{source} lines {lines[obs.ih[0]]}..{lines[obs.ih[-1]]}: the log's velocities "
                f"({names}) contradict its positions: {100 * agree.mean():.0f} % agree within "
                f"{100 * CONTRADICTION:g} % of the speed (the median differs by "
                f"{np.median(r):.0f} m/s at a median speed of {np.median(speed):.0f} m/s from "
                "the positions): a unit or a column mixed up?"
            )
        s = cfit.MAD_SCALE * float(np.median(r[agree])) if agree.any() else 0.0
        keep_h = agree & ((r <= OUTLIER_K * s) | (r <= OUTLIER_FLOOR))
    if obs.v is not None and obs.iv.size:
        r = np.abs(obs.v.v[:, 0] - rate_v[:, 0])
        agree = r <= np.maximum(0.5 * np.abs(rate_v[:, 0]), CONTRADICTION_V)
        if agree.mean() < AGREE_MIN and obs.iv.size >= 10:
            names = obs.names[2] if len(obs.names) > 2 else "vertical rate"
            raise InputError(
                f"{source} lines {lines[obs.iv[0]]}..{lines[obs.iv[-1]]}: the log's vertical "
                f"rates ({names}) contradict its heights: {100 * agree.mean():.0f} % agree "
                f"within half the rate or {CONTRADICTION_V:g} m/s: a unit or a column mixed up "
                "(the altitudes' alt_units, the rates')?",
                param="alt_units",
            )
        # barometric heights go wrong for minutes (held, from another source) where the
        # vertical rates do not: a rate is an outlier against its own neighbours only
        z = np.abs(cfit.loo_noise(obs.v.t, obs.v.v))[:, 0]
        s = cfit.MAD_SCALE * float(np.median(z)) if z.size else 0.0
        keep_v[2:-2] = (z <= OUTLIER_K * s) | (z <= OUTLIER_FLOOR)

    def sub(rt: cfit.Rates | None, keep: np.ndarray, sig: float) -> cfit.Rates | None:
        if rt is None:
            return None
        return cfit.Rates(rt.t[keep], rt.v[keep], np.full(int(keep.sum()), 1.0 / sig**2))

    return Observed(
        obs.ih[keep_h],
        obs.iv[keep_v],
        sub(obs.h, keep_h, s_h),
        sub(obs.v, keep_v, s_v),
        (s_h, s_v),
        obs.east_north[keep_h],
        obs.up[keep_v],
        obs.names,
        int((~keep_h).sum() + (~keep_v).sum()),
    )


def residuals(obs: Observed | None, samples: Any, t_start: float, ellipsoid: Any) -> dict | None:
    """Compare the flown velocity with the log's (JSON-ready; None without velocities).

    The flown velocity is that of the quintic spline :class:`~fieldmap.nav.flight.
    FlightTrajectory` flies (as :func:`fieldmap.nav.logs.report.kinematics`), at the times of
    the observations within the flown span. Returns the RMS and largest residual (flown − log)
    of the ground speed (m/s), the track (degrees, where faster than 10 m/s) and the vertical
    rate (m/s), the number of each, the σ the fit gave them and the outliers left out.
    """
    from scipy.interpolate import make_interp_spline

    from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef

    if obs is None:
        return None
    s = samples
    r = np.stack(geodetic_to_ecef(s.lat, s.lon, s.h, ellipsoid), -1)
    sp = make_interp_spline(s.t, r, k=5)
    out: dict[str, Any] = {
        "columns": list(obs.names),
        "sigma_h_m_s": float(obs.sigma[0]),
        "sigma_v_m_s": float(obs.sigma[1]),
        "outliers": int(obs.outliers),
    }

    def enu(tt: np.ndarray) -> np.ndarray:
        lat, lon = (np.interp(tt, s.t, x) for x in (s.lat, s.lon))
        return np.einsum("nij,nj->ni", C_e_to_enu(lat, lon), sp(tt, 1))

    def stats(x: np.ndarray) -> tuple[float, float]:
        return (float(np.sqrt(np.mean(x**2))), float(np.max(np.abs(x)))) if x.size else (0, 0)

    if obs.h is not None:
        tt = obs.h.t - t_start
        inside = (tt >= s.t[0]) & (tt <= s.t[-1])
        v = enu(tt[inside])
        en = obs.east_north[inside]
        gs_f, gs_o = np.hypot(v[:, 0], v[:, 1]), np.hypot(en[:, 0], en[:, 1])
        d_gs = gs_f - gs_o
        fast = (gs_o > MOVING) & (gs_f > MOVING)
        d_tr = np.degrees(
            np.angle(np.exp(1j * (np.arctan2(v[fast, 0], v[fast, 1]) - np.arctan2(*en[fast].T))))
        )
        out["horizontal_count"] = int(inside.sum())
        out["groundspeed_rms_m_s"], out["groundspeed_max_m_s"] = stats(d_gs)
        out["track_rms_deg"], out["track_max_deg"] = stats(d_tr)
        out["east_north_rms_m_s"] = stats(np.linalg.norm(v[:, :2] - en, axis=1) / np.sqrt(2))[0]
    if obs.v is not None:
        tt = obs.v.t - t_start
        inside = (tt >= s.t[0]) & (tt <= s.t[-1])
        d_v = enu(tt[inside])[:, 2] - obs.up[inside]
        out["vertical_count"] = int(inside.sum())
        out["vertical_rate_rms_m_s"], out["vertical_rate_max_m_s"] = stats(d_v)
    return out
