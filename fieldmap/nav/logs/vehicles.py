r"""Vehicle classes: the envelope and the motion model of each kind of vehicle a log comes from.

A class holds what the vehicle can do (its load factor, speed and climb: the bounds the report
checks the flown path against) and how it manoeuvres (the motion model of
:mod:`fieldmap.nav.logs.motion`: the largest horizontal and vertical accelerations it
sustains, the duration of a manoeuvre, how long a climb lasts), each with its source or the
reasoning behind it. The conditioning's jerk intensity :math:`q` is estimated from the log
within bounds that follow from them: the stationary acceleration of the Singer model,
:math:`\sigma_a = \sqrt{q\tau/2}`, stays below a third of the class's largest acceleration
(:math:`q_{max} = 2 (a_{max}/3)^2/\tau`: the largest acceleration is a 3σ manoeuvre), and above
a millionth of that bound in intensity (straight and level for hours).

=============== ========== ======= ======= ===== ===== ====== ===============================
class           load (g)   speed   climb   a_h   τ     τ_v    source / reasoning
                           (m/s)   (m/s)   m/s²  (s)   (s)
=============== ========== ======= ======= ===== ===== ====== ===============================
paraglider      0 … 3      35      10      10    4     60     EN 926 load tests; trim 10 m/s
                                                              air + wind; thermal climbs 5,
                                                              spirals 10 m/s; 45° bank turns
glider          −2.65 …5.3 100     15      12    6     120    CS-22 utility loads; Vne 75 m/s
                                                              + wind; thermalling at 45-50°
light-aircraft  −1.5 … 3.8 130     20      17    8     120    CS-23 normal category; 60° bank
turboprop       −1 … 2.5   190     25      10    15    300    CS-25 / CS-23 commuter limit
                                   (40)                       loads; 45° bank (calibration
                                                              orbits, standard-rate turns);
                                                              a business jet flown at these
                                                              speeds climbs at up to 40
airliner        −1 … 2.5   360     40      6     30    300    CS-25.337 limit loads (parabolic
                                   (130)                      flights reach 0 g); 30° bank in
                                                              service; Mach 0.9 + jet stream;
                                                              climbs 40 in service, 130 in a
                                                              parabolic flight's pull-up
helicopter      −0.5 … 3.5 110     20      10    8     60     CS-27/29 manoeuvring loads; 45°
fighter         −3 … 9     700     300     80    4     60     F-16 +9/−3 g; Mach 2
uav             −1 … 4     80      25      20    4     60     small drones, no basis: light
                                                              aircraft with a margin
car             0.3 … 1.6  90      15      8     4     30     tyres: ~1 g laterally and braking
pedestrian      0.5 … 1.5  20      5       3     3     30     walking, running, cycling
ship            0.7 … 1.3  30      5       0.5   60    10     seaway comfort criteria with
                                                              margin (NORDFORSK 1987); 60 kt
rocket          0 … 10     8000    8000    100   10    1e6    launch vehicles, 3-6 g axial
=============== ========== ======= ======= ===== ===== ====== ===============================

(``a_h``: the largest horizontal acceleration sustained, ``g·tan(bank)`` for an aircraft in a
coordinated turn; the vertical one is the load factor's excess ``(n_max − 1) g``. ``τ``: the
acceleration's correlation time; ``τ_v``: the vertical speed's, the damping of the height's
model, which over a gap longer than it returns the expected climb to zero. Stall speeds, the
slowest an aircraft flies: airliner 50 m/s, turboprop 35, fighter 60, light aircraft 20,
glider 15, paraglider 6; other classes hover or stop.)

**Climb.** ``climb`` is the fastest vertical speed of a class's ordinary flight, the bound a
flown path keeps within; a log whose own climbs are faster (:attr:`Evidence.top_climb`: the
99th percentile of its climbs, or the fastest vertical rate it reports that its neighbours
confirm) raises it to them, up to the largest the class reaches at all (in brackets;
:meth:`Vehicle.with_log_climb`). An airliner climbs and descends at up to 40 m/s in
service; flying parabolas (Airbus A310 Zero-G: a 1.8 g pull-up to 47° nose-up from about
240 m/s) it climbs at 106 m/s (20,800 ft/min in the ``traffic`` sample's vertical rates), and
the largest is taken as 130 m/s (47° at 180 m/s). The turboprop class is the guess for any
aircraft flying at its speeds, business jets on calibration flights among them, which climb at
up to 40 m/s (8,000 ft/min). A log with no such climbs keeps the ordinary bound, which holds
its path against altitude glitches that the fault model does not reject. The other classes'
ordinary climb is their largest.

Guess (:func:`guess_vehicle`), when the user names none: the ADS-B emitter category where the
log carries one (DO-260B §2.2.3.2.5.2: A1 light, A2 small, A3-A5 large and heavy, A6 high
performance, A7 rotorcraft, B1 glider, B4 ultralight/hang glider/paraglider, B6 UAV, C1/C2
surface vehicles); else the evidence of the log: the slowest class whose envelope holds the
log's robust top speed, climb (up to the largest the class reaches) and turn rate, among those
its format allows (an IGC file is
a glider's or paraglider's flight recorder); a vehicle that stays within its first height's
band at road speeds is a car, at walking speeds a pedestrian. The report gives the evidence.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fieldmap.errors import InputError, Keyword
from fieldmap.nav.logs.motion import VERTICAL_JERK_DOF, MotionModel
from fieldmap.units import STANDARD_GRAVITY as G0

#: the strongest surface wind (m/s) an aircraft takes off or lands in: 40 kt. An aircraft
#: flies at an airspeed above its stall speed, so its ground speed is at least its stall
#: speed less this: slower, it is on the ground
#: (:func:`fieldmap.nav.logs.condition.ground_level`)
SURFACE_WIND_MAX = 20.0
#: the steepest slope of a runway or taxiway (rise over run): ICAO Annex 14 vol. I allows up
#: to 2 % along a runway and 3 % along a taxiway; on the ground the height changes at most at
#: this times the ground speed
GROUND_SLOPE_MAX = 0.03
#: the name of the ground's vertical rates among a conditioning's channels
#: (:func:`fieldmap.nav.logs.condition.ground_level`)
GROUND_CHANNEL = "level on the ground"


@dataclass(frozen=True)
class Vehicle:
    """The envelope and motion model of one vehicle class (module docstring).

    Attributes
    ----------
    name : str
        The class (``airliner``, ``glider``, …).
    n_min, n_max : float
        Load factor range: the specific force's magnitude the vehicle can fly. Units: g.
    speed : float
        Largest speed over the ground. Units: m/s.
    climb : float
        Largest vertical speed of its ordinary flight, up or down: the bound the path keeps
        within unless the log shows faster climbs (:meth:`with_log_climb`). Units: m/s.
    accel_h : float
        Largest horizontal acceleration sustained (a turn, braking). Units: m/s².
    tau_s : float
        Correlation time of the acceleration (a manoeuvre's duration). Units: s.
    tau_climb_s : float
        Correlation time of the vertical speed. Units: s.
    stall : float
        Slowest speed it flies at (0: it hovers or stops). Units: m/s.
    climb_max : float or None
        Largest vertical speed it can reach at all (zoom climbs, parabolic flights, dives),
        where that is beyond ``climb``: how far a log's own climbs raise the bound. None:
        ``climb``. Units: m/s.
    """

    name: str
    n_min: float
    n_max: float
    speed: float
    climb: float
    accel_h: float
    tau_s: float
    tau_climb_s: float
    stall: float = 0.0
    climb_max: float | None = None

    @property
    def largest_climb(self) -> float:
        """Largest vertical speed the class can reach at all (m/s): ``climb_max`` or ``climb``."""
        return self.climb if self.climb_max is None else self.climb_max

    def with_log_climb(self, climb: float) -> Vehicle:
        """Return the class with its climb bound raised to a log's robust top climb (m/s).

        The bound is the log's own top climb (:attr:`Evidence.top_climb`: the 99th percentile
        of its vertical rates, or of its heights' running-median rates, or the fastest rate it
        reports that its neighbours confirm), no less than the class's ordinary ``climb`` and
        no more than the largest it can reach (:attr:`largest_climb`):
        a parabolic flight's airliner climbs at 106 m/s, which its ordinary 40 m/s would cut
        off, while a log with no such climbs keeps the ordinary bound against its glitches.
        """
        return replace(self, climb=float(min(max(climb, self.climb), self.largest_climb)))

    @property
    def accel_v(self) -> float:
        """Largest vertical acceleration (m/s²): the load factor's excess over 1 g."""
        return max(self.n_max - 1.0, 1.0 - self.n_min) * G0

    def horizontal_model(self) -> MotionModel:
        """Return the Singer model of each horizontal axis (no velocity damping)."""
        return MotionModel(tau_s=self.tau_s)

    def vertical_model(self) -> MotionModel:
        """Return the Singer model of the height (its vertical speed damped: ``tau_climb_s``).

        Its jerk is heavy-tailed: Student-t with
        :data:`~fieldmap.nav.logs.motion.VERTICAL_JERK_DOF` degrees of freedom (manoeuvres).
        """
        return MotionModel(
            tau_s=self.tau_s, beta=1.0 / self.tau_climb_s, jerk_dof=VERTICAL_JERK_DOF
        )

    def q_bounds(self, vertical: bool) -> tuple[float, float]:
        """Jerk intensity bounds (m²/s⁵): the largest acceleration is a 3σ manoeuvre."""
        a = self.accel_v if vertical else self.accel_h
        q_max = 2.0 * (a / 3.0) ** 2 / self.tau_s
        return q_max * 1e-6, q_max


