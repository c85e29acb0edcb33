"""Grid specification and grid synthesis (kernels/grid.py, fieldmap/grid.py).

The grid kernel (row Legendre pass + FFT over longitude) is checked against independent paths:
the scattered-point Warp kernel (fieldmap.field.gravity), the NumPy reference of the SH engine
(fieldmap.reference.sh), closed forms (the level ellipsoid's own zonal series gives a zero
disturbance), and its own direct (non-FFT) longitude sums.
"""

import math

import numpy as np
import pytest

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84
from fieldmap.grids import synthesis as G
from fieldmap.models.registry import kaula_model, load_model
from fieldmap.models.shmodel import SHModel
from fieldmap.reference.normal import zonal_sh_model


def _enu(model, grid, ih, quantity, device):
    """Scattered-point path at the grid nodes, geodetic ENU (m/s²)."""
    from fieldmap.field.gravity import disturbance, gravitation

    la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    h = grid.heights[ih]
    if quantity == "disturbance":
        return disturbance(la, lo, h, model=model, units="m/s2", device=device)
    return gravitation(la, lo, h, model=model, device=device)


# ----------------------------------------------------------------------------- grid spec
@pytest.mark.parametrize(
    "kwargs, msg",
    [
        ({"step_deg": 0}, "step"),
        ({"step_deg": -1}, "step"),
        ({"step_deg": float("nan")}, "step"),
        ({"step_deg": "x"}, "step"),
        ({"lat_max": 90.5}, "latitude"),
        ({"lat_max": -1}, "latitude"),
        ({"region": (10, 20, 30, 20)}, "empty region"),
        ({"region": (10, 20, -95, 20)}, "latitudes"),
        ({"region": (10, 20, 30)}, "west east south north"),
        ({"heights_m": [float("inf")]}, "finite"),
        ({"heights_m": [float("nan")]}, "finite"),
        ({"heights_m": [-50e3]}, "below"),
        ({"heights_m": []}, "no height"),
    ],
)
def test_bad_specs_raise(kwargs, msg):
    with pytest.raises(InputError, match=msg):
        G.make_grid(**kwargs)


def test_paper_grid_shape():
    # Chen et al. 2022 §4.1: 80S-80N, 180W-179E on 1 deg x 1 deg
    g = G.make_grid(1.0, 80.0)
    assert g.shape == (1, 161, 360)
    assert g.lon[0] == -180.0 and g.lon[-1] == 179.0 and g.is_global
    g5 = G.make_grid(5.0 / 60.0, 80.0)
    assert g5.lat.size == 1921 and g5.lon.size == 4320
    assert abs(g5.lat[-1] - 80.0) < 1e-9


def test_region_across_antimeridian():
    g = G.make_grid(1.0, region=(170, -170, -5, 5))
    assert g.lon[0] == 170 and g.lon[-1] == 190 and g.lon.size == 21 and not g.is_global
    g1 = G.make_grid(0.025, region=(100, 112, 18, 37))
    assert g1.lon.size == 481 and g1.lat.size == 761


def test_area_weights_closed_form():
    lat = np.linspace(-90, 90, 181)
    from fieldmap.products.statistics import area_weights

    w = area_weights(lat)
    assert w.sum() == pytest.approx(2.0, rel=1e-14, abs=0)  # ∫cos φ dφ over the sphere
    # the band 30..90 deg holds (1 - sin 30)/2 = 1/4 of the sphere; nodes above 30 carry it
    # except the half band of the 30-deg node itself
    frac = w[lat > 30].sum() / w.sum()
    expected = (1 - math.sin(math.radians(30.5))) / 2
    assert frac == pytest.approx(expected, rel=1e-12, abs=0)


# ----------------------------------------------------------------------------- synthesis
@pytest.fixture(scope="module")
def eigen():
    return load_model("eigen-6s", lmax=120)


