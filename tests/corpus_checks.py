r"""A flown corpus piece checked against what the aircraft itself reported (issue 34).

:func:`check_piece` takes a piece of ``tests/data/corpus/`` and the path that
:func:`fieldmap.nav.logs.load_flight` made of it, and measures, from the flown samples and the
raw log only (nothing of the conditioning's own report is read):

- the flown path's largest ground speed against the log's robust maximum, the 99.5th
  percentile (NumPy's linear interpolation) of its ``groundspeed`` column (every row that has
  one, read from the CSV itself, kt → m/s), so that one bad value does not set it: the
  issue's rule for a *suspect* path (:meth:`CorpusCheck.suspect`);
- the flown path's ground speed against what the aircraft reported *when it flew it*: at
  each instant, the larger of that robust maximum and the reported speed there (the running
  median of three consecutive reports, interpolated linearly in time, so that one bad report
  does not set it either). This is the corpus test's speed rule
  (:meth:`CorpusCheck.corpus_reasons`). The 99.5th percentile alone fails a path that flies
  exactly the reports wherever the aircraft's top speed lasts less than 0.5 % of the log (a
  calibration turboprop's one dive at 132 m/s in a log whose 99.5th percentile is 124):
  compared where it is flown, the top speed is judged against the reports of its own time.
  It is never stricter than the issue's rule: a path faster than the reports there but under
  1.05 × the log's 99.5th percentile meets both;
- the specific force of the flown path, its least and largest magnitude (g);
- the fraction of the log's span (first to last fix) that the flown path covers; the rows of
  a frozen end (the last rows repeating every value of the row before them:
  :func:`last_new_row_time`) are no fixes, neither here nor below;
- the fraction of the log's fixes (rows that :func:`~fieldmap.nav.logs.read.read_track` keeps)
  whose height is within ``k_sigma`` σ of the flown path's height at the fix's time (a fix
  outside the flown span counts as not within), with the worst offset and its line. The σ
  of a fix is :math:`\sqrt{\sigma_h^2 + (\dot z\,\sigma_\tau)^2}`: the height's noise and,
  where the fixes' time stamps err with σ :math:`\sigma_\tau` (the conditioning's estimate
  from the positions' along-track residuals), the height the path climbs in that time
  (:math:`\dot z` the flown path's vertical speed at the fix's time; 0 without time errors);
- how far the flown path passes from the log's positions: the horizontal distance of each
  flown-past fix from the path at its time, its median and 95th percentile (not a check: a
  measure of where the path flies, for the benchmark and the notes).

The flown path is the quintic interpolating spline (``make_interp_spline``, k = 5) of the
samples in ECEF: the path :class:`~fieldmap.nav.trajectory.FlightTrajectory` flies. It is
evaluated at the samples and half-way between them. The specific force is

.. math::

    \mathbf f = \ddot{\mathbf r}_e + 2\,\boldsymbol\Omega\times\dot{\mathbf r}_e
    + \gamma(\varphi, h)\,\mathbf u

with :math:`\ddot{\mathbf r}_e, \dot{\mathbf r}_e` the spline's ECEF derivatives,
:math:`\mathbf u` the ellipsoidal normal (up) and :math:`\gamma` normal gravity: Somigliana's
formula at the ellipsoid (Heiskanen & Moritz 1967 eq. 2-78) with the second-order height
expansion (eq. 2-124). At rest it is 1 g up.

:func:`path_kinematics` does the same for any samples (``bench_corpus.py`` measures
``traffic``'s smoother with it), so both methods are measured with one yardstick.
"""

from __future__ import annotations

import csv
import gzip
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic, geodetic_to_ecef
from fieldmap.nav.logs.read import _iso, read_track
from fieldmap.units import STANDARD_GRAVITY as G0

