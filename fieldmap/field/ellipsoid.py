"""Level ellipsoids (WGS84, GRS80) and their derived constants.

An :class:`Ellipsoid` is defined by its four defining constants (a, f, GM, omega) as in
Moritz (2000) "Geodetic Reference System 1980" and NIMA TR8350.2 (WGS84). Derived constants
follow Heiskanen & Moritz (1967), ch. 2-7 to 2-10.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property


def _q_series(x: float) -> float:
    r"""Return :math:`q(x) = \tfrac12[(1 + 3/x^2)\arctan x - 3/x]` for the ellipsoidal coordinates.

    Heiskanen & Moritz (1967) eq. 2-58 with x = E/u (x = e' on the ellipsoid). The closed form
    cancels catastrophically for small x, so the alternating series
    :math:`q = \tfrac12\sum_{k\ge1} (-1)^{k+1} \frac{4k\,x^{2k+1}}{(2k+1)(2k+3)}` is used
    for x < 0.5.
    """
    if x >= 0.5:
        return 0.5 * ((1.0 + 3.0 / (x * x)) * math.atan(x) - 3.0 / x)
    total, x2, term = 0.0, x * x, x
    for k in range(1, 60):
        term *= x2
        add = (4 * k) * term / ((2 * k + 1) * (2 * k + 3))
        total += add if k % 2 else -add
        if abs(add) < 1e-18 * abs(total):
            break
    return 0.5 * total


@dataclass(frozen=True)
class Ellipsoid:
    """A level (equipotential) ellipsoid of revolution.

    Parameters
    ----------
    name : str
        Short name, e.g. ``"WGS84"``.
    a : float
        Semi-major axis. Units: m.
    f : float
        Flattening (dimensionless).
    GM : float
        Geocentric gravitational constant. Units: m³/s².
    omega : float
        Angular velocity of rotation. Units: rad/s.
    reference : str
        Where the defining constants come from.
    """

    name: str
    a: float
    f: float
    GM: float
    omega: float
    reference: str = ""

    def __post_init__(self) -> None:
        for key in ("a", "f", "GM", "omega"):
            val = getattr(self, key)
            if not math.isfinite(val):
                raise ValueError(f"ellipsoid {self.name}: {key} must be finite, got {val}")
        if self.a <= 0 or self.GM <= 0 or self.omega < 0:
            raise ValueError(f"ellipsoid {self.name}: need a > 0, GM > 0, omega >= 0")
        if not 0 < self.f < 1:
            raise ValueError(f"ellipsoid {self.name}: flattening must be in (0, 1), got {self.f}")

    @cached_property
    def b(self) -> float:
        """Semi-minor axis b = a(1 − f). Units: m."""
        return self.a * (1.0 - self.f)

    @cached_property
    def e2(self) -> float:
        """First eccentricity squared e² = f(2 − f)."""
        return self.f * (2.0 - self.f)

    @cached_property
    def ep2(self) -> float:
        """Second eccentricity squared e'² = e²/(1 − e²)."""
        return self.e2 / (1.0 - self.e2)

    @cached_property
    def E(self) -> float:
        """Linear eccentricity E = sqrt(a² − b²). Units: m."""
        return math.sqrt(self.a**2 - self.b**2)

    @cached_property
    def q0(self) -> float:
        """q0 = q(e'), Heiskanen & Moritz (1967) eq. 2-58 at u = b."""
        return _q_series(math.sqrt(self.ep2))

    @cached_property
    def m(self) -> float:
        """Ratio m = ω²a²b/GM, Heiskanen & Moritz (1967) eq. 2-70."""
        return self.omega**2 * self.a**2 * self.b / self.GM

    @cached_property
    def J2(self) -> float:
        r"""Dynamical form factor from (a, f, GM, ω).

        .. math:: J_2 = \frac{e^2}{3}\left(1 - \frac{2}{15}\frac{m\,e'}{q_0}\right)

        Heiskanen & Moritz (1967) eq. 2-90; Moritz (2000) GRS80 eq. (4).
        """
        return self.e2 / 3.0 * (1.0 - 2.0 / 15.0 * self.m * math.sqrt(self.ep2) / self.q0)

    def J2n(self, n: int) -> float:
        r"""Even zonal coefficient :math:`J_{2n}` (unnormalised, positive J2 convention).

        .. math::
            J_{2n} = (-1)^{n+1} \frac{3 e^{2n}}{(2n+1)(2n+3)}
                     \left(1 - n + 5 n \frac{J_2}{e^2}\right)

        Heiskanen & Moritz (1967) eq. 2-92.
        """
        if n < 1:
            raise ValueError("J2n needs n >= 1")
        return (
            (-1) ** (n + 1)
            * 3.0
            * self.e2**n
            / ((2 * n + 1) * (2 * n + 3))
            * (1.0 - n + 5.0 * n * self.J2 / self.e2)
        )

    @property
    def J4(self) -> float:
        """J4 (Heiskanen & Moritz 1967 eq. 2-92, n = 2)."""
        return self.J2n(2)

    @property
    def J6(self) -> float:
        """J6 (Heiskanen & Moritz 1967 eq. 2-92, n = 3)."""
        return self.J2n(3)

    @cached_property
    def gamma_a(self) -> float:
        """Normal gravity at the equator (Heiskanen & Moritz 1967 eq. 2-141). Units: m/s²."""
        ep = math.sqrt(self.ep2)
        # q0' = 3 (1 + 1/e'^2) (1 - arctan(e')/e') - 1, H&M eq. 2-67
        q0p = 3.0 * (1.0 + 1.0 / self.ep2) * (1.0 - math.atan(ep) / ep) - 1.0
        return self.GM / (self.a * self.b) * (1.0 - self.m - self.m / 6.0 * ep * q0p / self.q0)

    @cached_property
    def gamma_b(self) -> float:
        """Normal gravity at the poles (Heiskanen & Moritz 1967 eq. 2-141). Units: m/s²."""
        ep = math.sqrt(self.ep2)
        q0p = 3.0 * (1.0 + 1.0 / self.ep2) * (1.0 - math.atan(ep) / ep) - 1.0
        return self.GM / self.a**2 * (1.0 + self.m / 3.0 * ep * q0p / self.q0)


WGS84 = Ellipsoid(
    name="WGS84",
    a=6378137.0,
    f=1.0 / 298.257223563,
    GM=3.986004418e14,
    omega=7.292115e-5,
    reference="NIMA TR8350.2 (2000), World Geodetic System 1984, 3rd ed.",
)

GRS80 = Ellipsoid(
    name="GRS80",
    a=6378137.0,
    f=1.0 / 298.257222101,
    GM=3.986005e14,
    omega=7.292115e-5,
    reference="Moritz (2000), Geodetic Reference System 1980, J. Geodesy 74, 128-133.",
)

ELLIPSOIDS = {"WGS84": WGS84, "GRS80": GRS80}


def get_ellipsoid(name_or_obj: Ellipsoid | str) -> Ellipsoid:
    """Return an :class:`Ellipsoid` from a name (``"WGS84"``, ``"GRS80"``) or pass one through."""
    if isinstance(name_or_obj, Ellipsoid):
        return name_or_obj
    key = str(name_or_obj).upper().replace("-", "")
    if key not in ELLIPSOIDS:
        from fieldmap.errors import InputError

        raise InputError(f"unknown ellipsoid {name_or_obj!r} (known: {', '.join(ELLIPSOIDS)})")
    return ELLIPSOIDS[key]
