"""The gravity compensation table: its model and interpolator, its builder, its files.

- :mod:`fieldmap.products.tables.model`: the :class:`CompensationTable` data class, the
  Catmull-Rom interpolator and the readers (pure NumPy);
- :mod:`fieldmap.products.tables.build`: the builder whose verified error is within a bound;
- :mod:`fieldmap.products.tables.files`: NetCDF, binary, C header and JSON report.
"""
