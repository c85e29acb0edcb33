"""Compensation tables in the kernels (issue 18): ``kernels/navtable.py`` vs the NumPy paths.

The kernel interpolation is checked against :func:`fieldmap.products.table_model.interpolate`
(the NumPy interpolator, written separately) at random points — cells next to the domain edges,
the ghost heights, a table across the antimeridian — and the navigation gravitation against the
exact normal gravitation of :mod:`fieldmap.field.normal` plus the interpolated δg rotated with
:func:`fieldmap.field.frames.C_e_to_enu` at the geodetic point of
:func:`fieldmap.field.frames.ecef_to_geodetic` (Bowring's iteration, not the kernel's).
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.normal import normal_gravitation_ecef
from fieldmap.nav.tablegravity import table_gravitation, table_points
from fieldmap.products.table_model import CompensationTable, interpolate


def _table(lon0=170.0, seed=4) -> CompensationTable:
    rng = np.random.default_rng(seed)
    nh, nlat, nlon = 4, 9, 12
    lat = 20.0 + 0.5 * np.arange(nlat)
    lon = lon0 + 0.75 * np.arange(nlon)
    h = 1000.0 + 4000.0 * np.arange(nh)
    H, LA, LO = np.meshgrid(h, lat, lon, indexing="ij")
    smooth = (
        np.stack(
            [
                30 * np.sin(LA / 3) * np.cos(LO / 5),
                20 * np.cos(LA / 2 + LO / 7),
                -15 * np.sin(LO / 4),
            ],
            axis=-1,
        )
        * np.exp(-H / 3e4)[..., None]
    )
    data = smooth + rng.normal(0.0, 2.0, smooth.shape)  # rough, so that every weight matters
    return CompensationTable(
        lat0=20.0, dlat=0.5, lon0=lon0, dlon=0.75, h0=1000.0, dh=4000.0, data=data
    )


def _inside(tab, n, seed=1):
    rng = np.random.default_rng(seed)
    w, e, s, nn, h0, h1 = tab.domain
    lat = rng.uniform(s, nn, n)
    lon = rng.uniform(w, e, n)
    h = rng.uniform(h0, h1, n)
    # the domain's corners and the ghost heights exactly
    lat[:4], lon[:4], h[:4] = [s, nn, s, nn], [w, e, e, w], [h0, h1, h1, h0]
    lon = np.where(lon > 180.0, lon - 360.0, lon)  # across the antimeridian, as a user gives it
    return lat, lon, h


@pytest.mark.parametrize("lon0", [170.0, -10.0])
def test_kernel_interpolation_equals_numpy(device, lon0):
    tab = _table(lon0)
    lat, lon, h = _inside(tab, 400)
    got = table_points(tab, lat, lon, h, device=device)
    want = interpolate(tab, lat, lon, h)
    assert np.abs(want).max() > 10.0
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-11)


def test_kernel_reproduces_the_nodes(device):
    tab = _table()
    H, LA, LO = np.meshgrid(tab.heights, tab.latitudes[1:-1], tab.longitudes[1:-1], indexing="ij")
    got = table_points(tab, LA, LO, H, device=device).reshape(H.shape + (3,))
    np.testing.assert_allclose(got, tab.data[:, 1:-1, 1:-1], rtol=0, atol=1e-11)


def test_navigation_gravitation_is_normal_plus_rotated_table(device):
    tab = _table()
    lat, lon, h = _inside(tab, 200, seed=2)
    x, y, z = frames.geodetic_to_ecef(lat, lon, h, WGS84)
    got = table_gravitation(tab, x, y, z, device=device)
    la, lo, hh = frames.ecef_to_geodetic(x, y, z, WGS84)
    d = interpolate(tab, la, lo, hh) * 1e-5  # north, east, down; m/s²
    enu = np.stack([d[:, 1], d[:, 0], -d[:, 2]], axis=-1)
    c = frames.C_e_to_enu(la, lo)  # rows: east, north, up in ECEF
    want = normal_gravitation_ecef(x, y, z, normal="exact", ellipsoid=WGS84) + np.einsum(
        "nij,ni->nj", c, enu
    )
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)  # m/s² (1e-8 mGal)


def test_points_outside_are_refused():
    tab = _table()
    with pytest.raises(InputError, match="outside the table"):
        table_points(tab, [25.0, 10.0], [175.0, 175.0], [2000.0, 2000.0])
