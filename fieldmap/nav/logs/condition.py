r"""Real flight logs made flyable: one motion model and its robust smoother, over the whole log.

:class:`~fieldmap.nav.trajectory.FlightTrajectory` interpolates its samples exactly (a quintic
spline), so the metre-level noise of a real log becomes tens of g and a kilometre-level
outlier hundreds. :func:`condition` turns a raw track (an ADS-B, GNSS or flight-recorder log
as read by :func:`fieldmap.nav.logs.read.read_track`) into samples on a regular grid that a
vehicle of its class could have flown, and a report of what it did
(:class:`~fieldmap.nav.logs.report.ConditionedFlight`).

**The model** (equations in :mod:`fieldmap.nav.logs.motion`). The path is the smoothed state
of a Singer manoeuvre model per axis (position, velocity, acceleration, driven by white jerk of
intensity :math:`q`): the three ECEF axes of the horizontal position's surface point share
one :math:`q_h`, the height has its own :math:`q_v` and a damped vertical speed. Every channel
the log holds is a measurement of it with its own noise: horizontal positions, heights, the
log's ground velocity (ground speed and track: :math:`v_E = s\sin\chi`, :math:`v_N = s\cos\chi`,
carried to the surface point's rate by :math:`N/(N+h)` and :math:`M/(M+h)`, the radii of
curvature; Heiskanen & Moritz 1967 eqs. 2-81, 5-58) and vertical rate. Each measurement is an
inlier with the channel's noise or a fault (uniform over the range the log spans); the
smoother (banded normal equations, the RTS smoother's mean) and the EM weights of that mixture
are solved over the whole log, and :math:`q` and each channel's noise maximise the marginal
likelihood, with :math:`q` bounded by the vehicle class
(:mod:`fieldmap.nav.logs.vehicles`).

**Steps.**

1. *Order* (:func:`order_log`): non-finite samples dropped (counted); a recording apart, a
   gap longer than the rest of the log away (a time tag from another day), dropped and named
   (:func:`recordings_apart`; with ``smooth=False`` and ``reorder=False`` too); times that go
   back sorted (or refused with ``reorder=False``); of samples sharing a time the first is
   kept.
2. *Measurements* (:func:`measurements`, :mod:`fieldmap.nav.logs.faults`): a repeated position
   is no new fix, a position interpolated between fixes or extrapolated from one is none
   either, nor a vertical rate off its column's steps; a rate that repeats the value before
   it is a copy or a fresh value, as the smoother's mixture finds (held values).
   A sample without a height of its own (an ADS-B surface report, whose altitude column
   holds a placeholder: :attr:`~fieldmap.nav.logs.read.RawTrack.no_height`) is a position
   only.
3. *Vehicle* (:func:`~fieldmap.nav.logs.vehicles.guess_vehicle`): given, or guessed from the
   ADS-B category, the file's format and the log's speeds, climbs and turns; its climb bound
   raised to the log's own top climb, up to the largest the class reaches
   (:meth:`~fieldmap.nav.logs.vehicles.Vehicle.with_log_climb`: a parabolic flight's).
4. *Estimate* (:func:`estimate`): the horizontal and vertical smoothers. Where the log's
   velocities contradict its positions (the joint fit would reject most positions or most
   velocities, or their speeds are a constant factor off the positions': a unit or column
   mistake, the vehicle then guessed again without them) they are left out and the report
   says so. The height's EM runs from two
   starts, the annealed one and the Huber M-estimate, compared at one set of noise levels
   by the mixture's likelihood (:func:`_height`): a long run of wrong altitudes cannot hold
   the path where the EM's first start put it. So does the horizontal one where the log
   repeats its velocities, the second start the fresh samples' path (:func:`_horizontal`):
   a ground speed held through a taxi cannot hold the path away from the taxi's positions.
   Where the positions show time errors, the heights in their rows carry them too, in
   proportion to the climb (motion module docstring, "Time errors"). An aircraft slower
   than its stall speed less the strongest surface wind is on the ground: there its
   vertical rate is 0 within a runway's slope, a constraint no run of heights outweighs
   (:func:`ground_level`, :func:`_on_ground`: a transponder's stale airborne altitudes
   while it taxis are faults).
5. *Samples*: the smoothed path at the grid nodes from the first sample to the last
   measured one (a frozen end, rows repeating every value of the row before, is measured by
   none: :func:`measured_end`; ``airborne_only`` trims the slow ends of an aircraft's log);
   the faults as runs with their lines (:func:`~fieldmap.nav.logs.faults.describe_faults`);
   the stretches longer than ``max_gap_s`` flown without a kept position or height
   (:func:`unfixed_stretches`): gaps between fixes, with the path's posterior σ at their
   middle, and the ends of the flown span before the first kept fix or after the last (a
   transponder's stale last altitudes, rejected), flown from one side only, with the σ at
   their far end.

Gaps are prediction: across an interval without fixes the path is the model's conditional
mean given both sides, within the vehicle's climb (its vertical speed relaxes to zero over the
class's climb time), with the σ the report gives. A fault costs its samples, never the log: a
log is refused only when nothing flyable is left (fewer than 6 samples, or a vehicle that never
leaves a 30 m circle and a 15 m height band: no flight).

``smooth=False`` does step 1 only: the exact interpolation of the ordered samples.

The options travel as one :class:`Conditioning`, validated once on construction; an
:class:`~fieldmap.errors.InputError` about one carries its name as ``param``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.stats import binom
from threadpoolctl import threadpool_limits

import fieldmap.nav.logs.faults as flt
from fieldmap.errors import Advice, InputError, Keyword, Label, Message, Pass, Setting
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic, geodetic_to_ecef
from fieldmap.nav.logs.motion import (
    TIMING_MAX_S,
    AxisSmoother,
    Channel,
    Grid,
    SmoothedAxis,
    log_mixture,
    mixture_components,
)
from fieldmap.nav.logs.vehicles import (
    GROUND_CHANNEL,
    GROUND_SLOPE_MAX,
    SURFACE_WIND_MAX,
    Evidence,
    Vehicle,
    evidence,
    guess_vehicle,
    vehicle_class,
)
from fieldmap.nav.trajectory import MIN_POINTS, FlightSamples
from fieldmap.units import STANDARD_GRAVITY

#: grid nodes beyond the data at either end (there the model alone shapes the path)
EDGE = 8
#: a vehicle within STILL_H m horizontally and STILL_V m vertically of one place never moved
STILL_H = 30.0
#: ... and the height band (m) it stays within
STILL_V = 15.0
#: a position's printed rounding finer than this (m) lets collinear fixes mark interpolation
INTERP_ROUNDING_M = 1.0
#: a height change smaller than this (m) between fixes is what a conversion adds (geoid, ISA)
LEVEL_M = 0.05
#: the steepest slope of the geoid (rad): the deflection of the vertical, whose largest values
#: are about 1' (3e-4 rad) in high mountains: a held altitude converted to heights changes by
#: up to this times the distance flown between fixes (:func:`height_quantum`)
GEOID_SLOPE_MAX = 3e-4
#: the coarsest step of a quantised altitude (m): Mode C's 100 ft (ICAO Annex 10 Vol IV,
#: Gillham code), with the 5 % of a step that the conversion to heights may add
HEIGHT_STEP_MAX_M = 100.0 * 0.3048 * 1.05
#: heights are quantised when this share of their changes are multiples of one step
QUANTISED_SHARE = 0.5
#: the changes (up to the coarsest step) a share of them is judged on; fewer are judged by the
#: chance that they agree on the step (:data:`QUANTISED_CHANCE`)
QUANTISED_MIN_CHANGES = 10
#: the chance that a change of heights that are not quantised falls within 5 % of a whole
#: multiple of a step, up to the coarsest step: the windows (0.1 k q wide for k = 1 to 4)
#: cover q of the 4.5 q those multiples span, so about a quarter
STEP_CHANCE = 0.25
#: the heights are quantised only when changes agreeing on one step by chance (binomial in
#: :data:`STEP_CHANCE`) are less likely than this
QUANTISED_CHANCE = 0.01
#: the coarsest grid step (s) the noise levels are estimated on (the measurement rows are a
#: Taylor step of up to half of it: jerk × (Δ/2)³/6, 0.2 m at 1 m/s³)
ESTIMATE_DT_S = 5.0
#: a log's rates differ from its path's by a unit's factor when they agree on it within this
#: spread (of the logarithms) where both move faster than UNIT_MIN_RATE (m/s)
UNIT_SPREAD = 0.15
#: the rate (m/s) both must exceed for their ratio to count
UNIT_MIN_RATE = 2.0
#: the heights' time errors are taken where they lower -2 log L by more than this (one
#: parameter: 3 standard errors' worth, chi-square of one degree of freedom at 9)
TIME_ERROR_EVIDENCE = 9.0
#: EM rounds of the heights' σ_τ and the path: each σ_τ maximises the likelihood at the last
#: round's path, and the first path (without the term) follows part of the time errors, so
#: the first σ_τ is low (savan_39b415_03: 0.22 s, then 0.29 s, 0.32 s by the fifth round)
TIME_ERROR_ROUNDS = 2
#: the positions' σ starts this many times its robust first guess where rates are measured
ANNEAL = 30.0
#: the height's second start is kept when its -2 log L is smaller than the first's by more
#: than this: 2 ln B > 10, "very strong" evidence on Kass & Raftery's (1995) scale (_height)
START_EVIDENCE = 10.0
#: a gap longer than this (s), and than the rest of the log, separates two recordings
#: (recordings_apart): the 30 min at which tests/data/corpus/make_corpus.py splits flights
APART_S = 1800.0
#: time shifts tried for a rejected run of positions (s, both ways)
SHIFT_MAX_S = 120.0
#: a fix is slower than the vehicle flies when its path's speed is, by this many σ of the
#: path's speed (one-sided 98 %)
GROUND_SIGMAS = 2.0
#: the ground's vertical rates' fault share to start from (:func:`_on_ground`)
GROUND_FAULT_START = 0.01


@dataclass(frozen=True)
class Conditioning:
    """The options of the conditioning of a flight log, validated once (on construction).

    Built alike by the command line (``fieldmap navsim --trajectory``) and by Python users,
    and passed as one object to :func:`condition` and :func:`fieldmap.nav.logs.load_flight`.

    Parameters
    ----------
    smooth : bool
        False: only order the samples and drop repeated times (exact interpolation).
    vehicle : str, optional
        The vehicle class (:data:`~fieldmap.nav.logs.vehicles.VEHICLES`) whose motion model
        and envelope the path keeps to. Default: guessed from the log (the report says how).
    position_noise_m : float or (float, float), optional
        Position noise σ (m): one value, or (horizontal per axis, vertical). Default:
        estimated from the log (marginal likelihood).
    max_gap_s : float
        Gaps longer than this (s) are listed in the report with the σ of the path across them.
    airborne_only : bool
        Trim the slow ends of the log (ground movement: slower than ``min_speed_mps``).
        Default False: the whole log is flown.
    min_speed_mps : float
        The speed below which the ends of a log are ground movement (``airborne_only``; the
        report's time on the ground uses the vehicle's stall speed).
    log_velocities : bool
        Use the velocities the log carries (ground speed, track, vertical rate) as
        measurements (default). False: positions and heights alone.
    reorder : bool
        Sort times that go back; False: refuse them (an :class:`InputError` naming the line).
    dt_out : float, optional
        Output sample interval (s): the last sample falls less than one interval after the last
        measured fix. Default: the median interval of the measured samples, within 0.1..1 s (5 s
        for a log whose fixes are further apart than that), shortened to divide their span:
        the first and the last sample on the first and the last measured fix (a frozen end's
        rows are none: :func:`measured_end`).
    ellipsoid : Ellipsoid
        Ellipsoid of the coordinates.

    Raises
    ------
    InputError
        An invalid option, naming it (``param``).
    """

    smooth: bool = True
    vehicle: str | None = None
    position_noise_m: float | tuple[float, float] | None = None
    max_gap_s: float = 60.0
    airborne_only: bool = False
    min_speed_mps: float = 30.0
    log_velocities: bool = True
    reorder: bool = True
    dt_out: float | None = None
    ellipsoid: Ellipsoid = WGS84

    def __post_init__(self) -> None:
        for name, optional in (("max_gap_s", False), ("min_speed_mps", False), ("dt_out", True)):
            v = getattr(self, name)
            if not (optional and v is None) and not (
                isinstance(v, (int, float))
                and not isinstance(v, bool)
                and math.isfinite(v)
                and v > 0
            ):
                raise InputError(
                    Keyword(name), f" must be a positive number, got {v!r}", param=name
                )
        for name in ("smooth", "airborne_only", "log_velocities", "reorder"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(
                    Keyword(name),
                    f" must be True or False, got {getattr(self, name)!r}",
                    param=name,
                )
        self.noise_m()
        if self.vehicle is not None:
            vehicle_class(self.vehicle)

    def noise_m(self) -> tuple[float, float] | None:
        """Return the position noise σ (m) as (horizontal, vertical), or None (estimated)."""
        noise = self.position_noise_m
        if noise is None:
            return None
        try:
            sig = [float(x) for x in np.broadcast_to(np.asarray(noise, dtype=float), (2,))]
        except (TypeError, ValueError):
            sig = [math.nan]
        if not all(math.isfinite(x) and x > 0 for x in sig):
            raise InputError(
                Keyword("position_noise_m"),
                f" must be positive metres, got {noise!r}",
                param="position_noise_m",
            )
        return sig[0], sig[1]

    def as_dict(self) -> dict[str, Any]:
        """Return the options as the report gives them (JSON-ready)."""
        noise = self.noise_m()
        return {
            "smooth": self.smooth,
            "vehicle": self.vehicle,
            "position_noise_m": None if noise is None else list(noise),
            "max_gap_s": float(self.max_gap_s),
            "airborne_only": self.airborne_only,
            "min_speed_mps": float(self.min_speed_mps),
            "log_velocities": self.log_velocities,
            "reorder": self.reorder,
            "dt_out": None if self.dt_out is None else float(self.dt_out),
        }


# -- step 1: order ---------------------------------------------------------------------------


@dataclass(frozen=True)
class OrderedLog:
    """The samples of a track in time order, without repeated times (step 1).

    ``t, lat, lon, h, lines`` (longitude unwrapped), ``index`` (each sample's index in the
    track), ``source``; the counts of what was dropped or sorted and the first line of each.
    """

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    h: np.ndarray
    lines: np.ndarray
    index: np.ndarray
    source: str
    n_in: int
    n_invalid: int
    first_invalid_line: int | None
    n_reordered: int
    first_reordered_line: int | None
    n_duplicates: int
    first_duplicate_line: int | None
    #: the recordings apart from the flown one that were dropped (:func:`recordings_apart`)
    apart: tuple[Apart, ...] = ()


@dataclass(frozen=True)
class Apart:
    """Samples dropped as a recording apart (:func:`recordings_apart`).

    ``samples`` of them, lines ``lines[0]..lines[1]`` (the first and last in time order),
    ``gap_s`` from the rest of the log.
    """

    samples: int
    lines: tuple[int, int]
    gap_s: float


def recordings_apart(t: np.ndarray) -> tuple[np.ndarray, list[tuple[int, int, float]]]:
    r"""Return the samples of the one recording a sorted log flies, and the parts apart from it.

    A flight log is one recording: its samples, in time order, leave no gap longer than the
    recording on both sides of it together. Where the largest gap :math:`g` is longer than the
    rest of the log's span :math:`T - g` and than :data:`APART_S` (the corpus's own split of
    flights, ``tests/data/corpus/make_corpus.py``), the two sides are not one flight: a time
    tag from another day (a receiver's clock reset, a GPS week rollover, a wrong date), or
    another flight in the same file. The side with fewer samples is dropped (the later of two
    equal ones), and the rule applied again to the rest. Flying across such a gap would be a
    prediction over days (and a grid of millions of nodes); a long coverage gap inside a flight
    (an ocean crossing's 3 h of a 7 h log) is shorter than the rest and stays a gap. A gap
    longer than both its sides (6 h between 30 and 40 minutes of coverage) is more prediction
    than log: the shorter side is dropped and named, and the rest flown.

    Returns the kept sample indices and, per dropped part, (first, last) indices and the gap.
    """
    lo, hi = 0, t.size
    dropped: list[tuple[int, int, float]] = []
    while hi - lo >= 2:
        gaps = np.diff(t[lo:hi])
        j = int(np.argmax(gaps))
        g = float(gaps[j])
        if g <= max(APART_S, float(t[hi - 1] - t[lo]) - g):
            break
        if j + 1 < hi - lo - (j + 1):  # fewer before the gap
            dropped.append((lo, lo + j, g))
            lo = lo + j + 1
        else:
            dropped.append((lo + j + 1, hi - 1, g))
            hi = lo + j + 1
    return np.arange(lo, hi), dropped


def order_log(track: Any, reorder: bool = True) -> OrderedLog:
    """Order a track's finite samples by time (step 1); refuse impossible coordinates."""
    src = str(getattr(track, "source", "flight"))
    arrs = [
        np.asarray(getattr(track, k), dtype=np.float64).ravel() for k in ("t", "lat", "lon", "h")
    ]
    n = arrs[0].size
    lines = getattr(track, "lines", None)
    lines = np.arange(1, n + 1) if lines is None else np.asarray(lines, dtype=np.int64).ravel()
    for name, a in zip(("lat", "lon", "h", "lines"), arrs[1:] + [lines]):
        if a.size != n:
            raise InputError(f"{src}: {a.size} values of {name}, {n} times")
    finite = np.all(np.isfinite(np.stack(arrs)), axis=0) if n else np.zeros(0, bool)
    n_invalid = int(n - finite.sum())
    first_invalid = int(lines[~finite][0]) if n_invalid else None
    t, lat, lon, h = (a[finite] for a in arrs)
    lines, index = lines[finite], np.flatnonzero(finite)
    for name, v, lim in (("latitude", lat, 90.0), ("longitude", lon, 540.0)):
        bad = np.flatnonzero(np.abs(v) > lim)
        if bad.size:
            raise InputError(
                f"{src} line {lines[bad[0]]}: {name} {v[bad[0]]:g} is beyond ±{lim:g} degrees"
            )
    # a recording apart (a time tag from another day) is dropped before the order is judged
    by_time = np.argsort(t, kind="stable")
    kept, parts = recordings_apart(t[by_time])
    apart = tuple(
        Apart(b - a + 1, (int(lines[by_time[a]]), int(lines[by_time[b]])), g) for a, b, g in parts
    )
    if parts:
        on = np.sort(by_time[kept])
        t, lat, lon, h, lines, index = (a[on] for a in (t, lat, lon, h, lines, index))
    back = np.flatnonzero(t[1:] < np.maximum.accumulate(t)[:-1]) + 1 if t.size else back_none()
    first_back = int(lines[back[0]]) if back.size else None
    if back.size:
        if not reorder:
            i = back[0]
            raise InputError(
                f"{src} line {lines[i]}: time {t[i]:.3f} s goes back from the previous "
                f"{t[i - 1]:.3f} s (line {lines[i - 1]})",
                Advice("; ", Pass("reorder", True), " to sort the log"),
                param="reorder",
            )
        order = np.argsort(t, kind="stable")
        t, lat, lon, h = (a[order] for a in (t, lat, lon, h))
        lines, index = lines[order], index[order]
    dup = np.concatenate([[False], np.diff(t) == 0.0]) if t.size else np.zeros(0, bool)
    keep = ~dup
    return OrderedLog(
        t[keep],
        lat[keep],
        np.degrees(np.unwrap(np.radians(lon[keep]))) if keep.any() else lon[keep],
        h[keep],
        lines[keep],
        index[keep],
        src,
        n,
        n_invalid,
        first_invalid,
        int(back.size),
        first_back,
        int(dup.sum()),
        int(lines[dup][0]) if dup.any() else None,
        apart,
    )


def back_none() -> np.ndarray:
    """No sample goes back (an empty index array)."""
    return np.zeros(0, np.int64)


# -- step 2: measurements --------------------------------------------------------------------


@dataclass(frozen=True)
class Measurements:
    """The channels of one log (step 2) and which ordered samples each holds.

    Attributes
    ----------
    positions, heights : Channel
        Horizontal positions (surface-point ECEF minus ``origin``; m) and heights (m).
    velocities, climbs : Channel or None
        The log's ground velocities (surface-point ECEF rates, m/s) and vertical rates.
    index : dict
        Channel name -> indices of the ordered samples it holds (the heights: those with a
        height of their own, :attr:`~fieldmap.nav.logs.read.RawTrack.no_height`).
    origin : numpy.ndarray
        The ECEF point subtracted from the positions (m).
    repeated, interpolated : numpy.ndarray
        The ordered samples whose position is a repeat or an interpolation (not measured).
    height_quantum : float
        Step of quantised heights (m; 0: none).
    position_rounding_m : float
        The printed rounding of the positions (m).
    velocity_columns : tuple of str
        The log's velocity columns.
    notes : tuple of str
        What was decided about the channels.
    """

    positions: Channel
    heights: Channel
    velocities: Channel | None
    climbs: Channel | None
    index: dict[str, np.ndarray]
    origin: np.ndarray
    repeated: np.ndarray
    interpolated: np.ndarray
    height_quantum: float
    position_rounding_m: float
    velocity_resolution: tuple[float, float, float]
    velocity_columns: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    source: str = "flight"
    #: every ordered sample's time (s)
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: the ordered samples that are surface reports: on the ground by the log's word (bool)
    surface: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))