KT = 1852.0 / 3600.0
FT_PER_MIN = 0.3048 / 60.0
#: the issue's "suspect" rules: flown ground speed over this factor of the log's robust maximum
SPEED_FACTOR = 1.05
#: ... specific force outside this range (g) for an aircraft that is not aerobatic
SPECIFIC_FORCE_RANGE = (0.3, 1.8)
#: ... less than this fraction of the log's span flown
MIN_FLOWN = 0.90
#: the corpus test's rules (stricter): at least this fraction of the log's span flown ...
CORPUS_MIN_FLOWN = 0.95
#: ... and at least this fraction of the fixes' heights within ``k_sigma`` σ of the path
CORPUS_MIN_WITHIN = 0.99


@dataclass(frozen=True)
class PathKinematics:
    """Peaks of a path through samples (see :func:`path_kinematics`).

    Attributes
    ----------
    max_ground_speed_m_s : float
        Largest horizontal speed. Units: m/s.
    max_ground_speed_t_s : float
        Its time, from the first sample. Units: s.
    specific_force_min_g, specific_force_max_g : float
        Least and largest magnitude of the specific force. Units: g (9.80665 m/s²).
    specific_force_worst_t_s : float
        Time of the magnitude furthest from 1 g, from the first sample. Units: s.
    """

    max_ground_speed_m_s: float
    max_ground_speed_t_s: float
    specific_force_min_g: float
    specific_force_max_g: float
    specific_force_worst_t_s: float