#: the vehicle classes, by name (module docstring)
VEHICLES: dict[str, Vehicle] = {
    v.name: v
    for v in (
        Vehicle("paraglider", 0.0, 3.0, 35.0, 10.0, 10.0, 4.0, 60.0, 6.0),
        Vehicle("glider", -2.65, 5.3, 100.0, 15.0, 12.0, 6.0, 120.0, 15.0),
        Vehicle("light-aircraft", -1.5, 3.8, 130.0, 20.0, 17.0, 8.0, 120.0, 20.0),
        Vehicle("turboprop", -1.0, 2.5, 190.0, 25.0, 10.0, 15.0, 300.0, 35.0, climb_max=40.0),
        Vehicle("airliner", -1.0, 2.5, 360.0, 40.0, 6.0, 30.0, 300.0, 50.0, climb_max=130.0),
        Vehicle("helicopter", -0.5, 3.5, 110.0, 20.0, 10.0, 8.0, 60.0),
        Vehicle("fighter", -3.0, 9.0, 700.0, 300.0, 80.0, 4.0, 60.0, 60.0),
        Vehicle("uav", -1.0, 4.0, 80.0, 25.0, 20.0, 4.0, 60.0),
        Vehicle("car", 0.3, 1.6, 90.0, 15.0, 8.0, 4.0, 30.0),
        Vehicle("pedestrian", 0.5, 1.5, 20.0, 5.0, 3.0, 3.0, 30.0),
        Vehicle("ship", 0.7, 1.3, 30.0, 5.0, 0.5, 60.0, 10.0),
        Vehicle("rocket", 0.0, 10.0, 8000.0, 8000.0, 100.0, 10.0, 1e6),
    )
}