def height_quantum(h: np.ndarray, distance: np.ndarray | None = None) -> float:
    r"""Step of quantised heights (m), e.g. 7.62 for 25 ft, or 0 when not quantised.

    A log's altitude printed in 25 ft (or 100 ft) steps keeps the steps through its
    conversion to heights, up to what the conversion adds smoothly: the ISA profile nothing
    to a held altitude, the geoid height :math:`N` up to its slope times the distance flown,
    :math:`|\Delta N| \le` :data:`GEOID_SLOPE_MAX` :math:`d` (0.3 m between fixes 1 km
    apart; 0.06 m is common between a cruise's fixes 10 s apart, more than a level flight's
    25 ft steps in number). The candidate steps are the changes beyond that and beyond
    :data:`LEVEL_M`; the step is their most common value (within 5 % of it; the median of
    those), up to :data:`HEIGHT_STEP_MAX_M`;
    the heights are quantised when at least :data:`QUANTISED_SHARE` of the changes are within
    5 % of a whole multiple of it (up to 40), judged on at least
    :data:`QUANTISED_MIN_CHANGES` changes up to the coarsest step. Fewer (a level flight's
    few steps of 25 ft) count when those on the step are too many for chance: of the n − 1
    besides one that sets the step, m − 1 or more agree by chance with probability
    :math:`P(X \ge m - 1)`, X binomial in n − 1 and :data:`STEP_CHANCE`, under
    :data:`QUANTISED_CHANCE` (5 changes all on the step count; 3 do not). A few changes off
    the steps (a glitch) do not hide them; altitudes interpolated between fixes (changes of
    a third or half a step, common) are not quantised.
    """
    dh = np.abs(np.diff(np.asarray(h, dtype=np.float64)))
    # at most half a 25 ft step (Mode S's, the finest an aircraft's altitude is printed in):
    # fixes tens of km apart (a tanker's) keep their steps as candidates
    level = (
        LEVEL_M
        if distance is None
        else np.clip(GEOID_SLOPE_MAX * distance, LEVEL_M, 0.5 * 25.0 * 0.3048)
    )
    nz = dh[(dh > level) & (dh <= HEIGHT_STEP_MAX_M)]
    if nz.size < 2:
        return 0.0
    values = np.unique(np.round(nz, 2))
    near = np.abs(nz[None, :] - values[:, None]) <= 0.05 * values[:, None]
    counts = near.sum(axis=1)
    c = int(np.flatnonzero(counts == counts.max())[-1])  # the largest of equally common
    q = float(np.median(nz[near[c]]))
    allnz = dh[dh > LEVEL_M]
    r = allnz / q
    k = np.round(r)
    share = np.mean((np.abs(r - k) <= 0.05 * np.maximum(k, 1.0)) & (k <= 40))
    rs = nz / q
    ks = np.round(rs)
    m = int(np.sum((ks >= 1.0) & (np.abs(rs - ks) <= 0.05 * ks)))
    chance = float(binom.sf(m - 2, nz.size - 1, STEP_CHANCE))  # P(X >= m - 1)
    enough = nz.size >= QUANTISED_MIN_CHANGES or chance < QUANTISED_CHANCE
    return q if share >= QUANTISED_SHARE and enough else 0.0