@dataclass(frozen=True)
class CorpusCheck:
    """A flown piece against its log (see the module docstring).

    Attributes
    ----------
    source : str
        The piece's file.
    reported_gs_max_m_s : float or None
        The log's robust maximum ground speed (99.5th percentile of its ``groundspeed``
        column); None when the log has none. Units: m/s.
    flown : PathKinematics
        The flown path's peaks.
    speed_ratio : float or None
        The largest ratio, over the path's instants, of its ground speed to the larger of
        ``reported_gs_max_m_s`` and the speed reported there (the module docstring); None
        when the log reports none.
    speed_ratio_p995 : float or None
        ``flown.max_ground_speed_m_s / reported_gs_max_m_s`` (the issue's suspect rule).
    speed_worst_t_s, speed_worst_m_s : float
        The time of ``speed_ratio``'s instant, from the first sample, and the path's ground
        speed there (NaN without one). Units: s, m/s.
    reported_there_m_s : float
        The reported speed (running median of three) at that instant (NaN without one).
        Units: m/s.
    log_span_s, flown_span_s : float
        Last minus first fix of the log (the last: :func:`last_new_row_time`); last minus
        first flown sample. Units: s.
    flown_fraction : float
        The part of the log's span inside the flown span (0..1).
    fixes : int
        Fixes of the log (rows that ``read_track`` keeps, up to :func:`last_new_row_time`).
    sigma_h_m, k_sigma : float
        The height σ given (m) and the multiple of it checked.
    height_time_sigma_s : float
        The σ of the fixes' time errors given (s; 0: none): a fix's σ is
        √(σ_h² + (ż σ_τ)²) (the module docstring).
    heights_within : float
        Fraction of the fixes whose height is within ``k_sigma`` σ of the flown path.
    fixes_outside_flown : int
        Fixes before the first or after the last flown sample (counted as not within).
    worst_height_offset_m : float
        Largest absolute height offset of a flown-past fix from the path (0 when none). Units: m.
    worst_height_line : int
        Its line in the file (0 when none).
    horizontal_offset_median_m, horizontal_offset_p95_m : float
        Median and 95th percentile of the horizontal distance of the flown-past fixes from
        the path at their times (NaN when none is flown past). Units: m.
    """

    source: str
    reported_gs_max_m_s: float | None
    flown: PathKinematics
    speed_ratio: float | None
    speed_ratio_p995: float | None
    speed_worst_t_s: float
    speed_worst_m_s: float
    reported_there_m_s: float
    log_span_s: float
    flown_span_s: float
    flown_fraction: float
    fixes: int
    sigma_h_m: float
    k_sigma: float
    heights_within: float
    fixes_outside_flown: int
    worst_height_offset_m: float
    worst_height_line: int
    horizontal_offset_median_m: float = float("nan")
    horizontal_offset_p95_m: float = float("nan")
    height_time_sigma_s: float = 0.0

    def suspect(self, envelope: tuple[float, float] | None = SPECIFIC_FORCE_RANGE) -> list[str]:
        """Return the issue's reasons to call the flown path suspect (empty: clean).

        Ground speed over :data:`SPEED_FACTOR` × the log's robust maximum, specific force
        outside ``envelope`` (g; default :data:`SPECIFIC_FORCE_RANGE`, that of an aircraft that
        is not aerobatic; None: not checked), less than :data:`MIN_FLOWN` of the log flown.
        """
        why = []
        if self.speed_ratio_p995 is not None and self.speed_ratio_p995 > SPEED_FACTOR:
            why.append(
                f"ground speed {self.flown.max_ground_speed_m_s:.0f} m/s = "
                f"{self.speed_ratio_p995:.2f} x reported {self.reported_gs_max_m_s:.0f}"
            )
        return why + self._force_and_span(envelope, MIN_FLOWN)

    def _force_and_span(self, envelope: tuple[float, float] | None, min_flown: float) -> list[str]:
        why = []
        f = self.flown
        lo, hi = envelope or (-np.inf, np.inf)
        if f.specific_force_min_g < lo or f.specific_force_max_g > hi:
            why.append(
                f"specific force {f.specific_force_min_g:.2f}..{f.specific_force_max_g:.2f} g"
            )
        if self.flown_fraction < min_flown:
            why.append(f"{100 * self.flown_fraction:.0f} % of the log flown")
        return why

    def corpus_reasons(self, envelope: tuple[float, float]) -> list[str]:
        """Return why the piece does not meet the corpus test's checks (empty: it meets them).

        The ground speed at most :data:`SPEED_FACTOR` × what the aircraft reported when it
        flew it (``speed_ratio``, the module docstring), the specific force within the vehicle
        class's load-factor ``envelope`` (g), at least :data:`CORPUS_MIN_FLOWN` of the log's
        span flown and at least :data:`CORPUS_MIN_WITHIN` of the fixes' heights within
        ``k_sigma`` σ.
        """
        why = []
        if self.speed_ratio is not None and self.speed_ratio > SPEED_FACTOR:
            why.append(
                f"ground speed {self.speed_worst_m_s:.0f} m/s at t = {self.speed_worst_t_s:.0f} s"
                f" = {self.speed_ratio:.2f} x the larger of the speed reported there "
                f"({self.reported_there_m_s:.0f} m/s) and the log's 99.5th percentile "
                f"({self.reported_gs_max_m_s:.0f})"
            )
        why += self._force_and_span(envelope, CORPUS_MIN_FLOWN)
        if self.heights_within < CORPUS_MIN_WITHIN:
            timed = (
                f" and {self.height_time_sigma_s:.2f} s of time error"
                if self.height_time_sigma_s > 0.0
                else ""
            )
            why.append(
                f"{100 * self.heights_within:.1f} % of the heights within {self.k_sigma:g}σ "
                f"({self.sigma_h_m:.1f} m{timed}; worst {self.worst_height_offset_m:.0f} m at "
                f"line {self.worst_height_line})"
            )
        return why


def _csv_rows(path: str | Path) -> csv.DictReader:
    """Return the rows of a traffic CSV (gzip or not), read from the file itself."""
    raw = Path(path).read_bytes()
    if raw[:2] == b"\x1f\x8b":
        raw = gzip.decompress(raw)
    return csv.DictReader(io.StringIO(raw.decode()))


#: the columns whose values make a row of a traffic CSV (:func:`last_new_row_time`), with the
#: altitude column the log is read with
ROW_VALUES = ("latitude", "longitude", "groundspeed", "track", "vertical_rate")