@pytest.mark.parametrize("quantity", ["gravitation", "disturbance"])
def test_grid_matches_scattered_points(eigen, device, quantity):
    """Grid kernel vs the scattered-point kernel: ≤ 1e-12 of |g|.

    The disturbance is a difference of two ~9.8 m/s² vectors, so its relative accuracy is
    bounded by |g|·eps, not by |δg|.
    """
    grid = G.make_grid(7.5, 90.0, heights_m=[0.0, 20e3, 100e3])
    out = G.synthesize(eigen, grid, quantity=quantity, device=device)
    for ih in range(grid.heights.size):
        ref = _enu(eigen, grid, ih, quantity, device)
        scale = 9.8
        assert np.max(np.abs(out[ih] - ref)) <= 1e-12 * scale


def test_grid_matches_numpy_reference(device):
    """Against the NumPy SH reference (independent recursion), Kaula model degree 90, 1e-12 rel."""
    from fieldmap.reference import sh as ref

    model = kaula_model(90, seed=3)
    grid = G.make_grid(0.5, region=(-20.25, 40, -89.75, 89.75), heights_m=[30e3])
    grid = G.GridSpec(grid.lat[::23], grid.lon[::7], grid.heights, 0.5)  # irregular sample
    la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    x, y, z = frames.geodetic_to_ecef(la, lo, 30e3)

    def ref_enu(m):
        g = ref.gravitation_ecef(m, x.ravel(), y.ravel(), z.ravel()).reshape(*la.shape, 3)
        return np.einsum("...ij,...j->...i", frames.C_e_to_enu(la, lo), g)

    out = G.synthesize(model, grid, quantity="gravitation", device=device)[0]
    enu = ref_enu(model)
    err = np.max(np.linalg.norm(out - enu, axis=-1) / np.linalg.norm(enu, axis=-1))
    assert err <= 1e-12
    # the whole field is ~GM/r²: check degrees 3..90 alone against their own size as well
    # (1.2e-14 of their max measured)
    C, S = model.C.copy(), model.S.copy()
    C[:3], S[:3] = 0.0, 0.0
    anom = SHModel("degrees-3-90", model.gm, model.radius, C, S, 90)
    out = G.synthesize(anom, grid, quantity="gravitation", device=device)[0]
    enu = ref_enu(anom)
    err = np.max(np.linalg.norm(out - enu, axis=-1)) / np.max(np.linalg.norm(enu, axis=-1))
    assert err <= 1e-12


def test_level_ellipsoid_series_gives_zero_disturbance():
    """The level ellipsoid's own zonal series as a model gives δg ≈ 0.

    Model: J2n of WGS84 (H&M eq. 2-92) with its GM and a, against the exact normal field; the
    closed form shares no code with the SH series.
    """
    model = zonal_sh_model(WGS84, nmax=10)  # degree 20
    grid = G.make_grid(10.0, 90.0, heights_m=[0.0, 20e3, 100e3])
    out = G.synthesize(model, grid, quantity="disturbance", device="cpu")
    # the J22 term left out is ~e²¹ ≈ 1e-24 of g; what remains is rounding of g − γ (ulp of 9.8
    # is 1.8e-15): 8.9e-15 m/s² measured, tolerance 2e-13 m/s² (2e-8 mGal)
    assert np.max(np.abs(out)) < 2e-13


def test_fft_and_direct_longitude_sums_agree(eigen):
    """Regular longitudes go through the FFT; a shifted copy with one extra node does not."""
    reg = G.make_grid(3.0, region=(-30, 60, -60, 60), heights_m=[20e3])
    assert G.regular_period(reg.lon) == 120
    irr_lon = np.append(reg.lon, 61.7)
    assert G.regular_period(irr_lon) is None
    irr = G.GridSpec(reg.lat, irr_lon, reg.heights, 3.0)
    a = G.synthesize(eigen, reg, device="cpu")
    b = G.synthesize(eigen, irr, device="cpu")
    # relative to the disturbance itself (~1e-3 m/s²), not to g: 7e-15 of max|δg| measured
    assert np.max(np.abs(a - b[..., :-1, :])) < 1e-12 * np.max(np.abs(a))


