"""The shapes of a map product: how its blocks are reduced and how the product is assembled.

Every quantity of the registry (:mod:`fieldmap.products.quantities`) names one of four layouts;
the block engine (:mod:`fieldmap.products.engine`) reads the layout of the quantity a request
names and never the quantity's name:

- ``vector`` (:class:`VectorLayout`, the disturbance): east, north, up and modulus in the units
  asked, plus ``modulus_mg``; each block converted and reduced in one pass (the modulus's
  statistics, percentiles and area fractions above thresholds), one map or a sweep;
- ``orders`` (:class:`OrdersLayout`, the J2n truncation error): the same vector, one layer per
  order at one height; statistics from the whole maps;
- ``components`` (:class:`ComponentsLayout`): model and normal gravity components, one map;
- ``fields`` (:class:`FieldsLayout`, every other quantity): scalar variables with their
  area-weighted min, max, mean and RMS, at one or several heights.

A layout holds no numbers of its own: the syntheses are the quantities', the attributes those of
:mod:`fieldmap.products.variables`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from fieldmap.products import variables as v
from fieldmap.products.quantities import Quantity, quantity
from fieldmap.products.statistics import joined_partials, rows_partial, scalar_partial

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec


class Layout:
    """What the engine asks of a product's shape (the ``fields`` layout's answers by default)."""

    #: A product that can be streamed block by block to a file (else computed in memory).
    streamable = True

    def stacked(self, output: Any) -> bool:
        """Tell whether the blocks' arrays hold a layer dimension (heights or orders)."""
        return True

    def grid(self, request: Any) -> GridSpec:
        """Return the grid the blocks cover: a layer per height (or per order: ``orders``)."""
        return request.grid

    def order(self, output: Any, layer: int) -> int:
        """Return the J2n order of a layer (truncation maps; 0 otherwise)."""
        return 0

    def thresholds(self, output: Any) -> tuple[float, ...]:
        """Return the thresholds of the area fractions of the blocks' statistics (mg)."""
        return ()

    def template(self, request: Any) -> v.Template:
        """Return the product without data (:class:`fieldmap.products.variables.Template`)."""
        out, mod = request.output, request.model
        q = quantity(out.quantity)
        extra = q.extra_attrs(request) if q.extra_attrs is not None else None
        return v.quantity_template(
            out.quantity, mod, request.grid, request.ellipsoid, out.degree0, extra
        )

    def block(self, job: Any, terms: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        """Return a block's variables {name: (rows, nlon)} and its partial statistics."""
        data = {k: a[0] for k, a in terms.items()}
        return data, {"vars": {k: scalar_partial(a, job.weights[0]) for k, a in data.items()}}

    def assemble(
        self, request: Any, values: dict[str, np.ndarray], stats: list[dict[str, Any]]
    ) -> xr.Dataset:
        """Return the product from the arrays of its variables and the statistics per layer."""
        return v.assemble_quantity(self.template(request), values, per_variable(stats))

    def lazy_attrs(self, request: Any) -> dict[str, Any]:
        """Return the global attributes of a lazy product besides the template's."""
        return {}

    def streamed_statistics(
        self, request: Any, tmpl: v.Template, stats: list[dict[str, Any]]
    ) -> tuple[dict[str, Any], dict[str, Any] | None, dict[str, Any] | None]:
        """Return a streamed product's statistics: (global attrs, variables, variables' attrs)."""
        per_var, extra = v.quantity_statistics_fields(tmpl, per_variable(stats))
        return {}, extra or None, per_var

    def statistics(self, stats: list[dict[str, Any]]) -> Any:
        """Return the statistics that :func:`fieldmap.products.engine.write_product` returns."""
        return per_variable(stats)


def per_variable(stats: list[dict]) -> dict:
    """[{var: s} per height] -> {var: [s per height]}."""
    return {name: [s[name] for s in stats] for name in stats[0]}


def disturbance_partial(
    vec: np.ndarray,
    units: str,
    row_weights: np.ndarray,
    thresholds: Sequence[float],
    hist_weights: np.ndarray,
) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Convert a block's m/s² vector in place and take its statistics, in one pass over the rows.

    The variables of :func:`fieldmap.products.variables.vector_vars` with ``overwrite=True``
    and the statistics of :func:`~fieldmap.products.statistics.block_partial` of their
    ``modulus_mg``, the same bits: each part of the rows (on the CPU threads) is converted
    (:func:`fieldmap.products.variables.convert_rows`) and reduced while it is in the cache.

    Returns
    -------
    (dict, dict)
        {name: (rows, nlon) array} of east, north, up, modulus, modulus_mg, and the partial.
    """
    from fieldmap.grids.longitude import map_rows
    from fieldmap.products.variables import convert_rows
    from fieldmap.units import get_unit

    scale = get_unit(units).si
    comps = np.moveaxis(vec, -1, 0)
    mods = np.empty((2, *comps.shape[1:]))
    rw, hw = np.asarray(row_weights), np.asarray(hist_weights)

    def part(
        a: int, b: int
    ) -> tuple[float, float, int, np.ndarray, np.ndarray, list[np.ndarray], np.ndarray] | None:
        convert_rows(comps, comps, mods, scale, a, b)
        return rows_partial(mods[1, a:b], rw[a:b], thresholds, hw[a:b])

    parts = map_rows(part, comps.shape[1], 32)
    names = ("east", "north", "up", "modulus", "modulus_mg")
    return dict(zip(names, (*comps, *mods))), joined_partials(parts, len(thresholds))


class FieldsLayout(Layout):
    """Scalar variables at one or several heights, with per-variable statistics."""


class VectorLayout(Layout):
    """The disturbance: a vector in the units asked and its modulus's statistics."""

    def stacked(self, output: Any) -> bool:
        """See :meth:`Layout.stacked`."""
        return bool(output.stacked)

    def thresholds(self, output: Any) -> tuple[float, ...]:
        """See :meth:`Layout.thresholds`."""
        return tuple(output.thresholds_mg)

    def template(self, request: Any) -> v.Template:
        """See :meth:`Layout.template`."""
        out = request.output
        return v.disturbance_template(
            request.model,
            request.grid,
            request.ellipsoid,
            out.units,
            out.thresholds_mg,
            out.stacked,
        )

    def block(self, job: Any, terms: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        """See :meth:`Layout.block`."""
        row_weights, hist_weights = job.weights
        # converted in place and reduced in one pass (vector_vars and block_partial, same bits)
        return disturbance_partial(
            terms["vector"], job.output.units, row_weights, job.thresholds, hist_weights
        )

    def assemble(
        self, request: Any, values: dict[str, np.ndarray], stats: list[dict[str, Any]]
    ) -> xr.Dataset:
        """See :meth:`Layout.assemble`."""
        out, grid = request.output, request.grid
        tmpl = self.template(request)
        if out.percentile_method == "exact":
            from fieldmap.products.statistics import (
                DEFAULT_PERCENTILES,
                area_weights,
                weighted_percentiles,
            )

            w = area_weights(grid.lat)[:, None]
            mod_mg = values["modulus_mg"].reshape(grid.shape)
            for k, st in enumerate(stats):
                qs = weighted_percentiles(mod_mg[k], w, DEFAULT_PERCENTILES)
                st.update({f"p{q:g}_mg": float(x) for q, x in zip(DEFAULT_PERCENTILES, qs)})
        attrs = dict(tmpl.attrs)
        data = {
            name: xr.Variable(tmpl.dims, values[name], va) for name, va in tmpl.variables.items()
        }
        if out.stacked:
            data.update(v.sweep_statistics(stats, out.thresholds_mg))
            attrs["percentile_method"] = v.percentile_method_text(out.percentile_method)
        else:
            attrs.update(v.map_attrs(stats[0], out.thresholds_mg, out.percentile_method))
        # one Dataset, built at once (an update would align the variables again)
        return v.index_height_km(v.dataset(data, tmpl.coords, attrs))

    def lazy_attrs(self, request: Any) -> dict[str, Any]:
        """See :meth:`Layout.lazy_attrs`."""
        return {"thresholds_mg": np.array(request.output.thresholds_mg)}

    def streamed_statistics(
        self, request: Any, tmpl: v.Template, stats: list[dict[str, Any]]
    ) -> tuple[dict[str, Any], dict[str, Any] | None, dict[str, Any] | None]:
        """See :meth:`Layout.streamed_statistics`."""
        out = request.output
        if out.stacked:
            attrs = {"percentile_method": v.percentile_method_text()}
            return attrs, v.sweep_statistics(stats, out.thresholds_mg) or None, None
        return v.map_attrs(stats[0], out.thresholds_mg), None, None

    def statistics(self, stats: list[dict[str, Any]]) -> Any:
        """See :meth:`Layout.statistics`."""
        return stats


class OrdersLayout(Layout):
    """The J2n truncation error: the vector of :class:`VectorLayout`, one layer per order."""

    streamable = False

    def grid(self, request: Any) -> GridSpec:
        """See :meth:`Layout.grid`."""
        n = len(request.output.orders)
        return dataclasses.replace(request.grid, heights=np.repeat(request.grid.heights[:1], n))

    def order(self, output: Any, layer: int) -> int:
        """See :meth:`Layout.order`."""
        return int(output.orders[layer])

    def template(self, request: Any) -> v.Template:
        """See :meth:`Layout.template`."""
        out = request.output
        return v.truncation_template(request.grid, request.ellipsoid, out.orders, out.units)

    def block(self, job: Any, terms: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        """See :meth:`Layout.block`."""
        from fieldmap.units import get_unit

        # converted as vector_vars converts (the same bits); its statistics are those of the
        # whole maps (assemble), so the block carries none
        comps = np.moveaxis(terms["vector"], -1, 0)
        mods = np.empty((2, *comps.shape[1:]))
        v.convert_rows(comps, comps, mods, get_unit(job.output.units).si)
        return dict(zip(v.DISTURBANCE_VARIABLES, (*comps, *mods))), {"vars": {}}

    def assemble(
        self, request: Any, values: dict[str, np.ndarray], stats: list[dict[str, Any]]
    ) -> xr.Dataset:
        """See :meth:`Layout.assemble`."""
        from fieldmap.products.statistics import map_statistics

        ds = _dataset_of(self.template(request), values)
        # the same area-weighted statistics as the disturbance maps (a plain node mean would
        # over-weight the high latitudes, where the J2n errors are largest), from the whole maps
        lat = request.grid.lat
        st = [map_statistics(m, lat, thresholds_mg=()) for m in ds["modulus_mg"].values]
        for key in ("max_mg", "mean_mg", "rms_mg"):
            long = f"{v.statistic_name(key)} truncation error"
            ds[key] = ("order", np.array([s[key] for s in st]), v.mg_attrs(long))
        return ds


class ComponentsLayout(Layout):
    """Model and normal gravity, east, north, up, at one height; no statistics."""

    streamable = False

    def stacked(self, output: Any) -> bool:
        """See :meth:`Layout.stacked`."""
        return bool(output.stacked)

    def template(self, request: Any) -> v.Template:
        """See :meth:`Layout.template`."""
        return v.components_template(request.model, request.grid, request.ellipsoid)

    def block(self, job: Any, terms: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        """See :meth:`Layout.block`."""
        return terms, {"vars": {}}

    def assemble(
        self, request: Any, values: dict[str, np.ndarray], stats: list[dict[str, Any]]
    ) -> xr.Dataset:
        """See :meth:`Layout.assemble`."""
        return _dataset_of(self.template(request), values)


def _dataset_of(tmpl: v.Template, values: dict) -> xr.Dataset:
    return xr.Dataset(
        {name: (tmpl.dims, values[name], a) for name, a in tmpl.variables.items()},
        coords=tmpl.coords,
        attrs=dict(tmpl.attrs),
    )


#: The layouts by the name a quantity's entry gives.
LAYOUTS: dict[str, Layout] = {
    "fields": FieldsLayout(),
    "vector": VectorLayout(),
    "orders": OrdersLayout(),
    "components": ComponentsLayout(),
}


def layout_of(q: str | Quantity) -> Layout:
    """Return the layout of a quantity (by name or entry)."""
    return LAYOUTS[(quantity(q) if isinstance(q, str) else q).layout]
