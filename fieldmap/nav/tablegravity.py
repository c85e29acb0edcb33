"""Compensation tables as navigation gravity: upload, and evaluation at points (Warp).

A table (:class:`fieldmap.products.table_model.CompensationTable`) navigates as the exact normal
gravitation plus the table's δg (``kernels/navtable.py``); the NumPy interpolator of
:mod:`fieldmap.products.table_model` is its reference (``tests/test_navtable.py``).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from fieldmap import _warp
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid

__all__ = ["kernel_table", "table_gravitation", "table_points"]


def kernel_table(table, device: str):
    """Return the device struct of ``table`` (its δg values as float64)."""
    from fieldmap.kernels.navtable import TableKernel

    _warp.init()
    kt = TableKernel()
    data = np.ascontiguousarray(np.asarray(table.data, dtype=np.float64))
    kt.data = wp.array(data, dtype=wp.vec3d, device=device)
    for name in ("lat0", "dlat", "lon0", "dlon", "h0", "dh"):
        setattr(kt, name, wp.float64(float(getattr(table, name))))
    return kt


def table_points(table, lat, lon, h, *, device: str | None = None) -> np.ndarray:
    """δg north, east, down (mGal) at geodetic points by the kernel; shape (n, 3).

    Every point must be inside the table (checked: the NumPy interpolator's error otherwise).
    """
    from fieldmap.kernels import navtable as knt
    from fieldmap.products.tables.model import check_inside

    lat, lon, h = (
        np.ascontiguousarray(np.ravel(v), dtype=np.float64)
        for v in np.broadcast_arrays(lat, lon, h)
    )
    check_inside(table, lat, lon, h)
    device = _warp.resolve_device(device)
    out = wp.zeros(lat.size, dtype=wp.vec3d, device=device)
    arrs: list = [wp.array(v, dtype=wp.float64, device=device) for v in (lat, lon, h)]
    wp.launch(
        knt.table_points_kernel,
        dim=lat.size,
        inputs=[kernel_table(table, device), *arrs, out],
        device=device,
    )
    return out.numpy()


def table_gravitation(
    table, x, y, z, *, ellipsoid: Ellipsoid | str = WGS84, device: str | None = None
) -> np.ndarray:
    """Navigation gravitation of a table at ECEF points: exact normal + δg; (n, 3) ECEF, m/s²."""
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import navtable as knt

    ell = get_ellipsoid(ellipsoid)
    p = np.ascontiguousarray(
        np.stack(np.broadcast_arrays(x, y, z), axis=-1).reshape(-1, 3), dtype=np.float64
    )
    device = _warp.resolve_device(device)
    out = wp.zeros(len(p), dtype=wp.vec3d, device=device)
    enu = wp.zeros(len(p), dtype=wp.vec3d, device=device)
    wp.launch(
        knt.table_gravitation_kernel,
        dim=len(p),
        inputs=[
            kernel_table(table, device),
            normal_params(ell),
            wp.array(p, dtype=wp.vec3d, device=device),
            out,
            enu,
        ],
        device=device,
    )
    return out.numpy()