#: other names a user may give a class
ALIASES = {
    "hang-glider": "paraglider",
    "hangglider": "paraglider",
    "business-jet": "airliner",
    "jet": "airliner",
    "bicycle": "pedestrian",
    "bike": "pedestrian",
    "drone": "uav",
}

#: ADS-B emitter categories (DO-260B, as ``traffic`` and OpenSky write them) -> class
CATEGORIES = {
    "A1": "light-aircraft",
    "A2": "turboprop",
    "A3": "airliner",
    "A4": "airliner",
    "A5": "airliner",
    "A6": "fighter",
    "A7": "helicopter",
    "B1": "glider",
    "B4": "paraglider",
    "B6": "uav",
    "C1": "car",
    "C2": "car",
}

#: classes a flight recorder's format allows (an IGC file is a glider's or paraglider's)
FORMAT_CLASSES = {"igc": ("paraglider", "glider", "light-aircraft")}


def vehicle_class(name: str) -> Vehicle:
    """Return the class ``name`` (or an alias); an unknown one is an :class:`InputError`."""
    key = str(name).strip().lower().replace("_", "-").replace(" ", "-")
    v = VEHICLES.get(ALIASES.get(key, key))
    if v is None:
        raise InputError(
            Keyword("vehicle"),
            f" must be one of {', '.join(VEHICLES)}, got {name!r}",
            param="vehicle",
        )
    return v