def last_new_row_time(
    path: str | Path, lines: np.ndarray | None = None, altitude: str = "altitude"
) -> float:
    """Return the time (s, POSIX) of the log's last row with a value new to it.

    The rows with a ``timestamp``, a ``latitude`` and a ``longitude`` (and, given ``lines``,
    at those lines of the file: the fixes a reader keeps), in time order (stable); the last
    of them whose cells in :data:`ROW_VALUES` and ``altitude`` (those the log has, compared
    as the text printed; an empty cell is no new value, and reads as its column's last one)
    differ from the row's before it. A log that ends with rows repeating every
    value of the row before them has measured nothing after that row (it froze, or was filled
    forward to a clock): those rows are no fixes, and the log's span ends there (issue 34:
    nothing invented). Read from the file itself; +inf when the last row does not repeat the
    one before it.
    """
    rows = _csv_rows(path)
    cols = [c for c in (*ROW_VALUES, altitude) if c in (rows.fieldnames or ())]
    wanted = None if lines is None else {int(x) for x in lines}
    kept = [
        (_iso(r["timestamp"].strip()), tuple((r[c] or "").strip() for c in cols))
        for line, r in enumerate(rows, start=2)
        if (r.get("timestamp") or "").strip()
        and (r.get("latitude") or "").strip()
        and (r.get("longitude") or "").strip()
        and (wanted is None or line in wanted)
    ]
    kept.sort(key=lambda x: x[0])
    last: list[str] = [""] * len(cols)  # an empty cell holds its column's last value
    for j, (t, cells) in enumerate(kept):
        last = [c or prev for c, prev in zip(cells, last)]
        kept[j] = (t, tuple(last))
    if len(kept) < 2 or kept[-1][1] != kept[-2][1]:
        return np.inf
    i = len(kept) - 1
    while i > 0 and kept[i][1] == kept[i - 1][1]:
        i -= 1
    return float(kept[i][0])


def reported_max_ground_speed(path: str | Path, q: float = 99.5) -> float | None:
    """Return the ``q``-th percentile of a traffic CSV's ``groundspeed`` column (m/s), or None.

    Read from the file itself (gzip or not), every row with a value: no fieldmap reader
    decides which rows count.
    """
    rows = _csv_rows(path)
    if "groundspeed" not in (rows.fieldnames or ()):
        return None
    v = np.array([float(r["groundspeed"]) for r in rows if r["groundspeed"].strip()])
    return float(np.percentile(v, q)) * KT if v.size else None


def _normal_gravity(lat_deg: np.ndarray, h: np.ndarray, ell: Ellipsoid) -> np.ndarray:
    """Magnitude of normal gravity (m/s²): Heiskanen & Moritz (1967) eqs. 2-78 and 2-124."""
    phi = np.radians(lat_deg)
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    a, b = ell.a, ell.b
    g0 = (a * ell.gamma_a * c2 + b * ell.gamma_b * s2) / np.sqrt(a * a * c2 + b * b * s2)
    return g0 * (1.0 - 2.0 * h / a * (1.0 + ell.f + ell.m - 2.0 * ell.f * s2) + 3.0 * (h / a) ** 2)


def _spline(t: np.ndarray, lat: np.ndarray, lon: np.ndarray, h: np.ndarray, ell: Ellipsoid) -> Any:
    from scipy.interpolate import make_interp_spline

    r = np.stack(geodetic_to_ecef(lat, lon, h, ell), -1)
    return make_interp_spline(t, r, k=5)


@dataclass(frozen=True)
class _PathSeries:
    """The path's ground speed and specific force at its samples and half-way between them."""

    t: np.ndarray
    ground_speed: np.ndarray
    specific_force_g: np.ndarray


def _path_series(
    t: np.ndarray, lat: np.ndarray, lon: np.ndarray, h: np.ndarray, ellipsoid: Ellipsoid
) -> _PathSeries:
    t = np.asarray(t, float)
    sp = _spline(t, lat, lon, h, ellipsoid)
    tt = np.sort(np.concatenate([t, 0.5 * (t[1:] + t[:-1])]))
    r, v, a = sp(tt), sp(tt, 1), sp(tt, 2)
    la, lo, hh = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], ellipsoid)
    C = C_e_to_enu(la, lo)
    v_enu = np.einsum("nij,nj->ni", C, v)
    w = np.array([0.0, 0.0, ellipsoid.omega])
    f = a + 2.0 * np.cross(w, v) + _normal_gravity(la, hh, ellipsoid)[:, None] * C[:, 2, :]
    return _PathSeries(tt, np.hypot(v_enu[:, 0], v_enu[:, 1]), np.linalg.norm(f, axis=1) / G0)


