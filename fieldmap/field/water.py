r"""Equivalent water height of a change of the gravity field (GRACE-type), with load Love numbers.

A change of the geopotential between two fields A and B (a GRACE month minus a mean field, or a
time-variable model at an epoch minus the same model at its reference epoch),
:math:`\Delta\bar C_{nm} = \bar C^A_{nm} - \bar C^B_{nm}`, is read as a thin layer of mass on
the sphere of radius a (the model's reference radius) that loads the elastic Earth. Its surface
density, divided by the density of water, is the equivalent water height (Wahr, Molenaar &
Bryan 1998, eq. 14 divided by :math:`\rho_w`; ICGEM's ``water_column``):

.. math::
    EWH(\varphi, \lambda) = \frac{a\,\rho_{ave}}{3\,\rho_w}\sum_{n}\frac{2n+1}{1+k'_n}
        \sum_{m=0}^{n}\bar P_{nm}(\sin\varphi)
        \left(\Delta\bar C_{nm}\cos m\lambda + \Delta\bar S_{nm}\sin m\lambda\right)

with :math:`\rho_{ave} = 5517` kg/m³ (Wahr et al. 1998), :math:`\rho_w = 1000` kg/m³ and the
load Love numbers :math:`k'_n` of :func:`love_numbers` (Wahr et al. 1998 Table 1, PREM); the sum
starts at degree 1 (the mass of the Earth does not change: :func:`ewh_weights`). The
latitude of a point or grid row is read as the spherical latitude on that sphere, as GRACE
Level-3 tools do (spherical approximation: no height enters; EWH is a property of the surface).

**Which change.** fieldmap's ICGEM reader evaluates the time-variable terms of a model
(``gfct``, ``trnd``, ``acos``, ``asin``) at one epoch and keeps C̄(t), S̄(t) only, so EWH is
always asked of the difference of two loaded fields, :func:`field_difference` (CLI:
``--model A --minus B``): a GRACE month minus a mean field, two months, or a time-variable
model at ``--epoch T`` minus the same model (loaded at its reference epoch t0), which gives
the change since t0. One field alone (static or not) is refused: its EWH would be the mass of
the whole Earth's field, not a change.

**Speed.** The sum is one synthesis of the difference weighted per degree by (2n+1)/(1+k'_n)
(:func:`fieldmap.field.geodesy.radial_weighted_model`), at points with
:func:`fieldmap.field.sh.sh_potential` on the unit sphere and on grids with the row-wise
Legendre pass of :func:`fieldmap.grids.synthesis.synthesize`. That engine takes a level
ellipsoid for the nodes' geometry; a unit "sphere" of flattening 1e-15 stands for the sphere
(radius and latitude differ from the sphere's by 1e-15 relative, below the rounding of the sum).
"""

from __future__ import annotations

from dataclasses import replace
from importlib import resources
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import Ellipsoid
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec

#: Mean density of the Earth of Wahr et al. (1998). Units: kg/m³.
RHO_EARTH = 5517.0
#: Density of fresh water. Units: kg/m³.
RHO_WATER = 1000.0
#: Highest degree of the Love-number table; above it n k'_n is held at its value there.
LOVE_TABLE_DEGREE = 200
#: The header key that marks a model as the difference of two fields (:func:`field_difference`)
DIFFERENCE_KEY = "fieldmap_difference_of"
#: definition written into EWH products
DEFINITION = (
    "equivalent water height of the change dC, dS between two fields: "
    "a rho_ave / (3 rho_w) sum_n (2n+1)/(1+k'_n) sum_m Pnm(sin lat)(dCnm cos m lon + dSnm sin m "
    "lon), n >= 1, on the sphere of the model's radius a (Wahr, Molenaar & Bryan 1998 eq. 14 over "
    "rho_w), rho_ave = 5517 kg m-3, rho_w = 1000 kg m-3, load Love numbers k'_n of Wahr et al. "
    "1998 Table 1 (PREM), linear in n between its degrees, n k'_n constant above degree 200"
)
#: the unit "sphere" of the grid synthesis (module docstring)
_UNIT_SPHERE = Ellipsoid(name="unit sphere", a=1.0, f=1e-15, GM=1.0, omega=0.0)


