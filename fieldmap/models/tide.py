r"""Permanent-tide systems of a gravity model: tide-free, zero-tide and mean-tide.

The degree-2 zonal tide-generating potential of the Sun and the Moon has a time-independent
part, the *permanent tide*. A model may leave out both its direct potential and the Earth's
permanent deformation under it (**tide-free**), keep the deformation only (**zero-tide**), or
keep both (**mean-tide**: the field a mean sea surface is level in). Only C̄20 differs
(IERS Conventions 2010, §6.2.2; Rapp 1989; Ekman 1989).

In units of the model's C̄20, with :math:`\delta = A_0 H_0` the direct permanent tide and
:math:`k_{20}` its Love number (IERS Conventions 2010 §6.2.2: the time-independent part of
eq. (6.8a) for n = 2, m = 0, :math:`\Delta\bar C_{20}^{perm} = A_0 H_0 k_{20}`):

.. math::
    \bar C_{20}^{zero} = \bar C_{20}^{free} + k_{20}\,A_0 H_0, \qquad
    \bar C_{20}^{mean} = \bar C_{20}^{zero} + A_0 H_0

(zero ↔ mean is the permanent tide's own potential, the direct term, with no Love number).
Constants (:data:`IERS2010`): :math:`A_0 = 1/(R_e\sqrt{4\pi}) = 4.4228\times10^{-8}` m⁻¹,
:math:`H_0 = -0.31460` m, :math:`k_{20} = 0.30190` (IERS Conventions 2010, §6.2.2 and
Table 6.3's nominal :math:`k_{20}`): :math:`A_0H_0k_{20} = -4.2007\times10^{-9}`.
NGA computed EGM96's and EGM2008's zero-tide C̄20 from the tide-free one with
:math:`k = 0.3` and :math:`\delta = -3.11080\times10^{-8}/\sqrt5` (the EGM96 README, used
again for EGM2008): :data:`NGA_EGM` reproduces their published pairs to the last digit, while
:data:`IERS2010` differs from them by 2.7e-11 in C̄20 (the Love number, 0.6 %).

The geoid of a mean-tide model differs from the zero-tide geoid by the direct term alone,
:func:`mean_minus_zero_geoid` (derived from :math:`\delta`; Ekman 1989 gives
(9.9 − 29.6 sin²φ) cm, :data:`EKMAN1989_CM`).

Exactness: a conversion never adds to a converted value. The converted model keeps the C̄20
and the system of the file it was read from (``header["tide_origin"]``), and every conversion
is made from those: C̄20 of the target is ``C20_file + (level(target) − level(file))``, and a
conversion back to the file's system restores ``C20_file`` itself, so there and back is
exact to the last bit whatever the path.

The offsets are in the model's own normalisation (GM, R); the (R/R_e)² factor of a model whose
radius is not the IERS R_e changes them by < 1e-7 of themselves and is left out. The
representation of the direct term (a potential growing as r²) by a C̄20 change (decaying as
r⁻³) is exact on the reference sphere only, as in every mean-tide model on ICGEM.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel

#: tide systems a model can be converted to (``unknown`` is read from files, never converted)
TIDE_SYSTEMS = ("tide_free", "zero_tide", "mean_tide")
UNKNOWN = "unknown"

#: Ekman (1989): mean-tide minus zero-tide geoid, N = a + b sin²φ. Units: cm.
EKMAN1989_CM = (9.9, -29.6)


@dataclass(frozen=True)
class PermanentTide:
    """Constants of the permanent tide in C̄20.

    Attributes
    ----------
    name : str
        Where the constants come from.
    direct : float
        δ = A0·H0: the direct permanent tide potential as a change of C̄20 (mean − zero).
        Dimensionless (fully normalised C̄20, units of GM/R).
    k20 : float
        Love number of the permanent deformation (zero − free = k20·δ).
    """

    name: str
    direct: float
    k20: float

    def level(self, system: str) -> float:
        """C̄20 of ``system`` minus the tide-free C̄20 (0, k20·δ or (1 + k20)·δ)."""
        system = check_tide_system(system)
        if system == "tide_free":
            return 0.0
        if system == "zero_tide":
            return self.k20 * self.direct
        return self.k20 * self.direct + self.direct

    def offset(self, source: str, target: str) -> float:
        """C̄20 of ``target`` minus C̄20 of ``source`` (the same model in two systems)."""
        return self.level(target) - self.level(source)


#: IERS Conventions (2010) §6.2.2: A0 = 4.4228e-8 m⁻¹, H0 = −0.31460 m, k20 = 0.30190
IERS2010 = PermanentTide("IERS Conventions (2010) §6.2.2", 4.4228e-8 * -0.31460, 0.30190)
#: NGA's EGM96/EGM2008 README: zero − free = −3.11080e-8 · 0.3 / √5 (k = 0.3)
NGA_EGM = PermanentTide("NGA EGM96/EGM2008 README (k = 0.3)", -3.11080e-8 / math.sqrt(5.0), 0.3)


def check_tide_system(name: object) -> str:
    """Return a tide-system name of :data:`TIDE_SYSTEMS`; an unknown one is one line."""
    key = str(name).strip().lower().replace("-", "_")
    if key not in TIDE_SYSTEMS:
        raise InputError(
            f"unknown tide system {name!r}: one of {', '.join(TIDE_SYSTEMS)}",
            param="tide_system",
        )
    return key


def convert_tide_system(
    model: SHModel, target: str, constants: PermanentTide = IERS2010
) -> SHModel:
    """Return ``model`` in the tide system ``target`` (only C̄20 changes).

    Parameters
    ----------
    model : SHModel
        A model whose :attr:`~SHModel.tide_system` is known.
    target : {"tide_free", "zero_tide", "mean_tide"}
        The system wanted.
    constants : PermanentTide
        δ and k20 (default :data:`IERS2010`).

    Returns
    -------
    SHModel
        ``model`` itself when already in ``target``; else a copy with C̄20 changed, its
        ``tide_system`` set and ``header["tide_origin"]`` holding the file's system and C̄20
        (module docstring: exact round trips).

    Raises
    ------
    InputError
        ``target`` is no tide system, or the model's is unknown.

    Examples
    --------
    >>> from fieldmap.models.registry import load_model
    >>> m = load_model("eigen-6s", lmax=2)
    >>> z = convert_tide_system(m, "zero_tide")
    >>> z.tide_system, float(z.C[2, 0] - m.C[2, 0])  # doctest: +ELLIPSIS
    ('zero_tide', -4.200...e-09)
    >>> bool(convert_tide_system(z, "tide_free").C[2, 0] == m.C[2, 0])
    True
    """
    target = check_tide_system(target)
    if model.tide_system == target:
        return model
    if model.tide_system not in TIDE_SYSTEMS:
        raise InputError(
            f"model {model.name}: its tide system is {model.tide_system}, so it cannot be "
            f"converted to {target} (leave out --tide-system, or give a model file that "
            "states its tide_system)",
            param="tide_system",
        )
    origin = model.header.get("tide_origin") if isinstance(model.header, dict) else None
    if origin is None:
        origin = {"system": model.tide_system, "c20": None}
        if model.lmax >= 2:
            origin["c20"] = float(model.C[2, 0])
    header = {**model.header, "tide_origin": origin}
    if model.lmax < 2:  # no C̄20: only the label changes
        return replace(model, tide_system=target, header=header)
    C = np.array(model.C, dtype=np.float64, copy=True)
    if origin["system"] == target:
        C[2, 0] = origin["c20"]
    else:
        C[2, 0] = origin["c20"] + constants.offset(origin["system"], target)
    return replace(model, C=C, tide_system=target, header=header)


def mean_minus_zero_geoid(lat_deg: np.ndarray | float, gm: float, radius: float) -> np.ndarray:
    r"""Mean-tide minus zero-tide geoid height, from the direct term of C̄20.

    Bruns' formula on the sphere for the C̄20 change δ of :data:`IERS2010`:

    .. math::
        N_{mean} - N_{zero} = \frac{GM}{R\,\gamma}\,\delta\,\bar P_{20}(\sin\varphi), \quad
        \gamma = GM/R^2, \quad \bar P_{20}(t) = \sqrt5\,(3t^2 - 1)/2

    i.e. R·δ·√5·(1.5 sin²φ − 0.5) = (9.92 − 29.77 sin²φ) cm for R = 6378137 m; Ekman (1989)
    gives (9.9 − 29.6 sin²φ) cm (:data:`EKMAN1989_CM`). The latitude is taken as geocentric:
    the geodetic one changes sin²φ by < 0.0034, < 0.1 mm here.

    Parameters
    ----------
    lat_deg : float or numpy.ndarray
        Latitude. Units: degrees.
    gm, radius : float
        The model's GM and reference radius. Units: m³/s², m.

    Returns
    -------
    numpy.ndarray
        N_mean − N_zero. Units: m.
    """
    s = np.sin(np.radians(np.asarray(lat_deg, dtype=np.float64)))
    gamma = gm / radius**2
    return gm / (radius * gamma) * IERS2010.direct * math.sqrt(5.0) * (1.5 * s * s - 0.5)


def conversion_note(model: SHModel) -> str:
    """One line saying from which system ``model`` was converted, and by how much (or '')."""
    origin = model.header.get("tide_origin") if isinstance(model.header, dict) else None
    if not origin or origin["system"] == model.tide_system:
        return ""
    change = ""
    if origin.get("c20") is not None and model.lmax >= 2:
        change = f", C̄20 {float(model.C[2, 0]) - origin['c20']:+.4e}"
    return (
        f"converted from {origin['system']} to {model.tide_system}{change} "
        f"(IERS Conventions 2010 §6.2.2)"
    )
