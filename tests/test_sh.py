"""Spherical-harmonic Warp kernels (kernels.sh via field.sh) against independent checks.

* the NumPy reference ``fieldmap.reference.sh`` (row-wise X-number ALFs, m+1 derivative identity);
* closed forms: point mass, J2-only field (Groves 2013 eq. 3.7.7, coded here);
* finite differences of the kernel potential;
* parity of the Legendre functions, P̄nm(−t) = (−1)^{n+m} P̄nm(t);
* the zonal J2n series of WGS84 against the exact normal gravitation of ``fieldmap.field.normal``.
"""

import numpy as np
import pytest
import warp as wp
from fieldmap.kernels import sh as ksh

from fieldmap.field import sh as fsh
from fieldmap.field.ellipsoid import WGS84
from fieldmap.models.registry import kaula_model, load_model
from fieldmap.models.shmodel import SHModel
from fieldmap.reference import sh as ref
from fieldmap.reference.normal import zonal_sh_model

GM, R = 3.986004415e14, 6378136.3  # EIGEN-6S header constants (any values would do here)


def sample_points(n=40, seed=3):
    """Return random ECEF points at -1 km .. 1000 km, plus poles and near-pole points."""
    rng = np.random.default_rng(seed)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    lon = rng.uniform(-180, 180, n)
    lat = np.r_[lat, 89.9, 89.99, -89.99, 90.0, -90.0, 0.0]
    lon = np.r_[lon, 12.0, -100.0, 250.0, 0.0, 33.0, 0.0]
    h = np.r_[rng.uniform(-1e3, 1e6, n), 0.0, 2e4, 100.0, 0.0, 1e5, 0.0]
    phi, lam = np.radians(lat), np.radians(lon)
    r = WGS84.a + h
    x, y, z = r * np.cos(phi) * np.cos(lam), r * np.cos(phi) * np.sin(lam), r * np.sin(phi)
    x[np.abs(lat) == 90.0] = 0.0  # exactly on the axis: u = 0
    y[np.abs(lat) == 90.0] = 0.0
    return x, y, z


def rel_vec(a, b):
    """Largest |a − b| / |b| over the rows of two (N, 3) arrays."""
    return np.max(np.linalg.norm(a - b, axis=-1) / np.linalg.norm(b, axis=-1))


@pytest.fixture(scope="module")
def eigen():
    """Model used for the comparisons: the bundled EIGEN-6S (degree 240)."""
    return load_model("eigen-6s")


@pytest.mark.parametrize("lmax", [2, 20, 240])
def test_kernel_vs_reference(eigen, device, lmax):
    """Kernel gravitation and potential vs the NumPy reference, 1e-12 relative."""
    x, y, z = sample_points()
    g = fsh.sh_gravitation(eigen, x, y, z, lmax=lmax, device=device)
    g_ref = ref.gravitation_ecef(eigen, x, y, z, lmax=lmax)
    assert np.all(np.isfinite(g))
    assert rel_vec(g, g_ref) <= 1e-12
    V = fsh.sh_potential(eigen, x, y, z, lmax=lmax, device=device)
    V_ref = ref.potential(eigen, x, y, z, lmax=lmax)
    np.testing.assert_allclose(V, V_ref, rtol=1e-12, atol=0)


def test_kernel_vs_reference_high_degree_part(device):
    """Only degrees 150..300 (no C00): the high-degree machinery relative to its own size.

    Points within 80° of the equator: near a pole t = z/r carries 1 − t = u²/2 with an absolute
    rounding of ~1e-16, which moves the point by δθ ≈ 1e-16/u and changes a degree-n field by
    ~n²·1e-16 relative (1e-11 at 89.9°, n = 300) in any float64 code fed with t, kernel and
    reference alike. Relative to the whole field that is < 1e-15 (checked in the other tests).
    """
    model = kaula_model(300, seed=11)
    C, S = model.C.copy(), model.S.copy()
    C[:150], S[:150] = 0.0, 0.0
    hi = SHModel("hi", GM, R, C, S, 300)
    x, y, z = sample_points(30, seed=5)
    keep = np.abs(z) < np.sin(np.radians(80.0)) * np.sqrt(x * x + y * y + z * z)
    x, y, z = x[keep], y[keep], z[keep]
    g = fsh.sh_gravitation(hi, x, y, z, device=device)
    g_ref = ref.gravitation_ecef(hi, x, y, z)
    assert rel_vec(g, g_ref) <= 1e-12