def test_aliasing_fold_is_exact():
    """Degree above the number of longitudes: orders fold mod L exactly on the nodes."""
    model = kaula_model(60, seed=1)
    grid = G.make_grid(10.0, region=(-180, 170, -50, 50), heights_m=[5e3])  # L = 36 < 61 orders
    a = G.synthesize(model, grid, quantity="gravitation", device="cpu")
    b = G.synthesize(
        model,
        G.GridSpec(grid.lat, np.append(grid.lon, 175.5), grid.heights, 10.0),
        quantity="gravitation",
        device="cpu",
    )
    assert np.max(np.abs(a - b[..., :-1, :])) < 1e-12 * 9.8


def test_row_blocks_do_not_change_results(eigen, monkeypatch):
    grid = G.make_grid(4.0, 80.0, heights_m=[20e3, 50e3])  # 2 x 41 rows
    full = G.synthesize(eigen, grid, device="cpu")
    # one row per block, clamped to 2 x the CPU threads: pinned to 2 threads (blocks of 4 rows),
    # else a machine with 41 or more cores would synthesize all 82 rows in one block
    monkeypatch.setattr(G, "BLOCK_BYTES", 1)
    calls = []
    row_setup = G._row_setup
    monkeypatch.setattr(G, "_row_setup", lambda *a, **k: calls.append(1) or row_setup(*a, **k))
    with _warp.threads(2):
        blocks = G.synthesize(eigen, grid, device="cpu", progress=True)
    assert len(calls) >= 82 // 4  # the blocks did happen (one row setup per block)
    # equal up to rounding: the FFT pairs series differently in other blocks (1.8e-16 of the
    # largest disturbance measured)
    np.testing.assert_allclose(full, blocks, rtol=0, atol=1e-14 * np.max(np.abs(full)))


def test_near_pole_high_degree_stays_finite():
    """Degree 700 at ±89.99° (u^m underflows unless applied in halves): matches the point path."""
    model = kaula_model(700, seed=2)
    grid = G.make_grid(0.01, region=(0, 0.05, 89.96, 90.0), heights_m=[20e3])
    out = G.synthesize(model, grid, quantity="gravitation", device="cpu")
    ref = _enu(model, grid, 0, "gravitation", "cpu")
    assert np.all(np.isfinite(out))
    assert np.max(np.abs(out - ref)) <= 1e-13 * 9.8  # 8.9e-15 m/s² measured


def test_normal_rows_match_reference():
    """Per-row normal gravitation (exact, J2, J4) vs the NumPy normal-gravity reference."""
    from fieldmap.reference import normal as nref

    grid = G.make_grid(10.0, 90.0, heights_m=[20e3])
    la = grid.lat
    for kind in ("exact", "j2", "j4", "j6"):
        rows = G.normal_rows(grid, WGS84, normal=kind, device="cpu")[0]
        ref = nref.normal_gravity(
            la, np.zeros_like(la), 20e3, WGS84, kind=kind, centrifugal=False, frame="enu"
        )
        assert np.max(np.abs(rows - ref)) < 1e-13 * 9.8, kind


def test_bad_quantity_and_device():
    grid = G.make_grid(30.0)
    with pytest.raises(InputError, match="quantity"):
        G.synthesize(kaula_model(4), grid, quantity="potential")
    with pytest.raises(InputError, match="device"):
        G.synthesize(kaula_model(4), grid, device="cuda:7")


def test_longitudes_past_one_turn_wrap(eigen):
    """A Driscoll-Healy-like row holding both 0 and 360 deg goes through the FFT.

    Its last node equals the first, and all equal the direct-sum path.
    """
    lon = 360.0 * np.arange(13) / 12
    assert G.regular_period(lon) == 12
    grid = G.GridSpec(np.array([-30.0, 45.0]), lon, np.array([20e3]), 30.0)
    a = G.synthesize(eigen, grid, device="cpu")
    scale = np.max(np.abs(a))  # the disturbance (~1e-3 m/s²), not g
    np.testing.assert_allclose(a[..., -1, :], a[..., 0, :], rtol=0, atol=1e-12 * scale)
    b = G.synthesize(
        eigen, G.GridSpec(grid.lat, np.append(lon, 1.3), grid.heights, 30.0), device="cpu"
    )
    assert np.max(np.abs(a - b[..., :-1, :])) < 1e-12 * scale  # 3e-15 of scale measured