def _off_resolution(x: np.ndarray, step: float) -> np.ndarray:
    """Return the values computed between measurements: off the grid of a quantised column.

    A measured value of resolution ``step`` (an ADS-B vertical rate in 64 ft/min steps) is a
    whole multiple of it. Where at least half of a column's values are, the column is
    quantised, and its values between the steps were computed (a log resampled to a clock, its
    values interpolated between fixes): not measurements, as an interpolated position is none
    (:mod:`fieldmap.nav.logs.faults`). A column mostly off the grid is in other units or
    finer: nothing is said of it (all False); zeros, on every grid, do not count. Applied to
    the vertical rates only: the ground speeds of a resampled log, interpolated the same way,
    are the ground velocity's, whose track has no grid to tell them by (tried on the corpus:
    dropping the ground speeds off their knots alone flew three pieces faster than reported).
    """
    out = np.zeros(x.shape, bool)
    fin = np.isfinite(x)
    if step <= 0.0 or not fin.any():
        return out
    r = x[fin] / step
    off = np.abs(r - np.round(r)) > 1e-6 * np.maximum(np.abs(r), 1.0)
    nonzero = r != 0.0  # a zero is on every grid: the share is that of the others
    if nonzero.any() and np.mean(off[nonzero]) <= 0.5:
        out[np.flatnonzero(fin)[off]] = True
    return out


def _computed_note(n: int, of: int, what: str) -> str:
    """Return the report's note on the values of a quantised column off its grid."""
    return (
        f"{n} of the log's {what} ({100.0 * n / of:.0f} %) are off the column's resolution: "
        "computed between measurements (a log resampled to a clock), not used"
    )


def _repeats(y: np.ndarray) -> np.ndarray | None:
    """Return the samples whose value (row of ``y``) repeats the one before exactly.

    None when none does. A repeat is a copy of the earlier value or a fresh one in the same
    printed cell (the smoother's mixture tells which: :mod:`fieldmap.nav.logs.motion`, "Held
    values"). The rates (ground velocity, vertical rate) are given it; the heights are not: a
    vehicle on the ground or in level flight repeats its height for minutes as a measurement,
    and the heights are what the path's height keeps to (tried on the corpus: heights taken
    for copies on the ground let the path float off 82 pieces' heights).
    """
    out = np.zeros(y.shape[0], bool)
    out[1:] = np.all(y[1:] == y[:-1], axis=1)
    return out if out.any() else None


def _radii(lat_deg: np.ndarray, ell: Ellipsoid) -> tuple[np.ndarray, np.ndarray]:
    """Prime vertical and meridian radii of curvature (m) at geodetic latitudes."""
    e2 = ell.f * (2.0 - ell.f)
    w2 = 1.0 - e2 * np.sin(np.radians(lat_deg)) ** 2
    return ell.a / np.sqrt(w2), ell.a * (1.0 - e2) / w2**1.5


def _fault_density(extent: float, dof: int) -> float:
    """Density of a fault uniform over a range ``extent`` wide (a disk of that radius in 2-D)."""
    return 1.0 / (math.pi * extent**2) if dof == 2 else 1.0 / (2.0 * extent)


def measured_end(log: OrderedLog, track: Any, options: Conditioning) -> int:
    """Return how many of the ordered samples are measured: all but a frozen end's.

    A frozen end (:func:`~fieldmap.nav.logs.faults.frozen_tail`) over the values the
    conditioning reads (position, height and, where it uses them, the velocities); none
    where fewer than ``MIN_POINTS`` samples would be left (a log of repeats: its repeats are
    all it has).
    """
    n = log.t.size
    vel = getattr(track, "velocity", None)
    values = [log.lat, log.lon, log.h]
    if vel is not None and options.log_velocities:
        values += [vel.speed[log.index], vel.track[log.index]]
        values += [vel.climb[log.index]] if vel.climb is not None else []
    frozen = flt.frozen_tail(values)
    return n - frozen if n - frozen >= MIN_POINTS else n


def _head(log: OrderedLog, end: int) -> OrderedLog:
    """Return the first ``end`` samples of an ordered log."""
    if end == log.t.size:
        return log
    return replace(
        log,
        t=log.t[:end],
        lat=log.lat[:end],
        lon=log.lon[:end],
        h=log.h[:end],
        lines=log.lines[:end],
        index=log.index[:end],
    )