def test_far_points_degree_cut(eigen, device):
    """Far above the sphere, where q^n < 1e-25 cuts the series, the kernel matches the full sum.

    Radii from 2 R to the GNSS radius 26 600 km, poles included.
    """
    rng = np.random.default_rng(12)
    n = 20
    r = np.r_[rng.uniform(1.2e7, 2.66e7, n), 1.3e7, 2.66e7]
    phi = np.r_[np.arcsin(rng.uniform(-1, 1, n)), np.pi / 2, -np.pi / 2]
    lam = np.r_[rng.uniform(-np.pi, np.pi, n), 0.0, 0.0]
    x, y, z = r * np.cos(phi) * np.cos(lam), r * np.cos(phi) * np.sin(lam), r * np.sin(phi)
    x[-2:], y[-2:] = 0.0, 0.0
    g = fsh.sh_gravitation(eigen, x, y, z, device=device)
    assert rel_vec(g, ref.gravitation_ecef(eigen, x, y, z)) <= 1e-12


def test_point_mass(device):
    """C00 = 1 only: V = GM/r, g = -GM r_vec / r^3 (Newton)."""
    C = np.zeros((4, 4))
    C[0, 0] = 1.0
    model = SHModel("pm", GM, R, C, np.zeros((4, 4)), 3)
    x, y, z = sample_points(30, seed=1)
    p = np.stack([x, y, z], axis=-1)
    r = np.linalg.norm(p, axis=-1)
    g = fsh.sh_gravitation(model, x, y, z, device=device)
    np.testing.assert_allclose(g, -GM * p / r[:, None] ** 3, rtol=0, atol=1e-14 * GM / r.min() ** 2)
    np.testing.assert_allclose(fsh.sh_potential(model, x, y, z, device=device), GM / r, rtol=1e-14)


def groves_j2_gravitation(x, y, z, gm, radius, j2):
    """Return the closed-form J2 gravitation, Groves (2013) eq. 3.7.7 (no centrifugal part)."""
    r = np.sqrt(x * x + y * y + z * z)
    k = 1.5 * j2 * (radius / r) ** 2
    zr2 = (z / r) ** 2
    gx = -gm / r**3 * (1.0 + k * (1.0 - 5.0 * zr2)) * x
    gy = -gm / r**3 * (1.0 + k * (1.0 - 5.0 * zr2)) * y
    gz = -gm / r**3 * (1.0 + k * (3.0 - 5.0 * zr2)) * z
    return np.stack([gx, gy, gz], axis=-1)


def test_j2_closed_form(device):
    """J2-only model vs Groves' closed form."""
    j2 = WGS84.J2
    C = np.zeros((3, 3))
    C[0, 0] = 1.0
    C[2, 0] = -j2 / np.sqrt(5.0)  # fully normalised: C20 = -J2/sqrt(5)
    model = SHModel("j2", WGS84.GM, WGS84.a, C, np.zeros((3, 3)), 2)
    x, y, z = sample_points(30, seed=2)
    g = fsh.sh_gravitation(model, x, y, z, device=device)
    assert rel_vec(g, groves_j2_gravitation(x, y, z, WGS84.GM, WGS84.a, j2)) <= 1e-14


def test_gradient_vs_finite_differences(eigen, device):
    """4th-order central differences of the kernel potential, step 40 m.

    Truncation (h^4 V^(5)/30 ~ 1e-15 m/s²) is far below the rounding: a few 1e-16 of V ≈ 6e7
    m²/s² divided by h gives ~1e-9 m/s², ~1e-10 of |g| (1.7e-10 observed); tolerance 1e-9.
    """
    x, y, z = sample_points(12, seed=4)
    p = np.stack([x, y, z], axis=-1)
    g = fsh.sh_gravitation(eigen, x, y, z, device=device)
    step = 40.0
    grad = np.zeros_like(p)
    for k in range(3):
        vals = []
        for s in (-2, -1, 1, 2):
            q = p.copy()
            q[:, k] += s * step
            vals.append(fsh.sh_potential(eigen, q[:, 0], q[:, 1], q[:, 2], device=device))
        grad[:, k] = (vals[0] - 8 * vals[1] + 8 * vals[2] - vals[3]) / (12 * step)
    err = np.linalg.norm(g - grad, axis=-1) / np.linalg.norm(g, axis=-1)
    assert np.max(err) <= 1e-9