def _peaks(p: _PathSeries) -> PathKinematics:
    gs, fs, tt = p.ground_speed, p.specific_force_g, p.t
    i, j = int(np.argmax(gs)), int(np.argmax(np.abs(fs - 1.0)))
    return PathKinematics(
        max_ground_speed_m_s=float(gs[i]),
        max_ground_speed_t_s=float(tt[i] - tt[0]),
        specific_force_min_g=float(fs.min()),
        specific_force_max_g=float(fs.max()),
        specific_force_worst_t_s=float(tt[j] - tt[0]),
    )


def path_kinematics(
    t: np.ndarray, lat: np.ndarray, lon: np.ndarray, h: np.ndarray, ellipsoid: Ellipsoid = WGS84
) -> PathKinematics:
    """Peaks of the quintic ECEF spline through samples (times strictly increasing).

    Parameters
    ----------
    t : numpy.ndarray
        Times. Units: s.
    lat, lon : numpy.ndarray
        Geodetic latitude, longitude. Units: degrees.
    h : numpy.ndarray
        Height above ``ellipsoid``. Units: m.
    ellipsoid : Ellipsoid
    """
    return _peaks(_path_series(t, lat, lon, h, ellipsoid))


def reported_ground_speeds(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Return the times (s, POSIX) and ground speeds (m/s) a traffic CSV reports, by time.

    Every row with a ``timestamp`` and a finite ``groundspeed``, read from the file itself
    (gzip or not; the times parsed as :func:`~fieldmap.nav.logs.read.read_track` parses them);
    the rows sorted by time (a stable sort: rows sharing a time keep their order). Empty arrays
    when the log has no ``groundspeed`` column.
    """
    rows = _csv_rows(path)
    if "groundspeed" not in (rows.fieldnames or ()):
        return np.zeros(0), np.zeros(0)
    t, v = [], []
    for r in rows:
        stamp, gs = (r.get("timestamp") or "").strip(), r["groundspeed"].strip()
        if gs and stamp and np.isfinite(float(gs)):
            t.append(_iso(stamp))  # as the reader reads the path's times
            v.append(float(gs) * KT)
    order = np.argsort(np.asarray(t), kind="stable")
    return np.asarray(t)[order], np.asarray(v)[order]


def reported_speed_at(t_report: np.ndarray, speed: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Return the reported ground speed at times ``t``: the running median of three, interpolated.

    Each report is replaced by the median of itself and its two neighbours, the first and last
    by the median of the first and last three reports, so that a single bad report sets
    nothing, at the ends too (two or more in a row do: a run of bad reports raises the speed
    reported where it lies). The result is interpolated linearly in time and held beyond the
    ends; at a time two reports share, ``numpy.interp`` takes one of them. With fewer than
    three reports none can be told bad: they are interpolated as they are; with none, NaN.
    """
    if speed.size < 3:
        return np.interp(t, t_report, speed) if speed.size else np.full(np.shape(t), np.nan)
    return np.interp(t, t_report, _median_of_three(speed))


def _median_of_three(x: np.ndarray) -> np.ndarray:
    """Return the running median of three of the rows of ``x`` (3 or more).

    Each row the median of itself and its two neighbours, the first and last the median of
    the first and last three (:func:`reported_speed_at`).
    """
    m3 = np.median(np.stack([x[:-2], x[1:-1], x[2:]]), axis=0)
    return np.concatenate([m3[:1], m3, m3[-1:]])


#: the half-width (s) of the window over which :func:`force_against_log` differences velocities
FORCE_WINDOW_S = 10.0


@dataclass(frozen=True)
class ForceAgainstLog:
    """A path's specific force against its log's velocities' (:func:`force_against_log`).

    Attributes
    ----------
    log_min_g, log_max_g : float
        The 0.5th and 99.5th percentiles of the log's load factor. Units: g.
    departure_p95_g : float
        The 95th percentile over the compared rows of :math:`|n_{path} - n_{log}|`. Units: g.
    rows : int
        The rows compared (0: the log reports no velocities; the other fields NaN).
    """

    log_min_g: float
    log_max_g: float
    departure_p95_g: float
    rows: int


def reported_velocities(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Return the times (s, POSIX) and the east, north, up velocities (m/s) a traffic CSV reports.

    Every row with a ``timestamp``, a ``groundspeed`` and a ``track`` (and a ``vertical_rate``
    where the log has that column; without it, up is 0 throughout), sorted by time (stably);
    each component then the running median of three (:func:`reported_speed_at`'s), so that
    one bad report sets nothing. Empty arrays when the log reports no velocities.
    """
    rows = _csv_rows(path)
    names = rows.fieldnames or ()
    if "groundspeed" not in names or "track" not in names:
        return np.zeros(0), np.zeros((0, 3))
    climbs = "vertical_rate" in names
    t, v = [], []
    for r in rows:
        stamp, gs, tr = (r.get("timestamp") or "").strip(), r["groundspeed"], r["track"]
        vr = r["vertical_rate"].strip() if climbs else "0"
        if not (stamp and gs.strip() and tr.strip() and vr):
            continue
        speed, chi = float(gs) * KT, np.radians(float(tr))
        up = float(vr) * FT_PER_MIN
        if np.isfinite(speed) and np.isfinite(chi) and np.isfinite(up):
            t.append(_iso(stamp))
            v.append((speed * np.sin(chi), speed * np.cos(chi), up))
    order = np.argsort(np.asarray(t), kind="stable")
    t_s, v_s = np.asarray(t)[order], np.asarray(v).reshape(-1, 3)[order]
    return t_s, (_median_of_three(v_s) if t_s.size >= 3 else v_s)


def _windowed_load(t: np.ndarray, v: np.ndarray, at: np.ndarray, g: np.ndarray, w: float):
    """Load factor at ``at`` from velocities ``v(t)`` (ENU) differenced over ``at`` ± ``w``."""
    lo = np.stack([np.interp(at - w, t, v[:, i]) for i in range(3)], -1)
    hi = np.stack([np.interp(at + w, t, v[:, i]) for i in range(3)], -1)
    a = (hi - lo) / (2.0 * w)
    a[:, 2] += g
    return np.linalg.norm(a, axis=1) / G0


def force_against_log(
    path: str | Path, samples: Any, *, window: float = FORCE_WINDOW_S, ellipsoid: Ellipsoid = WGS84
) -> ForceAgainstLog:
    r"""Compare a path's specific force with the one its log's own velocities report.

    The log reports no specific force, but it reports the velocity it was flown at (ground
    speed, track, vertical rate: :func:`reported_velocities`). Differenced over a window,
    :math:`\mathbf a = [\mathbf v(t+w) - \mathbf v(t-w)] / 2w` (each velocity interpolated
    linearly in time), it gives the load factor :math:`n = |\mathbf a + \gamma\,\mathbf
    u| / g_0` the aircraft reported (Coriolis and the frame's turn over the window, under
    0.002 g, left out). The path's velocity (the quintic ECEF spline's, in the local east,
    north, up frame at each end) is differenced over the same window at the same rows, so
    both are smoothed alike: a path that follows the reported turns and pull-ups has
    :math:`n_{path} \approx n_{log}` whatever the window; one smoothed through them departs.
    The rows compared: those whose window lies within the flown span and between the log's
    second and last but one velocity reports (the first and last have no median of three).
    ``samples`` as for :func:`check_piece`.
    """
    t, v = reported_velocities(path)
    s = samples
    f0, f1 = float(s.t_start + s.t[0]), float(s.t_start + s.t[-1])
    if t.size < 3:
        return ForceAgainstLog(np.nan, np.nan, np.nan, 0)
    at = t[(t - window >= max(t[1], f0)) & (t + window <= min(t[-2], f1))]
    if at.size == 0:
        return ForceAgainstLog(np.nan, np.nan, np.nan, 0)
    sp = _spline(np.asarray(s.t, float), s.lat, s.lon, s.h, ellipsoid)
    ends = np.concatenate([at - window, at + window]) - s.t_start
    r, dr = sp(ends), sp(ends, 1)
    la, lo, hh = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], ellipsoid)
    v_enu = np.einsum("nij,nj->ni", C_e_to_enu(la, lo), dr)
    a = (v_enu[at.size :] - v_enu[: at.size]) / (2.0 * window)
    g = _normal_gravity(la[: at.size], hh[: at.size], ellipsoid)
    a[:, 2] += g
    n_path = np.linalg.norm(a, axis=1) / G0
    n_log = _windowed_load(t, v, at, g, window)
    return ForceAgainstLog(
        log_min_g=float(np.percentile(n_log, 0.5)),
        log_max_g=float(np.percentile(n_log, 99.5)),
        departure_p95_g=float(np.percentile(np.abs(n_path - n_log), 95.0)),
        rows=int(at.size),
    )


def horizontal_offsets(
    r_path: np.ndarray,
    h_path: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    ellipsoid: Ellipsoid = WGS84,
) -> np.ndarray:
    """Return the horizontal distance (m) of fixes ``lat, lon`` from path points ``r_path``.

    ``r_path`` (n, 3): the path in ECEF at the fixes' times, ``h_path`` its heights there.
    Each fix is placed at the path's height, so that only the horizontal part of the offset
    remains: the chord between the two points (within 1e-7 of the distance along the surface
    up to 10 km).
    """
    fix = np.stack(geodetic_to_ecef(lat, lon, h_path, ellipsoid), axis=-1)
    return np.linalg.norm(fix - r_path, axis=1)


def check_piece(
    path: str | Path,
    samples: Any,
    *,
    sigma_h: float,
    k_sigma: float = 3.0,
    height_time_sigma: float = 0.0,
    height_ref: str = "pressure",
    ellipsoid: Ellipsoid = WGS84,
) -> CorpusCheck:
    """Check a flown piece against its log.

    Parameters
    ----------
    path : str or Path
        The piece (a traffic-layout CSV of ``tests/data/corpus``).
    samples : FlightSamples
        The flown samples: ``ConditionedFlight.samples`` (or the ``samples`` of the
        ``FlightTrajectory``) that :func:`~fieldmap.nav.logs.load_flight` returned: ``t`` from
        0, ``t_start`` in the log's time scale, ``lat``, ``lon``, ``h``.
    sigma_h : float
        The σ of a fix's height. Units: m.
    k_sigma : float
        A fix is within when its offset is at most ``k_sigma`` times its σ,
        ``sqrt(sigma_h**2 + (vz * height_time_sigma)**2)``.
    height_time_sigma : float
        The σ of the fixes' time errors (0: none; ``report["fit"]["height_time_sigma_s"]``),
        with ``vz`` the flown path's vertical speed at the fix's time. Units: s.
    height_ref : str
        The log's height reference, as given to ``load_flight``.
    ellipsoid : Ellipsoid
        That of the samples' heights.

    Returns
    -------
    CorpusCheck
    """
    # alt_units given: the reader's guess of the units refuses logs with altitude glitches,
    # and the traffic layout's altitudes are feet by definition
    log = read_track(path, height_ref=height_ref, alt_units="ft", ellipsoid=ellipsoid)
    s = samples
    t_abs = s.t_start + s.t
    series = _path_series(s.t, s.lat, s.lon, s.h, ellipsoid)
    flown = _peaks(series)
    reported = reported_max_ground_speed(path)
    ratio, worst_t, there, worst_v = None, np.nan, np.nan, np.nan
    if reported:
        t_rep, v_rep = reported_ground_speeds(path)
        local = reported_speed_at(t_rep, v_rep, s.t_start + series.t)
        r = series.ground_speed / np.fmax(reported, local)  # no report there: the percentile
        k = int(np.argmax(r))
        ratio, worst_t, there = float(r[k]), float(series.t[k] - series.t[0]), float(local[k])
        worst_v = float(series.ground_speed[k])
    t0, t1 = (
        float(log.t.min()),
        min(
            float(log.t.max()),
            last_new_row_time(
                path, log.lines, "geoaltitude" if height_ref == "msl" else "altitude"
            ),
        ),
    )
    f0, f1 = float(t_abs[0]), float(t_abs[-1])
    span = t1 - t0
    cover = max(0.0, min(t1, f1) - max(t0, f0))
    # a fix is a sample with a height of its own (a surface report's placeholder is none)
    has = np.ones(log.t.size, bool) if log.no_height is None else ~log.no_height
    has &= log.t <= t1  # a row of a frozen end is no fix
    inside = (log.t >= f0) & (log.t <= f1) & has
    ok = np.zeros(log.t.size, bool)
    worst, worst_line = 0.0, 0
    horizontal = np.zeros(0)
    if inside.any():
        sp = _spline(np.asarray(s.t, float), s.lat, s.lon, s.h, ellipsoid)
        r = sp(log.t[inside] - s.t_start)
        la, lo, h_path = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], ellipsoid)
        off = np.abs(log.h[inside] - h_path)
        sig = np.full(off.size, float(sigma_h))
        if height_time_sigma > 0.0:
            up = C_e_to_enu(la, lo)[:, 2, :]
            vz = np.sum(sp(log.t[inside] - s.t_start, 1) * up, axis=1)
            sig = np.sqrt(sig**2 + (vz * height_time_sigma) ** 2)
        ok[inside] = off <= k_sigma * sig
        k = int(np.argmax(off))
        worst, worst_line = float(off[k]), int(log.lines[inside][k])
        horizontal = horizontal_offsets(r, h_path, log.lat[inside], log.lon[inside], ellipsoid)
    return CorpusCheck(
        source=str(path),
        reported_gs_max_m_s=reported,
        flown=flown,
        speed_ratio=ratio,
        speed_ratio_p995=None if not reported else flown.max_ground_speed_m_s / reported,
        speed_worst_t_s=worst_t,
        speed_worst_m_s=worst_v,
        reported_there_m_s=there,
        log_span_s=span,
        flown_span_s=f1 - f0,
        flown_fraction=cover / span if span > 0 else float(f1 >= t1 and f0 <= t0),
        fixes=int(has.sum()),
        sigma_h_m=float(sigma_h),
        k_sigma=float(k_sigma),
        height_time_sigma_s=float(height_time_sigma),
        heights_within=float(ok[has].mean()) if has.any() else 0.0,
        fixes_outside_flown=int((~inside & has).sum()),
        worst_height_offset_m=worst,
        worst_height_line=worst_line,
        horizontal_offset_median_m=float(np.median(horizontal)) if horizontal.size else np.nan,
        horizontal_offset_p95_m=(
            float(np.percentile(horizontal, 95.0)) if horizontal.size else np.nan
        ),
    )


#: the columns ``--positions-only`` leaves out
VELOCITY_COLUMNS = ("groundspeed", "track", "vertical_rate")


def positions_only(path: Path, folder: Path) -> Path:
    """Write the log at ``path`` without its :data:`VELOCITY_COLUMNS` into ``folder``.

    Positions and altitudes alone, as IGC, GPX and many ADS-B exports come
    (``benchmarks/corpus_table.py --positions-only``); returns the file written.
    """
    with gzip.open(path, "rt") as f:
        rows = [r.split(",") for r in f.read().splitlines()]
    keep = [j for j, c in enumerate(rows[0]) if c not in VELOCITY_COLUMNS]
    out = folder / path.name.removesuffix(".gz")
    out.write_text("\n".join(",".join(r[j] for j in keep if j < len(r)) for r in rows) + "\n")
    return out