def measurements(
    log: OrderedLog, track: Any, options: Conditioning, top: Vehicle, end: int
) -> Measurements:
    """Return the channels of the ordered log (step 2; :mod:`fieldmap.nav.logs.faults`).

    Its first ``end`` samples are measured (:func:`measured_end`): the rest, a frozen end,
    are in no channel.
    """
    ell = options.ellipsoid
    n = log.t.size
    zero = np.zeros(n)
    p = np.stack(geodetic_to_ecef(log.lat, log.lon, zero, ell), -1)
    m_per_deg = math.radians(1.0) * ell.a
    rep = flt.repeated(log.lat, log.lon)
    interp, _ = flt.interpolated(log.t, log.lat, log.lon, m_per_deg, INTERP_ROUNDING_M)
    vel = getattr(track, "velocity", None)
    frozen = n - end
    origin = np.mean(p[:end], axis=0)
    state = [log.h]
    if vel is not None:
        state += [vel.speed[log.index], vel.track[log.index]]
        state += [vel.climb[log.index]] if vel.climb is not None else []
    state_tol = np.zeros(len(state))
    state_tol[0] = LEVEL_M  # the geoid and ISA terms a held altitude gains along the line
    interp |= flt.extrapolated(
        log.t, log.lat, log.lon, np.stack(state, -1), state_tol, p, top.speed
    )
    interp &= ~rep
    hi = np.flatnonzero(~rep[:end] & ~interp[:end])
    if hi.size < MIN_POINTS:  # a log of mostly repeats: its repeats are all it has
        hi = np.flatnonzero(~rep[:end]) if np.sum(~rep[:end]) >= MIN_POINTS else np.arange(end)
    rounding = min(flt.printed_step(log.lat), flt.printed_step(log.lon)) * m_per_deg
    span = float(np.max(np.linalg.norm(p[hi] - origin, axis=1))) if hi.size else 0.0
    positions = Channel(
        log.t[hi],
        p[hi] - origin,
        np.ones(hi.size),
        0,
        2,
        _fault_density(span + 1000.0, 2),
        "position",
        timing=True,
    )
    # the samples with a height of their own (a surface report's placeholder is none)
    sr = getattr(track, "surface_report", None)
    blank = getattr(track, "no_height", None)
    hr = np.arange(n) if blank is None else np.flatnonzero(~np.asarray(blank)[log.index])
    hr = hr[hr < end] if np.sum(hr < end) >= MIN_POINTS else np.arange(end)
    q = height_quantum(log.h[hr], np.linalg.norm(np.diff(p[hr], axis=0), axis=1))
    hspan = float(np.ptp(log.h[hr])) if hr.size else 0.0
    heights = Channel(
        log.t[hr],
        log.h[hr, None],
        np.ones(hr.size),
        0,
        1,
        _fault_density(hspan + 1000.0, 1),
        "height",
    )
    index = {"position": hi, "height": hr}
    vel = vel if options.log_velocities else None
    velocities = climbs = None
    notes: list[str] = []
    resolution = (0.0, 0.0, 0.0)
    columns: tuple[str, ...] = ()
    if vel is not None:
        resolution, columns = tuple(vel.resolution), tuple(vel.names)
        src = log.index
        speed, course = vel.speed[src], vel.track[src]
        ok = np.isfinite(speed) & np.isfinite(course) & (speed >= 0.0)
        ok[end:] = False
        if ok.sum() >= MIN_POINTS:
            iv = np.flatnonzero(ok)
            chi = np.radians(course[iv])
            nr, mr = _radii(log.lat[iv], ell)
            hh = log.h[iv]
            ve = speed[iv] * np.sin(chi) * nr / (nr + hh)
            vn = speed[iv] * np.cos(chi) * mr / (mr + hh)
            C = C_e_to_enu(log.lat[iv], log.lon[iv])
            v_ecef = ve[:, None] * C[:, 0, :] + vn[:, None] * C[:, 1, :]
            cells = resolution[0] * np.maximum(
                speed[iv] * math.radians(resolution[1]), resolution[0]
            )
            velocities = Channel(
                log.t[iv],
                v_ecef,
                np.ones(iv.size),
                1,
                2,
                _fault_density(top.speed, 2),
                "velocity",
                held=_repeats(np.stack([speed[iv], course[iv]], -1)),
                cell=float(np.median(cells)) if resolution[0] > 0.0 else 0.0,
            )
            index["velocity"] = iv
        if vel.climb is not None:
            climb = vel.climb[src]
            okc = np.isfinite(climb)
            computed = _off_resolution(climb, resolution[2]) & okc
            if computed.any():
                notes.append(_computed_note(int(computed.sum()), int(okc.sum()), "vertical rates"))
            okc &= ~computed
            okc[end:] = False
            if okc.sum() >= MIN_POINTS:
                ic = np.flatnonzero(okc)
                climbs = Channel(
                    log.t[ic],
                    climb[ic, None],
                    np.ones(ic.size),
                    1,
                    1,
                    _fault_density(top.climb, 1),
                    "vertical rate",
                    held=_repeats(climb[ic, None]),
                    cell=resolution[2],
                )
                index["vertical rate"] = ic
    elif getattr(track, "velocity", None) is not None:
        notes.append(
            Message("the log's velocities not used (", Setting("log_velocities", False), ")")
        )
    if end < n:
        notes.append(
            f"the log's last {frozen} rows (lines {log.lines[end]}..{log.lines[-1]}, "
            f"{log.t[-1] - log.t[end - 1]:.0f} s) repeat every value of line "
            f"{log.lines[end - 1]}: written again, not measured (the log froze there); the "
            "path ends at that line"
        )
    return Measurements(
        positions,
        heights,
        velocities,
        climbs,
        index,
        origin,
        rep,
        interp,
        q,
        rounding,
        resolution,
        columns,
        tuple(notes),
        log.source,
        log.t[:end],
        (np.zeros(n, bool) if sr is None else np.asarray(sr, bool)[log.index])[:end],
    )


# -- step 4: estimate ------------------------------------------------------------------------


@dataclass(frozen=True)
class PathEstimate:
    """The smoothed path of one log (step 4).

    Attributes
    ----------
    horizontal, vertical : SmoothedAxis
        The horizontal (3 ECEF axes of the surface point) and height smoothers' results.
    channels : dict
        Channel name -> (the Channel, its smoother, its position in that smoother's list).
    notes : tuple of str
        What was decided (velocities left out, ...).
    index : dict
        Channel name -> the ordered samples it is at, for the channels the model adds (the
        ground's, :func:`ground_level`); the log's are in :attr:`Measurements.index`.
    height_time_sigma_s : float
        The σ of the heights' time errors (s; 0: none), motion module docstring, "Time errors".
    speed_factor : float or None
        The constant factor between the log's ground speeds and its positions' (a unit or
        column mistake; the velocities left out), None where there is none.
    """

    horizontal: SmoothedAxis
    vertical: SmoothedAxis
    channels: dict[str, tuple[Channel, SmoothedAxis, int]]
    notes: tuple[str, ...] = ()
    index: dict[str, np.ndarray] = field(default_factory=dict)
    height_time_sigma_s: float = 0.0
    #: the constant factor between the log's ground speeds and its positions' where there is
    #: one (the velocities then left out), else None
    speed_factor: float | None = None

    def samples_of(self, name: str, meas: Measurements) -> np.ndarray:
        """Return the ordered samples channel ``name`` is at (the model's or the log's)."""
        return self.index[name] if name in self.index else meas.index[name]


def _first_scale(ch: Channel) -> float:
    """Return a robust first guess of a channel's noise σ (each sample against its neighbours)."""
    t, y = ch.t, ch.y
    if t.size < 5:
        return 1.0
    w = (t[1:-1] - t[:-2]) / (t[2:] - t[:-2])
    r = y[1:-1] - ((1.0 - w)[:, None] * y[:-2] + w[:, None] * y[2:])
    dist = np.linalg.norm(r, axis=1) / np.sqrt(1.0 + w**2 + (1.0 - w) ** 2)
    med = float(np.median(dist[dist > 0])) if np.any(dist > 0) else 0.0
    # the median of a chi distribution with `dof` degrees of freedom: √(2 ln 2) for 2, 0.674 for 1
    return med / (1.1774 if ch.dof == 2 else 0.6745) if med > 0 else 1.0


