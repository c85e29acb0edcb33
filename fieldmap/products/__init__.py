"""Products built from grids: maps, statistics, CF metadata, writers, plots, coastlines."""