def _love_table() -> np.ndarray:
    text = resources.files("fieldmap.data").joinpath("love_numbers_wahr1998.txt").read_text()
    return np.loadtxt(text.splitlines(), comments="#")


def love_numbers(lmax: int) -> np.ndarray:
    r"""Load Love numbers :math:`k'_n`, n = 0..lmax (dimensionless).

    Wahr, Molenaar & Bryan (1998) Table 1 (PREM; ``fieldmap/data/love_numbers_wahr1998.txt``)
    at its degrees 0–10, 12, 15, 20, 30, 40, 50, 70, 100, 150, 200; linear interpolation in n
    between them; above degree 200, :math:`k'_n = 200\,k'_{200}/n` (:math:`k'_n \propto 1/n`
    for large n, Farrell 1972).

    Parameters
    ----------
    lmax : int
        Highest degree, >= 0.

    Returns
    -------
    numpy.ndarray
        Shape ``(lmax + 1,)``.
    """
    table = _love_table()
    n = np.arange(int(lmax) + 1, dtype=np.float64)
    k = np.interp(n, table[:, 0], table[:, 1])
    top = table[-1]
    high = n > top[0]
    k[high] = top[0] * top[1] / n[high]
    return k


def ewh_weights(lmax: int, radius: float) -> np.ndarray:
    """Per-degree factor a ρ_ave (2n+1) / (3 ρ_w (1 + k'_n)) of the EWH sum (module docstring).

    Degree 0 has weight 0: the Earth's mass does not change, and a C̄00 difference of two fields
    is one of their GM conventions, not a load (as GRACE processing leaves it out). Units: m
    (a: ``radius``, m).
    """
    n = np.arange(int(lmax) + 1, dtype=np.float64)
    w = radius * RHO_EARTH / (3.0 * RHO_WATER) * (2.0 * n + 1.0) / (1.0 + love_numbers(lmax))
    w[0] = 0.0
    return w


def _describe(model: SHModel) -> str:
    epoch = "" if model.epoch is None else f" at {model.epoch:.4f}"
    return f"{model.name}{epoch}"


def field_difference(model: SHModel, reference: SHModel) -> SHModel:
    r"""Return the change ``model − reference`` of the field, in ``model``'s GM and radius.

    The reference's coefficients are re-expressed with the model's constants,
    :math:`\bar C^B_{nm}\,(GM_B/GM_A)(R_B/R_A)^n`, then subtracted, to the lower of the two
    degrees. Of two fields in different known tide systems the reference is converted to the
    model's first (:func:`fieldmap.models.tide.convert_tide_system`: their C̄20 differ by the
    permanent tide, not by a change of mass), and the difference's ``source`` says so.

    Parameters
    ----------
    model, reference : SHModel
        Fields A and B (e.g. ``load_model(a, epoch=...)`` and ``load_model(b)``).

    Returns
    -------
    SHModel
        The difference, named ``"A-minus-B"``; its header marks it as a difference (what
        :func:`equivalent_water_height` asks for).
    """
    for what, m in (("model", model), ("reference", reference)):
        if not isinstance(m, SHModel):
            raise InputError(f"{what} must be an SHModel, got {type(m).__name__}", param=what)
    known = {model.tide_system, reference.tide_system} - {"unknown"}
    if len(known) > 1:  # the permanent tide is no change of mass: one system for both
        from fieldmap.models.tide import convert_tide_system

        converted = f" ({reference.name} converted from {reference.tide_system} to "
        converted += f"{model.tide_system}, IERS Conventions 2010 §6.2.2)"
        reference = convert_tide_system(reference, model.tide_system)
    lmax = min(model.lmax, reference.lmax)
    n = np.arange(lmax + 1, dtype=np.float64)[:, None]
    scale = (reference.gm / model.gm) * (reference.radius / model.radius) ** n
    C = model.C[: lmax + 1, : lmax + 1] - reference.C[: lmax + 1, : lmax + 1] * scale
    S = model.S[: lmax + 1, : lmax + 1] - reference.S[: lmax + 1, : lmax + 1] * scale
    what = f"{_describe(model)} minus {_describe(reference)}"
    if len(known) > 1:
        what += converted
    return replace(
        model,
        name=f"{model.name}-minus-{reference.name}",
        C=C,
        S=S,
        sigma_c=None,
        sigma_s=None,
        source=what,
        header={**model.header, DIFFERENCE_KEY: what},
    )


