"""Grids at any degree (issue 17): the extended-range Legendre pass (kernels/grid_xrange.py).

Checked against three things it shares no code with: the 1e-280-scaled grid kernel (at degrees
where both work, poles and heights inside the sphere included), the extended-range *point*
path (the extended range of kernels/sh.py, itself checked against 30-digit mpmath in
test_any_degree.py) and the NumPy X-number reference (fieldmap/reference/sh.py), near the poles
and at the equator, above degree 2700. The lanes are checked for independence (same bits for
any grouping) and the SIMD snippet against the plain Warp version.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp
from fieldmap.kernels import grid_xrange as kgx

from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.gravity import gravitation
from fieldmap.field.sh import kernel_model, recursion_tables
from fieldmap.grids import synthesis as G
from fieldmap.grids.tables import grid_tables, grid_tables_x, pack_columns_direct, sectoral
from fieldmap.models.registry import kaula_model
from fieldmap.models.shmodel import SHModel
from fieldmap.reference import sh as ref

GM, R = 3.986004415e14, 6378136.3


def sparse_kaula(lmax: int, orders, seed: int, central: bool = True) -> SHModel:
    """Kaula-rule model (σ_n = 1e-5/n², C00 = 1, C20) with only ``orders`` non-zero.

    ``central=False``: no C00 and C20 (the field of the chosen orders alone).
    """
    rng = np.random.default_rng(seed)
    C = np.zeros((lmax + 1, lmax + 1))
    S = np.zeros_like(C)
    n = np.arange(lmax + 1, dtype=np.float64)
    sig = np.where(n >= 2, 1e-5 / np.maximum(n, 1.0) ** 2, 0.0)
    for m in orders:
        C[m:, m] = sig[m:] * rng.standard_normal(lmax + 1 - m)
        if m:
            S[m:, m] = sig[m:] * rng.standard_normal(lmax + 1 - m)
    C[0, 0], C[1, :] = 1.0, 0.0
    S[1, :] = 0.0
    C[2, 0] = -4.84165e-4
    if not central:
        C[0, 0] = C[2, 0] = 0.0
    return SHModel(f"kaula-{lmax}-sparse", GM, R, C, S, lmax)


def enu_reference(model, lat, lon, h):
    """NumPy X-number reference gravitation in geodetic ENU on a (lat, lon) mesh."""
    la, lo = np.meshgrid(lat, lon, indexing="ij")
    x, y, z = frames.geodetic_to_ecef(la, lo, h)
    g = ref.gravitation_ecef(model, x.ravel(), y.ravel(), z.ravel()).reshape(*la.shape, 3)
    return np.einsum("...ij,...j->...i", frames.C_e_to_enu(la, lo), g)


def test_direct_tables_equal_square_tables():
    """Tables packed order by order from closed forms = those packed from the square tables."""
    model = kaula_model(150, seed=4)
    km = kernel_model(model, "cpu")
    rec, start, zon = (a.numpy() for a in grid_tables(model, km, "cpu"))
    rec2, start2, zon2 = pack_columns_direct(model, 150)
    assert np.array_equal(rec.reshape(rec2.shape), rec2)
    assert np.array_equal(start, start2) and np.array_equal(zon, zon2)
    assert np.array_equal(sectoral(150), recursion_tables(150)["sect"])


@pytest.mark.parametrize("L", [30, 360])
def test_xrange_grid_equals_scaled_grid(L, device):
    """Where both kernels work (degree <= 2700): the same field to 1e-13 of |g| and of |V|.

    Global 1.5° grid with both poles, at h = 0 (near the poles inside the sphere), 20 and
    300 km; gravitation and potential.
    """
    model = kaula_model(L, seed=L)
    grid = G.make_grid(1.5, 90.0, heights_m=[0.0, 20e3, 300e3])
    a = G.synthesize(model, grid, quantity="gravitation", potential=True, device=device)
    b = G.synthesize(
        model, grid, quantity="gravitation", potential=True, device=device, legendre="xrange"
    )
    g = np.linalg.norm(a[..., :3], axis=-1)
    assert np.max(np.linalg.norm(b[..., :3] - a[..., :3], axis=-1) / g) <= 1e-13
    assert np.max(np.abs(b[..., 3] - a[..., 3]) / np.abs(a[..., 3])) <= 1e-13


def _coefficients_x(model, lat, h, row_a, row_b, simd, osc=None, ncol=None):
    """Run row_fourier8x_kernel on explicit unit groups: coefficients (nrow, 3, ncol).

    ``osc``: the order factors (default 1); ``ncol``: columns (default nm), the array starts
    as NaN.
    """
    L = model.lmax
    tabs = grid_tables_x(model, L, "cpu")
    geo, _ = G._row_setup(np.radians(lat), h, WGS84, model.radius, 0, "cpu")
    osc = wp.array(np.ones(L + 1) if osc is None else osc, dtype=wp.float64, device="cpu")
    coef = wp.full(
        (lat.size, 3, ncol or L + 1), wp.vec2d(np.nan, np.nan), dtype=wp.vec2d, device="cpu"
    )
    ra = wp.array(np.asarray(row_a, dtype=np.int32), dtype=wp.int32, device="cpu")
    rb = wp.array(np.asarray(row_b, dtype=np.int32), dtype=wp.int32, device="cpu")
    ng = ra.shape[0]
    wp.launch(
        kgx.row_fourier8x_kernel,
        dim=ng * (L + 1),
        inputs=[wp.float64(model.gm), L, *tabs, *geo, ra, rb, ng, simd, osc, coef, 0],
        device="cpu",
    )
    return coef.numpy()


@pytest.mark.parametrize("simd", [1, 0])
def test_xrange_lanes_do_not_mix(simd):
    """A row's coefficients have the same bits whichever rows share its thread.

    Degree 1200: at 60° and 52° the seeds of orders above ~480 are X-numbers below range
    (0.5^499 = 1e-150) whose columns come into range before degree 1200 (near n = m/u), at
    89.9° they never do, and an equator row is in range from the start: the rows of one group
    leave the masked loop at different degrees (or never).
    """
    model = kaula_model(1200, seed=11)
    lat = np.array([60.0, -60.0, 0.0, 52.0, -52.0, 89.99, 30.0, -30.0, 90.0, -90.0])
    h = np.array([0.0] * 8 + [20e3, 20e3])
    units = [(0, 1), (2, -1), (3, 4), (5, -1), (6, 7), (8, -1), (9, -1)]
    a = [u[0] for u in units] + [-1]
    b = [u[1] for u in units] + [-1]
    c1 = _coefficients_x(model, lat, h, [a], [b], simd)
    # other partners: the pole row alone, the equator row with the 89.99° row, other lanes
    groups = [[5, -1, -1, -1, -1, -1, -1, 3], [-1, 1, 4, 0, -1, 2, 6, -1]]
    a2 = [[units[k][0] if k >= 0 else -1 for k in grp] for grp in groups]
    b2 = [[units[k][1] if k >= 0 else -1 for k in grp] for grp in groups]
    c2 = _coefficients_x(model, lat, h, a2, b2, simd)
    assert np.array_equal(c1, c2)
    # and against the scaled kernel's engine columns (row_fourier_kernel), 1e-13 of the largest
    km = kernel_model(model, "cpu")
    geo, _ = G._row_setup(np.radians(lat), h, WGS84, model.radius, 0, "cpu")
    ref_c = wp.zeros((lat.size, 3, 1201), dtype=wp.vec2d, device="cpu")
    from fieldmap.kernels import grid as kgrid

    ones = wp.array(np.ones(1201), dtype=wp.float64, device="cpu")
    args = [km, *geo, 1201, ones, ref_c, 0]
    wp.launch(kgrid.row_fourier_kernel, dim=lat.size * 1201, inputs=args)
    rc = ref_c.numpy()
    assert np.max(np.abs(c1 - rc)) <= 1e-13 * np.max(np.abs(rc))


def test_simd_and_warp_lanes_agree():
    model = kaula_model(400, seed=12)
    lat = np.linspace(-89.95, 89.95, 16)
    h = np.full(16, 0.0)
    a = [list(range(8)), list(range(8, 16))]
    b = [[-1] * 8, [-1] * 8]
    c1 = _coefficients_x(model, lat, h, a, b, 1)
    c0 = _coefficients_x(model, lat, h, a, b, 0)
    assert np.max(np.abs(c1 - c0)) <= 1e-13 * np.max(np.abs(c1))


def test_degree3000_grid_vs_points_and_reference(device):
    """Above the scaled recursion's limit: grid = point path = NumPy reference, poles included.

    Orders 0, 1, 2, 1500, 2000, 2999, 3000 of a degree-3000 Kaula model; rows from 88.5° to
    90°, from 44° to 61° (where the seeds of orders 1500 and 2000, down to 1e-450, come into
    range before degree 3000: the X-number rescaling decides these rows) and around the
    equator; at 20 km (1e-13 of |g|) and at h = 0, where the polar rows lie inside the reference
    sphere (q^3000 ~ 3e4: the float64 t of a point moves P̄nm by ~n² 1e-16, so the point path
    and the reference are compared there at 5e-10).
    """
    model = sparse_kaula(3000, [0, 1, 2, 1500, 2000, 2999, 3000], seed=3000)
    grid = G.make_grid(1.0, region=(10.0, 12.0, 44.0, 61.0), heights_m=[20e3])
    out = G.synthesize(model, grid, quantity="gravitation", device=device)[0]
    la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    pts = gravitation(la, lo, 20e3, model=model, device=device)
    g = np.linalg.norm(pts, axis=-1)
    assert np.max(np.linalg.norm(out - pts, axis=-1) / g) <= 1e-13
    # orders 1500 and 2000 alone (their field is ~1e-9 of |g|): 1e-12 of their largest value
    high = sparse_kaula(3000, [1500, 2000], seed=3000, central=False)
    out = G.synthesize(high, grid, quantity="gravitation", device=device)[0]
    pts = gravitation(la, lo, 20e3, model=high, device=device)
    assert np.max(np.abs(out - pts)) <= 1e-12 * np.max(np.abs(pts))
    for h, tol in ((20e3, 1e-13), (0.0, 5e-10)):
        grid = G.make_grid(0.25, region=(10.0, 11.0, 88.5, 90.0), heights_m=[h])
        out = G.synthesize(model, grid, quantity="gravitation", device=device)[0]
        la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
        pts = gravitation(la, lo, h, model=model, device=device)
        g = np.linalg.norm(pts, axis=-1)
        assert np.all(np.isfinite(out))
        assert np.max(np.linalg.norm(out - pts, axis=-1) / g) <= tol
    grid = G.make_grid(0.5, region=(-1.0, 0.0, -1.0, 1.0), heights_m=[20e3])
    out = G.synthesize(model, grid, quantity="gravitation", device=device)[0]
    want = enu_reference(model, grid.lat, grid.lon, 20e3)
    g = np.linalg.norm(want, axis=-1)
    assert np.max(np.linalg.norm(out - want, axis=-1) / g) <= 1e-13
    lat = np.array([89.5, 90.0])
    grid = G.make_grid(0.5, region=(0.0, 0.5, 89.5, 90.0), heights_m=[20e3])
    out = G.synthesize(model, grid, quantity="gravitation", device=device)[0]
    want = enu_reference(model, lat, grid.lon, 20e3)
    g = np.linalg.norm(want, axis=-1)
    assert np.max(np.linalg.norm(out - want, axis=-1) / g) <= 1e-13


def test_refusals():
    model = kaula_model(20, seed=1)
    grid = G.make_grid(10.0, heights_m=[0.0])
    big = np.broadcast_to(np.float64(0.0), (2702, 2702))
    with pytest.raises(InputError, match="legendre='column' .* stops at degree 2700"):
        G.synthesize(SHModel("big", GM, R, big, big, 2701), grid, legendre="column")
    with pytest.raises(InputError, match="legendre must be one of auto, scaled, xrange, column"):
        G.synthesize(model, grid, legendre="x")
    huge = np.broadcast_to(np.float64(0.0), (10802, 10802))
    with pytest.raises(InputError, match="10800"):
        G.synthesize(SHModel("huge", GM, R, huge, huge, 10801), grid)


def test_xrange_order_factors_and_padding():
    """Order m is written times osc[m] (exactly), the columns past lmax are zeroed."""
    model = kaula_model(40, seed=3)
    lat = np.array([10.0, -10.0, 89.0, 0.0])
    h = np.full(4, 20e3)
    a, b = [[0, 2, 3] + [-1] * 5], [[1, -1, -1] + [-1] * 5]
    plain = _coefficients_x(model, lat, h, a, b, 1)
    osc = np.where(np.arange(41) % 3 == 0, 1.0, -0.5)
    got = _coefficients_x(model, lat, h, a, b, 1, osc=osc, ncol=47)
    assert np.array_equal(got[..., :41, :], plain * osc[:, None])
    assert np.all(got[..., 41:, :] == 0.0)
