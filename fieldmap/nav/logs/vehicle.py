r"""Vehicle classes: the envelope a conditioned flight log keeps within, and a guess from the log.

The smoothing of :mod:`fieldmap.nav.logs.condition` keeps the flown path within what the vehicle
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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fieldmap.errors import InputError


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


def vehicle(name: str) -> Vehicle:
    """Return the class ``name``; an unknown one is an :class:`InputError` naming the known."""
    v = VEHICLES.get(str(name).strip().lower())
    if v is None:
        raise InputError(
            f"vehicle must be one of {', '.join(VEHICLES)}, got {name!r}", param="vehicle"
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
