"""The grid Legendre pass: packed tables and the eight-lane kernel (kernels/grid.py).

The packed tables are checked against straightforward loops over the engine's square tables,
the eight-lane kernel (SIMD and plain Warp) against the engine's own column sums per row
(``row_fourier_kernel``), and the lanes against each other: a row's coefficients must not
depend on which rows share its thread (same bits for any grouping).
"""

import numpy as np
import pytest
import warp as wp
from fieldmap.kernels import grid as kgrid

from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.sh import kernel_model
from fieldmap.grids import synthesis as G
from fieldmap.grids.tables import grid_tables, pack_columns
from fieldmap.models.registry import kaula_model


def test_pack_columns_against_loops():
    L = 12
    rng = np.random.default_rng(1)
    anm, bnm, fnm, cnm, snm = (rng.standard_normal((L + 3, L + 3)) for _ in range(5))
    rec, start, zon = pack_columns(anm, bnm, fnm, cnm, snm, L)
    assert rec.shape == ((L + 1) * (L + 2) // 2, 8)
    for m in range(L + 1):
        for n in range(m, L + 1):
            w = rec[start[m] + n - m]
            f_c = cnm[m, n + 1] * fnm[m, n + 1] if n < L else 0.0
            f_s = snm[m, n + 1] * fnm[m, n + 1] if n < L else 0.0
            want = [anm[m, n], bnm[m, n], cnm[m, n], snm[m, n], (n + 1) * cnm[m, n]]
            want += [(n + 1) * snm[m, n], f_c, f_s]
            assert np.array_equal(w, want)
    assert np.array_equal(zon, [fnm[0, n] * cnm[0, n] for n in range(L + 1)])


def _coefficients(model, lat, h, row_a, row_b, simd, device="cpu", osc=None, ncol=None):
    """Run row_fourier8_kernel on explicit unit groups; coefficients (nrow, 3, ncol) complex.

    The engine's ``row_fourier_kernel`` gives the reference. ``osc``: the order factors of
    both (default 1); ``ncol``: columns (default nm), the arrays start as NaN.
    """
    km = kernel_model(model, device)
    tabs = grid_tables(model, km, device)
    geo, _ = G._row_setup(np.radians(lat), h, WGS84, model.radius, 0, device)
    nm = model.lmax + 1
    ones = wp.array(np.ones(nm) if osc is None else osc, dtype=wp.float64, device=device)
    nan = wp.vec2d(np.nan, np.nan)
    coef = wp.full((lat.size, 3, ncol or nm), nan, dtype=wp.vec2d, device=device)
    ra = wp.array(np.asarray(row_a, dtype=np.int32), dtype=wp.int32, device=device)
    rb = wp.array(np.asarray(row_b, dtype=np.int32), dtype=wp.int32, device=device)
    ng = ra.shape[0]
    wp.launch(
        kgrid.row_fourier8_kernel,
        dim=ng * nm,
        inputs=[
            km,
            *tabs,
            *geo,
            ra,
            rb,
            *G.row_powers(geo, model.lmax, device),
            ng,
            simd,
            ones,
            coef,
            0,
        ],
        device=device,
    )
    ref = wp.full((lat.size, 3, ncol or nm), nan, dtype=wp.vec2d, device=device)
    wp.launch(
        kgrid.row_fourier_kernel,
        dim=lat.size * nm,
        inputs=[km, *geo, nm, ones, ref, 0],
        device=device,
    )
    return coef.numpy(), ref.numpy()


@pytest.mark.parametrize("simd", [1, 0])
def test_eight_lanes_match_engine_columns_and_do_not_mix(simd):
    model = kaula_model(150, seed=5)
    # 10 rows: 4 mirrored pairs, the equator, a lone row at another height
    lat = np.array([10.0, -10.0, 33.3, -33.3, 0.0, 71.0, -71.0, 89.5, -89.5, 45.0])
    h = np.array([20e3] * 9 + [250e3])
    units = [(0, 1), (2, 3), (4, -1), (5, 6), (7, 8), (9, -1)]
    a = [u[0] for u in units] + [-1, -1]
    b = [u[1] for u in units] + [-1, -1]
    coef, ref = _coefficients(model, lat, h, [a], [b], simd)
    scale = np.max(np.abs(ref))
    assert np.max(np.abs(coef - ref)) <= 1e-13 * scale
    # the same units in another order, split over two groups with other partners: same bits
    perm = [5, 3, 0, -1, 4, 1, -1, 2]
    a2 = [units[k][0] if k >= 0 else -1 for k in perm]
    b2 = [units[k][1] if k >= 0 else -1 for k in perm]
    a2 = [a2, [-1] * 7 + [units[2][0]]]
    b2 = [b2, [-1] * 8]
    a2[0][7] = b2[0][7] = -1  # the equator row moves to lane 7 of the second group
    coef2, _ = _coefficients(model, lat, h, a2, b2, simd)
    assert np.array_equal(coef, coef2)


def test_simd_and_warp_lanes_agree():
    model = kaula_model(300, seed=9)
    lat = np.linspace(-85.0, 85.0, 16)
    h = np.full(16, 5e3)
    a = [list(range(8)), list(range(8, 16))]
    b = [[-1] * 8, [-1] * 8]
    c1, ref = _coefficients(model, lat, h, a, b, 1)
    c0, _ = _coefficients(model, lat, h, a, b, 0)
    scale = np.max(np.abs(ref))
    assert np.max(np.abs(c1 - c0)) <= 1e-13 * scale
    assert np.max(np.abs(c1 - ref)) <= 1e-13 * scale


def test_order_of_visits_every_order_once():
    @wp.kernel
    def orders(lmax: int, out: wp.array(dtype=wp.int32)):
        i = wp.tid()
        out[i] = kgrid.order_of(i, lmax)

    for lmax in (0, 1, 2, 7, 10):
        out = wp.zeros(lmax + 1, dtype=wp.int32, device="cpu")
        wp.launch(orders, dim=lmax + 1, inputs=[lmax, out], device="cpu")
        got = out.numpy()
        assert sorted(got) == list(range(lmax + 1))
        work = [lmax + 1 - m for m in got]
        pairs = [work[k] + work[k + 1] for k in range(0, lmax, 2)]
        assert len(set(pairs)) <= 1  # consecutive pairs hold the same number of degrees


def test_order_factors_and_padding(device):
    """Both kernels write order m times osc[m] (exactly) and zero the columns past lmax."""
    model = kaula_model(30, seed=2)
    lat = np.array([20.0, -20.0, 0.0, 80.0])
    h = np.full(4, 20e3)
    a, b = [[0, 2, 3] + [-1] * 5], [[1, -1, -1] + [-1] * 5]
    simd = int(device == "cpu")
    plain, plain_ref = _coefficients(model, lat, h, a, b, simd, device)
    osc = np.where(np.arange(31) % 2 == 0, 0.5, -0.5)
    osc[0] = 1.0
    got, ref = _coefficients(model, lat, h, a, b, simd, device, osc=osc, ncol=40)
    for g, p in ((got, plain), (ref, plain_ref)):
        assert np.array_equal(g[..., :31, :], p * osc[:, None])
        assert np.all(g[..., 31:, :] == 0.0)


def test_row_powers_against_numpy(device):
    # the power tables of the Legendre pass: u^k and q^m per row against NumPy's float powers
    u = np.array([0.0, 1.0, 0.3, 0.999999, 0.01, 0.7071067811865476])
    q = np.array([1.0, 0.99, 1.0033, 0.5, 0.95, 0.9969])
    geo = [wp.array(x, dtype=wp.float64, device=device) for x in (u, u, u, q)]
    lmax = 700
    upow, qpow = G.row_powers(geo, lmax, device)
    up, qp = upow.numpy(), qpow.numpy()
    assert up.shape == (lmax // 2 + 2, u.size) and qp.shape == (lmax + 1, q.size)
    for tab, x in ((up, u), (qp, q)):
        k = np.arange(tab.shape[0])[:, None]
        want = x[None, :] ** k
        assert np.all(tab[0] == 1.0)  # x^0 = 1, also at the pole (u = 0)
        assert np.array_equal(tab[1], x)
        normal = want > 1e-300  # below, the tables may differ in the subnormal range
        rel = np.abs(tab - want)[normal] / want[normal]
        assert np.max(rel) <= 32 * 2.3e-16
        assert np.all(np.abs(tab[~normal]) <= 1e-290)