@dataclass(frozen=True)
class Evidence:
    """What a log shows of its vehicle (robust statistics), for the guess and the report.

    Attributes
    ----------
    speed : float
        Top ground speed (99th percentile of a running median). Units: m/s.
    climb : float
        Top vertical speed, up or down (99th percentile). Units: m/s.
    turn_rate : float
        Top turn rate where faster than 3 m/s (95th percentile). Units: degrees/s.
    height_band : float
        Spread of the heights (99th − 1st percentile). Units: m.
    slow_airborne : float
        Fraction of the log slower than 3 m/s while more than 150 m above its lowest height
        (hover). Units: 1.
    circling_climb : float
        Fraction of the log turning faster than 6 °/s while climbing faster than 0.5 m/s (a
        thermal: what gliders and paragliders do, and powered aircraft rarely). Units: 1.
    category : str or None
        The ADS-B emitter category, when the log carries one.
    file_format : str or None
        The log's format (``igc``, ``gpx``, ``csv`` …).
    climb_reported : float or None
        Fastest vertical rate the log itself reports and its neighbours confirm: the largest
        median of three consecutive reports' magnitudes (one wild value is no climb; a rate
        that repeats the one before is a copy, and a rate off the column's steps was computed
        between reports: neither is a report). None for a log without vertical rates.
        Units: m/s.
    """

    speed: float
    climb: float
    turn_rate: float
    height_band: float
    slow_airborne: float
    circling_climb: float = 0.0
    category: str | None = None
    file_format: str | None = None
    climb_reported: float | None = None

    @property
    def top_climb(self) -> float:
        """The log's top climb (m/s): the faster of :attr:`climb` and :attr:`climb_reported`."""
        return max(self.climb, self.climb_reported or 0.0)

    def text(self) -> str:
        """Return the evidence in words."""
        return (
            f"ground speed to {self.speed:.0f} m/s, climb/descent to {self.climb:.1f} m/s, "
            f"turns to {self.turn_rate:.0f} °/s, heights over {self.height_band:.0f} m"
        )


def _pct(x: np.ndarray, q: float) -> float:
    x = np.asarray(x, dtype=np.float64)
    x = x[np.isfinite(x)]
    return float(np.percentile(x, q)) if x.size else 0.0


def _running_median(x: np.ndarray, half: int) -> np.ndarray:
    if x.size <= 2 * half + 1:
        return np.full_like(x, np.median(x) if x.size else 0.0)
    from numpy.lib.stride_tricks import sliding_window_view

    pad = np.concatenate([np.full(half, x[0]), x, np.full(half, x[-1])])
    return np.median(sliding_window_view(pad, 2 * half + 1), axis=-1)


def evidence(
    t: np.ndarray,
    east: np.ndarray,
    north: np.ndarray,
    h: np.ndarray,
    category: str | None = None,
    file_format: str | None = None,
) -> Evidence:
    """Robust statistics of a log for :func:`guess_vehicle`.

    ``t`` (s), ``east``, ``north`` (m, local), ``h`` (m) of the ordered fixes; step velocities
    smoothed by running medians over about 15 s (a wild fix moves none of them).
    """
    if t.size < 4:
        return Evidence(0.0, 0.0, 0.0, _pct(h, 99) - _pct(h, 1), 0.0, 0.0, category, file_format)
    dt = np.diff(t)
    dtm = float(np.median(dt))
    half = int(np.clip(round(7.5 / max(dtm, 1e-3)), 1, 15))
    ve = _running_median(np.diff(east) / dt, half)
    vn = _running_median(np.diff(north) / dt, half)
    vz = _running_median(np.diff(h) / dt, half)
    speed = np.hypot(ve, vn)
    track = np.unwrap(np.arctan2(ve, vn))
    tm = 0.5 * (t[1:] + t[:-1])
    rate = np.degrees(np.abs(np.diff(track) / np.maximum(np.diff(tm), 1e-3)))
    moving = (speed[1:] > 3.0) & (speed[:-1] > 3.0)
    rate_m = _running_median(rate, half)
    turn = _pct(rate_m[moving], 95) if moving.any() else 0.0
    hm = 0.5 * (h[1:] + h[:-1])
    slow_air = float(np.mean((speed < 3.0) & (hm > _pct(h, 1) + 150.0)))
    climb_m = 0.5 * (vz[1:] + vz[:-1])
    circling = float(np.mean(moving & (rate_m > 6.0) & (climb_m > 0.5))) if moving.any() else 0.0
    return Evidence(
        _pct(speed, 99),
        _pct(np.abs(vz), 99),
        turn,
        _pct(h, 99) - _pct(h, 1),
        slow_air,
        circling,
        category,
        file_format,
    )