def check_difference(model: SHModel) -> SHModel:
    """Return ``model`` if it is a difference of two fields (:func:`field_difference`), else raise.

    Raises
    ------
    fieldmap.errors.InputError
        One field alone: its equivalent water height is not a change of mass.
    """
    if not isinstance(model, SHModel) or DIFFERENCE_KEY not in model.header:
        name = model.name if isinstance(model, SHModel) else str(model)
        raise InputError(
            f"equivalent water height is that of a change of the field, and {name} is one "
            "field: give the difference of two (CLI: --minus REFERENCE, e.g. a mean field, or "
            "the same time-variable model with --epoch T for the change since its reference "
            "epoch; Python: fieldmap.field.water.field_difference(model, reference))",
            param="model",
        )
    return model


def _unit_model(diff: SHModel) -> SHModel:
    """Return the EWH series as a potential of GM = 1 on the unit sphere (its value: the sum, m)."""
    from fieldmap.field.geodesy import radial_weighted_model

    w = radial_weighted_model(diff, ewh_weights(diff.lmax, diff.radius))
    return replace(w, gm=1.0, radius=1.0)


def equivalent_water_height(
    latitude: ArrayLike,
    longitude: ArrayLike,
    *,
    model: SHModel,
    reference: SHModel | None = None,
    device: str | None = None,
) -> np.ndarray:
    """Equivalent water height of a change of the field at points (module docstring).

    Parameters
    ----------
    latitude, longitude : array_like
        Latitude (read as spherical latitude on the sphere of the model's radius) and
        longitude. Units: degrees.
    model : SHModel
        Field A, or already a difference (:func:`field_difference`) when ``reference`` is None.
    reference : SHModel, optional
        Field B: the result is the EWH of A − B.
    device : str, optional
        Warp device.

    Returns
    -------
    numpy.ndarray
        Broadcast shape of ``latitude``, ``longitude``. Units: m.
    """
    from fieldmap.field.sh import sh_potential
    from fieldmap.limits import check_geodetic

    diff = check_difference(model if reference is None else field_difference(model, reference))
    lat, lon, _ = check_geodetic(latitude, longitude, 0.0)
    phi, lam = np.radians(lat), np.radians(lon)
    x, y, z = np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)
    return sh_potential(_unit_model(diff), x, y, z, device=device)


def grid_ewh(
    model: SHModel,
    grid: GridSpec,
    *,
    device: str | None = None,
    progress: bool | None = None,
) -> dict[str, np.ndarray]:
    """Equivalent water height on every node of a grid (at h = 0), one Legendre pass per row.

    Parameters
    ----------
    model : SHModel
        A difference of two fields (:func:`field_difference`).
    grid : fieldmap.grids.spec.GridSpec
        Nodes (their heights are not used: EWH is a property of the surface).
    device : str, optional
        Warp device.
    progress : bool, optional
        Progress bar of the synthesis.

    Returns
    -------
    dict of numpy.ndarray
        ``{"ewh": array of shape (1, nlat, nlon)}``. Units: m.
    """
    from fieldmap.grids.synthesis import synthesize

    diff = check_difference(model)
    surface = replace(grid, heights=np.zeros(1))
    out = synthesize(
        _unit_model(diff),
        surface,
        _UNIT_SPHERE,
        quantity="gravitation",
        device=device,
        progress=progress,
        potential=True,
    )
    return {"ewh": out[..., 3]}
