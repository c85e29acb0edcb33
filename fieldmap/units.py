"""Units of acceleration accepted by fieldmap: one table, one spelling policy.

Every function that returns an acceleration in a chosen unit takes it as ``units=`` and looks it
up here. The canonical spellings are ``"mGal"``, ``"mg"`` and ``"m/s2"``; the lookup ignores
case and spaces, reads ``²``, ``^2`` and ``**2`` as ``2`` and accepts the aliases of
:data:`ALIASES` (``"m s-2"``, the UDUNITS spelling, among them). ``mg`` is the milli-g of
navigation (1e-3 standard gravity), not the milligram: a unit of mass is never meant here.

* 1 mGal = 1e-5 m/s² (the CGS gal, 1 cm/s²).
* 1 mg = 1e-3 g_n = 9.80665e-3 m/s², with standard gravity g_n = 9.80665 m/s² exactly
  (CGPM 1901; Chen et al. 2022 §4.1 quote their thresholds in mg).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.errors import InputError

#: Standard gravity g_n (3rd CGPM, 1901; exact). Units: m/s².
STANDARD_GRAVITY = 9.80665
#: 1 mg = 1e-3 g_n. Units: m/s².
MG = 1e-3 * STANDARD_GRAVITY
#: 1 mGal = 1e-5 m/s². Units: m/s².
MGAL = 1e-5


@dataclass(frozen=True)
class Unit:
    """A unit of acceleration.

    Attributes
    ----------
    name : str
        Canonical spelling (``"mGal"``, ``"mg"``, ``"m/s2"``).
    si : float
        Size of the unit: a value ``v`` in this unit is ``v * si`` m/s². Units: m/s².
    udunits : str
        The same unit as UDUNITS-2 reads it, for the ``units`` attribute of CF files (``mg``
        alone is the milligram there, a mass).
    long_name : str
        Name for text and figure labels.
    """

    name: str
    si: float
    udunits: str
    long_name: str


#: The units, by canonical name.
UNITS: dict[str, Unit] = {
    "mGal": Unit("mGal", MGAL, "mGal", "milligal (1e-5 m s-2)"),
    "mg": Unit("mg", MG, "0.00980665 m s-2", "milli-g (1e-3 standard gravity)"),
    "m/s2": Unit("m/s2", 1.0, "m s-2", "metre per second squared"),
}


def _key(units: str) -> str:
    text = str(units).strip().lower().replace("²", "2").replace("**", "").replace("^", "")
    return "".join(text.split())


#: Accepted spellings (after :func:`_key` normalisation) -> canonical name.
ALIASES: dict[str, str] = {
    "mgal": "mGal",
    "milligal": "mGal",
    "mg": "mg",
    "milli-g": "mg",
    "m/s2": "m/s2",
    "ms-2": "m/s2",  # "m s-2" (UDUNITS, CF) once spaces are dropped
    "m.s-2": "m/s2",
    "m/s/s": "m/s2",
}


# the UDUNITS spellings written in CF files read back as the same units
ALIASES.update({_key(u.udunits): name for name, u in UNITS.items()})


def get_unit(units: str | Unit) -> Unit:
    """Look a unit of acceleration up (see the module docstring for the spelling policy).

    Parameters
    ----------
    units : str or Unit
        ``"mGal"``, ``"mg"``, ``"m/s2"`` or an alias, in any case.

    Returns
    -------
    Unit

    Raises
    ------
    InputError
        For anything else (one line, naming the accepted spellings).
    """
    if isinstance(units, Unit):
        return units
    name = ALIASES.get(_key(units)) if isinstance(units, str) else None
    if name is None:
        raise InputError(
            f"units must be one of {', '.join(UNITS)} (any case; also 'm s-2', 'm/s^2'), "
            f"got {units!r}"
        )
    return UNITS[name]


def from_si(values: ArrayLike, units: str | Unit) -> np.ndarray:
    """Convert accelerations from m/s² to ``units``.

    Parameters
    ----------
    values : array_like
        Accelerations. Units: m/s².
    units : str or Unit
        Target unit (:func:`get_unit`).

    Returns
    -------
    numpy.ndarray
        The same accelerations. Units: ``units``.
    """
    u = get_unit(units)
    v = np.asarray(values, dtype=np.float64)
    return v if u.si == 1.0 else v / u.si
