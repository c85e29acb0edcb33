"""The map quantities: one entry each, read by the engine, the variables and the figures.

An entry (:class:`Quantity`) says everything fieldmap knows of one map quantity:

- its **synthesis**: what is computed on a block of grid rows, from the model (the functions
  below the entries, each a few lines over :mod:`fieldmap.grids.synthesis` and
  :mod:`fieldmap.field`);
- its **variables** (:class:`Variable`): names, units (UDUNITS spelling), CF long names and
  standard names where the CF table has one;
- the **layout** of its product (:mod:`fieldmap.products.layouts`): a vector in the units asked
  with its modulus statistics (the disturbance), a stack of J2n orders (the truncation error),
  model and normal components, or scalar fields (every other quantity);
- its **attributes** (definition, source, frame), the checks a request for it must pass, and
  its **figure style** (:class:`Style`).

:mod:`fieldmap.products.engine` runs the synthesis and the layout of the entry a request names,
:mod:`fieldmap.products.variables` builds the CF attributes from its variables,
:mod:`fieldmap.products.plots` draws it in its style, and the command line lists the entries as
the choices of ``fieldmap map --quantity``. Adding a quantity is adding one entry.

This module imports nothing heavy (the command line reads it at every start): the synthesis
functions import what they need when they run.

Examples
--------
>>> from fieldmap.products.quantities import quantity
>>> q = quantity("geoid")
>>> q.variables[0].name, q.variables[0].units, q.surface
('geoid', 'm', True)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal

from fieldmap.errors import InputError

if TYPE_CHECKING:
    from fieldmap.field.ellipsoid import Ellipsoid
    from fieldmap.models.shmodel import SHModel

#: The shapes of a product (:mod:`fieldmap.products.layouts`).
Layout = Literal["vector", "orders", "components", "fields"]
#: How a variable's colours are chosen from its values (:func:`fieldmap.products.plots.colours`).
Scale = Literal["signed", "magnitude", "level", "auto"]

#: The frame attribute of the scalar quantities.
SCALAR_FRAME = "geocentric spherical (deflection components), values are scalars otherwise"
#: The frame attribute of the gradient tensors.
ENU_FRAME = "local geodetic east-north-up at each node"


@dataclasses.dataclass(frozen=True)
class Variable:
    """One variable of a product, with its CF attributes.

    Attributes
    ----------
    name : str
    units : str or None
        UDUNITS spelling (``"mGal"``, ``"1e-9 s-2"``...); None: the units the request asks for
        (the disturbance vector).
    long_name : str
        May hold ``{model}`` and ``{ellipsoid}``, filled in with the product's.
    standard_name : str, optional
        The CF standard name, where the CF table has one.
    comment : str, optional
    """

    name: str
    units: str | None
    long_name: str
    standard_name: str | None = None
    comment: str | None = None


@dataclasses.dataclass(frozen=True)
class Style:
    """How a quantity's maps are drawn (:mod:`fieldmap.products.plots`).

    Attributes
    ----------
    figure : {"maps", "panels", "isolines", "truncation", "components"}
        ``maps``: one map per variable and height, in the one map style; ``panels``: one figure
        of every variable per height (the gradient tensor's six components); the others are
        the figures of Chen et al. (2022) for the disturbance, the J2n truncation and the
        components.
    scale : {"signed", "magnitude", "level", "auto"}
        ``signed``: a diverging scale symmetric about zero, to the ``clip`` percentile of |x|;
        ``magnitude``: 0 to the ``clip`` percentile (standard deviations; a sequential scale
        of the field's own range where it is far from zero everywhere); ``level``: from the
        ``100 - clip`` to the ``clip`` percentile (fields far from zero); ``auto``: ``signed``
        where the values take both signs, else ``level``. Values beyond the scale are drawn in
        its end colours and marked by the colour bar's arrows.
    clip : float
        Percentile (area-weighted) at which the scale ends. Units: %.
    cmap : str, optional
        Matplotlib colour map (default: ``RdBu_r`` for signed scales, ``magma_r`` for
        magnitudes, ``viridis`` for levels).
    suffix : str
        File suffix of a ``panels`` figure (``tensor``).
    """

    figure: Literal["maps", "panels", "isolines", "truncation", "components"] = "maps"
    scale: Scale = "signed"
    clip: float = 99.0
    cmap: str | None = None
    suffix: str = "panels"


@dataclasses.dataclass(frozen=True)
class Quantity:
    """One map quantity: its synthesis, variables, product layout, attributes and style.

    Attributes
    ----------
    name : str
        As the API and ``--quantity`` take it.
    help : str
        A short description for the command line's help.
    variables : tuple of Variable
        In the order of the product.
    synthesis : callable
        ``synthesis(model, job, ellipsoid)`` computes one block
        (:class:`fieldmap.products.engine.Job`: its ``grid`` of rows at one height, ``device``,
        ``output``, ``order``): {variable: (1, rows, nlon) array} for the ``fields`` layout,
        ``{"vector": (rows, nlon, 3) array}`` in m/s² for ``vector`` and ``orders``, the
        variables as (rows, nlon) arrays for ``components``.
    layout : {"fields", "vector", "orders", "components"}
    style : Style
    definition : callable, optional
        ``definition(degree0)``: the ``definition`` attribute (``fields``).
    source : str
        The ``source`` attribute after "fieldmap <version>: ", with ``{model}``, ``{lmax}``,
        ``{ellipsoid}`` filled in (``fields``).
    frame : str
        The ``frame`` attribute (``fields``).
    surface : bool
        A property of the ellipsoid's surface: computed at h = 0 whatever the heights asked.
    degree0 : bool
        Takes ``degree0`` (a quantity of the disturbing potential T).
    uses_model : bool
        A model enters it (False: the exact normal field, the J2n truncation error).
    omission_model : bool
        Takes ``omission_model`` (a degree-variance model).
    needs_sigma : bool
        Needs the model's coefficient standard deviations.
    check : callable, optional
        ``check(request)`` refuses a request that cannot be computed (one line).
    extra_attrs : callable, optional
        ``extra_attrs(request)``: global attributes added to the product's.
    in_quantity_map : bool
        One of the quantities of :func:`fieldmap.quantity_map` and ``fieldmap map
        --quantity`` (the truncation and component maps have their own).
    """

    name: str
    help: str
    variables: tuple[Variable, ...]
    synthesis: Callable[..., dict[str, Any]]
    layout: Layout = "fields"
    style: Style = Style()
    definition: Callable[[bool], str] | None = None
    source: str = "{model} degree {lmax} minus the {ellipsoid} normal field"
    frame: str = SCALAR_FRAME
    surface: bool = False
    degree0: bool = False
    uses_model: bool = True
    omission_model: bool = False
    needs_sigma: bool = False
    check: Callable[[Any], None] | None = None
    extra_attrs: Callable[[Any], dict[str, Any]] | None = None
    in_quantity_map: bool = True

    @property
    def names(self) -> tuple[str, ...]:
        """The variables' names, in order."""
        return tuple(v.name for v in self.variables)


# ------------------------------------------------------------------------ the syntheses


def _disturbance(model: SHModel, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """δg = g_model − γ_exact (gravitation), ENU, m/s²."""
    from fieldmap.grids.synthesis import synthesize

    vec = synthesize(model, job.grid, ell, "disturbance", job.device, progress=False)[0]
    return {"vector": vec}


def _truncation(model: None, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """Compute the J2n normal gravitation minus the exact one (axisymmetric: a row per latitude)."""
    import numpy as np

    from fieldmap.grids.synthesis import normal_rows

    exact = normal_rows(job.grid, ell, "exact", job.device)[0]
    err = normal_rows(job.grid, ell, f"j{job.order}", job.device)[0] - exact
    vec = np.empty((err.shape[0], job.grid.lon.size, 3))
    vec[...] = err[:, None, :]
    return {"vector": vec}


def _components(model: SHModel, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """Model gravity and exact normal gravity, both with the centrifugal acceleration."""
    import numpy as np

    from fieldmap.grids.synthesis import centrifugal_rows, normal_rows, synthesize

    g = synthesize(model, job.grid, ell, "gravity", job.device, progress=False)[0]
    gam = (normal_rows(job.grid, ell, "exact", job.device) + centrifugal_rows(job.grid, ell))[0]
    gam = np.broadcast_to(gam[:, None, :], g.shape)
    data = {}
    for k, c in enumerate(("east", "north", "up")):
        data[f"model_{c}"] = g[..., k]
        data[f"normal_{c}"] = np.array(gam[..., k])
    return data


def _functional(model: SHModel, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """T and its functionals (:func:`fieldmap.field.geodesy.grid_quantities`)."""
    from fieldmap.field.geodesy import grid_quantities

    return grid_quantities(
        model,
        job.grid,
        job.quantity,
        ellipsoid=ell,
        degree0=job.output.degree0,
        device=job.device,
    )


def _gradient(model: SHModel | None, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """Compute the gradient tensor or its invariants (``fieldmap.field.gradient.grid_gradient``)."""
    from fieldmap.field.gradient import grid_gradient

    return grid_gradient(model, job.grid, job.quantity, ellipsoid=ell, device=job.device)


def _commission(model: SHModel, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """σ propagated from the coefficients' σ (:func:`fieldmap.field.commission_grid`)."""
    from fieldmap.field.commission_grid import grid_commission

    return grid_commission(model, job.grid, job.quantity, ellipsoid=ell)


def _omission(model: SHModel, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """σ of the degrees above the model's (:func:`fieldmap.field.omission.grid_omission`)."""
    from fieldmap.field.omission import grid_omission

    shape = (job.grid.lat.size, job.grid.lon.size)
    return grid_omission(model, job.grid.heights, shape, job.output.omission_model)


def _ewh(model: SHModel, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """Equivalent water height of a difference of fields (:mod:`fieldmap.field.water`)."""
    from fieldmap.field.water import grid_ewh

    return grid_ewh(model, job.grid, device=job.device)


def _radial(model: SHModel, job: Any, ell: Ellipsoid) -> dict[str, Any]:
    """δg · r̂: the disturbance's up and north components turned by φ − ψ, in mGal."""
    import numpy as np

    from fieldmap.field.frames import geodetic_to_ecef
    from fieldmap.grids.synthesis import synthesize
    from fieldmap.units import MGAL

    vec = synthesize(model, job.grid, ell, "disturbance", job.device, progress=False)
    x, _, z = geodetic_to_ecef(job.grid.lat, 0.0, job.grid.heights[0], ell)
    tilt = (np.radians(job.grid.lat) - np.arctan2(z, x))[None, :, None]  # φ − ψ
    return {"radial": (np.cos(tilt) * vec[..., 2] - np.sin(tilt) * vec[..., 1]) / MGAL}


# ------------------------------------------------------------------------ checks, attributes


def _needs_difference(request: Any) -> None:
    from fieldmap.field.water import check_difference

    check_difference(request.model)


def _needs_sigma(request: Any) -> None:
    m, q = request.model, request.output.quantity
    if m.sigma_c is None or m.sigma_s is None:
        raise InputError(
            f"model {m.name} carries no coefficient standard deviations (sigma C, "
            f"sigma S): --quantity {q} needs an ICGEM file with sigma columns"
        )


def _omission_check(request: Any) -> None:
    from fieldmap.field.omission import Omission

    # validated once here (degree >= 2, a fitted law needs power in the model)
    Omission(request.model.lmax, str(request.output.omission_model), model=request.model)


def _omission_attrs(request: Any) -> dict[str, Any]:
    from fieldmap.field.omission import Omission

    om = Omission(request.model.lmax, request.output.omission_model, model=request.model)
    return {"omission_model": om.kind, "omission_max_degree": om.max_degree}


def _t_definition(extra: str = "") -> Callable[[bool], str]:
    """Return the definition of T's quantities (``extra``: a functional's own sentence)."""

    def text(degree0: bool) -> str:
        zero = (
            "the degree-0 term (GM - GM_ellipsoid)/r is included"
            if degree0
            else "the degree-0 term (GM - GM_ellipsoid)/r is left out, as GeographicLib's Gravity"
        )
        return (
            "T = W - U, model minus level-ellipsoid normal potential; "
            + zero
            + "; anomaly and deflection in the spherical approximation (Heiskanen & Moritz 1967 "
            "eq. 2-151c), gamma the normal gravity at the point; geoid N = T(h=0)/gamma0 "
            "(Somigliana) + HeightOffset and correction terms of a GeographicLib model" + extra
        )

    return text


def _gradient_definition(what: str, invariants: bool = False) -> Callable[[bool], str]:
    text = (
        f"second derivatives of the potential: d({what})_i / dx_j in the local geodetic "
        "east-north-up frame at each node (1 E = 1e-9 s-2); g is model gravitation plus "
        "centrifugal; synthesised from the second derivatives of the series (one Legendre "
        "pass per row, FFT in longitude), the normal field as its zonal J2n series, the "
        "centrifugal tensor in closed form; the tensor is symmetric, so six components"
    )
    if invariants:
        text += (
            "; invariants I1 = sum of the principal 2x2 minors, I2 = determinant "
            "(Pedersen & Rasmussen 1990), eigenvalues in decreasing order"
        )
    return lambda degree0: text


def _fixed(text: str) -> Callable[[bool], str]:
    return lambda degree0: text


def _ewh_definition(degree0: bool) -> str:
    from fieldmap.field.water import DEFINITION

    return DEFINITION


_SIGMA_DEFINITION = _fixed(
    "standard deviation of the quantity propagated from the model's coefficient "
    "standard deviations sigma C, sigma S, assumed uncorrelated (diagonal propagation: "
    "the full covariance is not used); the degrees above the model's degree are not "
    "counted (omission error); geoid at h = 0"
)
_OMISSION_DEFINITION = _fixed(
    "standard deviation of the gravity disturbance of the degrees above the model's "
    "degree L, an isotropic random field with the degree variances of the "
    "degree-variance model named in omission_model (fieldmap.field.omission: "
    "Tscherning & Rapp 1974 model 4, Kaula's rule, or a power law fitted to the model's "
    "degrees L/2..L); spherical approximation r = R + h, so the same at every node of a "
    "height; degrees L+1..omission_max_degree"
)

# ------------------------------------------------------------------------ variables

_MG_UNITS = "0.00980665 m s-2"  # fieldmap.products.variables.MG_UNITS
_MG_COMMENT = (
    "values in mg (milli-g): 1 mg = 1e-3 g_n = 9.80665e-3 m s-2 = 980.665 mGal; the units "
    "attribute spells it as a scaled SI unit because UDUNITS reads 'mg' as milligram"
)


def vector_variables(what: str) -> tuple[Variable, ...]:
    """east, north, up, modulus in the units asked, and modulus_mg, of the vector ``what``."""
    comps = {"east": "eastward", "north": "northward", "up": "upward"}
    return (
        *(Variable(c, None, f"{cf} component of the {what}") for c, cf in comps.items()),
        Variable("modulus", None, f"modulus of the {what}"),
        Variable("modulus_mg", _MG_UNITS, f"modulus of the {what} in mg", comment=_MG_COMMENT),
    )


def _tensor(what: str) -> tuple[Variable, ...]:
    return tuple(
        Variable(
            name,
            "1e-9 s-2",
            f"gradient tensor of {what}, d g_{name[2]} / d {name[3]} (ENU), Eotvos",
        )
        for name in ("T_ee", "T_en", "T_eu", "T_nn", "T_nu", "T_uu")
    )


_SIGMA = "standard deviation (commission error, diagonal propagation of the coefficient sigma)"
_OMISSION = (
    "standard deviation (omission error: the degrees above the model's, from a degree-variance "
    "model)"
)
_TENSOR_STYLE = Style(figure="panels", scale="auto", suffix="tensor")
_SIGMA_STYLE = Style(scale="magnitude")

# ------------------------------------------------------------------------ the entries

QUANTITIES: tuple[Quantity, ...] = (
    Quantity(
        "disturbance",
        "the gravity disturbance g_model - gamma_exact: east, north, up, modulus (default)",
        vector_variables("gravity disturbance"),
        _disturbance,
        layout="vector",
        style=Style(figure="isolines", scale="magnitude"),
    ),
    Quantity(
        "truncation",
        "the J2n normal gravitation minus the exact one, per order",
        vector_variables("normal gravitation truncation error"),
        _truncation,
        layout="orders",
        style=Style(figure="truncation", scale="magnitude"),
        uses_model=False,
        in_quantity_map=False,
    ),
    Quantity(
        "components",
        "model gravity and exact normal gravity, east, north, up",
        tuple(
            Variable(f"{kind}_{c}", "m s-2", f"{cf} component of {of}")
            for c, cf in (("east", "eastward"), ("north", "northward"), ("up", "upward"))
            for kind, of in (
                ("model", "gravity from {model}"),
                ("normal", "normal gravity ({ellipsoid})"),
            )
        ),
        _components,
        layout="components",
        style=Style(figure="components"),
        in_quantity_map=False,
    ),
    Quantity(
        "anomaly",
        "gravity anomaly, spherical approximation (mGal)",
        (Variable("anomaly", "mGal", "gravity anomaly, spherical approximation: -dT/dr - 2T/r"),),
        _functional,
        definition=_t_definition(),
        degree0=True,
    ),
    Quantity(
        "deflection",
        "deflection of the vertical xi, eta (arcsec)",
        (
            Variable("xi", "arcsec", "northerly component of the deflection of the vertical"),
            Variable("eta", "arcsec", "easterly component of the deflection of the vertical"),
        ),
        _functional,
        definition=_t_definition(),
        degree0=True,
    ),
    Quantity(
        "geoid",
        "geoid height (m, at h = 0)",
        (
            Variable(
                "geoid",
                "m",
                "geoid height above the reference ellipsoid (Bruns: T/gamma0)",
                "geoid_height_above_reference_ellipsoid",
            ),
        ),
        _functional,
        definition=_t_definition(),
        surface=True,
        degree0=True,
    ),
    Quantity(
        "potential",
        "disturbing potential T (m²/s²)",
        (Variable("potential", "m2 s-2", "disturbing potential T = W - U"),),
        _functional,
        definition=_t_definition(),
        degree0=True,
    ),
    Quantity(
        "gradient",
        "the six ENU components of the gradient tensor of gravity (Eötvös)",
        _tensor("gravity"),
        _gradient,
        style=_TENSOR_STYLE,
        definition=_gradient_definition("g"),
        source="{model} degree {lmax}",
        frame=ENU_FRAME,
    ),
    Quantity(
        "gradient-disturbance",
        "the gradient tensor of the gravity disturbance (Eötvös)",
        _tensor("gravity disturbance"),
        _gradient,
        style=_TENSOR_STYLE,
        definition=_gradient_definition("g - gamma_exact (gravitation)"),
        frame=ENU_FRAME,
    ),
    Quantity(
        "gradient-normal",
        "the gradient tensor of exact normal gravity (Eötvös; no model)",
        _tensor("exact normal gravity"),
        _gradient,
        style=_TENSOR_STYLE,
        definition=_gradient_definition("gamma_exact (with centrifugal)"),
        source="the exact normal gravity of {ellipsoid}",
        frame=ENU_FRAME,
        uses_model=False,
    ),
    Quantity(
        "gradient-invariants",
        "I1 (E²), I2 (E³) and the eigenvalues (E) of the model gravitation's tensor",
        (
            Variable("I1", "1e-18 s-4", "second invariant of the gravitation gradient tensor, E^2"),
            Variable(
                "I2",
                "1e-27 s-6",
                "third invariant (determinant) of the gravitation gradient tensor, E^3",
            ),
            *(
                Variable(
                    f"eig_{k}",
                    "1e-9 s-2",
                    f"{o} eigenvalue of the gravitation gradient tensor, Eotvos",
                )
                for k, o in ((1, "largest"), (2, "middle"), (3, "smallest"))
            ),
        ),
        _gradient,
        style=Style(scale="auto"),
        definition=_gradient_definition("model gravitation", invariants=True),
        source="{model} degree {lmax}",
        frame=ENU_FRAME,
    ),
    Quantity(
        "disturbance-sigma",
        "commission error of the disturbance's components from the coefficients' sigma (mGal)",
        tuple(
            Variable(
                f"sigma_{c}", "mGal", f"{_SIGMA} of the {c} component of the gravity disturbance"
            )
            for c in ("east", "north", "up")
        ),
        _commission,
        style=_SIGMA_STYLE,
        definition=_SIGMA_DEFINITION,
        needs_sigma=True,
        check=_needs_sigma,
    ),
    Quantity(
        "anomaly-sigma",
        "commission error of the gravity anomaly (mGal)",
        (Variable("anomaly_sigma", "mGal", f"{_SIGMA} of the gravity anomaly"),),
        _commission,
        style=_SIGMA_STYLE,
        definition=_SIGMA_DEFINITION,
        needs_sigma=True,
        check=_needs_sigma,
    ),
    Quantity(
        "geoid-sigma",
        "commission error of the geoid height (m, at h = 0)",
        (Variable("geoid_sigma", "m", f"{_SIGMA} of the geoid height"),),
        _commission,
        style=_SIGMA_STYLE,
        definition=_SIGMA_DEFINITION,
        surface=True,
        needs_sigma=True,
        check=_needs_sigma,
    ),
    Quantity(
        "omission-sigma",
        "sigma north, east, down and modulus (mGal) of the field above the model's degree "
        "(--lmax), from a degree-variance model (--omission-model)",
        (
            *(
                Variable(
                    f"omission_sigma_{c}",
                    "mGal",
                    f"{_OMISSION} of the {c} component of the gravity disturbance",
                )
                for c in ("north", "east", "down")
            ),
            Variable(
                "omission_sigma_modulus",
                "mGal",
                f"{_OMISSION} of the gravity disturbance vector (root of the three variances "
                "summed)",
            ),
        ),
        _omission,
        style=_SIGMA_STYLE,
        definition=_OMISSION_DEFINITION,
        omission_model=True,
        check=_omission_check,
        extra_attrs=_omission_attrs,
    ),
    # ICGEM's functionals (Barthelmes 2013; fieldmap.field.geodesy, fieldmap.field.water)
    Quantity(
        "height-anomaly",
        "height anomaly zeta on the ellipsoid (m, at h = 0)",
        (
            Variable(
                "height_anomaly",
                "m",
                "height anomaly on the ellipsoid (Bruns: T(h=0)/gamma0), ICGEM height_anomaly_ell",
            ),
        ),
        _functional,
        definition=_t_definition(
            "; height anomaly on the ellipsoid zeta = T(h=0)/gamma0 (Barthelmes 2013 sections "
            "2.2, 4.3: Bruns' formula; the geoid without a GeographicLib model's N - zeta terms)"
        ),
        surface=True,
        degree0=True,
    ),
    Quantity(
        "anomaly-classical",
        "classical gravity anomaly |grad W(h)| - |grad U(h - zeta)| (mGal)",
        (
            Variable(
                "anomaly_classical",
                "mGal",
                "classical gravity anomaly, |grad W(h)| - |grad U(h - zeta)|, ICGEM "
                "gravity_anomaly_cl",
            ),
        ),
        _functional,
        definition=_t_definition(
            "; classical gravity anomaly |grad W(P)| - |grad U(Q)|, Q on the ellipsoidal normal "
            "of P at height h - zeta with U(Q) = W(P) (Barthelmes 2013 sections 2.4.1, 4.5), "
            "zeta solved by Newton's method on the closed-form normal potential"
        ),
        degree0=True,
    ),
    Quantity(
        "disturbance-sa",
        "gravity disturbance in spherical approximation -dT/dr (mGal)",
        (
            Variable(
                "disturbance_sa",
                "mGal",
                "gravity disturbance in spherical approximation, -dT/dr, ICGEM "
                "gravity_disturbance_sa",
            ),
        ),
        _functional,
        definition=_t_definition(
            "; gravity disturbance in spherical approximation -dT/dr, geocentric radial "
            "derivative (Barthelmes 2013 sections 3.4, 4.4)"
        ),
        degree0=True,
    ),
    Quantity(
        "trr",
        "second radial derivative of T, d2T/dr2 (Eötvös)",
        (
            Variable(
                "trr",
                "1e-9 s-2",
                "second radial derivative of the disturbing potential, d2T/dr2, Eotvos, ICGEM "
                "second_r_derivative",
            ),
        ),
        _functional,
        definition=_t_definition(
            "; second radial derivative d2T/dr2 = r^-2 sum_n (n+1)(n+2) T_n (geocentric r; "
            "Barthelmes 2013 section 4.1), 1 E = 1e-9 s-2"
        ),
        degree0=True,
    ),
    Quantity(
        "ewh",
        "equivalent water height (m, at h = 0) of --model minus --minus",
        (
            Variable(
                "ewh",
                "m",
                "equivalent water height of the difference of two fields (load Love numbers), "
                "ICGEM water_column",
                "lwe_thickness",
            ),
        ),
        _ewh,
        definition=_ewh_definition,
        source="{model} degree {lmax}",
        surface=True,
        check=_needs_difference,
    ),
    Quantity(
        "radial",
        "radial (geocentric) component of the gravity disturbance g_model - gamma_exact (mGal)",
        (
            Variable(
                "radial",
                "mGal",
                "radial component of the gravity disturbance (g_model - gamma_exact), geocentric",
            ),
        ),
        _radial,
        definition=_fixed(
            "delta g . r_hat: the gravity disturbance of the disturbance maps (model minus exact "
            "normal gravitation, geodetic east-north-up) projected on the geocentric radial "
            "direction, cos(phi - psi) delta g_up - sin(phi - psi) delta g_north with psi the "
            "geocentric latitude of the node"
        ),
    ),
)

_BY_NAME = {q.name: q for q in QUANTITIES}
#: The quantities of :func:`fieldmap.quantity_map` and ``fieldmap map --quantity``.
MAP_QUANTITIES = tuple(q.name for q in QUANTITIES if q.in_quantity_map)


def quantity(name: str) -> Quantity:
    """Return the entry of a map quantity; an unknown name is one line listing the known ones."""
    try:
        return _BY_NAME[name]
    except (KeyError, TypeError):
        raise InputError(
            f"quantity must be one of {', '.join(_BY_NAME)}, got {name!r}", param="quantity"
        ) from None


def known(name: object) -> bool:
    """Whether ``name`` is a map quantity of the registry."""
    return isinstance(name, str) and name in _BY_NAME


def cli_help() -> str:
    """Return the help of ``--quantity``: each of :data:`MAP_QUANTITIES` with its description."""
    return "; ".join(f"{_BY_NAME[n].name}: {_BY_NAME[n].help}" for n in MAP_QUANTITIES)