def _smooth(
    grid: Grid,
    vehicle: Vehicle,
    vertical: bool,
    channels: list[Channel],
    floors: list[float],
    fixed: list[float | None],
    origin: np.ndarray | None = None,
    reported_speeds: tuple[np.ndarray, np.ndarray] | None = None,
    noise_of: SmoothedAxis | None = None,
    start: SmoothedAxis | None = None,
    fresh: bool = False,
    again: SmoothedAxis | None = None,
    speeds_of_positions: bool = False,
) -> SmoothedAxis:
    r"""Smooth one axis group (module docstring, step 4).

    ``start`` (with ``noise_of``): the EM starts from its weights instead of the Huber
    M-estimate's. ``fresh`` (with ``noise_of``): from the fresh samples' weights instead, 1
    for a sample and 0 for a repeat (:func:`_horizontal`). ``again`` (without ``noise_of``):
    the EM, noise levels included, starts from that solution's weights, noise levels, shares
    and time errors instead of the first guesses.

    ``noise_of``: a solution of the same channels whose noise levels :math:`q, s` and steps'
    weights :math:`\lambda` are held; the EM's weights and path (and the fault and copy shares,
    from that solution's) are estimated again from the weights of the Huber M-estimate
    (:meth:`~fieldmap.nav.logs.motion.AxisSmoother.huber_weights`, at ``noise_of``'s
    :math:`q`, the first guesses of the σ below and :math:`\lambda = 1`), a start that does not
    depend on the least-squares one (:func:`_height`). For channels without time errors
    (the height's): ``noise_of``'s are not carried.
    """
    model = vehicle.vertical_model() if vertical else vehicle.horizontal_model()
    lo, hi = vehicle.q_bounds(vertical)
    # a rate channel noisier than a tenth of the class's top speed (climb) tells nothing of
    # the path: its noise is bounded there, and a contradiction shows as faults instead
    top = vehicle.climb if vertical else vehicle.speed
    sbounds = [
        (max(f, 1e-3), max(f, 1e-3) * 1e5 if c.order == 0 else max(0.1 * top, 2.0 * f))
        for f, c in zip(floors, channels)
    ]
    # the height keeps within the class's climb and vertical load factor (bounds, not data)
    g = STANDARD_GRAVITY
    bounds = (
        {
            1: (-vehicle.climb, vehicle.climb),
            2: ((vehicle.n_min - 1.0) * g, (vehicle.n_max - 1.0) * g),
        }
        if vertical
        else None
    )

    def smoother(on: Grid) -> AxisSmoother:
        return AxisSmoother(
            on,
            model,
            channels,
            (lo, hi),
            sbounds,
            fixed,
            bounds,
            origin,
            reported_speeds,
            speeds_of_positions,
        )

    scales0 = [max(_first_scale(c), b[0]) for c, b in zip(channels, sbounds)]
    if len(channels) > 1 and channels[1].order == 1 and channels[0].order == 0:
        # annealing: the first weights are judged against a path shaped by the rates (a
        # stretch of displaced positions cannot pull it), with the positions' σ wide; the
        # likelihood then sets it (a log whose rates are the wrong ones shows as positions
        # mostly faults, and the rates are left out: estimate())
        scales0[0] *= ANNEAL
    if noise_of is not None:
        # the Huber M-estimate at the first guesses of the σ (annealed as above), then the
        # EM's weights and path at the noise levels of ``noise_of``
        sm = smoother(grid)
        q, scales = noise_of.q, list(noise_of.scales)
        if fresh:
            first = [
                np.where(np.asarray(c.held), 0.0, 1.0) if _copies(c) else np.ones(c.t.size)
                for c in channels
            ]
        else:
            first = sm.huber_weights(q, scales0) if start is None else start.weights()
        return sm.run(
            q,
            scales,
            hold_noise=True,
            weights0=first,
            lam0=noise_of.lam,
            shares0=(list(noise_of.fault_rate), list(noise_of.held_rate)),
        )
    q0 = math.sqrt(lo * hi) * 10.0
    weights0 = tau0 = lam0 = shares0 = None
    if again is not None:
        # the EM from ``again``'s weights, noise levels, shares and time errors
        q0, scales0, weights0 = again.q, list(again.scales), again.weights()
        shares0 = (list(again.fault_rate), list(again.held_rate))
        tau0 = (again.tau, again.sigma_tau)
    passes = 2
    # the noise levels are continuous-time quantities: estimated on a grid as coarse as the
    # fixes (up to ESTIMATE_DT_S), then the path solved on the output grid with them
    step = float(np.median(np.diff(channels[0].t))) if channels[0].t.size > 1 else grid.dt
    coarse_dt = min(step, ESTIMATE_DT_S)
    if coarse_dt >= 2.0 * grid.dt:
        k = int(coarse_dt // grid.dt)
        est = smoother(Grid(grid.t0, grid.dt * k, (grid.n - 1) // k + 2)).run(
            q0, scales0, weights0=weights0, tau0=tau0, shares0=shares0
        )
        q0, scales0, weights0 = est.q, est.scales, est.weights()
        shares0 = (est.fault_rate, est.held_rate)
        tau0 = (est.tau, est.sigma_tau)
        # a coarse step's weight holds for each fine step inside it (the jerk's scale)
        lam0 = est.lam[np.minimum(np.arange(grid.n - 1) // k, est.lam.size - 1)]
        passes = 0
    return smoother(grid).run(
        q0,
        scales0,
        passes=passes,
        weights0=weights0,
        tau0=tau0,
        lam0=lam0,
        shares0=shares0,
    )


def _copies(c: Channel) -> bool:
    """Whether the smoother takes some samples of ``c`` for copies (motion, "Held values")."""
    return c.held is not None and bool(np.any(c.held)) and c.cell > 0.0


def _horizontal(
    grid: Grid,
    vehicle: Vehicle,
    channels: list[Channel],
    floors: list[float],
    fixed: list[float | None],
    origin: np.ndarray,
    speeds_of_positions: bool = False,
) -> SmoothedAxis:
    r"""Smooth the horizontal path from two starts and keep the likelier (step 4).

    The EM's first path weighs every sample of the log, its repeats too (a copy or a fresh
    value: motion module docstring, "Held values"). Where a value is held for minutes while
    the positions move on (ADS-B's last airborne ground speed, 103 kt, filled forward through
    a 5-minute taxi), that first path follows the held value, the positions that contradict
    it turn faults, and the EM stays there: a local maximum (the taxi flown as a 4 km loop at
    53 m/s). The second start is the fresh samples' path: each repeat at weight 0, since a
    copy says nothing of the path, from which the EM's weights and path are estimated again
    at the first solution's noise levels. Of the two, the one with the smaller mixture
    :math:`-2\log L` (:func:`_height`'s comparison) is kept, the second only by more than
    :data:`START_EVIDENCE`, and only where its path keeps within the vehicle's top speed
    (motion module docstring, "Speed") or the first's does not either: the bound is the
    model's, a path it cannot hold flies fixes the vehicle could not reach. The noise levels
    stay the first's (as the height's): estimated again from the second start, the EM went
    on to σ of a few metres on 5-second helicopter fixes and flew their scatter at 6.7 g
    (tour_de_france_3924a4_16). Except where the first takes half of a channel for faults
    (its fault share at the EM's ceiling, 1/2) and the second does not: the first's noise
    levels are then those of a path that does not fly that channel, no estimate of its noise
    (the positions' σ at its 1 km ceiling, the taxi's turns cut by up to 190 m:
    zurich_airport_0083c3), and the EM goes on from the second start with the noise levels
    estimated again (there 3.9 m, the σ the positions alone give). Where the second rejects
    half a channel too, the channels contradict each other and :func:`estimate` leaves the
    velocities out. Without repeats there is one start.
    """

    def smooth(**start: Any) -> SmoothedAxis:
        return _smooth(
            grid,
            vehicle,
            False,
            channels,
            floors,
            fixed,
            origin,
            **start,
            speeds_of_positions=speeds_of_positions,
        )

    first = smooth()
    if not any(_copies(c) for c in channels):
        return first
    judged = smooth(noise_of=first, fresh=True)
    if first.mixture_neg2loglik - judged.mixture_neg2loglik <= START_EVIDENCE:
        return first
    if first.speed_bound_holds and not judged.speed_bound_holds:
        return first  # a path the vehicle's top speed cannot hold is no flight of it
    if max(first.fault_rate) >= 0.5 and max(judged.fault_rate) < 0.5:
        return smooth(again=judged)
    return judged


def _height(
    grid: Grid,
    vehicle: Vehicle,
    channels: list[Channel],
    floors: list[float],
    fixed: list[float | None],
) -> SmoothedAxis:
    r"""Smooth the height from two starts and keep the likelier (module docstring, step 4).

    The EM converges to a local maximum of the likelihood: from the annealed start, a long run
    of wrong altitudes (a transponder's stale airborne altitude for 100 s after a landing) can
    hold the path while the fixes before it are judged faults (in squares, 97 altitudes 10 km
    up outweigh the 240 fixes of the approach before them). The second start is the Huber
    M-estimate at the same first guesses of the σ (convex: its minimum does not depend on where
    its iteration starts, and a run of glitches pulls it with a bounded force per sample), from
    which the EM's weights and path are estimated again at the first solution's noise levels
    :math:`q, s` and steps' weights :math:`\lambda` (the fault and copy shares
    :math:`\epsilon, \eta` re-estimated with the weights, as in any E-step). Of the two, the
    one with the smaller

    .. math::

        -2\log L = J_Q(\hat x) + d\log\det A - d\sum_k\log\det(\lambda_k Q^{-1})
                  - d\log\det P_0
                  - 2\sum_i \log\big[\epsilon f + (1-\epsilon)(1-\eta_i)\,
                    N(y_i; h_i^\top\hat x, s^2\rho_i^2) + (1-\epsilon)\eta_i/c\big]

    (:math:`J_Q` the process and initial-state terms of :math:`J`, :math:`P_0` the initial
    state's precision, :math:`\eta_i = \eta` on a repeated sample of a channel with copies
    and 0 elsewhere: each measurement's whole mixture density,
    :meth:`~fieldmap.nav.logs.motion.AxisSmoother.mixture_loglik`) is kept, the second only
    where the evidence for it is very strong: smaller by more than :data:`START_EVIDENCE`
    (:math:`2\ln B > 10` on Kass & Raftery's 1995 scale, J. Am. Statist. Assoc. 90, 773-795).
    Where both starts reach the same optimum, their values differ by the EM's convergence
    alone, and the first is kept;
    at the same noise levels the comparison is between paths, not between noise levels (the
    mixture's likelihood rises as the σ falls and fixes turn faults, so two solutions with
    their own noise levels favour the one that rejects more).
    """
    first = _smooth(grid, vehicle, True, channels, floors, fixed)
    judged = _smooth(grid, vehicle, True, channels, floors, fixed, noise_of=first)
    if first.mixture_neg2loglik - judged.mixture_neg2loglik > START_EVIDENCE:
        return judged
    return first


def _on_ground(
    grid: Grid,
    vehicle: Vehicle,
    air: SmoothedAxis,
    channels: list[Channel],
    floors: list[float],
    fixed: list[float | None],
    level: float,
) -> SmoothedAxis:
    """Smooth the height again with the ground's vertical rates (:func:`ground_level`).

    The EM starts from the path without them, ``air``, and keeps its noise levels: the jerk
    intensity :math:`q` is the vehicle's in flight, which minutes of a level taxi would pull
    down to the bound of its class (and the take-off that follows would turn faults). A second
    start is the Huber M-estimate at those levels, kept where the mixture's likelihood favours
    it by more than :data:`START_EVIDENCE`, as in :func:`_height`: ``air``'s path may hold a
    taxi at stale airborne altitudes that the level ground then joins, where the Huber
    estimate (a bounded pull per sample) finds the field's.
    """
    extra = len(channels) - len(air.scales)
    held = replace(
        air,
        scales=list(air.scales) + [level] * extra,
        fault_prob=list(air.fault_prob) + [np.zeros(c.t.size) for c in channels[-extra:]],
        held_prob=list(air.held_prob) + [np.zeros(c.t.size) for c in channels[-extra:]],
        fault_rate=list(air.fault_rate) + [GROUND_FAULT_START] * extra,
        held_rate=list(air.held_rate) + [0.0] * extra,
    )
    first = _smooth(grid, vehicle, True, channels, floors, fixed, noise_of=held, start=held)
    judged = _smooth(grid, vehicle, True, channels, floors, fixed, noise_of=held)
    if first.mixture_neg2loglik - judged.mixture_neg2loglik > START_EVIDENCE:
        return judged
    return first


def estimate(
    meas: Measurements, vehicle: Vehicle, grid: Grid, options: Conditioning
) -> PathEstimate:
    """Smooth the horizontal path and the height (step 4; module docstring)."""
    fixed = options.noise_m()
    sq12 = math.sqrt(12.0)
    pos_floor = max(meas.position_rounding_m / sq12, 0.01)
    res_s, _, res_v = meas.velocity_resolution
    notes: list[str] = []

    velocities = meas.velocities
    alone: SmoothedAxis | None = None

    fix0 = None if fixed is None else fixed[0]

    def horizontal(
        use_velocities: bool, speeds_of_positions: bool = False
    ) -> tuple[SmoothedAxis, list[Channel]]:
        chans, floors, fix = [meas.positions], [pos_floor], [fix0]
        if use_velocities and velocities is not None:
            chans.append(velocities)
            floors.append(max(res_s / sq12, 0.01))
            fix.append(None)
        sm = _horizontal(grid, vehicle, chans, floors, fix, meas.origin, speeds_of_positions)
        return sm, chans

    factor = None
    if velocities is not None:
        alone, _ = horizontal(False)
        # a constant factor between the log's speeds and its positions' (a unit or column
        # mistake, or one speed held for the whole flight): the speeds say nothing of the
        # path, not even its top speed; the positions alone say where it flew
        factor = _unit_factor(
            np.linalg.norm(velocities.y, axis=1),
            np.linalg.norm(alone.value_at(velocities.t, 1), axis=1),
        )
        if factor is not None:
            notes.append(
                f"the log's ground speeds ({', '.join(meas.velocity_columns[:2])}) are "
                f"{factor:.3g} × its positions' throughout (a unit or column mistake, or a "
                "speed held from elsewhere): not used, the horizontal path follows the "
                "positions alone"
            )
        else:
            # the tracks against the positions' own path: a track column off (a fault uniform
            # in angle) keeps its ground speed, along the path's direction (track_faults)
            velocities, replaced = track_faults(velocities, alone)
            if replaced:
                notes.append(
                    f"{replaced} of the log's tracks "
                    f"({100.0 * replaced / velocities.t.size:.0f} %) are off the direction its "
                    "positions fly: their ground speeds used along the positions' direction"
                )
    if factor is not None:
        # the positions alone, bounded by the speeds they report (the log's are none of the
        # path's): ``alone`` is not, as the reference the log's speeds were judged against
        hz, hchans = horizontal(False, speeds_of_positions=True)
    else:
        hz, hchans = horizontal(True, speeds_of_positions=velocities is None)
    if len(hchans) > 1 and max(hz.fault_rate) >= 0.5:
        # the velocities and the positions cannot both hold: the positions say where it was
        off = [100.0 * float(np.mean(p > 0.5)) for p in hz.fault_prob]
        # their speeds still bound the path (motion module docstring, "Speed")
        assert velocities is not None
        speeds = (velocities.t, np.linalg.norm(velocities.y, axis=1))
        hz = _smooth(
            grid, vehicle, False, [meas.positions], [pos_floor], [fix0], meas.origin, speeds
        )
        hchans = [meas.positions]
        notes.append(
            f"the log's ground speeds and tracks contradict its positions (off the path the "
            f"positions and velocities would share: {off[1]:.0f} % of the velocities, "
            f"{off[0]:.0f} % of the positions): not used, the horizontal path follows the "
            "positions alone"
        )
    vchans = [meas.heights]
    vfloors = [max(meas.height_quantum / sq12, 0.01)]
    vfix = [None if fixed is None else fixed[1]]
    if meas.climbs is not None:
        vchans.append(meas.climbs)
        vfloors.append(max(res_v / sq12, 0.01))
        vfix.append(None)
    heights_alone = None
    # the heights' own rate, whatever the class's climb: a bound would hide the factor below
    # (an airliner's heights in feet read as metres climb at 3.3 × its rates)
    unbounded = replace(vehicle, climb=math.inf)
    if meas.climbs is not None:
        # a constant factor between the log's vertical rates and its heights' is a unit mistake
        heights_alone = _smooth(grid, unbounded, True, vchans[:1], vfloors[:1], vfix[:1])
        k = _unit_factor(meas.climbs.y[:, 0], heights_alone.value_at(meas.climbs.t, 1)[:, 0])
        if k is not None:
            raise InputError(
                f"{meas.source}: the log's vertical rates are {k:.3g} × the rate of its heights "
                "throughout (a unit mistake in the heights or the rates: feet read as "
                "metres?)",
                Advice("; check ", Keyword("alt_units")),
                param="alt_units",
            )
    vt = _height(grid, vehicle, vchans, vfloors, vfix)
    if len(vchans) > 1 and max(vt.fault_rate) >= 0.5:
        share = 100.0 * float(np.mean(vt.fault_prob[1] > 0.5))
        vchans, vfloors, vfix = vchans[:1], vfloors[:1], vfix[:1]
        vt = _height(grid, vehicle, vchans, vfloors, vfix)
        notes.append(
            f"the log's vertical rates contradict its heights ({share:.0f} % of them off the "
            "shared path): not used"
        )
    # the heights' time errors (motion module docstring, "Time errors"): only a row whose
    # position is a fix has one (a repeated or interpolated position, a row sent again, has
    # none that the positions measure)
    fix = np.isin(meas.index["height"], meas.index["position"])
    timing, shared = 0.0, (hz.sigma_tau[0] if hz.sigma_tau else 0.0)
    for _ in range(TIME_ERROR_ROUNDS):
        sigma_tau = _height_time_sigma(vt, meas.heights, fix, max(shared, timing))
        if sigma_tau <= timing:
            break
        # E-steps from the solution without the term (or the last round's), at its noise levels
        vz = np.where(fix, vt.value_at(meas.heights.t, 1)[:, 0], 0.0)
        vchans[0] = replace(meas.heights, time_variance=(vz * sigma_tau) ** 2)
        vt = _smooth(grid, vehicle, True, vchans, vfloors, vfix, noise_of=vt, start=vt)
        timing = sigma_tau
    added: dict[str, np.ndarray] = {}
    ground = ground_level(meas, hz, vehicle)
    level = GROUND_SLOPE_MAX * (vehicle.stall - SURFACE_WIND_MAX)  # the ground's rate σ
    if ground is not None and np.any(
        np.abs(vt.value_at(ground[0].t, 1)[:, 0]) > GROUND_SIGMAS * level
    ):
        added[ground[0].name] = ground[1]
        vchans, vfloors, vfix = vchans + [ground[0]], vfloors + [level], vfix + [level]
        vt = _on_ground(grid, vehicle, vt, vchans, vfloors, vfix, level)
    chans: dict[str, tuple[Channel, SmoothedAxis, int]] = {}
    for axis, cl in ((hz, hchans), (vt, vchans)):
        for i, c in enumerate(cl):
            chans[c.name] = (c, axis, i)
            copies = axis.copies(i)
            if copies:
                notes.append(
                    f"{copies} of the log's {flt.plural(c.name)} "
                    f"({100.0 * copies / c.t.size:.0f} %) repeat the value before them where the "
                    "path moves on: copies of it (a value held or filled forward), not "
                    "measurements"
                )
    return PathEstimate(hz, vt, chans, tuple(notes), added, timing, factor)


def _height_time_sigma(
    vt: SmoothedAxis, heights: Channel, fix: np.ndarray, at_least: float
) -> float:
    r"""Return the σ of the heights' time errors (s): ``at_least`` or, with evidence, more.

    A height stamped :math:`\tau` late or early is off the path by :math:`\dot z\,\tau`: its
    inlier density is :math:`N(r_i; 0, s^2 + \dot z_i^2\sigma_\tau^2)` in the heights'
    mixture (fault, inlier, copy: motion module docstring) at the path, noise scale and shares
    of the solution ``vt`` (:math:`\dot z_i = 0` where ``fix`` is False: a row whose position
    is no fix). An altitude updated less often than its rows (held for a second or two in a
    climb) is older than its stamp by more than its fix: the :math:`\sigma_\tau` in
    [``at_least``, :data:`~fieldmap.nav.logs.motion.TIMING_MAX_S`] that maximises that
    likelihood, where it beats ``at_least`` by more than :data:`TIME_ERROR_EVIDENCE` in
    :math:`-2\log L` (else ``at_least``).
    """
    r = heights.y - vt.value_at(heights.t)[:, :1]
    vz2 = np.where(fix, vt.value_at(heights.t, 1)[:, 0], 0.0) ** 2
    s, eps, eta = vt.scales[0], vt.fault_rate[0], vt.held_rate[0]

    def neg2(sig: float) -> float:
        timed = replace(heights, time_variance=vz2 * sig * sig)
        return -2.0 * float(np.sum(log_mixture(*mixture_components(timed, r, s, eps, eta))))

    if r.size < 10 or at_least >= TIMING_MAX_S:
        return at_least
    best = minimize_scalar(neg2, bounds=(at_least, TIMING_MAX_S), method="bounded")
    if neg2(at_least) - float(best.fun) > TIME_ERROR_EVIDENCE:
        return float(best.x)
    return at_least


def ground_level(
    meas: Measurements, path: SmoothedAxis, vehicle: Vehicle
) -> tuple[Channel, np.ndarray] | None:
    r"""Return the vertical rates a vehicle on the ground has, and the samples they are at.

    An aircraft flies at an airspeed of at least its stall speed :math:`v_s`, in a wind of at
    most :data:`~fieldmap.nav.logs.vehicles.SURFACE_WIND_MAX` (:math:`W`) near the ground,
    so at a ground speed :math:`|v| \ge v_s - W`. Where the horizontal path is slower (by
    :data:`GROUND_SIGMAS` of its posterior σ of speed) at a sample of the log, it is on the
    ground, where its height changes at most at the slope of a runway or taxiway
    (:data:`~fieldmap.nav.logs.vehicles.GROUND_SLOPE_MAX`, :math:`\gamma`): a vertical rate
    :math:`\dot h = 0` measured with σ :math:`\gamma (v_s - W)` and no fault component: a
    constraint of the model, which no run of heights outweighs (a transponder's stale airborne
    altitudes while it taxis are then the heights' faults). The samples are every sample of
    the log, with a height of its own or not (a surface report has none: the reader's
    :attr:`~fieldmap.nav.logs.read.RawTrack.no_height`); an ADS-B surface report is on the
    ground by the transponder's word, at any speed (the take-off roll;
    :attr:`~fieldmap.nav.logs.read.RawTrack.surface_report`). A vehicle that hovers or flies
    slower than the wind (:math:`v_s \le W`) has none.
    """
    slow = vehicle.stall - SURFACE_WIND_MAX
    if slow <= 0.0 or meas.t.size == 0:
        return None
    t = meas.t  # every sample's time: a vehicle standing still repeats its position
    speed = np.linalg.norm(path.value_at(t, 1), axis=1)
    on = np.flatnonzero(speed < slow)
    if on.size:
        # slower with confidence: by GROUND_SIGMAS of the path's posterior σ of speed (per
        # axis), which fixes far apart or noisy leave wide
        nodes, where = np.unique(path.grid.locate(t[on])[0], return_inverse=True)
        sure = speed[on] + GROUND_SIGMAS * path.sigmas_at(nodes, 1)[where] < slow
        on = on[sure]
    if meas.surface.any():  # on the ground by the transponder's word, however fast
        on = np.union1d(on, np.flatnonzero(meas.surface))
    if on.size < MIN_POINTS:
        return None
    ch = Channel(
        t[on],
        np.zeros((on.size, 1)),
        np.ones(on.size),
        1,
        1,
        0.0,
        GROUND_CHANNEL,
    )
    return ch, on


def track_faults(vel: Channel, path: SmoothedAxis) -> tuple[Channel, int]:
    r"""Return the velocity channel with its faulty tracks replaced by the path's direction.

    The angle δ between a log's velocity and the positions-only path's velocity (where the path
    moves faster than :data:`UNIT_MIN_RATE`) is an inlier, :math:`N(0, \sigma_\chi^2)`, or a
    fault, uniform over ±180°: EM for :math:`\sigma_\chi` and the fault share, and a track is
    a fault where its posterior probability is over 1/2. Such a sample keeps its speed, along
    the path's direction (a measurement of the speed alone: the direction is the path's own).
    """
    pv = path.value_at(vel.t, 1)
    ps = np.linalg.norm(pv, axis=1)
    ls = np.linalg.norm(vel.y, axis=1)
    moving = (ps > UNIT_MIN_RATE) & (ls > UNIT_MIN_RATE)
    if moving.sum() < 10:
        return vel, 0
    cosang = np.sum(vel.y[moving] * pv[moving], axis=1) / (ls[moving] * ps[moving])
    ang = np.arccos(np.clip(cosang, -1.0, 1.0))
    sig, eps = math.radians(5.0), 0.1
    pi = np.zeros(ang.size)
    for _ in range(20):
        log_in = -0.5 * (ang / sig) ** 2 - math.log(sig * math.sqrt(2.0 * math.pi)) + math.log(2.0)
        log_out = -math.log(math.pi)
        a, b = math.log(eps) + log_out, math.log1p(-eps) + log_in
        pi = 1.0 / (1.0 + np.exp(b - a))
        w = 1.0 - pi
        sig = max(math.sqrt(float(np.sum(w * ang**2) / max(np.sum(w), 1.0))), math.radians(0.5))
        eps = float(np.clip(np.mean(pi), 1e-4, 0.999))
    bad = np.flatnonzero(moving)[pi > 0.5]
    if bad.size == 0:
        return vel, 0
    y = vel.y.copy()
    y[bad] = (ls[bad] / ps[bad])[:, None] * pv[bad]
    return replace(vel, y=y), int(bad.size)


def _unit_factor(log_rate: np.ndarray, path_rate: np.ndarray) -> float | None:
    """Return the constant factor between a log's rates and its path's, where there is one.

    Where the path moves (|rate| over :data:`UNIT_MIN_RATE`), the log's rates over the path's:
    their median k, and the spread of their logarithms (1.4826 × MAD). A factor is a unit
    (or column) mistake when k is off 1 by more than a quarter and the ratios agree on it
    within :data:`UNIT_SPREAD` (velocities stale or from another source scatter instead).
    """
    moving = (np.abs(path_rate) > UNIT_MIN_RATE) & (np.abs(log_rate) > UNIT_MIN_RATE)
    moving &= np.sign(log_rate) == np.sign(path_rate)
    if moving.sum() < 20 or moving.mean() < 0.5 * np.mean(np.abs(path_rate) > UNIT_MIN_RATE):
        return None
    lr = np.log(np.abs(log_rate[moving]) / np.abs(path_rate[moving]))
    k = float(np.exp(np.median(lr)))
    spread = 1.4826 * float(np.median(np.abs(lr - np.median(lr))))
    return k if abs(math.log(k)) > math.log(1.25) and spread < UNIT_SPREAD else None


# -- the whole conditioning ------------------------------------------------------------------


@dataclass(frozen=True)
class Gap:
    """A stretch flown without fixes, longer than ``max_gap_s``, and the path's σ there.

    Attributes
    ----------
    t_from_s, t_to_s : float
        Its start and end (the log's time scale; s).
    lines : (int, int)
        The lines of the fixes kept on either side (at an end of the flown span: the span's
        first or last line).
    sigma_h_m, sigma_v_m : float
        The path's posterior σ per horizontal axis and vertically (m): at the middle of a gap
        between fixes, at the far end of a stretch at an end of the flown span (its largest).
    fixes : str
        What is missing there: ``"positions and heights"`` (no fix at all), ``"positions"``
        or ``"heights"`` (the other channel's fixes are kept).
    edge : str or None
        ``"start"`` or ``"end"``: a stretch before the first kept fix or after the last, flown
        from the fixes on one side only; None: a gap between fixes.
    """

    t_from_s: float
    t_to_s: float
    lines: tuple[int, int]
    sigma_h_m: float
    sigma_v_m: float
    fixes: str = "positions and heights"
    edge: str | None = None


@dataclass(frozen=True)
class Stretch:
    """A stretch of the flown span without a kept fix of a channel (:func:`unfixed_stretches`).

    ``t_from_s``, ``t_to_s``, ``lines``, ``fixes`` and ``edge`` as in :class:`Gap`.
    """

    t_from_s: float
    t_to_s: float
    lines: tuple[int, int]
    fixes: str
    edge: str | None = None


def unfixed_stretches(
    t: np.ndarray,
    lines: np.ndarray,
    kept: dict[str, np.ndarray],
    flown: tuple[float, float],
    flown_lines: tuple[int, int],
    max_gap_s: float,
) -> list[Stretch]:
    """Return the stretches of the flown span without a kept fix of a channel, over ``max_gap_s``.

    ``kept`` maps ``"positions"`` and ``"heights"`` to the ordered samples whose fix of that
    channel the path kept (bool, like ``t``); ``flown`` is the flown span (s), ``flown_lines``
    its first and last lines. Between two kept fixes further apart than ``max_gap_s`` the path
    is the model's prediction from both sides; before the first kept fix and after the last,
    from one side only. Stretches of the two channels that overlap are reported as one, over
    their union, as missing ``"positions and heights"``. In time order.
    """
    found: list[Stretch] = []
    for name, keep in kept.items():
        tk, lk = t[keep], lines[keep]
        if tk.size == 0:  # none kept at all: the channel's faults say so
            continue
        # between kept fixes (those outside the flown span too: a span trimmed to the air
        # keeps the fixes on the ground beside it), the part inside the flown span
        for j in np.flatnonzero(np.diff(tk) > max_gap_s):
            a, b = max(float(tk[j]), flown[0]), min(float(tk[j + 1]), flown[1])
            if b - a > max_gap_s:
                found.append(Stretch(a, b, (int(lk[j]), int(lk[j + 1])), name))
        if tk[0] - flown[0] > max_gap_s:
            found.append(
                Stretch(flown[0], float(tk[0]), (flown_lines[0], int(lk[0])), name, "start")
            )
        if flown[1] - tk[-1] > max_gap_s:
            found.append(
                Stretch(float(tk[-1]), flown[1], (int(lk[-1]), flown_lines[1]), name, "end")
            )
    found.sort(key=lambda g: (g.t_from_s, g.t_to_s))
    merged: list[Stretch] = []
    for g in found:
        m = merged[-1] if merged else None
        if m is not None and g.t_from_s < m.t_to_s and g.fixes != m.fixes:
            first, last = (m if m.t_from_s <= g.t_from_s else g), (m if m.t_to_s >= g.t_to_s else g)
            merged[-1] = Stretch(
                first.t_from_s,
                last.t_to_s,
                (first.lines[0], last.lines[1]),
                "positions and heights",
                m.edge or g.edge,
            )
        else:
            merged.append(g)
    return merged


@dataclass(frozen=True)
class Conditioned:
    """Everything the conditioning found: what the report is built from.

    Attributes
    ----------
    log : OrderedLog
    measurements : Measurements
    vehicle : Vehicle
    vehicle_how : str
        How the class was chosen (given, or the guess and its evidence).
    evidence : Evidence or None
    estimate : PathEstimate or None
        None with ``smooth=False``.
    grid : Grid or None
    samples : FlightSamples
    flown : (int, int)
        The first and last grid node flown.
    faults : list of Fault
    gaps : list of Gap
    residuals : dict
        Channel name -> each of its samples' distance from the flown path (m, m/s).
    rejected : dict
        Channel name -> the samples the fault model rejected (bool).
    options : Conditioning
    notes : tuple of str
    """

    log: OrderedLog
    measurements: Measurements | None
    vehicle: Vehicle
    vehicle_how: str
    evidence: Evidence | None
    estimate: PathEstimate | None
    grid: Grid | None
    samples: FlightSamples
    flown: tuple[int, int]
    faults: list[flt.Fault] = field(default_factory=list)
    gaps: list[Gap] = field(default_factory=list)
    residuals: dict[str, np.ndarray] = field(default_factory=dict)
    rejected: dict[str, np.ndarray] = field(default_factory=dict)
    options: Conditioning = field(default_factory=Conditioning)
    notes: tuple[str, ...] = ()
    track_notes: tuple[str, ...] = ()
    height_ref: str | None = None
    t0_utc: str | None = None
    #: the log's ground speed (m/s), track (degrees) and vertical rate (m/s) at the ordered
    #: samples, as given (NaN where none), or None
    velocity_log: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None


def _track_info(track: Any, log: OrderedLog) -> dict[str, Any]:
    """Return what the report takes from the track as it is: notes, height reference, velocities."""
    vel = getattr(track, "velocity", None)
    vlog = None
    if vel is not None:
        src = log.index
        climb = vel.climb[src] if vel.climb is not None else np.full(src.size, np.nan)
        vlog = (vel.speed[src], vel.track[src], climb)
    return {
        "track_notes": tuple(getattr(track, "notes", ()) or ()),
        "height_ref": getattr(track, "height_ref", None),
        "t0_utc": getattr(track, "t0_utc", None),
        "velocity_log": vlog,
    }


def _refuse_still(log: OrderedLog, ell: Ellipsoid) -> None:
    """Refuse a log whose vehicle never moves beyond the noise of its fixes (no flight)."""
    if log.t.size < 2:
        return
    p = np.stack(geodetic_to_ecef(log.lat, log.lon, np.zeros_like(log.h), ell), -1)
    across = float(np.max(np.linalg.norm(p - np.median(p, axis=0), axis=1)))
    up = float(np.ptp(log.h))
    if across < STILL_H and up < STILL_V:
        raise InputError(
            f"{log.source} lines {log.lines[0]}..{log.lines[-1]}: not a flight: the vehicle "
            f"never moves (its {log.t.size} samples over {np.ptp(log.t):g} s stay within "
            f"{STILL_H:g} m horizontally and {STILL_V:g} m vertically of one place)"
        )


def _too_few(log: OrderedLog) -> None:
    if log.t.size < MIN_POINTS:
        raise InputError(
            f"{log.source}: {log.t.size} usable samples (of {log.n_in}), a flight needs at "
            f"least {MIN_POINTS}"
        )


def _vehicle(
    log: OrderedLog, track: Any, options: Conditioning, log_speeds: bool = True
) -> tuple[Vehicle, str, Evidence]:
    """Return the vehicle class, how it was chosen and the evidence.

    ``log_speeds``: the log's ground speeds are evidence of its speed (False where they are
    a unit's factor off the positions').
    """
    ell = options.ellipsoid
    lat0, lon0 = float(np.median(log.lat)), float(np.median(log.lon))
    p = np.stack(geodetic_to_ecef(log.lat, log.lon, np.zeros_like(log.h), ell), -1)
    C = C_e_to_enu(lat0, lon0)
    en = (p - p.mean(axis=0)) @ C[:2].T
    keep = ~flt.repeated(log.lat, log.lon)
    fmt = getattr(track, "file_format", None) or _format_of(log.source)
    ev = evidence(
        log.t[keep], en[keep, 0], en[keep, 1], log.h[keep], getattr(track, "category", None), fmt
    )
    vel = getattr(track, "velocity", None) if options.log_velocities else None
    if vel is not None:
        # what the vehicle itself reported is better evidence of its speed and climb than the
        # differences of its fixes (a glitch or a jump moves those)
        gs = vel.speed[log.index]
        gs = gs[np.isfinite(gs)]
        if log_speeds and gs.size >= 20:
            ev = replace(ev, speed=float(np.percentile(gs, 99)))
        if vel.climb is not None:
            rates = vel.climb[log.index]
            # a rate computed between measurements (off the column's steps) reports nothing
            rates = rates[np.isfinite(rates) & ~_off_resolution(rates, vel.resolution[2])]
            if rates.size >= 20:
                ev = replace(ev, climb=float(np.percentile(np.abs(rates), 99)))
                # a rate that repeats the one before is a copy, no new report (held values)
                fresh = np.abs(rates[np.r_[True, rates[1:] != rates[:-1]]])
                if fresh.size >= 3:
                    windows = np.lib.stride_tricks.sliding_window_view(fresh, 3)
                    ev = replace(ev, climb_reported=float(np.median(windows, axis=1).max()))
    if options.vehicle is not None:
        return vehicle_class(options.vehicle), "given", ev
    v, why = guess_vehicle(ev)
    return v, why, ev


def _format_of(source: str) -> str | None:
    s = source.lower()
    for suffix in (".gz", ".bz2", ".xz"):
        if s.endswith(suffix):
            s = s[: -len(suffix)]
    dot = s.rfind(".")
    return s[dot + 1 :] if dot >= 0 else None


def condition(track: Any, options: Conditioning | None = None) -> Any:
    """Clean, smooth samples of a raw flight log, and a report of what was done.

    Parameters
    ----------
    track : RawTrack
        Anything with arrays ``t`` (s), ``lat``, ``lon`` (degrees), ``h`` (m above the
        ellipsoid) and ``lines``, and a ``source`` string
        (:class:`~fieldmap.nav.logs.read.RawTrack`); its ``velocity``, ``category``,
        ``notes``, ``height_ref`` and ``t0_utc`` are used where present.
    options : Conditioning, optional
        The options (default ``Conditioning()``).

    Returns
    -------
    ConditionedFlight
        The samples, the report and the raw samples with their fate
        (:class:`~fieldmap.nav.logs.report.ConditionedFlight`).

    Raises
    ------
    InputError
        Times going back with ``reorder=False``; fewer than 6 usable samples; no flight (the
        vehicle never leaves a 30 m circle and a 15 m height band); nothing left after
        ``airborne_only`` trims the ground; each in one line naming the source and its lines.
    """
    from fieldmap.nav.logs.report import conditioned_flight

    options = Conditioning() if options is None else options
    log = order_log(track, options.reorder)
    _too_few(log)
    _refuse_still(log, options.ellipsoid)
    info = _track_info(track, log)
    if not options.smooth:
        samples = FlightSamples(
            log.t - log.t[0], log.lat, log.lon, log.h, None, log.source, log.lines, float(log.t[0])
        )
        veh = vehicle_class(options.vehicle or "airliner")
        c = Conditioned(
            log,
            None,
            veh,
            "given" if options.vehicle else "not used (smooth=False)",
            None,
            None,
            None,
            samples,
            (0, log.t.size - 1),
            options=options,
            **info,
        )
        return conditioned_flight(c)
    end = measured_end(log, track, options)
    measured = _head(log, end)  # the samples measured: a frozen end's are none
    vehicle, how, ev = _vehicle(measured, track, options)
    vehicle = vehicle.with_log_climb(ev.top_climb)
    meas = measurements(log, track, options, vehicle, end)
    # the grid as fine as the fixes, within 0.1..1 s; a log whose fixes are further apart than
    # ESTIMATE_DT_S is solved on the grid its noise levels are estimated on: a 1 s grid there
    # would hold a stiff model's straight lines by faint data alone (a normal matrix past the
    # digits of float64), and the flight's quintic flies between the nodes
    step = float(np.median(np.diff(meas.t)))
    dt = options.dt_out or (
        ESTIMATE_DT_S if step > ESTIMATE_DT_S else float(np.clip(step, 0.1, 1.0))
    )
    t_lo, t_hi = float(log.t[0]), float(meas.t[-1])  # to the last row measured
    # the first and the last node on the first and the last fix: the step shortened to divide
    # the span (a given dt_out is kept, and the last node falls less than a step after the
    # last fix)
    ng = int(math.ceil((t_hi - t_lo) / dt - 1e-9)) + 1
    if options.dt_out is None and ng > 1:
        dt = (t_hi - t_lo) / (ng - 1)
    if ng < MIN_POINTS:
        raise InputError(
            f"{log.source} lines {log.lines[0]}..{log.lines[-1]}: the flight lasts "
            f"{t_hi - t_lo:.1f} s, {ng} samples at {dt:g} s, fewer than {MIN_POINTS}"
        )
    grid = Grid(t_lo - EDGE * dt, dt, ng + 2 * EDGE)
    # the smoother's systems are banded (bands of 5 to 17): a BLAS thread pool only spins on
    # them, and two logs conditioned at once on two cores took 15 × as long with it
    with threadpool_limits(limits=1, user_api="blas"):
        est = estimate(meas, vehicle, grid, options)
        if est.speed_factor is not None and options.vehicle is None:
            # the speeds a unit's factor off are no evidence of the vehicle either
            again, why, ev2 = _vehicle(measured, track, options, log_speeds=False)
            if again.name != vehicle.name:
                vehicle, ev = again.with_log_climb(ev2.top_climb), ev2
                how = f"{why} (the log's ground speeds left out: a unit's factor off)"
                meas = measurements(log, track, options, vehicle, end)
                est = estimate(meas, vehicle, grid, options)
    return conditioned_flight(_finish(log, meas, vehicle, how, ev, est, grid, options, info))


def _finish(
    log: OrderedLog,
    meas: Measurements,
    vehicle: Vehicle,
    how: str,
    ev: Evidence,
    est: PathEstimate,
    grid: Grid,
    options: Conditioning,
    info: dict[str, Any],
) -> Conditioned:
    """Compute the samples, faults, gaps and residuals of an estimate (step 5)."""
    ell = options.ellipsoid
    ng = grid.n - 2 * EDGE
    a, b = EDGE, EDGE + ng - 1
    hz, vt = est.horizontal, est.vertical
    notes = list(meas.notes) + list(est.notes)
    if options.airborne_only:
        speed = np.linalg.norm(hz.x[:, 1, :], axis=1)
        fast = np.flatnonzero(speed[a : b + 1] >= options.min_speed_mps)
        if fast.size < MIN_POINTS:
            raise InputError(
                f"{log.source} lines {log.lines[0]}..{log.lines[-1]}: no airborne part: the "
                f"vehicle stays slower than {options.min_speed_mps:g} m/s",
                Label("min_speed_mps"),
                Advice("; ", Pass("airborne_only", False), " to fly the ground movement"),
                param="airborne_only",
            )
        if fast[0] > 0 or a + fast[-1] < b:
            notes.append(
                f"ground movement trimmed (airborne_only): {fast[0] * grid.dt:.0f} s at the "
                f"start, {(b - a - fast[-1]) * grid.dt:.0f} s at the end"
            )
        a, b = a + int(fast[0]), a + int(fast[-1])
    nodes = np.arange(a, b + 1)
    r = hz.x[nodes, 0, :] + meas.origin
    lat, lon, _ = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], ell)
    lon = np.degrees(np.unwrap(np.radians(lon)))
    lon += 360.0 * np.round((log.lon[0] - lon[0]) / 360.0)
    h = vt.x[nodes, 0, 0]
    tg = grid.t[nodes]
    near = np.clip(np.searchsorted(meas.t, tg), 0, meas.t.size - 1)  # a measured sample's
    samples = FlightSamples(
        tg - tg[0], lat, lon, h, None, log.source, log.lines[near], float(tg[0])
    )
    # residuals and faults of every channel
    residuals: dict[str, np.ndarray] = {}
    rejected: dict[str, np.ndarray] = {}
    faults: list[flt.Fault] = []
    for name, (ch, axis, i) in est.channels.items():
        idx = est.samples_of(name, meas)
        tau = axis.tau[i] if axis.tau else np.zeros(ch.t.size)
        fit = axis.value_at(ch.t + tau, ch.order)  # at the re-timed times (time errors)
        res = np.linalg.norm(ch.y - fit, axis=1)
        residuals[name], rejected[name] = res, axis.fault_prob[i] > 0.5
        if ch.timing and axis.sigma_tau[i] > 0.0:
            faults += flt.retimed_runs(
                name, ch.t, log.lines[idx], tau, axis.sigma_tau[i], rejected[name]
            )
        distance_at = None
        if name == "position":
            pos = ch.y

            def distance_at(
                j: np.ndarray, shift: float, pos: np.ndarray = pos, ch: Channel = ch
            ) -> np.ndarray:
                return np.linalg.norm(pos[j] - hz.value_at(ch.t[j] + shift), axis=1)

        if name == GROUND_CHANNEL:
            continue  # the model's, not the log's: no fault of the log
        shifts = np.arange(-SHIFT_MAX_S, SHIFT_MAX_S + 0.5 * grid.dt, max(grid.dt, 1.0))
        faults += flt.describe_faults(
            name,
            ch.t,
            log.lines[idx],
            rejected[name],
            res,
            distance_at,
            axis.scales[i] * math.sqrt(ch.dof),
            shifts,
        )
    faults.sort(key=lambda f: f.t_start_s)
    # stretches flown without the fixes of a channel: between kept fixes, and at the ends
    kept = {}
    for name, channel in (("positions", "position"), ("heights", "height")):
        kept[name] = np.zeros(log.t.size, bool)
        kept[name][meas.index[channel][~rejected[channel]]] = True
    gaps = []
    for st in unfixed_stretches(
        log.t,
        log.lines,
        kept,
        (float(tg[0]), float(tg[-1])),
        (int(samples.lines[0]), int(samples.lines[-1])),
        options.max_gap_s,
    ):
        at = {None: 0.5 * (st.t_from_s + st.t_to_s), "start": st.t_from_s, "end": st.t_to_s}
        k = int(np.clip(np.rint((at[st.edge] - grid.t0) / grid.dt), 0, grid.n - 1))
        sigma_h, sigma_v = hz.sigma_at(k), vt.sigma_at(k)
        gaps.append(Gap(st.t_from_s, st.t_to_s, st.lines, sigma_h, sigma_v, st.fixes, st.edge))
    return Conditioned(
        log,
        meas,
        vehicle,
        how,
        ev,
        est,
        grid,
        samples,
        (a, b),
        faults,
        gaps,
        residuals,
        rejected,
        options,
        tuple(notes),
        **info,
    )