@pytest.mark.parametrize(
    "nm, nper, lon0",
    [
        (5, 12, 0.0),
        (7, 12, -180.0),
        (12, 12, 3.0),
        (13, 11, 0.0),
        (40, 9, 17.5),
        (6, 11, 100.0),
        (10, 12, -180.0),
        (9, 8, 45.0),
        (8, 9, -40.0),
    ],
)
def test_longitude_sums_match_explicit_series(nm, nper, lon0):
    """FFT path (real inverse FFT, aliasing fold, phase shift) vs the explicit cos/sin series."""
    rng = np.random.default_rng(nm * 100 + nper)
    W = rng.normal(size=(3 + nm % 2, nm)) + 1j * rng.normal(size=(3 + nm % 2, nm))  # odd, even
    lon = lon0 + 360.0 / nper * np.arange(nper)
    got = G.longitude_sums(W, lon)
    m = np.arange(nm)[:, None]
    lam = np.radians(lon)[None, :]
    ref = W.real @ np.cos(m * lam) - W.imag @ np.sin(m * lam)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-13 * np.abs(W).sum())


@pytest.mark.parametrize(
    "nm, nper, lon0, ready",
    [
        (5, 12, 0.0, True),
        (7, 12, -180.0, True),
        (7, 12, 180.0, True),
        (7, 13, 0.0, True),
        (7, 12, 30.0, False),
        (8, 12, 0.0, False),
        (4, 12, 1.0, False),
    ],
)
def test_spectrum_layout_read_as_it_is(nm, nper, lon0, ready):
    """Series written as spectrum_layout says give the explicit cos/sin sums."""
    rng = np.random.default_rng(nm * 10 + nper)
    W = rng.normal(size=(3, nm)) + 1j * rng.normal(size=(3, nm))
    lon = lon0 + 360.0 / nper * np.arange(nper)
    ncol, osc, got_ready = G.spectrum_layout(lon, nm)
    assert got_ready == ready
    Wl = np.zeros((3, ncol), dtype=complex)
    Wl[:, :nm] = W * osc
    got = G.longitude_sums(Wl, lon, ready=ready)
    m = np.arange(nm)[:, None]
    lam = np.radians(lon)[None, :]
    ref = W.real @ np.cos(m * lam) - W.imag @ np.sin(m * lam)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-13 * np.abs(W).sum())
    if not ready:
        with pytest.raises(ValueError, match="ready layout"):
            G.longitude_sums(W, lon, ready=True)


def test_mirror_group_path_matches_engine_column_path(eigen, device):
    """The grouped even/odd recursion (mirror rows, 4 per thread) equals the sh_column path.

    On a symmetric grid with an equator row, two heights and padding, and on a region.
    """
    grid = G.make_grid(11.0, 77.0, heights_m=[0.0, 35e3])
    assert len(G.mirror_pairs(grid.lat)) == (grid.lat.size + 1) // 2
    a = G.synthesize(eigen, grid, quantity="gravitation", device=device, legendre="auto")
    b = G.synthesize(eigen, grid, quantity="gravitation", device=device, legendre="column")
    assert np.max(np.abs(a - b)) < 1e-13 * 9.8
    reg = G.make_grid(2.5, region=(10, 20, -5, 9), heights_m=[20e3])  # 2 mirror pairs, 2 singles
    pairs = G.mirror_pairs(reg.lat)
    assert sum(b >= 0 for _, b in pairs) == 2
    a = G.synthesize(eigen, reg, device=device, legendre="auto")
    b = G.synthesize(eigen, reg, device=device, legendre="column")
    assert np.max(np.abs(a - b)) < 1e-13 * 9.8


