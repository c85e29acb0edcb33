"""The pipeline of :func:`fieldmap.nav.conditioning.condition`: its steps on one log.

Internal. :class:`Stages` runs steps 1-4 (order, stale values, outliers, breaks, ground) on
construction and steps 6-7 (noise, the robust penalised spline, the vehicle limits) per segment
in :meth:`Stages.fit`; see :mod:`fieldmap.nav.conditioning` for the method.
"""

from __future__ import annotations

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import Ellipsoid
from fieldmap.field.frames import ecef_to_geodetic
from fieldmap.nav import conditioning_fit as cfit
from fieldmap.nav import conditioning_steps as steps
from fieldmap.nav.conditioning_report import (
    DROPPED,
    GAP,
    GROUND,
    KEPT,
    OUTLIER_H,
    OUTLIER_HV,
    OUTLIER_V,
    STALE,
    STATUS_NAMES,
)
from fieldmap.nav.flight import MIN_POINTS, FlightSamples
from fieldmap.nav.spelling import advice, keyword
from fieldmap.units import STANDARD_GRAVITY as G0

#: vehicle limits: aim below LIMIT_MARGIN × the bound; at most LIMIT_ITER softenings
LIMIT_MARGIN, LIMIT_ITER = 0.9, 12
#: grid nodes beyond the data at either end
EDGE = 8
#: smallest noise σ (m) estimated
SIGMA_MIN = 0.05
#: local noise: RMS over ±NOISE_HALF samples, at least NOISE_FRAC × the segment's
NOISE_HALF, NOISE_FRAC = 25, 0.3
#: quantised heights repeated this long (s) are level flight
LEVEL_S = 20.0
#: a vehicle that stays within STILL_H metres horizontally and STILL_V vertically of one place
#: never moved beyond the noise of its fixes (the outlier floors): not a flight
STILL_H, STILL_V = steps.FLOOR_H, steps.FLOOR_V


def _named(text: str, name: str) -> str:
    """``text`` followed by the option that sets it, where the reader can set it."""
    option = keyword(name)
    return f"{text} ({option})" if option else text


