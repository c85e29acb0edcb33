"""A finished product store (NetCDF-4 file or zarr folder): atomic placement, decimated view.

:func:`atomic_store` gives the writers of :mod:`fieldmap.products.blockio` a hidden temporary
name next to the final one, renamed only when the whole product, statistics included, is
complete: a failed or interrupted run leaves no partial product under the final name.
:func:`decimated` reads a stored product back at a resolution fit for figures.
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import xarray as xr


@contextlib.contextmanager
def atomic_store(final):
    """Yield a hidden temporary path next to ``final``; on success rename it to ``final``.

    Works for a file or a folder (zarr). An existing product of the same name is replaced
    only once the new one is complete; on any error the temporary path is removed.
    """
    final = Path(final)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
    tmp.rmdir()  # the writer creates it (a file or a folder)
    try:
        yield tmp
        if final.is_dir() and not final.is_symlink():
            old = final.with_name(f".{final.name}.old-{os.getpid()}")
            os.replace(final, old)
            os.replace(tmp, final)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, final)
    except BaseException:
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                tmp.unlink()
        raise


def decimated(path, fmt: str, max_nodes: int = 2_000_000) -> xr.Dataset:
    """Return a view of a stored product with at most about ``max_nodes`` nodes per map, in memory.

    Every ``s``-th row and column (``s = ceil(sqrt(nodes / max_nodes))``), read lazily from
    the store, so that figures of huge grids never hold the full-resolution arrays. ``s`` > 1
    is kept in ``attrs["figure_decimation"]`` (:func:`fieldmap.products.mapaxes.node_step`);
    the other attributes are the product's.
    """
    opener = (
        (lambda p: xr.open_zarr(p, consolidated=True))
        if fmt == "zarr"
        else (lambda p: xr.open_dataset(p, engine="netcdf4"))
    )
    with opener(path) as ds:
        n = ds.sizes["latitude"] * ds.sizes["longitude"]
        s = max(1, math.ceil(math.sqrt(n / max_nodes)))
        view = ds.isel(latitude=slice(None, None, s), longitude=slice(None, None, s)).load()
    view.attrs = {k: v.item() if isinstance(v, np.generic) else v for k, v in view.attrs.items()}
    if s > 1:  # the product's attributes stay as stored (grid_step_deg: the product's step)
        view.attrs["figure_decimation"] = s
    return view
