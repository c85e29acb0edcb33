r"""Real flight logs made flyable: from a raw track to samples a :class:`FlightTrajectory` flies.

:class:`~fieldmap.nav.trajectory.FlightTrajectory` interpolates its samples exactly (a quintic
spline), so the metre-level noise of a real log becomes tens of g and a kilometre-level outlier
hundreds. :func:`condition` turns a raw track (an ADS-B or GNSS log as read by
:func:`fieldmap.nav.logs.read.read_track`) into clean, smooth samples on a regular grid, with the
vehicle's real kinematics, and a report of what it did (:attr:`ConditionedFlight.report`,
:meth:`ConditionedFlight.format_report`, :func:`plot_conditioning`; all three in
:mod:`fieldmap.nav.logs.report`).

Steps (the positions as the ECEF of the ellipsoid-surface point, no singularity at the poles or
the antimeridian; the heights on their own; the numerical parts in :mod:`fieldmap.nav.logs.fit`).
:class:`Stages` runs steps 1-4 on construction and 6-7 per segment (:meth:`Stages.fit`); the
cleaning steps are the functions below it, each on one segment of ordered samples.

1. **Order.** Non-finite samples are dropped (counted). Times that go back are sorted (stable;
   counted, the first line named) or, with ``reorder=False``, refused. Of samples sharing a
   time the first in the file is kept. A horizontal position repeated exactly while the vehicle
   moves is *stale* (a receiver re-sending its last position): its height is used, not it.
2. **Outliers**, per stretch without gaps, for positions (local east/north metres) and heights
   apart: a Hampel identifier (Hampel 1974) on the offsets from a robust local trend (running
   medians of the step velocities and of the detrended positions; Tukey 1977), beyond
   ``threshold`` (5) local robust standard deviations (1.4826 × MAD, widened by the 90th
   percentile for heavy-tailed noise) and at least 30 m (heights: 15 m and 3 quanta, so that
   25 ft steps are never outliers), iterated; runs longer than a burst (7 samples, 10 s) are
   motion, not outliers. Where steps are jumps (faster than 1.5 × the vehicle class's speed,
   or than the fastest the log reports, with a second of slack in the time stamps; heights
   ``max_climb_mps``), the fewest fixes go that leave a path the vehicle could fly: a fix from
   another transmitter whichever side its jump is, positions a receiver dead-reckoned at a
   repeated state (they count half). A height
   held and then left faster than 50 m/s was not updated (stale). Later, the robust fit
   rejects what is left (step 6).
3. **Breaks**: jumps that are no short bursts (a displaced stretch: spoofing, a wrong altitude
   held for minutes) split the log into segments; so do gaps longer than ``max_gap_s``, unless
   ``on_long_gap="bridge"`` (default).
4. **Ground.** The leading and trailing parts of each segment slower than ``min_speed_mps``
   and within 30 m of the segment's first (last) height (any height for a vehicle whose stall
   speed is above ``min_speed_mps``) are ground movement: taxi, parking, the slow part of the
   take-off and landing rolls. With ``airborne_only=True`` they are trimmed. By default the
   whole log is flown: a vehicle without a stall speed (helicopter, drone, car, ship, rocket)
   moves slowly within its own envelope, and its slow ends are fitted with the rest; an
   aircraft (a stall speed) is fitted in three pieces, because a ground roll, a parked hour
   and the flight share neither their noise, nor their smoothness, nor their limits (fitted
   together, the ground's few-metre noise and slow speeds change the one σ, λ and timing
   jitter of the whole fit, and the flight is flown differently). The flight is fitted as
   with ``airborne_only=True`` (steps 6-7: the same bits but for its :data:`JOIN_OVERLAP_S`
   seconds next to a piece), then each piece of ground movement next to it
   (:func:`ground_piece`) as an aircraft moves on the ground: a penalised spline with the
   noise σ and λ of its own samples, the log's ground speeds and tracks as observations (a
   parked aircraft reports 0 kt: it does not move), level (no vertical speed: the height of
   the ground; ADS-B surface positions carry no altitude, readers fill 0 or hold the last),
   joined to the flight (the flight's free end, its first or last :data:`JOIN_OVERLAP_S`
   seconds, fitted again with the piece from the flight's own samples, and the flight's path
   held beyond: position, velocity and acceleration continue), and kept within
   :data:`ON_GROUND` (0.5 g horizontally, 5 m/s³) by step 7, the overlap within the
   vehicle's envelope. A segment with no flight left beside its ground movement is flown as
   one piece. The report says how much of the log was on the ground and flown as such (``ground``).
5. **Segment.** ``on_long_gap="bridge"`` (default) flies across gaps of any length (step 6)
   and the longest of the segments jumps leave; ``"longest"`` flies the longest segment that
   gaps and jumps leave and lists the others in the report; ``"refuse"`` raises an
   :class:`InputError` naming the first break. :func:`condition_segments` conditions each.
6. **Smoothing** on a regular grid (``dt_out``, default the median sample interval within
   0.1..1 s, extended past the data so that the ends are no free ends): a penalised
   least-squares path, the discrete cubic smoothing spline (Whittaker 1923, Reinsch 1967,
   Eilers 2003), with weights ``1/σ²`` and λ from the discrepancy principle: the residuals as
   large as the noise σ leaves them given the fit's degrees of freedom (Hutchinson's 1989
   trace estimate). σ is ``position_noise_m`` or estimated from leave-one-out cubic predictions
   (a local RMS: ADS-B noise grows with speed) of the fixes: positions interpolated between
   two fixes (a track resampled to a clock: collinear with their neighbours at equal time
   steps within the rounding of the digits printed, :meth:`OrderedLog.interpolated_positions`)
   are predicted without error, so they are left out of it and of the timing jitter's (6b),
   and a run of L of them is one observation (weight ``1/(L σ²)``); heights quantised in
   ``q`` have at least ``q/√12`` and no noise in level flight. Iteratively reweighted
   (Tukey's bisquare; Garcia 2010): samples beyond 4.685 robust σ are outliers. Gaps are
   bridged by the fit itself:
   across an interval without samples the penalised spline is the cubic that joins the
   positions and velocities at both ends with the least ∫|a|² (Reinsch 1967), a path the
   vehicle can fly; its uncertainty is the fit's Bayesian posterior σ at the middle of each
   gap longer than ``max_gap_s`` (Wahba 1983; :func:`~fieldmap.nav.logs.fit.posterior_sigma`),
   given in the report.
7. **Vehicle limits.** Where the path as flown (the quintic through the output) exceeds
   ``max_accel_g`` (2.5 g) or ``max_jerk`` (5 m/s³), the noise σ of the samples there is
   raised and the path refitted, until it keeps within them: stale or late ADS-B positions and
   the corners of resampled tracks demand more than an aircraft can do.

``smooth=False`` does step 1 only: today's exact interpolation of the ordered samples. Either
way a log whose vehicle never moves (within 30 m horizontally and 15 m vertically of one place)
is refused: it is no flight.

The options travel as one :class:`Conditioning`, validated once on construction. Messages that
say what to change name its fields; an :class:`~fieldmap.errors.InputError` about one carries
its name as ``param`` (the command line rewords the message with its own options:
:mod:`fieldmap.cli`).

**Vehicle classes** (:class:`Vehicle`, :data:`VEHICLES`, :func:`guess_vehicle`). The smoothing
of :mod:`fieldmap.nav.logs.condition` keeps the flown path within what the vehicle
can do: its load factor (the specific force in g, what an accelerometer senses), its jerk and its
speed. One generic envelope (2.5 g, 5 m/s³) fits no vehicle: it lets an airliner pull 2 g where
it flies 0.7…1.4 g, and stops a glider or a rocket short of theirs. Each class here holds one
envelope, with its source or the reasoning behind it:

============== =========== ========= ========= ==========================================
class          load factor jerk      speed     source / reasoning
               n (g)       (m/s³)    (m/s)
============== =========== ========= ========= ==========================================
airliner       0.5 … 1.6   3         360       transport category (CS-25.337) limit loads
                                               are −1…+2.5 g, but an airliner in service flies
                                               0.7…1.4 g: turns at most 30° bank (n = 1.15),
                                               turbulence rarely beyond ±0.5 g (ICAO Annex 3
                                               "severe" is ±1 g); ground speed: Mach 0.9 at
                                               cruise plus a 200 kt jet stream
light-aircraft −1.5 … 3.8  10        130       CS-23 normal category limit loads (+3.8/−1.52
                                               g); Vne of light singles and twins about 100
                                               m/s, plus wind
glider         −2.65 … 5.3 10        100       CS-22 utility category (+5.3/−2.65 g); Vne
                                               about 75 m/s (270 km/h), plus wind
helicopter     −0.5 … 3.5  10        110       CS-27/29 limit manoeuvring loads (+3.5/−0.5 g);
                                               the helicopter speed record is 111 m/s
uav            −1 … 4      20        80        small fixed-wing and multirotor drones (no
                                               certification basis): the light-aircraft loads
                                               with a margin; racing multirotors stay below 80
                                               m/s
fighter        −3 … 9      50        700       the F-16's +9/−3 g; Mach 2 at altitude
car            0.3 … 1.6   10        90        tyres hold about 1 g laterally and in braking
                                               (√(1 + 1²) = 1.41 g); bumps ±0.3 g; emergency
                                               braking builds up within 0.1…0.2 s (≈ 10 m/s³);
                                               325 km/h
ship           0.7 … 1.3   2         30        heave and roll of a vessel in a seaway: the
                                               accelerations of passenger comfort criteria
                                               (0.2 g vertical, NORDFORSK 1987) with margin;
                                               60 kt fast craft
rocket         0 … 10      100       8000      launch vehicles: 3…6 g axial at burnout
                                               (Saturn V 4 g, Space Shuttle 3 g), 0 g in
                                               coast; orbital speed 7.9 km/s
============== =========== ========= ========= ==========================================

Stall speeds (the slowest a class flies; slower at the ends of a log is ground movement whatever
the altitude column says): airliner 50 m/s (a wide-body's approach speed is 70 m/s, its stall in
landing configuration about 55 m/s), fighter 60 m/s, light aircraft 20 m/s (CS-23 singles stall
at 25…30 m/s), glider 15 m/s; helicopters, drones and surface vehicles none.

The conditioning keeps the specific force ``|a − γ|`` within ``[n_min, n_max] g`` and the jerk
below the class's; the report compares the flown speeds with the class's.

Guess (:func:`guess_vehicle`), when the user names none: from an ADS-B emitter category where the
log carries one (DO-260B: A1 light, A2 small, A3 large, A4 high-vortex, A5 heavy, A6 high
performance, A7 rotorcraft, B1 glider, B6 UAV, C1/C2 surface vehicles), else from the log's robust
ground speed and height: over 1.2 km/s or 300 m/s vertically a rocket; over 130 m/s or above 7 km an
airliner; slower than 45 m/s within 150 m of one height a car; else a light aircraft. The report
says which class, and whether it was guessed.

The references (Hampel 1974, Tukey 1977, Theil 1950, Sen 1968, Whittaker 1923, Reinsch 1967,
Eilers 2003, Buja et al. 1989, Hutchinson 1989, Beaton & Tukey 1974, Garcia 2010) are given in
full in :mod:`fieldmap.nav.logs.fit`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from typing import Any, NoReturn

import numpy as np

import fieldmap.nav.logs.fit as cfit
from fieldmap.errors import Advice, InputError, Keyword, Label, Part, Pass
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic, geodetic_to_ecef
from fieldmap.nav.logs.report import (
    DROPPED,
    GAP,
    GROUND,
    KEPT,
    OUTLIER_H,
    OUTLIER_HV,
    OUTLIER_V,
    STALE,
    STATUS_NAMES,
    ConditionedFlight,
    finish,
)
from fieldmap.nav.trajectory import MIN_POINTS, FlightSamples
from fieldmap.units import STANDARD_GRAVITY as G0

#: running-median half-window (samples): about HALF_SPAN_S seconds, within HALF_MIN..HALF_MAX
HALF_MAX, HALF_SPAN_S, HALF_MIN = 7, 15.0, 2
#: an outlier burst lasts at most BURST_S seconds and HALF_MAX samples; longer runs are motion
BURST_S = 10.0
#: the outlier scale is taken over ±SCALE_HALF samples
SCALE_HALF = 50
#: smallest outlier offsets and jump margins (m): horizontal, vertical (or 3 height quanta)
FLOOR_H, FLOOR_V = 30.0, 15.0
#: a step between two fixes faster than this × the vehicle class's speed (plus FLOOR_H) is a
#: jump: one of them is wrong (the class speeds already hold a wind margin)
JUMP_FACTOR = 1.5
#: a receiver's time stamps err by up to this (s): a step may be this much longer in time
TIME_SLACK_S = 1.0
#: the longest run of repeated reported states (samples) a path may leave out at once
CHAIN_MAX = 60
#: a height held and then left faster than this (m/s) was not updated
HOLD_RATE = 50.0
#: ground: within this height (m) of the segment's first (last) height
GROUND_DH = 30.0
#: vehicle limits: aim below LIMIT_MARGIN × the bound; at most LIMIT_ITER softenings
LIMIT_MARGIN, LIMIT_ITER = 0.9, 12
#: grid nodes beyond the data at either end
EDGE = 8
#: timing jitter: modelled when the along-track residual variance exceeds JITTER_RATIO × the
#: across-track one; RETIME_ITER passes
JITTER_RATIO, RETIME_ITER = 2.0, 3
#: a fix is moved by at most JITTER_CLIP jitter σ
JITTER_CLIP = 3.0
#: positions collinear with their neighbours within a rounding finer than this (m) are
#: interpolated between fixes (:meth:`OrderedLog.interpolated_positions`); a coarser rounding
#: (4 decimals of a degree: 11 m) hides a real fix's noise, and says nothing
INTERP_TOL_M = 1.0
#: ... and only in a track resampled to a clock: at least this fraction of the positions
#: interpolated (the ``traffic`` package's resampled samples 51..55 %; real 1 Hz logs under 1 %,
#: and refuelling orbits 8 %, whose few collinear positions move the noise estimate by little)
INTERP_MIN_FRACTION = 0.2
#: smallest noise σ (m) estimated
SIGMA_MIN = 0.05
#: local noise: RMS over ±NOISE_HALF samples, at least NOISE_FRAC × the segment's
NOISE_HALF, NOISE_FRAC = 25, 0.3
#: quantised heights repeated this long (s) are level flight
LEVEL_S = 20.0
#: a vehicle that stays within STILL_H metres horizontally and STILL_V vertically of one place
#: never moved beyond the noise of its fixes (the outlier floors): not a flight
STILL_H, STILL_V = FLOOR_H, FLOOR_V


# -- vehicle classes ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Vehicle:
    """The envelope of one vehicle class (see the module docstring for the values' sources).

    Attributes
    ----------
    name : str
        The class (``airliner``, ``glider``, …).
    n_min, n_max : float
        Load factor range: the specific force's magnitude the flown path keeps within.
        Units: g.
    jerk : float
        Largest jerk (rate of the acceleration). Units: m/s³.
    speed : float
        Largest speed over the ground. Units: m/s.
    climb : float
        Largest vertical speed, up or down. Units: m/s.
    stall : float
        Slowest speed it flies at (0: any, or it does not fly). Units: m/s.
    """

    name: str
    n_min: float
    n_max: float
    jerk: float
    speed: float
    climb: float
    stall: float = 0.0


#: the vehicle classes, by name (module docstring)
VEHICLES: dict[str, Vehicle] = {
    v.name: v
    for v in (
        Vehicle("airliner", 0.5, 1.6, 3.0, 360.0, 40.0, 50.0),
        Vehicle("light-aircraft", -1.5, 3.8, 10.0, 130.0, 20.0, 20.0),
        Vehicle("glider", -2.65, 5.3, 10.0, 100.0, 20.0, 15.0),
        Vehicle("helicopter", -0.5, 3.5, 10.0, 110.0, 20.0),
        Vehicle("uav", -1.0, 4.0, 20.0, 80.0, 25.0),
        Vehicle("fighter", -3.0, 9.0, 50.0, 700.0, 300.0, 60.0),
        Vehicle("car", 0.3, 1.6, 10.0, 90.0, 15.0),
        Vehicle("ship", 0.7, 1.3, 2.0, 30.0, 5.0),
        Vehicle("rocket", 0.0, 10.0, 100.0, 8000.0, 8000.0),
    )
}

#: ADS-B emitter categories (DO-260B, as ``traffic`` and OpenSky write them) -> class
CATEGORIES = {
    "A1": "light-aircraft",
    "A2": "light-aircraft",
    "A3": "airliner",
    "A4": "airliner",
    "A5": "airliner",
    "A6": "fighter",
    "A7": "helicopter",
    "B1": "glider",
    "B6": "uav",
    "C1": "car",
    "C2": "car",
}


def vehicle_class(name: str) -> Vehicle:
    """Return the class ``name``; an unknown one is an :class:`InputError` naming the known."""
    v = VEHICLES.get(str(name).strip().lower())
    if v is None:
        raise InputError(
            Keyword("vehicle"),
            f" must be one of {', '.join(VEHICLES)}, got {name!r}",
            param="vehicle",
        )
    return v


def guess_vehicle(
    speed: np.ndarray, climb: np.ndarray, h: np.ndarray, category: str | None = None
) -> tuple[Vehicle, str]:
    """Guess the class of a log's vehicle, and say from what (module docstring).

    Parameters
    ----------
    speed, climb : numpy.ndarray
        Robust ground speed and vertical speed along the log (running medians of the step
        speeds: a wild sample moves neither). Units: m/s.
    h : numpy.ndarray
        Heights. Units: m.
    category : str, optional
        An ADS-B emitter category (``"A3"``), when the log carries one.

    Returns
    -------
    (Vehicle, str)
        The class, and why (for the report).
    """
    if category is not None and str(category).strip().upper() in CATEGORIES:
        c = str(category).strip().upper()
        return VEHICLES[CATEGORIES[c]], f"guessed from the ADS-B emitter category {c}"

    def pct(x: np.ndarray, q: float) -> float:
        x = np.asarray(x, dtype=np.float64)
        x = x[np.isfinite(x)]
        return float(np.percentile(x, q)) if x.size else 0.0

    v95, up95, top = pct(speed, 95), pct(np.abs(climb), 95), pct(h, 99)
    band = top - pct(h, 1)
    why = f"ground speed to {v95:.0f} m/s, heights to {top:.0f} m"
    if v95 > 1200.0 or up95 > 300.0:
        name = "rocket"
    elif v95 > 100.0 or top > 7000.0:
        name = "airliner"
    elif v95 < 45.0 and band < 150.0:
        name = "car"
    else:
        name = "light-aircraft"
    return VEHICLES[name], f"guessed from the log ({why})"


@dataclass(frozen=True)
class Conditioning:
    """The options of the conditioning of a flight log, validated once (on construction).

    Built alike by the command line (``fieldmap nav --trajectory``) and by Python users, and
    passed as one object to :func:`condition`, :func:`condition_segments` and
    :func:`fieldmap.nav.logs.load_flight`.

    Parameters
    ----------
    position_noise_m : float or (float, float), optional
        Position noise σ (m): one value, or (horizontal, per axis; vertical). Default:
        estimated from the data.
    max_gap_s : float
        Gaps longer than this (s) are long gaps: bridged and reported with their uncertainty
        (``on_long_gap="bridge"``), or breaks that split the log.
    airborne_only : bool
        Trim leading and trailing ground movement (slower than ``min_speed_mps``). Default
        False: the whole log is flown, an aircraft's ground movement as an aircraft moves on
        the ground (step 4 of :mod:`fieldmap.nav.logs.condition`).
    smooth : bool
        False: only order the samples and drop repeated times (exact interpolation).
    reorder : bool
        Sort times that go back; False: refuse them (:class:`InputError` naming the line).
    on_long_gap : {"bridge", "longest", "refuse"}
        Gaps longer than ``max_gap_s``: bridge them by the fit (default; the report gives the
        bridged position's σ), or let them split the log with jumps and fly the longest
        segment (the report lists the others), or refuse naming the first break.
    ellipsoid : Ellipsoid
        Ellipsoid of the coordinates.
    min_speed_mps : float
        Ground speed below which a vehicle near its first (last) height is on the ground
        (trimmed with ``airborne_only``, else flown as such).
    max_speed_mps, max_climb_mps : float
        Horizontal and vertical speeds between consecutive samples beyond which one of them is
        wrong (m/s): a short run between such jumps is an outlier burst, a longer one a break.
        Generous (any vehicle's noisy steps stay within them), not the vehicle's envelope; the
        outlier step (2) takes the smaller of ``max_speed_mps`` and 1.5 × the vehicle's speed
        (or the fastest the log reports).
    vehicle : str, optional
        The vehicle class (:data:`VEHICLES`: ``airliner``,
        ``light-aircraft``, ``glider``, ``helicopter``, ``uav``, ``fighter``, ``car``,
        ``ship``, ``rocket``) whose load factor, jerk and speeds the conditioned path keeps
        within. Default: guessed from the log
        (:func:`guess_vehicle`), and the report says so.
    max_accel_g, max_jerk : float, optional
        Further limits: acceleration (g, relative to the Earth; default none beyond the
        vehicle's load factor) and jerk (m/s³; default the vehicle's).
    threshold : float
        Outlier threshold in robust standard deviations.
    dt_out : float, optional
        Output sample interval (s). Default: the median sample interval, within 0.1..1 s.
    log_velocities : bool
        Use the velocities the log carries (ADS-B ground speed, track and vertical rate, NMEA
        RMC speed and course, GPX speed): checked against the positions, then observations
        of the path, the log's fastest speed for the jump bound, and its repeated states for
        dead-reckoned fixes (default). False: the log's velocity columns are not used at all
        (a log whose velocity columns are stale or from another source; the report says so).

    Raises
    ------
    InputError
        An invalid option, naming it (``param``: the command line rewords the message with its
        own option, :mod:`fieldmap.cli`).
    """

    position_noise_m: float | tuple[float, float] | None = None
    max_gap_s: float = 60.0
    airborne_only: bool = False
    smooth: bool = True
    reorder: bool = True
    on_long_gap: str = "bridge"
    ellipsoid: Ellipsoid = WGS84
    min_speed_mps: float = 30.0
    max_speed_mps: float = 1200.0
    max_climb_mps: float = 300.0
    max_accel_g: float | None = None
    max_jerk: float | None = None
    threshold: float = 5.0
    dt_out: float | None = None
    vehicle: str | None = None
    log_velocities: bool = True

    def __post_init__(self) -> None:
        if self.on_long_gap not in ("bridge", "longest", "refuse"):
            raise InputError(
                Keyword("on_long_gap"),
                f" must be 'bridge', 'longest' or 'refuse', got {self.on_long_gap!r}",
                param="on_long_gap",
            )
        for name, optional in (
            ("max_gap_s", False),
            ("min_speed_mps", False),
            ("max_speed_mps", False),
            ("max_climb_mps", False),
            ("threshold", False),
            ("max_accel_g", True),
            ("max_jerk", True),
            ("dt_out", True),
        ):
            v = getattr(self, name)
            if not (optional and v is None) and not (
                isinstance(v, (int, float)) and np.isfinite(v) and v > 0
            ):
                raise InputError(
                    Keyword(name), f" must be a positive number, got {v!r}", param=name
                )
        self.noise_m()
        if self.vehicle is not None:
            vehicle_class(self.vehicle)

    def noise_m(self) -> list[float] | None:
        """Return the position noise σ (m) as [horizontal, vertical], or None (estimated)."""
        noise = self.position_noise_m
        if noise is None:
            return None
        try:
            sig = [float(x) for x in np.broadcast_to(np.asarray(noise, dtype=float), (2,))]
        except (TypeError, ValueError):
            sig = [np.nan]
        if not all(np.isfinite(x) and x > 0 for x in sig):
            raise InputError(
                Keyword("position_noise_m"),
                f" must be positive metres, got {noise!r}",
                param="position_noise_m",
            )
        return sig

    def report_options(self) -> dict[str, Any]:
        """Return the options as the report gives them (JSON-ready)."""
        return {
            "position_noise_m": self.noise_m(),
            "max_gap_s": float(self.max_gap_s),
            "airborne_only": bool(self.airborne_only),
            "smooth": bool(self.smooth),
            "min_speed_mps": float(self.min_speed_mps),
            "max_speed_mps": float(self.max_speed_mps),
            "max_climb_mps": float(self.max_climb_mps),
            "max_accel_g": None if self.max_accel_g is None else float(self.max_accel_g),
            "max_jerk": None if self.max_jerk is None else float(self.max_jerk),
            "threshold": float(self.threshold),
            "dt_out": None if self.dt_out is None else float(self.dt_out),
            "vehicle": self.vehicle,
            "log_velocities": bool(self.log_velocities),
        }


def without_velocities(track: Any) -> Any:
    """Return ``track`` without the velocities it carries (``log_velocities=False``).

    A :class:`~fieldmap.nav.logs.read.RawTrack` (or any dataclass with its fields) is copied
    with ``velocity=None`` and a note saying so; anything else is returned as it is when it
    has no velocities.
    """
    vel = getattr(track, "velocity", None)
    if vel is None:
        return track
    note = f"the log's velocities ({'/'.join(vel.names)}) not used (log_velocities=False)"
    return replace(track, velocity=None, notes=(*getattr(track, "notes", ()), note))


def condition(track: Any, options: Conditioning | None = None) -> ConditionedFlight:
    """Clean, smooth samples of a raw flight log, and a report of what was done.

    Parameters
    ----------
    track : RawTrack
        Anything with arrays ``t`` (s), ``lat``, ``lon`` (degrees), ``h`` (m above the
        ellipsoid) and ``lines``, and a ``source`` string
        (:class:`~fieldmap.nav.logs.read.RawTrack`); its ``notes``, ``height_ref`` and
        ``t0_utc`` go into the report.
    options : Conditioning, optional
        The options (default ``Conditioning()``). The 0.1 keywords (``max_gap_s=`` …) still
        work, with a ``DeprecationWarning``.

    Returns
    -------
    ConditionedFlight

    Raises
    ------
    InputError
        Times going back with ``reorder=False``; more than one segment with
        ``on_long_gap="refuse"``; nothing left to fly (all on the ground with
        ``airborne_only=True``, too few samples);
        no flight (the vehicle never leaves a 30 m circle and a 15 m height band, also with
        ``smooth=False``, whatever ``airborne_only``), each in one line naming the source and
        its lines.
    """
    options = Conditioning() if options is None else options
    st = Stages(track, options)
    if not options.smooth:
        return finish(st, st.exact())
    ids = st.segment_ids()
    if options.on_long_gap == "refuse" and len(ids) > 1:
        st.refuse_break(ids)
    return finish(st, st.fit(st.longest(ids)))


def condition_segments(track: Any, options: Conditioning | None = None) -> list[ConditionedFlight]:
    """Condition every segment of a log (gaps and jumps separate them), in time order.

    Options as :func:`condition` (``on_long_gap`` and ``smooth`` ignored); segments too short
    to fly are left out. Raises :class:`InputError` when none is left.
    """
    options = Conditioning() if options is None else options
    st = Stages(track, replace(options, smooth=True, on_long_gap="longest"))
    out = []
    for s in st.segment_ids():
        try:
            out.append(finish(st, st.fit(s)))
        except InputError:
            continue
    if not out:
        st.nothing_left()
    return out


class Stages:
    """Steps 1-4 on construction; :meth:`fit` does 6-7 for one segment.

    :meth:`fit` also flies the ground movement next to the segment (step 4, :meth:`_fly_ground`).
    """

    def __init__(self, track: Any, options: Conditioning) -> None:
        if not options.log_velocities:
            track = without_velocities(track)
        self.track, self.options = track, options
        self.opts = opts = options.report_options()
        self.log = log = OrderedLog(track, options.ellipsoid, options.reorder)
        n = log.t.size
        z = np.zeros(n, bool)
        self.stale, self.stale_v, self.out_h, self.out_v = z.copy(), z.copy(), z.copy(), z.copy()
        self.ground, self.in_gap, self.dropped_mask = z.copy(), z.copy(), z.copy()
        #: ground movement flown (``airborne_only=False``), and the segment it belongs to
        self.on_ground, self.ground_seg = z.copy(), np.full(n, -1, np.int64)
        self.hv_all, self.vv_all = ~z, ~z
        #: the ground pieces of the last fitted segment (the report's ``ground``)
        self.ground_pieces: list[dict[str, Any]] = []
        self.ground_envelope = ON_GROUND
        self.off_h, self.off_v = np.zeros(n), np.zeros(n)
        self.obs: cfit.Observed | None = None
        #: the log's velocities before the check left its outliers out (the report's residuals)
        self.obs_all: cfit.Observed | None = None
        self.t_h, self.p_h = log.t, log.p
        self.timing: dict[str, Any] | None = None
        self.quantum = cfit.height_quantum(log.h)
        self.breaks: list[tuple[int, int, str]] = []
        self.dropped: list[dict] = []
        self.seg = np.zeros(n, np.int64)
        self.hv, self.vv = ~z, ~z
        self.vehicle, self.vehicle_why = vehicle_class(options.vehicle or "airliner"), "given"
        #: positions interpolated between fixes: the interior count of each one's run (0: a fix)
        self.interpolated, self.interpolated_tol = np.zeros(n), 0.0
        if n >= 3:
            log.geometry()
            self.stale = log.stale_positions()
            self.interpolated, self.interpolated_tol = log.interpolated_positions()
        if options.vehicle is None:
            self.vehicle, self.vehicle_why = self._guess(~self.stale)
        veh = self.vehicle
        #: the limits in force: the options where given, else the vehicle's
        self.lim = {
            "max_speed_mps": opts["max_speed_mps"],
            "max_climb_mps": opts["max_climb_mps"],
            "max_accel_g": opts["max_accel_g"],
            "max_jerk": opts["max_jerk"] or veh.jerk,
            "n_min": veh.n_min,
            "n_max": veh.n_max,
        }
        if not opts["smooth"] or n < 3:
            return
        o, q = dict(opts, **self.lim), self.quantum
        floor_v = max(3.0 * q, FLOOR_V)
        hv, vv = ~self.stale, ~z
        comps = [(hv, log.p, np.inf, 0.0), (vv, log.h[:, None], np.inf, 0.0)]
        seg, _ = segments(log.t, comps, o["max_gap_s"])
        repeated = log.repeated_states(self.track)
        for s in np.unique(seg[seg >= 0]):
            m = np.flatnonzero(seg == s)
            en, tt, k = log.en[m], log.t[m], o["threshold"]
            bad_h, self.off_h[m] = outliers(
                tt,
                log.p[m],
                hv[m],
                lambda e: to_en(en, e),
                k,
                FLOOR_H,
                min(o["max_speed_mps"], self._jump_speed()),
                repeated[m],
            )
            bad_v, self.off_v[m] = outliers(
                tt, log.h[m, None], vv[m], lambda e: e, k, floor_v, o["max_climb_mps"]
            )
            self.out_h[m[bad_h]], self.out_v[m[bad_v]] = True, True
        hv &= ~self.out_h
        vv &= ~self.out_v
        iv = np.flatnonzero(vv)
        self.stale_v[iv] = stale_heights(log.t[iv], log.h[iv], floor_v)
        vv &= ~self.stale_v
        comps = [
            (hv, log.p, o["max_speed_mps"], FLOOR_H),
            (vv, log.h[:, None], o["max_climb_mps"], floor_v),
        ]
        if options.on_long_gap == "bridge":  # jumps are left to the robust fit (step 6)
            comps = [(hv, log.p, np.inf, FLOOR_H), (vv, log.h[:, None], np.inf, floor_v)]
        seg, self.breaks = segments(log.t, comps, o["max_gap_s"])
        if options.on_long_gap == "bridge" and any(
            (hv & (seg == s)).sum() >= MIN_POINTS and (vv & (seg == s)).sum() >= MIN_POINTS
            for s in np.unique(seg[seg >= 0])
        ):
            # one flight across every gap, from the first sample to the last (step 5): the
            # ground trimming below then sees its real ends (a glider parked after landing)
            seg[:] = 0
        self.in_gap = seg < 0
        # an aircraft (a stall speed) is flown on the ground as such, apart from its flight
        fly_ground = not o["airborne_only"] and self.vehicle.stall > 0.0
        if o["airborne_only"] or fly_ground:
            for s in np.unique(seg[seg >= 0]):
                m = np.flatnonzero(seg == s)
                g = ground(
                    log.t[m],
                    log.p[m],
                    log.h[m],
                    (hv[m], vv[m]),
                    o["min_speed_mps"],
                    self.vehicle.stall > o["min_speed_mps"],
                )
                if fly_ground:
                    air = m[~g]
                    if hv[air].sum() < MIN_POINTS or vv[air].sum() < MIN_POINTS:
                        continue  # no flight to join: the whole segment is flown as one
                    self.on_ground[m[g]] = True
                    self.ground_seg[m[g]] = s
                else:
                    self.ground[m[g]] = True
                seg[m[g]] = -1
        #: the usable samples before the ground was set apart (the ground pieces use them)
        self.hv_all, self.vv_all = hv.copy(), vv.copy()
        self.hv, self.vv, self.seg = hv & (seg >= 0), vv & (seg >= 0), seg

    def _jump_speed(self) -> float:
        """Speed (m/s) beyond which a step between two fixes is a jump (:data:`JUMP_FACTOR`).

        × the vehicle class's speed, or × the fastest the log itself reports (its 99th
        percentile ground speed, from 20 values) when that is lower.
        """
        speed = self.vehicle.speed
        vel = getattr(self.track, "velocity", None)
        if vel is not None:
            gs = vel.speed[np.isfinite(vel.speed)]
            if gs.size >= 20:
                speed = min(speed, float(np.percentile(gs, 99)))
        return JUMP_FACTOR * speed

    def _guess(self, hv: np.ndarray) -> tuple[Any, str]:
        """Guess the vehicle class from robust speeds (:func:`~.vehicle.guess_vehicle`)."""
        log = self.log
        cat = getattr(self.track, "category", None)
        idx = np.flatnonzero(hv)
        if idx.size < 3:
            return guess_vehicle(np.zeros(1), np.zeros(1), log.h, cat)
        t, half = log.t[idx], half_window(log.t[idx])
        dt = np.diff(t)
        v = cfit.running_median(np.diff(log.p[idx], axis=0) / dt[:, None], half)
        w = cfit.running_median(np.diff(log.h)[:, None] / np.diff(log.t)[:, None], half)
        h = cfit.running_median(log.h[:, None], half)[:, 0]
        return guess_vehicle(np.linalg.norm(v, axis=1), w[:, 0], h, cat)

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
                self.dropped_mask[self.ground_seg == s] = True
        return best

    def refuse_break(self, ids: list[int]) -> None:
        """Raise an :class:`InputError` naming the break between the first two segments."""
        t, lines = self.log.t, self.log.lines
        a = int(np.flatnonzero(self.seg == ids[0])[-1])
        b = int(np.flatnonzero(self.seg == ids[1])[0])
        kind = next((k for i, j, k in self.breaks if a <= i < b or a < j <= b), "gap")
        o = dict(self.opts, **self.lim)
        why: tuple[Part, ...] = (
            (f"more than {o['max_gap_s']:g} s", Label("max_gap_s"), ": raise the limit")
            if kind == "gap"
            else (
                f"a position or height jump (faster than {o['max_speed_mps']:g} m/s "
                f"horizontally or {o['max_climb_mps']:g} m/s vertically)",
            )
        )
        raise InputError(
            f"{self.log.source} lines {lines[a]}..{lines[b]}: the flight breaks for "
            f"{t[b] - t[a]:.1f} s (t = {t[a]:.1f} .. {t[b]:.1f} s), ",
            *why,
            Advice("; ", Pass("on_long_gap", "longest"), " to fly the longest segment"),
            param="max_gap_s" if kind == "gap" else "on_long_gap",
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

    def nothing_left(self) -> NoReturn:
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
            raise InputError(
                f"{where}: no airborne part: the vehicle stays slower than "
                f"{o['min_speed_mps']:g} m/s",
                Label("min_speed_mps"),
                f" near its first/last height ({counts['ground']} of {n} samples on the ground, "
                "trimmed)",
                Advice("; ", Pass("airborne_only", False), " to fly the ground movement"),
                param="airborne_only",
            )
        what = ", ".join(f"{v} {k}" for k, v in counts.items())
        dtm = median_interval(log.t)
        hint: tuple[Part, ...] = ()
        if dtm > o["max_gap_s"]:
            hint = (f"; the samples are {dtm:g} s apart", Advice(": raise ", Keyword("max_gap_s")))
        raise InputError(
            f"{where}: no stretch of at least {MIN_POINTS} usable samples without a gap over "
            f"{o['max_gap_s']:g} s",
            Label("max_gap_s"),
            f" or a jump ({what})",
            *hint,
            param="max_gap_s",
        )

    def _noise(
        self, hi: np.ndarray, vi: np.ndarray
    ) -> tuple[Any, list[np.ndarray], np.ndarray, bool]:
        """σ (horizontal, vertical), per-sample σ of each, vertical noise energies, estimated."""
        log, q, sig = self.log, self.quantum, self.opts["position_noise_m"]
        if sig is None:
            k = self.opts["threshold"]
            # the fixes only: a position interpolated between two is predicted without error
            fx = hi[self.interpolated[hi] == 0.0]
            fx = fx if hi.size > fx.size >= 2 * MIN_POINTS else hi
            zh = to_en(log.en[fx[2:-2]], cfit.loo_noise(log.t[fx], log.p[fx]))
            zv = cfit.loo_noise(log.t[vi], log.h[vi, None])
            nh = cfit.noise_sigma(zh, k, 0.0, NOISE_HALF, NOISE_FRAC)
            nv = cfit.noise_sigma(zv, k, 3.0 * q, NOISE_HALF, NOISE_FRAC)
            if fx.size < hi.size:
                nh = (nh[0], np.interp(log.t[hi], log.t[fx], nh[1]))
            if q > 0.0:  # quantised: q²/12 (or more) wherever not level; uniform
                moving = ~cfit.level_runs(log.t[vi], log.h[vi], LEVEL_S)[2:-2]
                sv = max(cfit.noise_sigma(zv[moving], k, 3.0 * q)[0], q / np.sqrt(12.0))
                nv = (sv, np.full(vi.size, sv))
            sig = [max(nh[0], SIGMA_MIN), max(nv[0], SIGMA_MIN)]
            loc = [np.maximum(nh[1], SIGMA_MIN), np.maximum(nv[1], SIGMA_MIN)]
        else:
            loc = [np.full(hi.size, sig[0]), np.full(vi.size, sig[1])]
        # the L positions interpolated between two fixes are one observation: weight 1/(L σ²)
        L = self.interpolated[hi]
        loc[0] = loc[0] * np.sqrt(np.maximum(L, 1.0))
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
            np.clip(median_interval(np.unique(log.t[np.concatenate([hi, vi])])), 0.1, 1.0)
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
        fh = cfit.fit_path(grid, th, ph, loc[0], cfit.PathFit(2, max_run=burst_length(th)))
        height_fit = cfit.PathFit(
            1, edf_correction=q == 0.0, floor=3.0 * q, max_run=burst_length(tv)
        )
        fv = cfit.fit_path(grid, tv, hh, loc[1], height_fit, energy=energy)
        inside = np.flatnonzero(m & (log.t >= t_lo) & (log.t <= t_hi))
        obs = self.obs = self.obs_all = cfit.observations(log, self.track, inside)
        if obs is not None:  # the log's own velocities: checked, then observations of the path
            rh = np.zeros((0, 3)) if obs.h is None else cfit.fitted_rates(grid, fh["g"], obs.h.t)
            rv = np.zeros((0, 1)) if obs.v is None else cfit.fitted_rates(grid, fv["g"], obs.v.t)
            obs = self.obs = cfit.check(obs, rh, rv, log.source, log.lines)
            # with the rates the fit follows the real motion: a long run of outliers is wrong
            # values (a height held for minutes), not motion the fit lags
            horizontal_fit = cfit.PathFit(2, max_run=burst_length(th))
            fh = cfit.fit_path(grid, th, ph, loc[0], horizontal_fit, rates=obs.h, lam=fh["lam"])
            if obs.v is not None and obs.v.t.size >= 0.5 * tv.size:
                height_fit = replace(height_fit, max_run=tv.size)
            fv = cfit.fit_path(
                grid, tv, hh, loc[1], height_fit, energy=energy, rates=obs.v, lam=fv["lam"]
            )
        self.t_h, self.p_h = log.t.copy(), log.p.copy()
        fix = self.interpolated[hi] == 0.0
        th, fh, loc[0], self.timing = self._retime(grid, th, ph, loc[0], fh, fix)
        self.t_h[hi] = th
        if "p" in fh:
            self.p_h[hi] = fh["p"]
        self.out_h[hi[fh["outlier"]]], self.out_v[vi[fv["outlier"]]] = True, True
        keep_h, keep_v = ~fh["outlier"], ~fv["outlier"]
        hi, vi, loc = hi[keep_h], vi[keep_v], [loc[0][keep_h], loc[1][keep_v]]
        gh, gv, softened = self._limits(grid, hi, vi, loc, fh, fv)
        bridges = self._bridges(grid, hi, vi, loc, (fh["lam"], fv["lam"]))
        gh, gv = gh[EDGE : EDGE + ng], gv[EDGE : EDGE + ng]
        used = np.union1d(hi, vi)
        inside = np.flatnonzero(m & (log.t >= t_lo) & (log.t <= t_hi))
        self.ground_pieces = []
        if self.on_ground.any():  # the ground movement at either end, flown as such (step 4)
            gh, gv, t_lo, t_hi, on_ground = self._fly_ground(
                s, (float(t_lo), dt), (gh, gv), sig, (fh["lam"], fv["lam"]), (hi, vi, loc)
            )
            used, inside = np.union1d(used, on_ground), np.union1d(inside, on_ground)
            ng = gh.shape[0]
        tg = t_lo + dt * np.arange(ng)
        lat, lon, _ = ecef_to_geodetic(gh[:, 0], gh[:, 1], gh[:, 2], log.ellipsoid)
        lon = np.degrees(np.unwrap(np.radians(lon)))
        lon += 360.0 * np.round((log.lon[hi[0]] - lon[0]) / 360.0)
        near = used[np.clip(np.searchsorted(log.t[used], tg), 0, used.size - 1)]
        samples = FlightSamples(
            tg - t_lo, lat, lon, gv[:, 0], None, log.source, log.lines[near], float(t_lo)
        )
        rows = cfit.lagrange_rows(t_lo, dt, ng, log.t[inside])
        rows_h = cfit.lagrange_rows(t_lo, dt, ng, self.t_h[inside])  # the fixes' own times
        self.off_h[inside] = np.linalg.norm(
            to_en(log.en[inside], log.p[inside] - cfit.on_grid(gh, rows_h)), axis=1
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
            "bridges": bridges,
            "velocity": cfit.residuals(
                self.obs, samples, float(t_lo), log.ellipsoid, every=self.obs_all
            ),
            "timing": self.timing,
        }

    def _fly_ground(
        self,
        s: int,
        start: tuple[float, float],
        path: tuple[np.ndarray, np.ndarray],
        sig: Any,
        lam: tuple[float, float],
        flight: tuple[np.ndarray, np.ndarray, list[np.ndarray]],
    ) -> tuple[np.ndarray, np.ndarray, float, float, np.ndarray]:
        """Step 4b: the ground movement at either end of segment ``s``, flown as such.

        ``start``: the time of the flight's first output node and the output interval; ``path``:
        the flight's output grid values (horizontal (ng, 3), heights (ng, 1)); ``sig``, ``lam``:
        the flight's noise σ and λ (horizontal, vertical); ``flight``: its samples (horizontal,
        vertical) and their σ. Each piece (the ground samples before
        the flight, those after it) is a penalised spline of its own (:func:`ground_piece`):
        its own noise σ and λ (the discrepancy principle on its samples; the flight's where it
        has fewer than ``2 MIN_POINTS``), the log's ground speeds and tracks as observations,
        level, and joined to the flight by holding the flight's :data:`JOIN_NODES` output
        nodes next to it; then softened (step 7) to :data:`ON_GROUND` where on the ground, to the
        vehicle's envelope across a gap between the ground and the flight.

        Returns the grid values with the pieces, the times of their first and last nodes,
        and the ground samples flown.
        """
        log = self.log
        t_lo, dt = start
        gh, gv = path
        t_end = t_lo + dt * (gh.shape[0] - 1)
        mine = self.on_ground & (self.ground_seg == s) & self.hv_all
        used: list[np.ndarray] = []
        for side, idx in (
            (-1, np.flatnonzero(mine & (log.t < t_lo))),
            (1, np.flatnonzero(mine & (log.t > t_end))),
        ):
            if idx.size == 0:
                continue
            join = (t_lo if side < 0 else t_end, dt)
            piece = ground_piece(self, side, idx, join, (gh, gv), sig, lam, flight)
            if piece is None:
                continue
            ph, pv, info = piece
            k, over = ph.shape[0], info.pop("overlap")
            if side < 0:
                gh, gv = np.concatenate([ph, gh[over:]]), np.concatenate([pv, gv[over:]])
                t_lo -= (k - over) * dt
            else:
                n = gh.shape[0] - over
                gh, gv = np.concatenate([gh[:n], ph]), np.concatenate([gv[:n], pv])
            used.append(idx)
            self.ground_pieces.append(info)
        self.ground_pieces.sort(key=lambda d: d["t_start"])
        idx = np.concatenate(used) if used else np.zeros(0, np.int64)
        return gh, gv, t_lo, t_lo + dt * (gh.shape[0] - 1), idx

    def _retime(
        self,
        grid: tuple[float, float, int],
        th: np.ndarray,
        ph: np.ndarray,
        loc: np.ndarray,
        fh: dict[str, Any],
        fix: np.ndarray,
    ) -> tuple[np.ndarray, dict[str, Any], np.ndarray, dict[str, Any] | None]:
        r"""Step 6b: the timing jitter of the fixes, modelled as a time error per fix.

        A receiver's timestamps are late or early by a varying δ (a position kept until the next
        report, positions resampled to a clock): the fix is the path's position at ``t + δ``,
        off the path by ``v δ`` *along* the track, not across it. The leave-one-out prediction
        errors of the fixes (:func:`~fieldmap.nav.logs.fit.loo_noise`) split along and across
        the fitted track (where faster than :data:`~fieldmap.nav.logs.cfit.MOVING`) give
        σ_a and σ_c; when σ_a² exceeds ``JITTER_RATIO`` σ_c², the jitter is
        σ_t² = (σ_a² − σ_c²) / v². Then, :data:`RETIME_ITER` times: a path that does not follow
        the along-track errors (the fixes at σ_a, λ from their discrepancy, the log's
        velocities at that λ), and each fix's time moved by the posterior mean of its δ,

        .. math:: \hat\delta = \frac{a}{v} \, \frac{\sigma_t^2 v^2}{\sigma_t^2 v^2 +
                  \sigma_c^2}

        (a its along-track residual, δ at most ``JITTER_CLIP`` σ_t). The path is then fitted to
        the re-timed fixes in the same way. Without jitter nothing changes; without the log's
        velocities (what anchors the reference along the track) the jitter stays in the
        fixes' noise σ.

        Returns the fixes' times, the fit, their σ and the timing summary (None: no jitter).
        """
        t0, dt, ng = grid
        settings = cfit.PathFit(2, max_run=burst_length(th))
        rates = None if self.obs is None else self.obs.h
        ok0 = ~fh["outlier"]
        if (fix & ok0).sum() >= 10:  # the jitter of the fixes: an interpolated one has none
            ok0 = ok0 & fix
        if ok0.sum() < 10 or rates is None or rates.t.size < 10:
            return th, fh, loc, None
        z = cfit.loo_noise(th[ok0], ph[ok0])
        v_fit = cfit.fitted_rates(grid, fh["g"], th[ok0])[2:-2]
        speed = np.linalg.norm(v_fit, axis=1)
        moving = speed > cfit.MOVING
        if moving.sum() < 10:
            return th, fh, loc, None
        u = v_fit[moving] / speed[moving, None]
        za = np.sum(z[moving] * u, axis=1)
        zc = z[moving] - za[:, None] * u
        s_a = cfit.noise_sigma(za[:, None], self.opts["threshold"])[0]
        # across: one horizontal direction; noise_sigma averages over the three components,
        # the other two (along, the normal) hold none
        s_c = math.sqrt(3.0) * cfit.noise_sigma(zc, self.opts["threshold"])[0]
        s_c = max(s_c, SIGMA_MIN)
        if s_a**2 < JITTER_RATIO * s_c**2:
            return th, fh, loc, None
        v2 = float(np.median(speed[moving] ** 2))
        s_t2 = (s_a**2 - s_c**2) / v2
        iso = float(np.sqrt(np.mean(np.sum(z[moving] ** 2, axis=1)) / 2.0))
        loc_a = loc * s_a / max(iso, SIGMA_MIN)

        def fitted(t_fix: np.ndarray, sig: np.ndarray) -> dict[str, Any]:
            pos = cfit.fit_path(grid, t_fix, ph, sig, settings)
            if rates is None:
                return pos
            return cfit.fit_path(grid, t_fix, ph, sig, settings, rates=rates, lam=pos["lam"])

        t_fix = th.copy()
        clip = JITTER_CLIP * math.sqrt(s_t2)
        for _ in range(RETIME_ITER):
            ref = fitted(t_fix, loc_a)
            p_fit = cfit.on_grid(ref["g"], cfit.lagrange_rows(t0, dt, ng, t_fix))
            v = cfit.fitted_rates(grid, ref["g"], t_fix)
            sp = np.linalg.norm(v, axis=1)
            ok = (sp > cfit.MOVING) & ~ref["outlier"]
            a = np.sum((ph - p_fit) * v, axis=1) / np.maximum(sp, 1e-9)
            k = s_t2 * sp**2 / (s_t2 * sp**2 + s_c**2)
            # beyond JITTER_CLIP σ_t an along-track offset is no jitter (an outlier, a change of
            # speed the reference missed)
            delta = np.clip(k * a / np.maximum(sp, 1e-9), -clip, clip)
            t_fix = t_fix + np.where(ok, delta, 0.0)
        # the re-timed fixes at σ_c, at the λ of the reference: the along-track errors are gone
        # from the fixes, not from the noise of what is left
        # what is left along the track is no noise to average but the reference's to keep:
        # each fix is moved onto it along the track (a pseudo-fix, across-track as measured),
        # and the path fitted to them at the noise across, σ_c
        ref = fitted(t_fix, loc_a)
        p_fit = cfit.on_grid(ref["g"], cfit.lagrange_rows(t0, dt, ng, t_fix))
        v = cfit.fitted_rates(grid, ref["g"], t_fix)
        sp = np.linalg.norm(v, axis=1)
        ok = (sp > cfit.MOVING) & ~ref["outlier"]
        u = v / np.maximum(sp, 1e-9)[:, None]
        a = np.sum((ph - p_fit) * u, axis=1)
        p_new = ph - np.where(ok, a, 0.0)[:, None] * u
        loc_c = loc * s_c / max(iso, SIGMA_MIN)
        fh = cfit.fit_path(grid, t_fix, p_new, loc_c, settings)
        fh = cfit.fit_path(grid, t_fix, p_new, loc_c, settings, rates=rates, lam=fh["lam"])
        fh["p"] = p_new
        d = t_fix - th
        info = {
            "jitter_s": math.sqrt(s_t2),
            "sigma_along_m": s_a,
            "sigma_across_m": s_c,
            "speed_m_s": math.sqrt(v2),
            "fixes_retimed": int(np.count_nonzero(d)),
            "time_shift_rms_s": float(np.sqrt(np.mean(d**2))),
            "time_shift_max_s": float(np.max(np.abs(d))),
        }
        return t_fix, fh, loc_c, info

    def _bridges(
        self,
        grid: tuple[float, float, int],
        hi: np.ndarray,
        vi: np.ndarray,
        loc: list[np.ndarray],
        lam: tuple[float, float],
    ) -> list[dict[str, Any]]:
        """Return the long gaps the path bridges, each with the path's posterior σ at its middle.

        A long gap: more than ``max_gap_s`` between the samples of the horizontal or the
        vertical fit (overlapping ones joined). σ per horizontal axis and vertical (m) from
        :func:`~fieldmap.nav.logs.fit.posterior_sigma` with the fit's final weights and λ.
        """
        log = self.log
        t0, dt, ng = grid
        out: list[dict[str, Any]] = []
        spans = []
        for idx in (hi, vi):
            tt = log.t[idx]
            for j in np.flatnonzero(np.diff(tt) > self.opts["max_gap_s"]):
                spans.append((int(idx[j]), int(idx[j + 1])))
        pairs: list[tuple[int, int]] = []
        for a, b in sorted(spans):  # a gap of either component; overlapping ones joined
            if pairs and a < pairs[-1][1]:
                pairs[-1] = (pairs[-1][0], max(b, pairs[-1][1]))
            else:
                pairs.append((a, b))
        if not pairs:
            return out
        mid = np.array([0.5 * (log.t[a] + log.t[b]) for a, b in pairs])
        nodes = np.clip(np.round((mid - t0) / dt).astype(np.int64), 0, ng - 1)
        rh, rv = (None, None) if self.obs is None else (self.obs.h, self.obs.v)
        sh = cfit.posterior_sigma(grid, self.t_h[hi], loc[0], lam[0], nodes, rh)
        sv = cfit.posterior_sigma(grid, log.t[vi], loc[1], lam[1], nodes, rv)
        for (a, b), s_h, s_v in zip(pairs, sh, sv):
            out.append(
                {
                    "t_from": float(log.t[a]),
                    "t_to": float(log.t[b]),
                    "lines": [int(log.lines[a]), int(log.lines[b])],
                    "sigma_h_m": float(s_h),
                    "sigma_v_m": float(s_v),
                }
            )
        return out

    def _limits(
        self,
        grid: tuple[float, float, int],
        hi: np.ndarray,
        vi: np.ndarray,
        loc: list[np.ndarray],
        fh: dict[str, Any],
        fv: dict[str, Any],
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """Step 7: soften the fits where the path as flown exceeds the vehicle limits.

        Where the load factor of the quintic through the output
        (:func:`~fieldmap.nav.logs.fit.quintic_load_factor`) leaves the vehicle's range
        (narrowed by ``LIMIT_MARGIN`` about 1 g), or its acceleration or jerk
        (:func:`~fieldmap.nav.logs.fit.quintic_kinematics`) exceeds ``LIMIT_MARGIN ×
        max_accel_g`` or ``× max_jerk`` (the vehicle's unless given), the σ of the samples
        nearby is raised (twice within two sample intervals, tapering to none at four) for the
        component(s) carrying at least half of it; both are refitted at the same λ, up to
        :data:`LIMIT_ITER` times. Returns the grid values and the number of samples softened.
        """
        log, o = self.log, self.lim
        gh, gv = fh["g"], fv["g"]
        a_max = np.inf if o["max_accel_g"] is None else o["max_accel_g"] * G0 * LIMIT_MARGIN
        j_max = np.inf if o["max_jerk"] is None else o["max_jerk"] * LIMIT_MARGIN
        # aim inside the load-factor range by the same margin, measured from 1 g
        n_lo = 1.0 - LIMIT_MARGIN * (1.0 - o["n_min"])
        n_hi = 1.0 + LIMIT_MARGIN * (o["n_max"] - 1.0)
        t0, dt, ng = grid
        out = slice(EDGE, ng - EDGE)
        tg = t0 + dt * np.arange(ng)[out]
        touched = np.zeros(log.t.size, bool)
        span = 2.0 * max(dt, median_interval(log.t[hi]))
        rates: list[cfit.Rates | None] = (
            [None, None] if self.obs is None else [self.obs.h, self.obs.v]
        )

        def near(tt: np.ndarray, tb: np.ndarray) -> np.ndarray:
            return soften_factor(tt, tb, span)

        for _ in range(LIMIT_ITER):
            (ah, jh), (av, jv) = (cfit.quintic_kinematics(g[out], dt) for g in (gh, gv))
            acc, jerk = np.hypot(ah, av), np.hypot(jh, jv)
            nl, nh = cfit.quintic_load_factor(gh[out], gv[out], dt, G0)
            bad = (acc > a_max) | (jerk > j_max) | (nl < n_lo) | (nh > n_hi)
            if not bad.any():
                break
            for k, (idx, a, j) in enumerate(((hi, ah, jh), (vi, av, jv))):
                tb = tg[bad & ((a >= 0.5 * acc) | (j >= 0.5 * jerk))]
                if tb.size:
                    f = near(log.t[idx], tb)
                    loc[k] = loc[k] * f
                    touched[idx[f > 1.0]] = True
                    rt = rates[k]
                    if rt is not None:
                        # the log's velocities there too (late, stale), less: their σ by √f,
                        # for they hold the along-track motion that resampled fixes get wrong
                        rates[k] = cfit.Rates(rt.t, rt.v, rt.w / near(rt.t, tb))
            gh = cfit.refit(grid, self.t_h[hi], self.p_h[hi], loc[0], fh["lam"], rates[0])[0]
            gv = cfit.refit(grid, log.t[vi], log.h[vi, None], loc[1], fv["lam"], rates[1])[0]
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
            "bridges": [],
            "velocity": None,
            "timing": None,
        }


#: an aircraft on the ground (taxi, parking, the roll below ``min_speed_mps``): level, at
#: most 0.5 g horizontally (an airliner's hardest braking, a rejected take-off; taxi turns
#: take 0.1..0.3 g), so 0.9..√(1 + 0.5²) = 1.12 g with 0.1 g for the vertical join to the
#: flight; jerk 5 m/s³ (full braking, 0.5 g, applied within a second); slower than 30 m/s
#: (the ground step's ``min_speed_mps``); no climb
ON_GROUND = Vehicle("ground", 0.9, 1.12, 5.0, 30.0, 0.0)
#: a ground piece is joined to the flight by holding this many of the flight's output nodes
#: next to it (one more than the penalty's stencil: position, velocity and acceleration)
JOIN_NODES = 4
#: the flight's first (last) seconds fitted again with a ground piece next to them: the end of
#: the flight's own fit is a free end (straight beyond its data), no join
JOIN_OVERLAP_S = 10.0
#: σ (m) of the held nodes: a join the fit cannot move
JOIN_SIGMA = 1e-3
#: σ (m/s) of the vertical speed 0 of an aircraft on the ground (a runway's 1 % slope at 10 m/s)
LEVEL_RATE_SIGMA = 0.1


def ground_piece(
    st: Any,
    side: int,
    idx: np.ndarray,
    join: tuple[float, float],
    path: tuple[np.ndarray, np.ndarray],
    sig: Any,
    lam: tuple[float, float],
    flight: tuple[np.ndarray, np.ndarray, list[np.ndarray]],
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]] | None:
    """Fly one piece of ground movement next to the flight (step 4b of :class:`Stages`).

    ``st``: the :class:`Stages`; ``side``: -1 before the flight, +1 after it; ``idx``: the
    piece's usable ground samples (ordered log indices); ``join``: the time of the flight's
    output node next to the piece and the output interval; ``path``: the flight's output grid
    values; ``sig``, ``lam``: the flight's noise σ and λ (horizontal, vertical).

    The piece gets a grid of its own, aligned with the flight's, that reaches
    :data:`JOIN_OVERLAP_S` into the flight (the flight's free end: fitted again, from the
    flight's own samples ``flight`` = (horizontal, vertical indices, their σ), within the
    vehicle's envelope) and holds the flight's :data:`JOIN_NODES` output nodes beyond (σ
    :data:`JOIN_SIGMA`): the piece continues the flight's position, velocity and
    acceleration. Horizontally a penalised spline as the
    flight's (step 6) with the noise σ of the piece's own samples (leave-one-out, local) and
    λ from their discrepancy, the log's velocities as observations (a parked aircraft reports
    0 kt: it does not move); with fewer than ``2 MIN_POINTS`` samples the flight's σ and λ.
    Vertically level: an aircraft on the ground is at the height of the ground, which along
    an aerodrome varies by metres, while the heights logged there are no measurement of it
    (ADS-B surface positions carry no altitude: readers fill 0 or hold the last one). Level
    is a vertical speed of 0 (σ :data:`LEVEL_RATE_SIGMA`) at the piece's nodes: the height is
    the one the flight's path reaches at the join when the piece reaches the flight within
    ``max_gap_s``, else (a gap between) also held to the median of the piece's own heights.
    Then step 7 with :data:`ON_GROUND` at the nodes within the piece's samples, the vehicle's
    envelope in the overlap and across a gap between them and the flight.

    Returns the piece's output grid values (horizontal (k, 3), heights (k, 1)) in time order,
    the overlap's nodes included (they replace the flight's: ``overlap`` in the summary), and
    its summary for the report; None where the piece is shorter than one output interval.
    """
    log, o, veh = st.log, st.opts, st.vehicle
    t_join, dt = join
    gh, gv = path
    a = JOIN_NODES
    th = log.t[idx]
    k = int(np.floor(abs(th[0 if side < 0 else -1] - t_join) / dt + 1e-9))
    if k < 1:
        return None
    # the flight's first (last) nodes are fitted again with the piece: its free end is no join
    hi, vi, loc = flight
    over = int(np.ceil(JOIN_OVERLAP_S / dt))
    if gh.shape[0] < 2 * (over + a):
        over = 0
    ngp = a + k + over + EDGE
    if side < 0:
        t0 = t_join - (k + EDGE) * dt
        held, out = np.arange(ngp - a, ngp), np.arange(EDGE, EDGE + k + over)
        held_h, held_v = gh[over : over + a], gv[over : over + a]
    else:
        t0 = t_join - (over + a - 1) * dt
        held, out = np.arange(a), np.arange(a, a + over + k)
        n = gh.shape[0] - over
        held_h, held_v = gh[n - a : n], gv[n - a : n]
    grid = (t0, dt, ngp)
    tn = t0 + dt * np.arange(ngp)
    lo_o, hi_o = (t_join, t_join + over * dt) if side < 0 else (t_join - over * dt, t_join)
    th_all = st.t_h[hi]
    fh_in = (th_all >= lo_o - 0.5 * dt) & (th_all <= hi_o + 0.5 * dt) if over else th_all < -np.inf
    fv_in = (
        (log.t[vi] >= lo_o - 0.5 * dt) & (log.t[vi] <= hi_o + 0.5 * dt)
        if over
        else log.t[vi] < -np.inf
    )
    f_t, f_p, f_s = th_all[fh_in], st.p_h[hi[fh_in]], loc[0][fh_in]
    fv_t, fv_h, fv_s = log.t[vi[fv_in]], log.h[vi[fv_in], None], loc[1][fv_in]
    ph = log.p[idx]
    # horizontal: the piece's own noise and λ
    if idx.size >= 2 * MIN_POINTS:
        zh = to_en(log.en[idx[2:-2]], cfit.loo_noise(th, ph))
        nh = cfit.noise_sigma(zh, o["threshold"], 0.0, NOISE_HALF, NOISE_FRAC)
        loc_h = np.maximum(nh[1], SIGMA_MIN)
        free = cfit.fit_path(grid, th, ph, loc_h, cfit.PathFit(2, max_run=burst_length(th)))
        lam_h, keep = float(free["lam"]), ~free["outlier"]
        sigma_h = max(nh[0], SIGMA_MIN)
    else:
        loc_h, lam_h = np.full(idx.size, float(sig[0])), float(lam[0])
        keep, free, sigma_h = np.ones(idx.size, bool), None, float(sig[0])
    rates = None
    obs = cfit.observations(log, st.track, idx[keep])
    if obs is not None and obs.h is not None and free is not None:
        t_obs = obs.h.t
        obs = replace(obs, iv=obs.iv[:0], v=None, up=obs.up[:0])
        try:
            rates = cfit.check(
                obs,
                cfit.fitted_rates(grid, free["g"], t_obs),
                np.zeros((0, 1)),
                log.source,
                log.lines,
            ).h
        except InputError:  # velocities that contradict the ground positions: not used
            rates = None
    # vertical: level (no vertical speed), joined to the flight's height, or at the piece's own
    # heights across a gap longer than max_gap_s
    near_join = th[-1 if side < 0 else 0]
    joined = abs(near_join - t_join) <= o["max_gap_s"]
    hv_ok = idx[st.vv_all[idx]]
    level_from = "joined to the flight"
    on = out[(tn[out] >= th[0] - 0.5 * dt) & (tn[out] <= th[-1] + 0.5 * dt)]
    if on.size == 0:
        on = out
    t_lvl = tn[on]
    t_v, y_v = np.concatenate([fv_t, tn[held]]), np.concatenate([fv_h, held_v])
    sv = fv_s.copy()
    if not joined and hv_ok.size:
        level_from = "the piece's own heights"
        t_v = np.concatenate([t_lvl, t_v])
        y_v = np.concatenate([np.full((on.size, 1), float(np.median(log.h[hv_ok]))), y_v])
        sv = np.concatenate([np.full(on.size, max(float(sig[1]), SIGMA_MIN)), sv])
    sr = np.full(on.size, LEVEL_RATE_SIGMA)
    t_h = np.concatenate([th[keep], f_t, tn[held]])
    y_h = np.concatenate([ph[keep], f_p, held_h])
    pin = np.full(a, JOIN_SIGMA)
    sh = np.concatenate([loc_h[keep], f_s])

    def solve() -> tuple[np.ndarray, np.ndarray]:
        g1 = cfit.refit(grid, t_h, y_h, np.concatenate([sh, pin]), lam_h, rates)[0]
        level = cfit.Rates(t_lvl, np.zeros((on.size, 1)), 1.0 / sr**2)
        g2 = cfit.refit(grid, t_v, y_v, np.concatenate([sv, pin]), float(lam[1]), level)[0]
        return g1, g2

    g_h, g_v = solve()
    # step 7: the ground envelope on the ground, the vehicle's across a gap to the flight
    span = 2.0 * max(dt, median_interval(th))
    rng = np.arange(min(out[0], held[0]), max(out[-1], held[-1]) + 1)
    ground_node = np.isin(rng, on)
    lim = st.lim
    n_lo = np.where(ground_node, ON_GROUND.n_min, veh.n_min)
    n_hi = np.where(ground_node, ON_GROUND.n_max, veh.n_max)
    n_lo, n_hi = 1.0 - LIMIT_MARGIN * (1.0 - n_lo), 1.0 + LIMIT_MARGIN * (n_hi - 1.0)
    j_max = LIMIT_MARGIN * np.where(ground_node, ON_GROUND.jerk, lim["max_jerk"])
    touched = np.zeros(idx.size, bool)
    kept = np.flatnonzero(keep)
    for _ in range(LIMIT_ITER):
        (ah, jh), (av, jv) = (cfit.quintic_kinematics(g[rng], dt) for g in (g_h, g_v))
        jerk = np.hypot(jh, jv)
        nl, nh2 = cfit.quintic_load_factor(g_h[rng], g_v[rng], dt, G0)
        bad = (jerk > j_max) | (nl < n_lo) | (nh2 > n_hi)
        bad &= ~np.isin(rng, held)
        if not bad.any():
            break
        acc = np.hypot(ah, av)
        tb = tn[rng][bad & ((ah >= 0.5 * acc) | (jh >= 0.5 * jerk))]
        if tb.size:
            f = soften_factor(t_h[: sh.size], tb, span)
            sh *= f
            touched[kept[f[: kept.size] > 1.0]] = True
            if rates is not None:
                rates = cfit.Rates(rates.t, rates.v, rates.w / soften_factor(rates.t, tb, span))
        tb = tn[rng][bad & ((av >= 0.5 * acc) | (jv >= 0.5 * jerk))]
        if tb.size:
            sr *= soften_factor(t_lvl, tb, span)
            sv *= soften_factor(t_v[: sv.size], tb, span)
        g_h, g_v = solve()
    st.out_h[idx[~keep]] = True
    fit_at = cfit.on_grid(g_h, cfit.lagrange_rows(t0, dt, ngp, th[keep]))
    rms = float(np.sqrt(np.mean(np.sum(to_en(log.en[idx[keep]], ph[keep] - fit_at) ** 2, 1)) / 2))
    info = {
        "side": "before" if side < 0 else "after",
        "t_start": float(th[0]),
        "t_end": float(th[-1]),
        "lines": [int(log.lines[idx[0]]), int(log.lines[idx[-1]])],
        "samples": int(idx.size),
        "outliers": int((~keep).sum()),
        "sigma_h_m": float(sigma_h),
        "residual_rms_h_m": rms,
        "height_m": float(np.median(g_v[on, 0])),
        "height_from": level_from,
        "overlap": over,
        "softened_samples": int(touched.sum()),
        "velocities": rates is not None,
    }
    return g_h[out], g_v[out], info


def soften_factor(tt: np.ndarray, tb: np.ndarray, span: float) -> np.ndarray:
    """Return the σ factor (step 7) at the times ``tt`` near the bad nodes at the times ``tb``.

    2 within ``span`` of a bad node, 1 beyond 2 ``span``, linear between.
    """
    pos = np.searchsorted(tb, tt)
    d = np.minimum(
        np.abs(tt - tb[np.clip(pos - 1, 0, tb.size - 1)]),
        np.abs(tt - tb[np.clip(pos, 0, tb.size - 1)]),
    )
    return np.clip(3.0 - d / span, 1.0, 2.0)


# -- the cleaning steps (1-4), each on one segment of ordered samples --------------------------


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

    def __init__(self, track: Any, ellipsoid: Ellipsoid, reorder: bool) -> None:
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
        index = np.flatnonzero(finite)
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
                i = back[0]
                raise InputError(
                    f"{src} line {lines[i]}: time {t[i]:.3f} s goes back from the previous "
                    f"{t[i - 1]:.3f} s (line {lines[i - 1]})",
                    Advice("; ", Pass("reorder", True), " to sort the log"),
                    param="reorder",
                )
            order = np.argsort(t, kind="stable")
            t, lat, lon, h, lines = t[order], lat[order], lon[order], h[order], lines[order]
            index = index[order]
        dup = np.concatenate([[False], np.diff(t) == 0.0])
        self.n_duplicates = int(dup.sum())
        self.first_duplicate_line = int(lines[dup][0]) if dup.any() else None
        self.t, self.lat, self.lon, self.h, self.lines = (a[~dup] for a in (t, lat, lon, h, lines))
        #: each ordered sample's index in the track
        self.index = index[~dup]
        self.lon = np.degrees(np.unwrap(np.radians(self.lon)))
        self.ellipsoid = ellipsoid
        self.p = self.en = np.zeros((0, 3))

    def geometry(self) -> None:
        """Surface ECEF positions ``p`` (n, 3) and the local east/north rows ``en`` (n, 2, 3)."""
        zero = np.zeros_like(self.h)
        self.p = np.stack(geodetic_to_ecef(self.lat, self.lon, zero, self.ellipsoid), -1)
        self.en = C_e_to_enu(self.lat, self.lon)[:, :2, :]

    def repeated_states(self, track: Any) -> np.ndarray:
        """Length of the run of identical reported states each sample is in, (n,) (1: none).

        A state is the log's own ground speed, track and vertical rate together
        (:class:`~fieldmap.nav.logs.read.Velocities`); a receiver that lost the vehicle and
        dead-reckons its position from the last state (ADS-B and FLARM relays extrapolate
        for a minute or more) repeats it unchanged while the position moves on. Logs without
        velocities: all 1.
        """
        vel = getattr(track, "velocity", None)
        n = self.t.size
        if vel is None or n == 0:
            return np.ones(n)
        src = self.index
        climb = vel.climb[src] if vel.climb is not None else np.zeros(n)
        x = np.stack([vel.speed[src], vel.track[src], climb], -1)
        same = np.all((x[1:] == x[:-1]) & np.isfinite(x[1:]), axis=1)
        out = np.ones(n)
        for a, b in runs(same):
            out[a : b + 1] = b + 1 - a
        return out

    def interpolated_positions(self) -> tuple[np.ndarray, float]:
        """Positions interpolated between fixes: the run's interior count per sample, (n,).

        A sample whose position lies on the straight line through its two neighbours at equal
        time steps (the second differences of latitude and longitude within the rounding of
        the digits printed, :func:`printed_step`: 2 q for a step q, each value within q/2)
        while the vehicle moves is a linear interpolation between the fixes either side (a
        track resampled to a clock, the ``traffic`` package's samples), not a measurement.
        Only where that rounding is finer than :data:`INTERP_TOL_M` (a real fix's noise,
        metres, is collinear within it only by chance), and where at least
        :data:`INTERP_MIN_FRACTION` of the positions are. Each interior sample of a run gets
        the number L of interior samples of its run (the run's ends, the fixes, 0): the L are
        one observation, not L. Returns those counts and the tolerance (degrees; 0 where none).
        """
        n = self.t.size
        out = np.zeros(n)
        if n < 3:
            return out, 0.0
        lat, lon = self.lat, self.lon
        tol = 2.0 * max(printed_step(lat), printed_step(lon))
        if tol * math.radians(1.0) * self.ellipsoid.a > INTERP_TOL_M:
            return out, 0.0
        dt = np.diff(self.t)
        inner = (
            (dt[1:] == dt[:-1])
            & (np.abs(lat[2:] - 2.0 * lat[1:-1] + lat[:-2]) <= tol)
            & (np.abs(lon[2:] - 2.0 * lon[1:-1] + lon[:-2]) <= tol)
            & ((lat[2:] != lat[1:-1]) | (lon[2:] != lon[1:-1]))
        )
        if inner.mean() < INTERP_MIN_FRACTION:  # no resampled track: a few by chance
            return out, 0.0
        d = np.diff(np.concatenate([[0], inner.astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            out[a + 1 : b + 1] = b - a
        return out, tol

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


def printed_step(x: np.ndarray) -> float:
    """Return the finest step of the decimals printed in ``x`` (n,): 10^-(most), ≥ 1e-12.

    A value read from text printed with d decimals is within float rounding of a multiple of
    10^-d (trailing zeros are not printed: the most decimals any value holds is the file's
    precision, as the readers take a velocity column's resolution); values with more
    (computed, binary sources) give 1e-12.
    """
    x = np.asarray(x, dtype=np.float64)
    x = x[np.isfinite(x)]
    for k in range(12):
        if np.all(np.abs(np.round(x, k) - x) <= 1e-9 * 10.0**-k):
            return 10.0**-k
    return 1e-12


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
    repeated: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Outliers (n,) and offsets (m, (n,)) of one component (``y`` (n, d)) of one segment.

    Hampel identifier (Hampel 1974): offsets from the robust trend of the valid samples not
    yet rejected (:func:`~fieldmap.nav.logs.fit.robust_trend`, ``proj`` maps them to
    the local axes) beyond ``max(k s, floor)``, ``s`` the local robust scale
    (:func:`~fieldmap.nav.logs.fit.local_scale`), iterated to a fixed point (a sample
    rejected early is taken back when the cleaner trend passes near it). A run of rejections
    longer than a burst (:func:`burst_length`) is motion the trend misses, kept. Then, where
    steps are faster than ``max_speed``, the fewest samples go that leave a path the vehicle could
    fly (:func:`feasible_chain`); a sample in a run of ``repeated`` identical reported states
    (:meth:`OrderedLog.repeated_states`, (n,)) counts 1/(2 run length): a dead-reckoned stretch
    ending in a jump goes whole, like a burst.
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
    if jumps(t[idx] + TIME_SLACK_S * np.arange(idx.size), y[idx], max_speed, floor).any():
        rep = np.ones(t.size) if repeated is None else repeated
        chain = feasible_chain(t[idx], y[idx], max_speed, floor, (burst, rep[idx]))
        keep[idx[~chain]] = False
    return valid & ~keep, off


def feasible_chain(
    t: np.ndarray, y: np.ndarray, max_speed: float, margin: float, drops: tuple[int, np.ndarray]
) -> np.ndarray:
    """Return the samples (n,) kept by the cheapest drops leaving no step over ``max_speed``.

    A path the vehicle could fly through the samples: every step between kept samples within
    ``max_speed`` × Δt + ``margin`` (:func:`jumps`). ``drops`` = (``burst``, ``repeated``):
    a sample costs 1 to drop, or 1/(2L) in a run of L identical reported states (dead-reckoned
    positions: the run counts as half a measured fix); a run of dropped samples is at most
    ``burst`` long, or one such run of repeated states; steps may take :data:`TIME_SLACK_S`
    longer (time stamps err). Where no such path exists (a displaced stretch longer than that)
    the jump stays, at the cost of ``burst`` + 1, and is left to the breaks or the robust fit.
    Dynamic programming over (sample, predecessor): the least cost, ties to the nearer
    predecessor, so that a fix from another transmitter goes whichever side of it the jump is.
    """
    burst, repeated = drops
    n = t.size
    w = np.where(repeated > 1.0, 0.5 / repeated, 1.0)
    cw = np.concatenate([[0.0], np.cumsum(w)])  # cost of dropping samples a..b-1: cw[b] - cw[a]
    reach = burst + 1 + int(min(np.max(repeated, initial=1.0), CHAIN_MAX))
    big = float(burst + 1)
    cost = np.full(n, np.inf)
    prev = np.full(n, -1, dtype=np.int64)
    for j in range(n):
        if j <= burst:
            cost[j] = cw[j]  # the samples before j dropped
        for i in range(max(0, j - reach), j):
            gap = j - i - 1
            if gap > burst and not np.all(repeated[i + 1 : j] > 1.0):
                continue
            reach_m = max_speed * (t[j] - t[i] + TIME_SLACK_S) + margin
            step = np.linalg.norm(y[j] - y[i]) > reach_m
            if step and gap:
                continue
            c = cost[i] + (cw[j] - cw[i + 1]) + (big if step else 0.0)
            if c <= cost[j]:
                cost[j], prev[j] = c, i
    ends = np.arange(max(0, n - burst - 1), n)
    j = int(ends[np.argmin(cost[ends] + (cw[n] - cw[ends + 1]))])
    keep = np.zeros(n, bool)
    while j >= 0:
        keep[j] = True
        j = int(prev[j])
    return keep


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
    t: np.ndarray,
    p: np.ndarray,
    h: np.ndarray,
    valid: tuple[np.ndarray, np.ndarray],
    min_speed: float,
    any_height: bool = False,
) -> np.ndarray:
    """Leading and trailing ground samples (n,) of one segment.

    Ground: robust ground speed (running median of the step velocities) below ``min_speed``
    and height within :data:`GROUND_DH` of the segment's first (last) height, from the start
    (end) up to the first sample that is not: taxi, parking, the first part of a take-off run.
    ``any_height``: a vehicle that cannot fly that slowly (an airliner's stall speed is above
    it) is on the ground whatever its height says (a barometric altitude held from the last
    flight during the take-off roll). ``valid``: the usable horizontal and vertical samples.
    """
    hv, vv = valid
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
        slow = (speed[order] < min_speed) & (any_height | (np.abs(hk[order] - h[end]) < GROUND_DH))
        out[order[: n if slow.all() else int(np.argmin(slow))]] = True
    return out
