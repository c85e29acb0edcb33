"""The gradient tensor by synthesis (issue 28), against paths that share no code with it.

- the NumPy reference :func:`fieldmap.reference.gradient.spherical_tensor` (another Legendre
  road: the m+1 identity and its derivative, Reed's Hessian), on every device, points and
  grids (mirrored rows);
- central differences of fieldmap's gravity vector
  (:func:`fieldmap.reference.gradient.central_difference_tensor`), every quantity and normal
  field, poles included, and at degree 2190 near the poles;
- pyshtools' ``SHGravCoeffs.tensor`` on its own Driscoll-Healy grid on a sphere, with its
  invariants and eigenvalues;
- Laplace: trace 2ω² (gravity) and 0 (disturbance) to 1e-6 E on a global grid with poles;
- the same bits for any block of rows and any thread count.
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.frames import C_e_to_enu, ecef_to_geodetic
from fieldmap.field.gradient import (
    EOTVOS,
    GRID_COMPONENTS,
    INVARIANTS,
    gradient_invariants,
    gradient_tensor,
    grid_gradient,
)
from fieldmap.grids import synthesis as G
from fieldmap.models.registry import kaula_model, load_model
from fieldmap.reference.gradient import central_difference_tensor, spherical_tensor

TWO_OMEGA2 = 2.0 * WGS84.omega**2 / EOTVOS
IDX = list(GRID_COMPONENTS.values())


@pytest.fixture(scope="module")
def model60():
    return load_model("eigen-6s", lmax=60)


def _points(n=20, seed=5):
    rng = np.random.default_rng(seed)
    lat = np.r_[np.degrees(np.arcsin(rng.uniform(-0.999, 0.999, n))), 89.99, -89.95, 0.0]
    lon = np.r_[rng.uniform(-180, 180, n), 10.0, -170.0, 0.0]
    h = np.r_[rng.uniform(-100.0, 2e5, n), 0.0, 3000.0, 0.0]
    return lat, lon, h


def test_kernel_equals_numpy_reference_at_points_and_on_grids(model60, device):
    lat, lon, h = _points()
    want = spherical_tensor(model60, lat, lon, h, WGS84) / EOTVOS
    got = G.tensor_points(model60, lat, lon, h, WGS84, device) / EOTVOS
    assert np.abs(want).max() > 3000.0
    for c, (i, j) in enumerate(IDX):
        np.testing.assert_allclose(got[:, c], want[:, i, j], rtol=0, atol=1e-8, err_msg=str(c))
    # a grid: rows and their mirrors share one recursion; longitudes of part of a turn
    grid = G.make_grid(region=(-30.0, 47.0, -60.0, 60.0), step_deg=7.5, heights_m=[0.0, 4e4])
    tg = G.synthesize_tensor(model60, grid, WGS84, device) / EOTVOS
    la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    for k, hk in enumerate(grid.heights):
        ref = spherical_tensor(model60, la.ravel(), lo.ravel(), np.full(la.size, hk), WGS84)
        ref = ref.reshape(la.shape + (3, 3)) / EOTVOS
        for c, (i, j) in enumerate(IDX):
            np.testing.assert_allclose(tg[k, ..., c], ref[..., i, j], rtol=0, atol=1e-8)


@pytest.mark.parametrize(
    "quantity",
    ["gravity", "gravitation", "disturbance", "normal", "normal:j2", "normal:j4",
     "normal:j6", "normal:groves-j2", "disturbance:j6"],
)  # fmt: skip
def test_synthesis_equals_central_differences_poles_included(model60, quantity):
    """Every quantity and normal field (the normal field as its zonal series) vs differences."""
    lat, lon, h = _points(12, seed=7)
    lat = np.r_[lat, 90.0, -90.0]
    lon = np.r_[lon, 33.0, 0.0]
    h = np.r_[h, 0.0, 1e4]
    ref, _ = central_difference_tensor(lat, lon, h, model60, quantity, WGS84, "enu", "cpu")
    got = gradient_tensor(lat, lon, h, model=model60, quantity=quantity, device="cpu")
    np.testing.assert_allclose(got, ref, rtol=0, atol=5e-5)
    for frame in ("ned", "ecef"):
        ref_f, _ = central_difference_tensor(lat, lon, h, model60, quantity, WGS84, frame, "cpu")
        got_f = gradient_tensor(lat, lon, h, model=model60, quantity=quantity, frame=frame)
        np.testing.assert_allclose(got_f, ref_f, rtol=0, atol=5e-5)


@pytest.mark.slow
def test_degree_2190_near_the_poles_equals_central_differences():
    """Stable at high degree: a Kaula-rule model of degree 2190, from the equator to the pole."""
    m = kaula_model(2190, seed=11)
    lat = np.array([0.0, 45.0, -70.0, 89.0, 89.99, -90.0])
    lon = np.array([0.0, 12.0, -100.0, 45.0, 170.0, 0.0])
    h = np.array([5e3, 20e3, 0.0, 10e3, 20e3, 30e3])
    got = gradient_tensor(lat, lon, h, model=m, quantity="gravitation", device="cpu")
    ref, _ = central_difference_tensor(lat, lon, h, m, "gravitation", WGS84, "enu", None)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, ref, rtol=0, atol=2e-3)


def test_grid_trace_and_poles_at_degree_240():
    """Laplace on a global grid with both poles: trace 2ω² and 0 to 1e-6 E; poles as points."""
    m = load_model("eigen-6s", lmax=240)
    grid = G.make_grid(step_deg=10.0, lat_max=90.0, heights_m=[0.0, 2e4])
    grav = grid_gradient(m, grid, "gradient")
    dist = grid_gradient(m, grid, "gradient-disturbance")
    tr_g = grav["T_ee"] + grav["T_nn"] + grav["T_uu"]
    tr_d = dist["T_ee"] + dist["T_nn"] + dist["T_uu"]
    assert np.abs(tr_g - TWO_OMEGA2).max() < 1e-6
    assert np.abs(tr_d).max() < 1e-6
    assert np.abs(dist["T_uu"]).max() > 10.0  # the field is there
    # the pole rows (every longitude: the ENU frame turns with it) vs central differences
    for row in (0, -1):
        lat = np.full(grid.lon.size, grid.lat[row])
        for k, hk in enumerate(grid.heights):
            ref, _ = central_difference_tensor(
                lat, grid.lon, np.full(lat.size, hk), m, "gravity", WGS84, "enu", None
            )
            for name, (i, j) in GRID_COMPONENTS.items():
                np.testing.assert_allclose(grav[name][k, row], ref[:, i, j], rtol=0, atol=5e-5)


def test_pyshtools_tensor_on_its_own_grid(model60):
    """Equals pyshtools' ``SHGravCoeffs.tensor`` (sphere r = R + 20 km, its DH grid) to 1e-6 E.

    pyshtools' frame: x north, y west, z up. Its two pole rows are left out: its formulas
    divide by sin θ there (the values it returns at the poles are not the tensor); the poles
    are checked against central differences above and against GeographicLib in
    tests/test_gradient.py.
    """
    pysh = pytest.importorskip("pyshtools")
    m = model60.truncated(30)
    coeffs = pysh.SHGravCoeffs.from_array(
        np.stack([m.C, m.S]), m.gm, m.radius, normalization="4pi", csphase=1
    )
    a = m.radius + 20e3
    ten = coeffs.tensor(a=a, f=0.0, degree0=True)
    LA, LO = np.meshgrid(ten.vxx.lats(), ten.vxx.lons(), indexing="ij")
    psi, lam = np.radians(LA), np.radians(LO)
    x, y, z = a * np.cos(psi) * np.cos(lam), a * np.cos(psi) * np.sin(lam), a * np.sin(psi)
    gl, go, gh = ecef_to_geodetic(x.ravel(), y.ravel(), z.ravel(), WGS84)
    t = gradient_tensor(gl, go, gh, model=m, quantity="gravitation", frame="ecef")
    c = C_e_to_enu(LA.ravel(), LO.ravel())  # the sphere's (geocentric) east-north-up
    t = (c @ t @ np.swapaxes(c, -1, -2)).reshape(LA.shape + (3, 3))
    ours = {
        "vxx": t[..., 1, 1], "vyy": t[..., 0, 0], "vzz": t[..., 2, 2],
        "vxy": -t[..., 0, 1], "vxz": t[..., 1, 2], "vyz": -t[..., 0, 2],
    }  # fmt: skip
    inner = slice(1, -1)
    for name, v in ours.items():
        theirs = getattr(ten, name).data
        np.testing.assert_allclose(v[inner], theirs[inner], rtol=0, atol=1e-6, err_msg=name)
    ten.compute_invar()
    ten.compute_eig()
    inv = gradient_invariants(t)
    np.testing.assert_allclose(inv["I1"][inner], ten.i1.data[inner], rtol=1e-12)
    np.testing.assert_allclose(inv["I2"][inner], ten.i2.data[inner], rtol=1e-11, atol=1e-3)
    eig = np.sort(np.stack([ten.eig1.data, ten.eig2.data, ten.eig3.data]), axis=0)[::-1]
    for k in range(3):
        np.testing.assert_allclose(inv[f"eig_{k + 1}"][inner], eig[k][inner], atol=1e-6)


def test_invariants_closed_form():
    """Any rotation of diag(a, b, c): I1 = ab + bc + ca, I2 = abc, eigenvalues a ≥ b ≥ c."""
    rng = np.random.default_rng(2)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    d = np.array([2900.0, -1400.0, -1500.0])
    inv = gradient_invariants(q @ np.diag(d) @ q.T)
    assert inv["I1"] == pytest.approx(d[0] * d[1] + d[1] * d[2] + d[0] * d[2], rel=1e-12)
    assert inv["I2"] == pytest.approx(np.prod(d), rel=1e-12)
    np.testing.assert_allclose([inv["eig_1"], inv["eig_2"], inv["eig_3"]], np.sort(d)[::-1])
    assert set(inv) == set(INVARIANTS)
    with pytest.raises(InputError, match="3, 3"):
        gradient_invariants(np.zeros((3, 2)))


def test_same_bits_for_any_block_and_thread_count(model60, monkeypatch):
    grid = G.make_grid(step_deg=6.0, lat_max=90.0, heights_m=[0.0, 1e4])
    ref = G.synthesize_tensor(model60, grid, WGS84, "cpu")
    monkeypatch.setattr(G, "BLOCK_BYTES", 1)  # two rows a block: mirrors split apart
    with _warp.threads(1):
        small = G.synthesize_tensor(model60, grid, WGS84, "cpu")
    monkeypatch.undo()
    assert np.array_equal(ref, small)
    # a block of rows of the grid gives the bits of the whole grid
    sub = G.make_grid(region=(grid.lon[0], grid.lon[-1], 12.0, 30.0), step_deg=6.0,
                      heights_m=[0.0, 1e4])  # fmt: skip
    part = G.synthesize_tensor(model60, sub, WGS84, "cpu")
    rows = np.searchsorted(grid.lat, sub.lat)
    assert np.array_equal(part, ref[:, rows])


def test_tensor_degree_limit(model60):
    from fieldmap.field.sh import MAX_DEGREE_GRID
    from fieldmap.models.shmodel import SHModel

    L = MAX_DEGREE_GRID + 1
    big = SHModel("big", model60.gm, model60.radius, np.eye(L + 1), np.zeros((L + 1, L + 1)), L)
    with pytest.raises(InputError, match="degree"):
        gradient_tensor(0.0, 0.0, 0.0, model=big, quantity="gravitation")


@pytest.mark.slow
def test_degree_2700_near_the_poles_equals_numpy_reference():
    """The top degree of the scaled recursion at 89.99°: the NumPy reference (X-numbers).

    Measured 5e-5 E of 2.4e5 E (2e-10); central differences of the vector are 1000 times
    further off there (the vector's own rounding over 2 m), so the reference is the NumPy one.
    """
    m = kaula_model(2700, seed=3)
    lat = np.array([89.99, 89.9, -89.95, 60.0])
    lon = np.array([10.0, 20.0, -75.0, 40.0])
    h = np.array([0.0, 100.0, 0.0, 0.0])
    got = gradient_tensor(lat, lon, h, model=m, quantity="gravitation", device="cpu")
    want = spherical_tensor(m, lat, lon, h, WGS84) / EOTVOS
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())