#: the top ground speed (m/s) of ordinary flight (a log's 99th percentile) of the classes the
#: guess walks through, slowest first: their cruise plus a strong wind
CRUISE = {
    "paraglider": 25.0,
    "glider": 60.0,
    "light-aircraft": 80.0,
    "turboprop": 160.0,
    "airliner": 330.0,
    "fighter": 700.0,
}


def guess_vehicle(ev: Evidence) -> tuple[Vehicle, str]:
    """Guess the class of a log's vehicle from its :class:`Evidence`, and say from what.

    In order: the ADS-B emitter category; a rocket's speeds; the file's format (an IGC
    file: the slowest glider class whose cruise holds the log's speed); hovering (a
    helicopter); thermalling (circling climbs: a glider, or a paraglider where slower than
    its cruise); a vehicle that stays within one height band (a pedestrian or a car by its
    speed); else the slowest aircraft whose cruise holds the log's top speed (:data:`CRUISE`).
    """
    if ev.category is not None and str(ev.category).strip().upper() in CATEGORIES:
        c = str(ev.category).strip().upper()
        return VEHICLES[CATEGORIES[c]], f"guessed from the ADS-B emitter category {c}"
    why = f"guessed from the log: {ev.text()}"
    allowed = FORMAT_CLASSES.get((ev.file_format or "").lower())
    if allowed is not None:
        kinds = ", ".join(allowed)
        why += f"; a {(ev.file_format or '').upper()} file (a flight recorder of {kinds})"
        for name in allowed:
            if ev.speed <= CRUISE[name] and ev.climb <= VEHICLES[name].climb:
                return VEHICLES[name], why
        return VEHICLES[allowed[-1]], why
    if ev.speed > 1200.0 or ev.climb > 300.0:
        return VEHICLES["rocket"], why
    if ev.slow_airborne > 0.05 and ev.speed <= VEHICLES["helicopter"].speed:
        share = 100 * ev.slow_airborne
        return VEHICLES["helicopter"], why + f"; hovers {share:.0f} % of the time"
    if ev.circling_climb > 0.03 and ev.speed <= CRUISE["glider"]:
        name = "paraglider" if ev.speed <= CRUISE["paraglider"] else "glider"
        share = 100 * ev.circling_climb
        return VEHICLES[name], why + f"; circles in climbs {share:.0f} % of the time"
    if ev.height_band < 150.0 and ev.climb < 5.0:
        for name, top in (("pedestrian", 10.0), ("car", 45.0)):
            if ev.speed <= top:
                return VEHICLES[name], why + "; stays near one height"
    for name in ("light-aircraft", "turboprop", "airliner", "fighter"):
        if ev.speed <= CRUISE[name] and ev.climb <= VEHICLES[name].largest_climb:
            return VEHICLES[name], why
    return VEHICLES["fighter"], why


def describe(v: Vehicle) -> str:
    """One line: the class and its envelope."""
    return (
        f"{v.name}: load factor {v.n_min:g}..{v.n_max:g} g, speed to {v.speed:g} m/s, climb to "
        f"{v.climb:g} m/s, accelerations to {v.accel_h:g} m/s² horizontally and "
        f"{v.accel_v:.1f} m/s² vertically (manoeuvres of {v.tau_s:g} s)"
    )


__all__ = [
    "ALIASES",
    "CATEGORIES",
    "CRUISE",
    "VEHICLES",
    "Evidence",
    "Vehicle",
    "describe",
    "evidence",
    "guess_vehicle",
    "vehicle_class",
]
