"""The cleaning steps of :mod:`fieldmap.nav.conditioning`: order, stale values, outliers, breaks.

Internal: :func:`fieldmap.nav.conditioning.condition` runs them. Positions are handled as the
ECEF of the ellipsoid-surface point (``p``, m) with its local east/north axes (``en``), heights
on their own; every function works on one segment of ordered samples.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import Ellipsoid
from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
from fieldmap.nav import conditioning_fit as cfit
from fieldmap.nav.spelling import advice

#: running-median half-window (samples): about HALF_SPAN_S seconds, within HALF_MIN..HALF_MAX
HALF_MAX, HALF_SPAN_S, HALF_MIN = 7, 15.0, 2
#: an outlier burst lasts at most BURST_S seconds and HALF_MAX samples; longer runs are motion
BURST_S = 10.0
#: the outlier scale is taken over ±SCALE_HALF samples
SCALE_HALF = 50
#: smallest outlier offsets and jump margins (m): horizontal, vertical (or 3 height quanta)
FLOOR_H, FLOOR_V = 30.0, 15.0
#: a height held and then left faster than this (m/s) was not updated
HOLD_RATE = 50.0
#: ground: within this height (m) of the segment's first (last) height
GROUND_DH = 30.0


def median_interval(t: np.ndarray) -> float:
    """Return the median sample interval of ``t`` (s); 1 for fewer than two samples."""
    return float(np.median(np.diff(t))) if t.size > 1 else 1.0


def burst_length(t: np.ndarray) -> int:
    """Longest outlier burst (samples) at the sampling of ``t``: 7 at 1 Hz, 1 at 10 s."""
    return int(np.clip(BURST_S // max(median_interval(t), 1e-9), 1, HALF_MAX))


def half_window(t: np.ndarray) -> int:
    """Running-median half-window (samples) at the sampling of ``t``."""
    return int(np.clip(round(HALF_SPAN_S / max(median_interval(t), 1e-9)), HALF_MIN, HALF_MAX))


def to_en(en: np.ndarray, e: np.ndarray) -> np.ndarray:
    """ECEF vectors ``e`` (n, 3) to local east/north components (n, 2)."""
    return np.einsum("nij,nj->ni", en, e)


def runs(same: np.ndarray) -> Iterator[tuple[int, int]]:
    """(first, last) index of each run of equal values; ``same[i]``: value i+1 equals value i."""
    starts = np.flatnonzero(~np.concatenate([[False], same]))
    ends = np.append(starts[1:], same.size + 1) - 1
    keep = ends > starts
    return zip(starts[keep].tolist(), ends[keep].tolist())


class OrderedLog:
    """The samples of a track in time order, without repeated times (step 1 of conditioning).

    Attributes ``t, lat, lon, h, lines`` (longitude unwrapped), ``source``, the counts
    ``n_in, n_invalid, n_reordered, n_duplicates`` and the first line of each kind.
    """

    def __init__(self, track, ellipsoid: Ellipsoid, reorder: bool):
        src = self.source = str(getattr(track, "source", "flight"))
        arrs = [
            np.asarray(getattr(track, k), dtype=np.float64).ravel()
            for k in ("t", "lat", "lon", "h")
        ]
        n = arrs[0].size
        lines = getattr(track, "lines", None)
        lines = np.arange(1, n + 1) if lines is None else np.asarray(lines, dtype=np.int64).ravel()
        for name, a in zip(("lat", "lon", "h", "lines"), arrs[1:] + [lines]):
            if a.size != n:
                raise InputError(f"{src}: {a.size} values of {name}, {n} times")
        finite = np.all(np.isfinite(np.stack(arrs)), axis=0)
        self.n_in, self.n_invalid = n, int(n - finite.sum())
        self.first_invalid_line = int(lines[~finite][0]) if self.n_invalid else None
        t, lat, lon, h = (a[finite] for a in arrs)
        lines = lines[finite]
        for name, v, lim in (("latitude", lat, 90.0), ("longitude", lon, 540.0)):
            bad = np.flatnonzero(np.abs(v) > lim)
            if bad.size:
                raise InputError(
                    f"{src} line {lines[bad[0]]}: {name} {v[bad[0]]:g} is beyond ±{lim:g} degrees"
                )
        back = np.flatnonzero(t[1:] < np.maximum.accumulate(t)[:-1]) + 1
        self.n_reordered = int(back.size)
        self.first_reordered_line = int(lines[back[0]]) if back.size else None
        if back.size:
            if not reorder:
                i, tip = back[0], advice("reorder", True)
                raise InputError(
                    f"{src} line {lines[i]}: time {t[i]:.3f} s goes back from the previous "
                    f"{t[i - 1]:.3f} s (line {lines[i - 1]})"
                    + (f"; {tip} to sort the log" if tip else "")
                )
            order = np.argsort(t, kind="stable")
            t, lat, lon, h, lines = t[order], lat[order], lon[order], h[order], lines[order]
        dup = np.concatenate([[False], np.diff(t) == 0.0])
        self.n_duplicates = int(dup.sum())
        self.first_duplicate_line = int(lines[dup][0]) if dup.any() else None
        self.t, self.lat, self.lon, self.h, self.lines = (a[~dup] for a in (t, lat, lon, h, lines))
        self.lon = np.degrees(np.unwrap(np.radians(self.lon)))
        self.ellipsoid = ellipsoid
        self.p = self.en = np.zeros((0, 3))

    def geometry(self) -> None:
        """Surface ECEF positions ``p`` (n, 3) and the local east/north rows ``en`` (n, 2, 3)."""
        zero = np.zeros_like(self.h)
        self.p = np.stack(geodetic_to_ecef(self.lat, self.lon, zero, self.ellipsoid), -1)
        self.en = C_e_to_enu(self.lat, self.lon)[:, :2, :]

    def stale_positions(self) -> np.ndarray:
        """Find samples repeating the previous horizontal position while the vehicle moves.

        A run of one position is stale after its first sample when the next position is over
        1 m/s away: a receiver re-sending its last position (ADS-B state vectors).
        """
        n = self.t.size
        st = np.zeros(n, bool)
        for s, e in runs((self.lat[1:] == self.lat[:-1]) & (self.lon[1:] == self.lon[:-1])):
            a, b = (s, e + 1) if e + 1 < n else (max(s - 1, 0), s)
            if b > a and np.linalg.norm(self.p[b] - self.p[a]) > self.t[b] - self.t[a]:
                st[s + 1 : e + 1] = True
        return st


def stale_heights(t: np.ndarray, h: np.ndarray, dh_min: float) -> np.ndarray:
    """Find the samples of a held height (n,): a run of one value that then jumps.

    The run is stale after its first sample when the next height differs by more than
    ``dh_min`` and faster than :data:`HOLD_RATE` from the run's last sample: the height was
    not updated (OpenSky state vectors). Level flight holds its quantised height too, but
    leaves it by one quantum, or slowly.
    """
    st = np.zeros(t.size, bool)
    for s, e in runs(np.abs(np.diff(h)) <= cfit.HEIGHT_EQ):
        if e + 1 < t.size:
            dh = abs(h[e + 1] - h[e])
            if dh > dh_min and dh > HOLD_RATE * (t[e + 1] - t[e]):
                st[s + 1 : e + 1] = True
    return st


def jumps(t: np.ndarray, y: np.ndarray, max_speed: float, margin: float) -> np.ndarray:
    """Flag steps between samples faster than ``max_speed`` beyond ``margin`` m, (n-1,)."""
    if t.size < 2:
        return np.zeros(0, bool)
    return np.linalg.norm(np.diff(y, axis=0), axis=1) > max_speed * np.diff(t) + margin


def outliers(
    t: np.ndarray,
    y: np.ndarray,
    valid: np.ndarray,
    proj: Callable[[np.ndarray], np.ndarray],
    k: float,
    floor: float,
    max_speed: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Outliers (n,) and offsets (m, (n,)) of one component (``y`` (n, d)) of one segment.

    Hampel identifier (Hampel 1974): offsets from the robust trend of the valid samples not
    yet rejected (:func:`~fieldmap.nav.conditioning_fit.robust_trend`, ``proj`` maps them to
    the local axes) beyond ``max(k s, floor)``, ``s`` the local robust scale
    (:func:`~fieldmap.nav.conditioning_fit.local_scale`), iterated to a fixed point (a sample
    rejected early is taken back when the cleaner trend passes near it). A run of rejections
    longer than a burst (:func:`burst_length`) is motion the trend misses, kept. Then short runs
    between jumps (steps faster than ``max_speed``) are rejected: bursts of any size.
    """
    keep = valid.copy()
    off = np.zeros(t.size)
    vidx = np.flatnonzero(valid)
    if vidx.size < 3:
        return np.zeros(t.size, bool), off
    burst, half = burst_length(t[vidx]), half_window(t[vidx])
    for _ in range(12):
        idx = np.flatnonzero(keep)
        if idx.size < 3:
            break
        ref = cfit.robust_trend(t[idx], y[idx], half)
        e = proj(y - cfit.interpolate_trend(t[idx], ref, t))
        off = np.linalg.norm(e, axis=1)
        s = np.interp(t, t[idx], cfit.local_scale(off[idx], e.shape[1], SCALE_HALF))
        far = valid & (off > np.maximum(k * s, floor))
        d = np.diff(np.concatenate([[0], far[vidx].astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            if b - a > burst:
                far[vidx[a:b]] = False
        if np.array_equal(valid & ~far, keep):
            break
        keep = valid & ~far
    idx = np.flatnonzero(keep)
    jump = jumps(t[idx], y[idx], max_speed, floor)
    edges = np.concatenate([[0], np.flatnonzero(jump) + 1, [idx.size]])
    if jump.any() and (np.diff(edges) > burst).any():
        for a, b in zip(edges[:-1], edges[1:]):
            if b - a <= burst:
                keep[idx[a:b]] = False
    return valid & ~keep, off


def segments(
    t: np.ndarray, comps: list[tuple[np.ndarray, np.ndarray, float, float]], max_gap: float
) -> tuple[np.ndarray, list[tuple[int, int, str]]]:
    """Segment number of each sample (-1: inside a break of one component), and the breaks.

    ``comps``: (valid mask, values (n, d), speed limit, margin) per component. A break is a gap
    longer than ``max_gap`` or a jump (:func:`jumps`) between consecutive valid samples;
    breaks are (index before, index after, ``"gap"`` or ``"jump"``).
    """
    found: dict[tuple[int, int], str] = {}
    for mask, y, vmax, margin in comps:
        idx = np.flatnonzero(mask)
        dt = np.diff(t[idx])
        jump = jumps(t[idx], y[idx], vmax, margin) & (dt <= max_gap)
        for j in np.flatnonzero((dt > max_gap) | jump):
            key = (int(idx[j]), int(idx[j + 1]))
            found[key] = "jump" if jump[j] or found.get(key) == "jump" else "gap"
    breaks = [(a, b, kind) for (a, b), kind in found.items()]
    seg = np.zeros(t.size, np.int64)
    inside = np.zeros(t.size, bool)
    for a, b, _ in breaks:
        seg[b:] += 1
        inside[a + 1 : b] = True
    seg[inside] = -1
    return seg, sorted(breaks)


def ground(
    t: np.ndarray, p: np.ndarray, h: np.ndarray, hv: np.ndarray, vv: np.ndarray, min_speed: float
) -> np.ndarray:
    """Leading and trailing ground samples (n,) of one segment.

    Ground: robust ground speed (running median of the step velocities) below ``min_speed``
    and height within :data:`GROUND_DH` of the segment's first (last) height, from the start
    (end) up to the first sample that is not: taxi, parking, the first part of a take-off run.
    """
    n = t.size
    out = np.zeros(n, bool)
    idx, vidx = np.flatnonzero(hv), np.flatnonzero(vv)
    if idx.size < 3 or vidx.size < 1:
        return out
    dt = np.diff(t[idx])
    v = cfit.running_median(np.diff(p[idx], axis=0) / dt[:, None], half_window(t[idx]))
    speed = np.interp(t, 0.5 * (t[idx][1:] + t[idx][:-1]), np.linalg.norm(v, axis=1))
    hk = np.interp(t, t[vidx], h[vidx])
    for order, end in ((np.arange(n), vidx[0]), (np.arange(n)[::-1], vidx[-1])):
        slow = (speed[order] < min_speed) & (np.abs(hk[order] - h[end]) < GROUND_DH)
        out[order[: n if slow.all() else int(np.argmin(slow))]] = True
    return out