def test_grid_disturbance_matches_geographiclib_tool(tmp_path, eigen):
    """External check: GeographicLib's ``Gravity -D`` at the nodes of a coarse grid.

    Debian geographiclib-tools; EIGEN-6S degree 120, WGS84 normal field, 20 and 100 km.
    """
    from fieldmap.models.geographiclib import gravity_tool, run_gravity_tool, write_egm

    if gravity_tool() is None:
        pytest.skip("GeographicLib's Gravity tool is not installed")
    name = write_egm(eigen, tmp_path, "eigen6s120")
    grid = G.make_grid(15.0, 75.0, heights_m=[20e3, 100e3])
    ours = G.synthesize(eigen, grid, device="cpu") / 1e-5  # mGal
    la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    for ih, h in enumerate(grid.heights):
        pts = np.stack([la.ravel(), lo.ravel(), np.full(la.size, h)], axis=-1)
        ref = run_gravity_tool(pts, tmp_path, name, "disturbance").reshape(ours[ih].shape)
        # two float64 evaluations of |δg| ~ 100 mGal from |g| ~ 9.8e5 mGal: ~1e-9 mGal observed
        assert np.max(np.abs(ours[ih] - ref)) < 1e-8


# ---------------------------------------------------------------------- symmetric global grids
@pytest.mark.parametrize(
    "step, lat_max, top, nrows",
    [
        (1.0, 80.0, 80.0, 161),  # the paper's grid: 2 lat_max a whole number of steps
        (30.0, 80.0, 60.0, 5),  # was -80..70: now the multiples of 30 within +-80
        (6.0, 80.0, 78.0, 27),
        (2.0, 81.0, 81.0, 82),  # +81 reachable from -81 by whole steps: kept, no equator row
        (0.3, 80.0, 79.8, 533),
        (5.0 / 60.0, 80.0, 80.0, 1921),
        (7.0, 90.0, 84.0, 25),
    ],
)
def test_global_grids_are_symmetric(step, lat_max, top, nrows):
    g = G.make_grid(step, lat_max)
    assert g.lat.size == nrows
    np.testing.assert_array_equal(g.lat, -g.lat[::-1])  # exact mirrors, for mirror_pairs
    assert abs(g.lat[-1] - top) < 1e-9 and g.lat[-1] <= lat_max
    np.testing.assert_allclose(np.diff(g.lat), step, rtol=1e-9)
    if nrows % 2:
        assert g.lat[nrows // 2] == 0.0  # the equator row is exactly 0
    pairs = G.mirror_pairs(g.lat)
    assert len(pairs) == (nrows + 1) // 2


def test_symmetric_grid_names_its_extent():
    """The file stem of the CLI is built from the region: step 30 now says latmax60, not 70."""
    g = G.make_grid(30.0, 80.0)
    assert g.region == (-180.0, 150.0, -60.0, 60.0)


def _pairs_reference(lat):
    """Mirror pairs by a plain loop: each row, in order, takes the last unused row at -lat."""
    where = {float(v): i for i, v in enumerate(lat)}
    used, out = set(), []
    for i, v in enumerate(lat):
        if i in used:
            continue
        j = where.get(-float(v)) if v != 0 else None
        if j is not None and j != i and j not in used:
            out.append((i, j))
            used.update((i, j))
        else:
            out.append((i, -1))
            used.add(i)
    return out


def test_mirror_pair_array_equals_mirror_pairs():
    """The index array of the synthesis and mirror_pairs hold the pairs of a plain loop."""
    rng = np.random.default_rng(0)
    cases = [
        G.make_grid(0.5, 90.0).lat,
        G.make_grid(1.0, 80.0).lat,
        G.make_grid(0.25, region=(-20, 40, 30, 60)).lat,
        np.array([10.0, -10.0, 0.0, 5.0]),
        np.array([3.0, 3.0, -3.0]),
        np.array([0.0]),
        np.array([-5.0, 5.0, -5.0, 5.0]),
        np.array([30.0, 10.0, -30.0, -10.0, 0.0]),
    ]
    cases += [np.round(rng.uniform(-90, 90, 12), 0) for _ in range(20)]  # repeats too
    cases += [np.sort(np.round(rng.uniform(-9, 9, 9), 0))[::-1] for _ in range(5)]
    cases += [np.linspace(-80, 80, 17)[::-1], rng.permutation(np.linspace(-80, 80, 17))]
    for lat in cases:
        want = _pairs_reference(lat)
        got = G.mirror_pair_array(lat)
        assert [tuple(p) for p in got.tolist()] == want, lat
        assert G.mirror_pairs(lat) == want, lat