@pytest.mark.parametrize("n,m", [(2, 0), (3, 1), (7, 4), (20, 19), (31, 0), (120, 57)])
def test_parity(device, n, m):
    """One coefficient C_nm = S_nm = 1: V(λ, −φ) = (−1)^{n+m} V(λ, φ), g_up alike, g_north odd."""
    C = np.zeros((n + 1, n + 1))
    S = np.zeros((n + 1, n + 1))
    C[n, m] = 1.0
    S[n, m] = 1.0 if m > 0 else 0.0
    model = SHModel("one", GM, R, C, S, n)
    lat = np.radians([5.0, 33.0, 61.0, 89.99])
    lon = np.radians([10.0, -70.0, 123.0, 200.0])
    r = 6.4e6
    x, y, z = r * np.cos(lat) * np.cos(lon), r * np.cos(lat) * np.sin(lon), r * np.sin(lat)
    sign = (-1.0) ** (n + m)
    V_n = fsh.sh_potential(model, x, y, z, device=device)
    V_s = fsh.sh_potential(model, x, y, -z, device=device)
    np.testing.assert_allclose(V_s, sign * V_n, rtol=1e-13, atol=1e-13 * np.max(np.abs(V_n)))
    g_n = fsh.sh_gravitation(model, x, y, z, device=device)
    g_s = fsh.sh_gravitation(model, x, y, -z, device=device)
    # mirroring z -> -z: horizontal-in-xy parts keep the parity sign, the z part flips it
    scale = np.max(np.abs(g_n))
    np.testing.assert_allclose(g_s[:, :2], sign * g_n[:, :2], rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(g_s[:, 2], -sign * g_n[:, 2], rtol=0, atol=1e-13 * scale)


def test_reference_legendre_parity_and_known_values():
    """Reference ALFs: parity and low-degree closed forms.

    P̄10 = √3 t, P̄11 = √3 u, P̄20 = √5 (3t²−1)/2, P̄22 = √(15)/2 u² (Heiskanen & Moritz 1967
    eq. 1-62 with the normalisation of eq. 1-73).
    """
    phi = np.radians([-89.99, -40.0, 0.0, 17.0, 72.0])
    P = ref.legendre_matrix(phi, 60)
    Pm = ref.legendre_matrix(-phi, 60)
    n = np.arange(61)[:, None]
    m = np.arange(61)[None, :]
    np.testing.assert_allclose(Pm, (-1.0) ** (n + m) * P, rtol=1e-13, atol=1e-300)
    t, u = np.sin(phi), np.cos(phi)
    np.testing.assert_allclose(P[:, 1, 0], np.sqrt(3) * t, rtol=1e-15)
    np.testing.assert_allclose(P[:, 1, 1], np.sqrt(3) * u, rtol=1e-15)
    np.testing.assert_allclose(P[:, 2, 0], np.sqrt(5) * (3 * t * t - 1) / 2, rtol=1e-14)
    np.testing.assert_allclose(P[:, 2, 2], np.sqrt(15) / 2 * u * u, rtol=1e-14)


def test_reference_orthonormality():
    """4π normalisation: ∫ P̄nm P̄km dt over [−1, 1] = 2 (2 − δ_m0) δ_nk.

    Heiskanen & Moritz (1967) eq. 1-74 with ∫cos² mλ dλ = π(1 + δ_m0); Gauss-Legendre quadrature
    is exact for these polynomials.
    """
    lmax = 40
    t, w = np.polynomial.legendre.leggauss(lmax + 2)
    P = ref.legendre_matrix(np.arcsin(t), lmax)
    for m in (0, 1, 5, 40):
        G = np.einsum("p,pn,pk->nk", w, P[:, m:, m], P[:, m:, m]) / (2.0 if m == 0 else 4.0)
        np.testing.assert_allclose(G, np.eye(lmax + 1 - m), rtol=0, atol=2e-13)  # 1.6e-14 measured


def test_geodetic_kernel_matches_ecef_path(eigen, device):
    """The geodetic-input kernel equals the ECEF kernel fed with NumPy's geodetic → ECEF."""
    from fieldmap.field.frames import geodetic_to_ecef

    rng = np.random.default_rng(8)
    lat = np.r_[rng.uniform(-90, 90, 30), 90.0, -90.0, 89.99]
    lon = np.r_[rng.uniform(-180, 360, 30), 0.0, 10.0, 20.0]
    h = np.r_[rng.uniform(-500, 5e5, 30), 0.0, 1e4, 0.0]
    g = fsh.sh_gravitation_geodetic(eigen, lat, lon, h, WGS84, lmax=120, device=device)
    x, y, z = geodetic_to_ecef(lat, lon, h, WGS84)
    g2 = fsh.sh_gravitation(eigen, x, y, z, lmax=120, device=device)
    # the two geodetic -> ECEF conversions differ by rounding (~1e-9 m), i.e. ~1e-15 of g
    assert rel_vec(g, g2) <= 1e-13


def test_kernel_model_cache_and_errors():
    """Cache hits by identity and degree; bad degree and the Earth's centre are rejected."""
    from fieldmap.errors import InputError

    model = kaula_model(10)
    a = fsh.kernel_model(model, "cpu")
    assert fsh.kernel_model(model, "cpu") is a
    assert fsh.kernel_model(model, "cpu", lmax=5) is not a
    assert fsh.kernel_model(model, "cpu", lmax=5).lmax == 5
    with pytest.raises(InputError):
        fsh.kernel_model(model, "cpu", lmax=11)
    with pytest.raises(InputError):
        fsh.sh_gravitation(model, 0.0, 0.0, 0.0)
    with pytest.raises(InputError):
        fsh.sh_gravitation(model, np.nan, 0.0, 7e6)
    big = SHModel("big", GM, R, np.zeros((2802, 2802)), np.zeros((2802, 2802)), 2801)
    with pytest.raises(InputError, match="2700"):
        fsh.kernel_model(big, "cpu")
    assert fsh.kernel_model(big, "cpu", lmax=20).lmax == 20


def test_recursion_tables_identities():
    """b_nm = a_nm / a_{n-1,m} and f_nm = (2n+1)/a_nm (algebraic identities of H&F 2002)."""
    tab = fsh.recursion_tables(50)
    a, b, f = tab["anm"], tab["bnm"], tab["fnm"]
    for m in (0, 3, 20):
        n = np.arange(m + 2, 51)
        np.testing.assert_allclose(b[m, n], a[m, n] / a[m, n - 1], rtol=1e-14)
        if m > 0:
            np.testing.assert_allclose(f[m, n], (2 * n + 1) / a[m, n], rtol=1e-14)
    n = np.arange(51)
    np.testing.assert_allclose(f[0], np.sqrt(n * (n + 1) / 2.0), rtol=1e-15)


@pytest.mark.parametrize("h", [0.0, 2e4, 1e5])
def test_zonal_series_vs_exact_normal(device, h):
    """WGS84 zonal J2n series (degree 24) vs the exact level-ellipsoid gravitation."""
    from fieldmap.field import normal
    from fieldmap.field.frames import geodetic_to_ecef

    model = zonal_sh_model(WGS84)
    lat = np.r_[np.linspace(-90, 90, 37), 89.99]
    lon = np.linspace(0, 300, lat.size)
    x, y, z = geodetic_to_ecef(lat, lon, np.full(lat.size, h))
    g = fsh.sh_gravitation(model, x, y, z, device=device)
    gamma = normal.normal_gravitation_ecef(x, y, z, ellipsoid=WGS84, normal="exact", device=device)
    assert rel_vec(g, gamma) <= 1e-13


@wp.kernel
def _columns_kernel(
    model: ksh.SHKernelModel,
    m: wp.array(dtype=int),
    t: wp.array(dtype=wp.float64),
    q: wp.array(dtype=wp.float64),
    single: wp.array2d(dtype=ksh.sh_vec8),
    pair: wp.array2d(dtype=ksh.sh_vec8),
):
    i = wp.tid()
    k = m[i]
    single[i, 0] = ksh.sh_column(model, k, t[2 * i], q[2 * i])
    single[i, 1] = ksh.sh_column(model, k, t[2 * i + 1], q[2 * i + 1])
    single[i, 2] = ksh.sh_column(model, wp.max(k - 1, 0), t[2 * i], q[2 * i])
    if k >= 2:
        p = ksh.sh_column_pair(model, k, t[2 * i], q[2 * i])
        pair[i, 0] = p[0]
        pair[i, 1] = p[1]


def test_column_variants_match_sh_column(eigen, device):
    """sh_column_pair (orders m, m-1, as the point kernel runs them) equals sh_column."""
    ms = np.array([2, 3, 7, 50, 121, 239, 240, 0, 1], dtype=np.int32)
    rng = np.random.default_rng(9)
    t = np.sin(np.radians(np.r_[rng.uniform(-90, 90, 2 * ms.size - 2), 89.99, -90.0]))
    q = eigen.radius / (6378137.0 + np.r_[rng.uniform(0, 1e6, 2 * ms.size - 2), 0.0, 1e5])
    km = fsh.kernel_model(eigen, device)
    out = [wp.zeros((ms.size, n), dtype=ksh.sh_vec8, device=device) for n in (3, 2)]
    wp.launch(
        _columns_kernel,
        dim=ms.size,
        device=device,
        inputs=[
            km,
            wp.array(ms, dtype=int, device=device),
            wp.array(t, dtype=wp.float64, device=device),
            wp.array(q, dtype=wp.float64, device=device),
            *out,
        ],
    )
    single, pair = (o.numpy() for o in out)
    assert np.all(single[-1, :2, 6] != 0)  # order 1 carries the m = 0 derivative sum
    p2 = ms >= 2
    for got, want in ((pair[p2, 0, :6], single[p2, 0, :6]), (pair[p2, 1, :6], single[p2, 2, :6])):
        scale = np.max(np.abs(want), axis=1, keepdims=True)
        assert np.all(scale > 0)
        assert np.all(np.abs(got - want) <= 1e-14 * scale)