class Stages:
    """Steps 1-4 on construction; :meth:`fit` does 6-7 for one segment."""

    def __init__(self, track, opts: dict, reorder: bool, ellipsoid: Ellipsoid):
        self.track, self.opts = track, opts
        self.log = log = steps.OrderedLog(track, ellipsoid, reorder)
        n = log.t.size
        z = np.zeros(n, bool)
        self.stale, self.stale_v, self.out_h, self.out_v = z.copy(), z.copy(), z.copy(), z.copy()
        self.ground, self.in_gap, self.dropped_mask = z.copy(), z.copy(), z.copy()
        self.off_h, self.off_v = np.zeros(n), np.zeros(n)
        self.quantum = cfit.height_quantum(log.h)
        self.breaks: list[tuple[int, int, str]] = []
        self.dropped: list[dict] = []
        self.seg = np.zeros(n, np.int64)
        self.hv, self.vv = ~z, ~z
        if not opts["smooth"] or n < 3:
            return
        o, q = opts, self.quantum
        floor_v = max(3.0 * q, steps.FLOOR_V)
        log.geometry()
        self.stale = log.stale_positions()
        hv, vv = ~self.stale, ~z
        comps = [(hv, log.p, np.inf, 0.0), (vv, log.h[:, None], np.inf, 0.0)]
        seg, _ = steps.segments(log.t, comps, o["max_gap_s"])
        for s in np.unique(seg[seg >= 0]):
            m = np.flatnonzero(seg == s)
            en, tt, k = log.en[m], log.t[m], o["threshold"]
            bad_h, self.off_h[m] = steps.outliers(
                tt,
                log.p[m],
                hv[m],
                lambda e: steps.to_en(en, e),
                k,
                steps.FLOOR_H,
                o["max_speed_mps"],
            )
            bad_v, self.off_v[m] = steps.outliers(
                tt, log.h[m, None], vv[m], lambda e: e, k, floor_v, o["max_climb_mps"]
            )
            self.out_h[m[bad_h]], self.out_v[m[bad_v]] = True, True
        hv &= ~self.out_h
        vv &= ~self.out_v
        iv = np.flatnonzero(vv)
        self.stale_v[iv] = steps.stale_heights(log.t[iv], log.h[iv], floor_v)
        vv &= ~self.stale_v
        comps = [
            (hv, log.p, o["max_speed_mps"], steps.FLOOR_H),
            (vv, log.h[:, None], o["max_climb_mps"], floor_v),
        ]
        seg, self.breaks = steps.segments(log.t, comps, o["max_gap_s"])
        self.in_gap = seg < 0
        if o["airborne_only"]:
            for s in np.unique(seg[seg >= 0]):
                m = np.flatnonzero(seg == s)
                g = steps.ground(log.t[m], log.p[m], log.h[m], hv[m], vv[m], o["min_speed_mps"])
                self.ground[m[g]] = True
                seg[m[g]] = -1
        self.hv, self.vv, self.seg = hv & (seg >= 0), vv & (seg >= 0), seg

    def status(self) -> np.ndarray:
        """Each ordered sample's fate, codes of :data:`STATUS_NAMES`."""
        st = np.full(self.log.t.size, KEPT, np.int64)
        for mask, code in (
            (self.dropped_mask, DROPPED),
            (self.ground, GROUND),
            (self.in_gap, GAP),
            (self.stale | self.stale_v, STALE),
            (self.out_v, OUTLIER_V),
            (self.out_h, OUTLIER_H),
            (self.out_h & self.out_v, OUTLIER_HV),
        ):
            st[mask] = code
        return st

    def segment_ids(self) -> list[int]:
        """Segments with at least 6 usable samples of each component, in time order."""
        out = []
        for s in np.unique(self.seg[self.seg >= 0]):
            m = self.seg == s
            if (self.hv & m).sum() >= MIN_POINTS and (self.vv & m).sum() >= MIN_POINTS:
                out.append(int(s))
        return out

    def longest(self, ids: list[int]) -> int | None:
        """Pick the longest segment (duration); record the others as dropped."""
        if not ids:
            return None
        t, lines = self.log.t, self.log.lines
        best = ids[int(np.argmax([np.ptp(t[self.seg == s]) for s in ids]))]
        for s in ids:
            if s != best:
                m = np.flatnonzero(self.seg == s)
                self.dropped.append(
                    {
                        "t_start_s": float(t[m[0]]),
                        "t_end_s": float(t[m[-1]]),
                        "lines": [int(lines[m[0]]), int(lines[m[-1]])],
                        "samples": int(m.size),
                    }
                )
                self.dropped_mask[m] = True
        return best

    def refuse_break(self, ids: list[int]) -> None:
        """Raise an :class:`InputError` naming the break between the first two segments."""
        t, lines = self.log.t, self.log.lines
        a = int(np.flatnonzero(self.seg == ids[0])[-1])
        b = int(np.flatnonzero(self.seg == ids[1])[0])
        kind = next((k for i, j, k in self.breaks if a <= i < b or a < j <= b), "gap")
        o, tip = self.opts, advice("on_long_gap", "longest")
        why = (
            "more than " + _named(f"{o['max_gap_s']:g} s", "max_gap_s") + ": raise the limit"
            if kind == "gap"
            else f"a position or height jump (faster than {o['max_speed_mps']:g} m/s "
            f"horizontally or {o['max_climb_mps']:g} m/s vertically)"
        )
        raise InputError(
            f"{self.log.source} lines {lines[a]}..{lines[b]}: the flight breaks for "
            f"{t[b] - t[a]:.1f} s (t = {t[a]:.1f} .. {t[b]:.1f} s), {why}"
            + (f"; {tip} to fly the longest segment" if tip else "")
        )

    def refuse_still(self, idx: np.ndarray | None = None) -> None:
        """Refuse a log (its samples ``idx``; default all) whose vehicle never moves.

        Within :data:`STILL_H` m horizontally and :data:`STILL_V` m vertically of one place from
        the first sample to the last, a vehicle moved no more than the noise of its fixes: the
        log is no flight, whatever is trimmed or smoothed.
        """
        log = self.log
        i = np.arange(log.t.size) if idx is None else np.asarray(idx)
        if i.size < 2:
            return
        if log.p.shape[0] != log.t.size:
            log.geometry()
        p = log.p[i]
        across = float(np.max(np.linalg.norm(p - np.median(p, axis=0), axis=1)))
        up = float(np.ptp(log.h[i]))
        if across < STILL_H and up < STILL_V:
            raise InputError(
                f"{log.source} lines {log.lines[i[0]]}..{log.lines[i[-1]]}: not a flight: the "
                f"vehicle never moves (its {i.size} samples over {np.ptp(log.t[i]):g} s stay "
                f"within {STILL_H:g} m horizontally and {STILL_V:g} m vertically of one place)"
            )

    def nothing_left(self) -> None:
        """Raise the reason no segment can be flown."""
        log, st, o = self.log, self.status(), self.opts
        n, src = log.t.size, log.source
        if n < MIN_POINTS:
            raise InputError(
                f"{src}: {n} usable samples (of {log.n_in}), a flight needs at least {MIN_POINTS}"
            )
        self.refuse_still()
        counts = {STATUS_NAMES[c]: int((st == c).sum()) for c in np.unique(st)}
        where = f"{src} lines {log.lines[0]}..{log.lines[-1]}"
        if counts.get("ground", 0) >= 0.5 * n:
            tip = advice("airborne_only", False)
            raise InputError(
                f"{where}: no airborne part: the vehicle stays slower than "
                + _named(f"{o['min_speed_mps']:g} m/s", "min_speed_mps")
                + f" near its first/last height ({counts['ground']} of {n} samples on the "
                "ground)" + (f"; {tip} to keep ground movement" if tip else "")
            )
        what = ", ".join(f"{v} {k}" for k, v in counts.items())
        dtm, gap = steps.median_interval(log.t), keyword("max_gap_s")
        hint = ""
        if dtm > o["max_gap_s"]:
            hint = f"; the samples are {dtm:g} s apart" + (f": raise {gap}" if gap else "")
        raise InputError(
            f"{where}: no stretch of at least {MIN_POINTS} usable samples without a gap over "
            + _named(f"{o['max_gap_s']:g} s", "max_gap_s")
            + f" or a jump ({what}){hint}"
        )

    def _noise(self, hi: np.ndarray, vi: np.ndarray):
        """σ (horizontal, vertical), per-sample σ of each, vertical noise energies, estimated."""
        log, q, sig = self.log, self.quantum, self.opts["position_noise_m"]
        if sig is None:
            k = self.opts["threshold"]
            zh = steps.to_en(log.en[hi[2:-2]], cfit.loo_noise(log.t[hi], log.p[hi]))
            zv = cfit.loo_noise(log.t[vi], log.h[vi, None])
            nh = cfit.noise_sigma(zh, k, 0.0, NOISE_HALF, NOISE_FRAC)
            nv = cfit.noise_sigma(zv, k, 3.0 * q, NOISE_HALF, NOISE_FRAC)
            if q > 0.0:  # quantised: q²/12 (or more) wherever not level; uniform
                moving = ~cfit.level_runs(log.t[vi], log.h[vi], LEVEL_S)[2:-2]
                sv = max(cfit.noise_sigma(zv[moving], k, 3.0 * q)[0], q / np.sqrt(12.0))
                nv = (sv, np.full(vi.size, sv))
            sig = [max(nh[0], SIGMA_MIN), max(nv[0], SIGMA_MIN)]
            loc = [np.maximum(nh[1], SIGMA_MIN), np.maximum(nv[1], SIGMA_MIN)]
        else:
            loc = [np.full(hi.size, sig[0]), np.full(vi.size, sig[1])]
        energy = loc[1] ** 2
        if q > 0.0:  # a long run of one height is level flight: it leaves no residual
            energy[cfit.level_runs(log.t[vi], log.h[vi], LEVEL_S)] = 0.0
        return sig, loc, energy, self.opts["position_noise_m"] is None

    def fit(self, s: int | None) -> dict:
        """Smooth segment ``s`` and resample it (steps 6-7); the pieces for the report."""
        if s is None:
            self.nothing_left()
        log, q = self.log, self.quantum
        m = self.seg == s
        hi, vi = np.flatnonzero(self.hv & m), np.flatnonzero(self.vv & m)
        self.refuse_still(np.union1d(hi, vi))
        sig, loc, energy, estimated = self._noise(hi, vi)
        t_lo, t_hi = max(log.t[hi[0]], log.t[vi[0]]), min(log.t[hi[-1]], log.t[vi[-1]])
        inh, inv = ((log.t[i] >= t_lo) & (log.t[i] <= t_hi) for i in (hi, vi))
        hi, vi, loc, energy = hi[inh], vi[inv], [loc[0][inh], loc[1][inv]], energy[inv]
        dt = self.opts["dt_out"] or float(
            np.clip(steps.median_interval(np.unique(log.t[np.concatenate([hi, vi])])), 0.1, 1.0)
        )
        ng = int(np.floor((t_hi - t_lo) / dt + 1e-9)) + 1
        if ng < MIN_POINTS or hi.size < MIN_POINTS or vi.size < MIN_POINTS:
            raise InputError(
                f"{log.source} lines {log.lines[hi[0]]}..{log.lines[hi[-1]]}: the flight lasts "
                f"{t_hi - t_lo:.1f} s, {ng} samples at {dt:g} s, fewer than {MIN_POINTS}"
            )
        # EDGE nodes past the data: there the penalty alone shapes the path (straight), so the
        # first and last samples are interior nodes, not free ends
        grid = (float(t_lo) - EDGE * dt, dt, ng + 2 * EDGE)
        th, tv, ph, hh = log.t[hi], log.t[vi], log.p[hi], log.h[vi, None]
        fh = cfit.fit_path(grid, th, ph, loc[0], 2, max_run=steps.burst_length(th))
        fv = cfit.fit_path(
            grid,
            tv,
            hh,
            loc[1],
            1,
            energy=energy,
            edf_correction=q == 0.0,
            floor=3.0 * q,
            max_run=steps.burst_length(tv),
        )
        self.out_h[hi[fh["outlier"]]], self.out_v[vi[fv["outlier"]]] = True, True
        keep_h, keep_v = ~fh["outlier"], ~fv["outlier"]
        hi, vi, loc = hi[keep_h], vi[keep_v], [loc[0][keep_h], loc[1][keep_v]]
        gh, gv, softened = self._limits(grid, hi, vi, loc, fh, fv)
        tg = t_lo + dt * np.arange(ng)
        gh, gv = gh[EDGE : EDGE + ng], gv[EDGE : EDGE + ng]
        lat, lon, _ = ecef_to_geodetic(gh[:, 0], gh[:, 1], gh[:, 2], log.ellipsoid)
        lon = np.degrees(np.unwrap(np.radians(lon)))
        lon += 360.0 * np.round((log.lon[hi[0]] - lon[0]) / 360.0)
        used = np.union1d(hi, vi)
        near = used[np.clip(np.searchsorted(log.t[used], tg), 0, used.size - 1)]
        samples = FlightSamples(
            tg - t_lo, lat, lon, gv[:, 0], None, log.source, log.lines[near], float(t_lo)
        )
        inside = np.flatnonzero(m & (log.t >= t_lo) & (log.t <= t_hi))
        rows = cfit.lagrange_rows(t_lo, dt, ng, log.t[inside])
        self.off_h[inside] = np.linalg.norm(
            steps.to_en(log.en[inside], log.p[inside] - cfit.on_grid(gh, rows)), axis=1
        )
        self.off_v[inside] = np.abs(log.h[inside] - cfit.on_grid(gv, rows)[:, 0])
        rms = (
            float(np.sqrt(np.mean(self.off_h[hi] ** 2) / 2.0)),
            float(np.sqrt(np.mean(self.off_v[vi] ** 2))),
        )
        return {
            "samples": samples,
            "sigma": sig,
            "sigma_estimated": estimated,
            "rms": rms,
            "lam": (fh["lam"], fv["lam"]),
            "edf": (fh["edf"], fv["edf"]),
            "hi": hi,
            "vi": vi,
            "t_lo": float(t_lo),
            "t_hi": float(t_hi),
            "dt_out": dt,
            "softened": softened,
        }

    def _limits(self, grid, hi, vi, loc, fh, fv):
        """Step 7: soften the fits where the path as flown exceeds the vehicle limits.

        Where the acceleration or jerk of the quintic through the output
        (:func:`~fieldmap.nav.conditioning_fit.quintic_kinematics`) exceeds
        ``LIMIT_MARGIN × max_accel_g`` or ``× max_jerk``, the σ of the samples nearby is raised
        (twice within two sample intervals, tapering to none at four) for the component(s)
        carrying at least half of it; both are refitted at the same λ, up to
        :data:`LIMIT_ITER` times. Returns the grid values and the number of samples softened.
        """
        log, o = self.log, self.opts
        gh, gv = fh["g"], fv["g"]
        a_max = np.inf if o["max_accel_g"] is None else o["max_accel_g"] * G0 * LIMIT_MARGIN
        j_max = np.inf if o["max_jerk"] is None else o["max_jerk"] * LIMIT_MARGIN
        if np.isinf(a_max) and np.isinf(j_max):
            return gh, gv, 0
        t0, dt, ng = grid
        out = slice(EDGE, ng - EDGE)
        tg = t0 + dt * np.arange(ng)[out]
        touched = np.zeros(log.t.size, bool)
        span = 2.0 * max(dt, steps.median_interval(log.t[hi]))
        for _ in range(LIMIT_ITER):
            (ah, jh), (av, jv) = (cfit.quintic_kinematics(g[out], dt) for g in (gh, gv))
            acc, jerk = np.hypot(ah, av), np.hypot(jh, jv)
            bad = (acc > a_max) | (jerk > j_max)
            if not bad.any():
                break
            for k, (idx, a, j) in enumerate(((hi, ah, jh), (vi, av, jv))):
                tb = tg[bad & ((a >= 0.5 * acc) | (j >= 0.5 * jerk))]
                if tb.size:
                    pos = np.searchsorted(tb, log.t[idx])
                    d = np.minimum(
                        np.abs(log.t[idx] - tb[np.clip(pos - 1, 0, tb.size - 1)]),
                        np.abs(log.t[idx] - tb[np.clip(pos, 0, tb.size - 1)]),
                    )
                    f = np.clip(3.0 - d / span, 1.0, 2.0)
                    loc[k] = loc[k] * f
                    touched[idx[f > 1.0]] = True
            gh = cfit.refit(grid, log.t[hi], log.p[hi], loc[0], fh["lam"])[0]
            gv = cfit.refit(grid, log.t[vi], log.h[vi, None], loc[1], fv["lam"])[0]
        return gh, gv, int(touched.sum())

    def exact(self) -> dict:
        """``smooth=False``: the ordered samples themselves."""
        log = self.log
        if log.t.size < MIN_POINTS:
            self.nothing_left()
        self.refuse_still()
        samples = FlightSamples(
            log.t - log.t[0], log.lat, log.lon, log.h, None, log.source, log.lines, float(log.t[0])
        )
        idx = np.arange(log.t.size)
        return {
            "samples": samples,
            "sigma": None,
            "sigma_estimated": False,
            "rms": (0.0, 0.0),
            "lam": (0.0, 0.0),
            "edf": (0.0, 0.0),
            "hi": idx,
            "vi": idx,
            "t_lo": float(log.t[0]),
            "t_hi": float(log.t[-1]),
            "dt_out": None,
            "softened": 0,
        }
