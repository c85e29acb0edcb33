"""Products built from grids, one idea per module.

- :mod:`~fieldmap.products.request`: :class:`MapRequest`, what to compute, where and how,
  validated once;
- :mod:`~fieldmap.products.maps`: the public façades (disturbance map, sweep, truncation,
  components, quantity maps), each building a request;
- :mod:`~fieldmap.products.quantities`: the registry of map quantities, one entry each (its
  synthesis, variables with units and CF names, layout, attributes and figure style);
- :mod:`~fieldmap.products.layouts`: the four shapes of a product (a vector with its modulus
  statistics, a stack of J2n orders, components, scalar fields);
- :mod:`~fieldmap.products.engine`: the one block engine (plan, one block, local, Dask and
  lazy executors, the product in memory);
- :mod:`~fieldmap.products.unit_hints`: warnings for a map that looks like a unit typed wrong;
- :mod:`~fieldmap.products.variables`: CF-1.8 attributes of the registry's variables, templates
  and the JSON summary;
- :mod:`~fieldmap.products.statistics`: area-weighted statistics, whole and folded from blocks;
- :mod:`~fieldmap.products.sinks`: memory, NetCDF-4 and zarr targets, atomic stores, streamed
  products;
- :mod:`~fieldmap.products.io`: atomic writers of NetCDF, JSON and PNG files;
- :mod:`~fieldmap.products.degree`: SH omission maps and the degree a tolerance needs;
- :mod:`~fieldmap.products.tables`: the gravity compensation table (model, build, files);
- :mod:`~fieldmap.products.plots` and :mod:`~fieldmap.products.coastline`: figures.
"""
