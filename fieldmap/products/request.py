"""A map product request: what to compute, where, and how to run it — validated once.

Every map product (disturbance map or sweep, truncation map, component maps, quantity maps)
is described by one frozen :class:`MapRequest`, built by the CLI and by the Python façades
(:mod:`fieldmap.products.maps`) alike with :meth:`MapRequest.build`. Everything is checked at
construction, in one place, each bad value refused with one line naming it; the engine
(:mod:`fieldmap.products.engine`) and the sinks (:mod:`fieldmap.products.sinks`) trust it.

A request holds the model (loaded once, with its degree and epoch applied), the grid (its
heights in metres), the ellipsoid, what the product holds (:class:`Output`) and how its
blocks run (:class:`Execution`: device, executor, block rows, a lazy result).

Examples
--------
>>> from fieldmap.products.request import MapRequest
>>> req = MapRequest.build(lmax=12, height_km=[10, 20], step_deg=30.0, stacked=True)
>>> req.grid.heights.tolist(), req.model.lmax, req.output.stacked
([10000.0, 20000.0], 12, True)
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt

from fieldmap import limits
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import Ellipsoid
from fieldmap.grids.spec import GridSpec

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

DEFAULT_THRESHOLDS_MG = (0.02, 0.05, 0.06, 0.10)


def _set(obj: object, **values: Any) -> None:
    for k, v in values.items():
        object.__setattr__(obj, k, v)


@dataclasses.dataclass(frozen=True)
class Output:
    """What a product holds.

    Attributes
    ----------
    quantity : str
        ``"disturbance"`` (default) or another quantity of the registry
        (:mod:`fieldmap.products.quantities`), ``"truncation"`` and ``"components"`` included.
    units : str
        Units of the disturbance vector (any spelling of :mod:`fieldmap.units`; kept in its
        canonical name). ``modulus_mg`` is always added.
    thresholds_mg : tuple of float
        Thresholds of the area fractions (positive, distinct; sorted). Units: mg.
    orders : tuple of int
        J2n orders of a truncation map (distinct, among 2, 4, 6).
    degree0 : bool
        Keep the degree-0 term of T (the quantities of T only: their entry's ``degree0``).
    stacked : bool
        A stack of heights (a sweep: ``height`` is a dimension) rather than one map.
    percentile_method : {"histogram", "exact"}
        Percentiles of the modulus from merged block histograms, or exact ones.
    omission_model : str, optional
        Degree-variance model of ``"omission-sigma"``
        (:data:`fieldmap.field.omission.DEGREE_VARIANCE_MODELS`; default
        ``"tscherning-rapp"``); refused for a quantity whose entry does not take one.
    """

    quantity: str = "disturbance"
    units: str = "mGal"
    thresholds_mg: tuple[float, ...] = DEFAULT_THRESHOLDS_MG
    orders: tuple[int, ...] = (2, 4, 6)
    degree0: bool = False
    stacked: bool = False
    percentile_method: str = "histogram"
    omission_model: str | None = None

    def __post_init__(self) -> None:
        from fieldmap.products.quantities import quantity
        from fieldmap.products.statistics import check_percentile_method, parse_thresholds
        from fieldmap.units import get_unit

        q = quantity(self.quantity)
        if self.degree0 and not q.degree0:
            what = "δg" if self.quantity == "disturbance" else self.quantity
            raise InputError(
                f"degree0 applies to the potential T and its quantities, not to {what}"
            )
        _set(
            self,
            units=get_unit(self.units).name,
            percentile_method=check_percentile_method(self.percentile_method),
            thresholds_mg=parse_thresholds(self.thresholds_mg),
            degree0=bool(self.degree0),
            stacked=bool(self.stacked),
        )
        if q.layout == "orders":
            _set(self, orders=limits.check_orders(self.orders))
        _set(self, omission_model=_omission_model(self.quantity, self.omission_model))


def _omission_model(name: str, kind: str | None) -> str | None:
    """Return the degree-variance model of an omission product (None for others)."""
    from fieldmap.products.quantities import QUANTITIES, quantity

    if not quantity(name).omission_model:
        if kind is not None:
            takes = ", ".join(q.name for q in QUANTITIES if q.omission_model)
            raise InputError(
                f"omission_model applies to the {takes} quantity, not to {name}",
                param="omission_model",
            )
        return None
    from fieldmap.field.omission import DEGREE_VARIANCE_MODELS, degree_variance_model

    return degree_variance_model(DEGREE_VARIANCE_MODELS[0] if kind is None else kind)


@dataclasses.dataclass(frozen=True)
class Execution:
    """How the blocks of a product run; none of it changes a bit of the result.

    Attributes
    ----------
    device : str, optional
        Warp device (checked here; each worker resolves it again for itself).
    executor : None, str or dask.distributed.Client
        None: the blocks run here, one after the other (each on every core); ``"threads"``:
        the same; ``"local:N"``: a LocalCluster of N processes for the run; a scheduler
        address; or a ``dask.distributed.Client``.
    chunks : int, dict or "auto", optional
        Return a lazy dask-backed Dataset (blocks of at most this many latitude rows); it
        carries no statistics.
    rows_per_block : int, optional
        Most latitude rows per block (default: from the memory budget and the grid).
    progress : bool, optional
        Progress bar over the blocks on stderr (None: for large grids on a terminal).
    window : int, optional
        Blocks in flight on a cluster (default: four per worker).
    """

    device: str | None = None
    executor: Any = None
    chunks: Any = None
    rows_per_block: int | None = None
    progress: bool | None = None
    window: int | None = None

    def __post_init__(self) -> None:
        if isinstance(self.executor, str):
            from fieldmap.cluster import parse_scheduler

            parse_scheduler(self.executor)  # one line for a malformed scheduler
        if self.chunks is not None:
            if isinstance(self.executor, str):
                raise InputError("chunks= returns a lazy Dataset: pass client=, not scheduler=")
            if self.rows_per_block is not None:
                raise InputError(
                    "chunks= sets the rows of a lazy Dataset's blocks: no rows_per_block"
                )
        if self.device is not None:
            from fieldmap.grids.synthesis import resolve_device

            resolve_device(self.device)

    @property
    def client(self) -> Any:
        """The Dask client given, or None (a scheduler string is opened by the engine)."""
        return None if self.executor is None or isinstance(self.executor, str) else self.executor

    @property
    def scheduler(self) -> Any:
        """The parsed scheduler string (:func:`fieldmap.cluster.parse_scheduler`)."""
        if not isinstance(self.executor, str):
            return None
        from fieldmap.cluster import parse_scheduler

        return parse_scheduler(self.executor)


@dataclasses.dataclass(frozen=True)
class MapRequest:
    """One map product to compute: model, grid, ellipsoid, output and execution, all checked.

    Build it with :meth:`build` from the options a user gives (the façades and the CLI do);
    constructing it from parts checks that they belong together (a sigma quantity needs a
    model with coefficient standard deviations, a single map one height, ...).

    Attributes
    ----------
    model : SHModel or None
        The model, loaded once, degree and epoch applied (None for a truncation map).
    grid : fieldmap.grids.spec.GridSpec
        Latitudes, longitudes and heights (m). The whole product need not fit in memory (it
        can be streamed); :func:`fieldmap.products.engine.compute` checks that it does.
    ellipsoid : fieldmap.field.ellipsoid.Ellipsoid
        The normal field.
    output : Output
    execution : Execution
    """

    model: Any
    grid: GridSpec
    ellipsoid: Ellipsoid
    output: Output = Output()
    execution: Execution = Execution()

    def __post_init__(self) -> None:
        from fieldmap.products.layouts import layout_of
        from fieldmap.products.quantities import quantity

        q = self.output.quantity
        entry = quantity(q)
        if self.model is None and entry.layout != "orders":
            raise InputError(f"a {q} product needs a model")
        if entry.surface and not np.array_equal(self.grid.heights, [0.0]):
            raise InputError(f"{q} is a property of the surface: its grid has the one height 0")
        if not self.output.stacked and self.grid.heights.size != 1:
            raise InputError("one map takes one height; a sweep (stacked) takes several")
        if entry.check is not None:  # one line, before anything is computed or written
            entry.check(self)
        if self.execution.chunks is not None and not layout_of(entry).streamable:
            raise InputError(f"a {q} map is computed at once: no chunks=")
        if self.execution.chunks is not None and self.output.percentile_method != "histogram":
            raise InputError("a lazy Dataset (chunks=) carries no statistics: no percentile_method")

    @classmethod
    def build(
        cls,
        *,
        model: SHModel | str | os.PathLike[str] | None = None,
        lmax: int | None = None,
        epoch: float | str | None = None,
        height_km: float | str | Sequence[float | str] | None = None,
        heights_m: npt.ArrayLike | None = None,
        step_deg: float = 1.0,
        lat_max: float = 80.0,
        region: Sequence[float] | None = None,
        ellipsoid: Ellipsoid | str = "WGS84",
        load: Callable[[], SHModel] | None = None,
        quantity: str = "disturbance",
        units: str = "mGal",
        thresholds_mg: Sequence[float | str] = DEFAULT_THRESHOLDS_MG,
        orders: Sequence[int] = (2, 4, 6),
        degree0: bool = False,
        stacked: bool = False,
        percentile_method: str = "histogram",
        omission_model: str | None = None,
        device: str | None = None,
        client: Any = None,
        scheduler: str | None = None,
        executor: Any = None,
        chunks: int | str | dict | None = None,
        rows_per_block: int | None = None,
        progress: bool | None = None,
        window: int | None = None,
    ) -> MapRequest:
        """Build a request from a user's options, validating each once.

        Parameters
        ----------
        model : str, path or SHModel, optional
            Bundled name, ICGEM file or model (default ``"eigen-6s"``), loaded with ``lmax``
            and ``epoch``; or ``load``, a callable returning the model (the CLI's, with its
            model-file options).
        lmax : int, optional
            Truncation degree.
        epoch : float or str, optional
            Epoch of time-variable terms. Units: decimal year or ``'YYYY-MM-DD'``.
        height_km : float or sequence of float, optional
            One height (a map) or several distinct ones (``stacked``), default 20. Units: km.
        heights_m : array_like, optional
            The heights in metres instead (not with ``height_km``). Units: m.
        step_deg, lat_max : float
            Grid spacing and latitude limit of a global grid. Units: degrees.
        region : (west, east, south, north), optional
            A regional grid instead. Units: degrees.
        ellipsoid : Ellipsoid or str
            The normal field (a name or an :class:`~fieldmap.field.ellipsoid.Ellipsoid`).
        load : callable, optional
            Returns the model (instead of ``model``, ``lmax``, ``epoch``).
        quantity, units, thresholds_mg, orders, degree0, stacked, percentile_method, \
omission_model
            What the product holds: the fields of :class:`Output`.
        device, executor, chunks, rows_per_block, progress, window
            How its blocks run: the fields of :class:`Execution`.
        client, scheduler
            Spellings of ``executor``: a ``dask.distributed.Client``, or a scheduler string
            (``"local:N"``, an address, ``"threads"``).

        Raises
        ------
        fieldmap.errors.InputError
            One line naming the bad value.
        """
        if sum(x is not None for x in (client, scheduler, executor)) > 1:
            raise InputError("pass client= or scheduler=, not both", param="client")
        output = Output(
            quantity=quantity,
            units=units,
            thresholds_mg=cast(Any, thresholds_mg),  # parsed and sorted by Output
            orders=cast(Any, orders),
            degree0=degree0,
            stacked=stacked,
            percentile_method=percentile_method,
            omission_model=omission_model,
        )
        execution = Execution(
            device=device,
            executor=next((x for x in (client, scheduler, executor) if x is not None), None),
            chunks=chunks,
            rows_per_block=rows_per_block,
            progress=progress,
            window=window,
        )
        if height_km is not None and heights_m is not None:
            raise InputError("give height_km= or heights_m=, not both", param="height_km")
        grid = _grid(output, height_km, heights_m, step_deg, lat_max, region)
        ell = ellipsoid_of(ellipsoid)
        from fieldmap.products.quantities import quantity as quantity_of

        if quantity_of(output.quantity).layout == "orders":  # the J2n series: no model
            mod = None
        elif load is not None:
            mod = load()
        else:
            from fieldmap.models.registry import load_model

            mod = load_model("eigen-6s" if model is None else model, lmax=lmax, epoch=epoch)
        return cls(mod, grid, ell, output, execution)

    def compute(self) -> Any:
        """Compute the product (:func:`fieldmap.products.engine.compute`): an xarray.Dataset."""
        from fieldmap.products.engine import compute

        return compute(self)

    def replace(self, **changes: Any) -> MapRequest:
        """Return a copy with some parts changed (``output``, ``execution``...), checked."""
        return dataclasses.replace(self, **changes)

    def executing(self, **changes: Any) -> MapRequest:
        """Return a copy with fields of :class:`Execution` changed (``executor=client``)."""
        return self.replace(execution=dataclasses.replace(self.execution, **changes))


def ellipsoid_of(name_or_obj: Any) -> Ellipsoid:
    """Return the ellipsoid of a name or object; an unknown one lists the known names."""
    from fieldmap.field.ellipsoid import get_ellipsoid

    try:
        return get_ellipsoid(name_or_obj)
    except InputError:
        raise
    except (KeyError, ValueError) as exc:
        raise InputError(f"unknown ellipsoid {name_or_obj!r}") from exc


def heights_m(height_km: Any, one: str | None = None) -> np.ndarray:
    """Distinct heights in m from km; ``one``: the message raised unless there is one height.

    The rule is :func:`fieldmap.limits.heights_from_km`.
    """
    return limits.heights_from_km(height_km, distinct=True, one=one)


def _grid(
    output: Output,
    height_km: Any,
    heights_m_: Any,
    step_deg: float,
    lat_max: float,
    region: Sequence[float] | None,
) -> GridSpec:
    from fieldmap.grids.spec import make_grid
    from fieldmap.products.quantities import quantity

    if quantity(output.quantity).surface:
        h = np.zeros(1)  # the geoid is a property of the surface
    elif heights_m_ is not None:
        h = np.asarray(heights_m_, dtype=np.float64).ravel()
    else:
        one = None if output.stacked else f"a {output.quantity} map takes one height"
        if output.quantity == "disturbance" and not output.stacked:
            one = "disturbance_map takes one height; use altitude_sweep for several"
        h = heights_m(20.0 if height_km is None else height_km, one)
    return make_grid(step_deg, lat_max, cast(Any, region), h, whole_in_memory=False)
