"""Point synthesis above degree 2700 (issue 17): the extended-range path against mpmath.

The mpmath synthesis below is written for these tests and shares nothing with the kernels or
the NumPy reference: it runs the plain fully normalised column recursion of P̄nm in 30-digit
arithmetic (mpmath's exponent range is unbounded, so nothing under- or overflows at any degree
or latitude), differentiates the recursion itself for dP̄nm/dφ (d/dφ of ``a t P_{n−1}`` is
``a (u P_{n−1} + t dP_{n−1}/dφ)``) and carries P̄nm/u as its own recursion (seeded with
``u^(m−1)``) for the east component, finite on the axis. The rotation to ECEF is written out here.

Cost control (pure-Python mpmath, ~1e-4 s per degree of one order): every column stops at its
highest non-zero coefficient; near the poles a dense model is summed in increasing m until three
orders in a row add less than 1e-24 of the sums (P̄nm falls off like (n u/2)^m/m!); elsewhere the
models keep a few orders only (all degrees of each) and the kernel evaluates the same models.
Results are compared with 1e-13 of |g| (and of |V|).
"""

from __future__ import annotations

import os
import subprocess
import sys

import mpmath as mp
import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field import sh as fsh
from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.frames import geodetic_to_ecef
from fieldmap.models.icgem import read_icgem
from fieldmap.models.shmodel import SHModel
from fieldmap.reference import sh as ref

GM, R = 3.986004415e14, 6378136.3


def kaula(lmax: int, seed: int, orders=None, c00_only_zonal: bool = False) -> SHModel:
    """Kaula-rule model (σ_n = 1e-5/n², C00 = 1, C20 = −4.84165e-4, degree 1 zero).

    ``orders``: keep only these orders (all their degrees); the other coefficients stay zero
    (``np.zeros`` pages that are never written cost no memory). ``c00_only_zonal``: the zonal
    column holds C00 and C20 only.
    """
    rng = np.random.default_rng(seed)
    L = int(lmax)
    sig = np.zeros(L + 1)
    sig[2:] = 1e-5 / np.arange(2, L + 1, dtype=np.float64) ** 2
    C = np.zeros((L + 1, L + 1))
    S = np.zeros((L + 1, L + 1))
    if orders is None:
        for A in (C, S):
            rng.standard_normal(out=A)
            A *= sig[:, None]
            for n in range(L + 1):
                A[n, n + 1 :] = 0.0
    else:
        for m in orders:
            C[m:, m] = rng.standard_normal(L + 1 - m) * sig[m:]
            S[m:, m] = rng.standard_normal(L + 1 - m) * sig[m:]
    S[:, 0] = 0.0
    C[1, :], S[1, :] = 0.0, 0.0
    if c00_only_zonal:
        C[:, 0] = 0.0
    C[0, 0] = 1.0
    C[2, 0] = -4.84165e-4
    return SHModel(f"kaula-{L}-seed{seed}", GM, R, C, S, L, source="synthetic")


def mp_synthesis(model: SHModel, x, y, z, orders=None, tol="1e-24"):
    """Potential and gravitation (ECEF) of ``model`` at (x, y, z) in mpmath, 30 digits.

    Returns ``(V, [gx, gy, gz])`` as mpf. ``orders``: sum these orders only (None: all, in
    increasing m, stopping when three orders in a row add less than ``tol`` of the sums).
    """
    mp.mp.dps = 30
    x, y, z = mp.mpf(float(x)), mp.mpf(float(y)), mp.mpf(float(z))
    rho = mp.sqrt(x * x + y * y)
    r = mp.sqrt(rho * rho + z * z)
    t, u = z / r, rho / r
    lam = mp.atan2(y, x)
    q = mp.mpf(float(model.radius)) / r
    L = model.lmax
    nz = (model.C != 0.0) | (model.S != 0.0)
    tops = [int(np.flatnonzero(nz[:, m])[-1]) if nz[:, m].any() else -1 for m in range(L + 1)]
    top_all = max(tops)
    qpow = [mp.mpf(1)]
    for _ in range(top_all):
        qpow.append(qpow[-1] * q)
    sV = sR = sN = sE = mp.mpf(0)
    sect = mp.mpf(1)  # P̄mm / u^m
    quiet = 0
    tol = mp.mpf(tol)
    for m in range(L + 1):
        if m == 1:
            sect = mp.sqrt(3)
        elif m > 1:
            sect *= mp.sqrt(mp.mpf(2 * m + 1) / (2 * m))
        if orders is not None and m not in orders:
            continue
        cm, sm = mp.cos(m * lam), mp.sin(m * lam)
        # m = 0: recursion of P itself; m >= 1: of W = P/u (P = u W), and of D = dP/dφ
        if m == 0:
            W1, D1 = mp.mpf(1), mp.mpf(0)
        else:
            um1 = u ** (m - 1)
            W1, D1 = sect * um1, -m * t * sect * um1
        W2 = D2 = mp.mpf(0)
        cV = cR = cN = cE = mp.mpf(0)
        Ccol = model.C[:, m]
        Scol = model.S[:, m]
        for n in range(m, tops[m] + 1):
            if n > m:
                a = mp.sqrt(mp.mpf((2 * n - 1) * (2 * n + 1)) / ((n - m) * (n + m)))
                if n - m >= 2:
                    b = mp.sqrt(
                        mp.mpf((2 * n + 1) * (n + m - 1) * (n - m - 1))
                        / ((n - m) * (n + m) * (2 * n - 3))
                    )
                else:
                    b = mp.mpf(0)
                P1 = W1 if m == 0 else u * W1
                W = a * t * W1 - b * W2
                D = a * (u * P1 + t * D1) - b * D2
                W2, W1, D2, D1 = W1, W, D1, D
            c, s = float(Ccol[n]), float(Scol[n])
            if c == 0.0 and s == 0.0:
                continue
            P = W1 if m == 0 else u * W1
            A = (c * cm + s * sm) * qpow[n]
            cV += A * P
            cR += (n + 1) * A * P
            cN += A * D1
            if m > 0:
                cE += m * (s * cm - c * sm) * qpow[n] * W1
        sV, sR, sN, sE = sV + cV, sR + cR, sN + cN, sE + cE
        size = max(abs(cV), abs(cR), abs(cN), abs(cE))
        quiet = quiet + 1 if size < tol * max(abs(sR), abs(sN), abs(sE)) else 0
        if orders is None and quiet >= 3 and m > 2:
            break
    k = mp.mpf(float(model.gm)) / r
    g_up, g_n, g_e = -k / r * sR, k / r * sN, k / r * sE
    cl, sl = mp.cos(lam), mp.sin(lam)
    h = u * g_up - t * g_n
    return k * sV, [h * cl - g_e * sl, h * sl + g_e * cl, t * g_up + u * g_n]


def ecef(lat_deg, lon_deg, h):
    """WGS84 geodetic point (exactly on the axis at ±90°, at z = ±(b + h)).

    Near the poles at h = 0 the point lies inside the reference sphere (r = b < R, q = R/r =
    1.0034, q^10800 ~ 6e15): the high-degree terms of a Kaula model are then large, and the
    check covers the growth of the folded powers q^n as well.
    """
    if abs(lat_deg) == 90.0:
        return 0.0, 0.0, float(np.sign(lat_deg)) * (WGS84.b + h)
    x, y, z = geodetic_to_ecef(lat_deg, lon_deg, h, WGS84)
    return float(x), float(y), float(z)


_MP = {}  # (model name, orders, point) -> (V, g) as floats


#: Bound for points inside the reference sphere near the poles (h = 0 above ~88°: r < R): there
#: q^n reaches 1.2e8 (degree 5540) or 6e15 (10,800) and the Kaula high degrees dominate |g|;
#: float64 rounding of t = sin φ (1e-16 absolute) alone moves P̄nm near t = ±1 by ~n²·1e-16/2
#: (dP̄/dt ~ n²/2 P̄ there), and the forward recursion at t = ±1 gathers a few 1e-12 along n, so
#: 1e-13 of |g| is out of reach of any float64 recursion in t there (measured on the axis at
#: h = 0: 4.5e-10 at degree 5540, 2.3e-9 at 10,800).
INSIDE_TOL = 5e-9


def compare(model, points, orders=None, device="cpu"):
    """Worst relative differences (g, V) of the kernel vs mpmath at ``points``.

    Each point is ``(lat, lon, h)`` (tolerance 1e-13) or ``(lat, lon, h, tol)``; returns the
    worst ratios error/tolerance for g and for V (the test passes when both are <= 1).
    """
    pts = [ecef(*p[:3]) for p in points]
    x, y, z = (np.array(c) for c in zip(*pts))
    g = fsh.sh_gravitation(model, x, y, z, device=device)
    v = fsh.sh_potential(model, x, y, z, device=device)
    eg = ev = 0.0
    for i, p in enumerate(points):
        tol = p[3] if len(p) > 3 else 1e-13
        key = (model.name, None if orders is None else tuple(orders), p[:3])
        if key not in _MP:
            V_mp, g_mp = mp_synthesis(model, *pts[i], orders=orders)
            _MP[key] = (float(V_mp), np.array([float(c) for c in g_mp]))
        V_mp, g_mp = _MP[key]
        assert np.all(np.isfinite(g[i])) and np.isfinite(v[i])
        err_g = float(np.linalg.norm(g[i] - g_mp) / np.linalg.norm(g_mp))
        err_v = abs(v[i] - V_mp) / abs(V_mp)
        print(f"{model.name} {p[:3]}: g {err_g:.2e}, V {err_v:.2e} (tolerance {tol:.0e})")
        eg, ev = max(eg, err_g / tol), max(ev, err_v / tol)
    return eg, ev


# ---------------------------------------------------------------------------------- fast


def test_limits_points_and_grids():
    """Points accept degree > 2700 (extended range), grids and the default struct refuse it."""
    big = kaula(2710, seed=1, orders=[2, 2710])
    with pytest.raises(InputError, match="2700"):
        fsh.kernel_model(big, "cpu")
    km = fsh.kernel_model(big, "cpu", points=True)
    assert km.xrange == 1 and km.lmax == 2710
    assert fsh.kernel_model(big, "cpu", lmax=2700, points=True).xrange == 0
    g = fsh.sh_gravitation(big, 0.0, 0.0, 6.4e6)
    assert np.all(np.isfinite(g))
    from fieldmap.grids.spec import make_grid
    from fieldmap.grids.synthesis import synthesize

    grid = make_grid(1.0, region=(0.0, 2.0, 0.0, 2.0), heights_m=(0.0,))
    with pytest.raises(InputError, match="2700"):
        synthesize(big, grid, device="cpu")
    # above the readers' 10,800: refused before anything is allocated (zero-stride arrays)
    huge = np.broadcast_to(np.float64(0.0), (10802, 10802))
    with pytest.raises(InputError, match="10800"):
        fsh.kernel_model(SHModel("huge", GM, R, huge, huge, 10801), "cpu", points=True)


@pytest.mark.parametrize("lmax", [2, 240])
def test_xrange_equals_scaled_recursion(lmax, device):
    """At degree <= 2700 the extended-range path equals the 1e-280 / Horner path (1e-14)."""
    import warp as wp
    from fieldmap.kernels import sh as ksh

    model = kaula(lmax, seed=7)
    lat = [0.0, 10.0, -45.0, 70.0, 89.0, 89.999, 90.0, -90.0, -89.99]
    lon = [0.0, 20.0, 190.0, 33.0, 5.0, 300.0, 0.0, 0.0, 77.0]
    h = [0.0, 2e4, 0.0, 5e5, 0.0, 2e4, 0.0, 1e3, 0.0]
    pos = np.array([ecef(*p) for p in zip(lat, lon, h)])
    out = {}
    for xr in (False, True):
        km = fsh.kernel_model(model, device, points=True, xrange=xr)
        pa = wp.array(pos, dtype=wp.vec3d, device=device)
        g = wp.zeros(len(pos), dtype=wp.vec3d, device=device)
        v = wp.zeros(len(pos), dtype=wp.float64, device=device)
        wp.launch(ksh.sh_points_ecef_kernel, dim=len(pos), inputs=[km, pa, g, 0], device=device)
        wp.launch(ksh.sh_potential_kernel, dim=len(pos), inputs=[km, pa, v, 0], device=device)
        out[xr] = g.numpy(), v.numpy()
    (g0, v0), (g1, v1) = out[False], out[True]
    assert np.max(np.linalg.norm(g1 - g0, axis=-1) / np.linalg.norm(g0, axis=-1)) <= 1e-14
    assert np.max(np.abs(v1 - v0) / np.abs(v0)) <= 1e-14


def test_pack_coefficients():
    """Packed (C, S): column m from row m (2L+3−m)/2, degrees m..L."""
    model = kaula(300, seed=3)
    cs = fsh.pack_coefficients(model, 300)
    for m in (0, 1, 150, 299, 300):
        off = m * (2 * 300 + 3 - m) // 2
        np.testing.assert_array_equal(cs[off : off + 301 - m, 0], model.C[m:, m])
        np.testing.assert_array_equal(cs[off : off + 301 - m, 1], model.S[m:, m])
    assert cs.shape == (301 * 302 // 2, 2)


def test_degree2800_vs_mpmath_and_reference(device):
    """Degree 2800 (extended range, just above the old limit): mpmath and the NumPy reference."""
    orders = [0, 1, 1400, 2799, 2800]
    model = kaula(2800, seed=2800, orders=orders, c00_only_zonal=True)
    pts = [(0.0, 10.0, 0.0), (89.999, 200.0, 0.0, INSIDE_TOL), (-90.0, 0.0, 2e4)]
    eg, ev = compare(model, pts, orders=orders, device=device)
    assert eg <= 1.0 and ev <= 1.0
    x, y, z = (np.array(c) for c in zip(*[ecef(*p[:3]) for p in pts]))
    g = fsh.sh_gravitation(model, x, y, z, device=device)
    g_ref = ref.gravitation_ecef(model, x, y, z)
    tol = np.array([p[3] if len(p) > 3 else 1e-13 for p in pts])
    assert np.all(np.linalg.norm(g - g_ref, axis=-1) / np.linalg.norm(g_ref, axis=-1) <= tol)


# ---------------------------------------------------------------------------------- slow

POLES = [(90.0, 0.0, 0.0, INSIDE_TOL), (-90.0, 0.0, 2e4), (89.999, 30.0, 0.0, INSIDE_TOL)]


@pytest.fixture(scope="module")
def dense5540():
    """Dense degree-5540 Kaula model."""
    return kaula(5540, seed=5540)


@pytest.mark.slow
def test_degree5540_dense_poles_vs_mpmath(dense5540, device):
    """All orders on the axis, +90° (h = 0, inside the sphere) and −90° (20 km), vs mpmath."""
    eg, ev = compare(dense5540, POLES[:2], device=device)
    assert eg <= 1.0 and ev <= 1.0


@pytest.mark.slow
def test_degree5540_dense_vs_reference(dense5540, device):
    """Kernel vs the NumPy X-number reference, all orders, equator to pole (1e-13)."""
    pts = [(0.0, 0.0, 0.0), (89.0, -30.0, 2e4), (89.999, 30.0, 0.0, INSIDE_TOL)]
    x, y, z = (np.array(c) for c in zip(*[ecef(*p[:3]) for p in pts]))
    g = fsh.sh_gravitation(dense5540, x, y, z, device=device)
    g_ref = ref.gravitation_ecef(dense5540, x, y, z)
    v = fsh.sh_potential(dense5540, x, y, z, device=device)
    v_ref = ref.potential(dense5540, x, y, z)
    tol = np.array([p[3] if len(p) > 3 else 1e-13 for p in pts])
    assert np.all(np.linalg.norm(g - g_ref, axis=-1) / np.linalg.norm(g_ref, axis=-1) <= tol)
    assert np.all(np.abs(v - v_ref) / np.abs(v_ref) <= tol)


XGM_ORDERS = [0, 1, 2770, 5000, 5539, 5540]


def write_xgm_like(path, model: SHModel) -> None:
    """ICGEM file with an XGM2019e-style header, every (n, m) line (15.4 M at degree 5540)."""
    head = """XGM2019e-like test model (synthetic Kaula coefficients)
begin_of_head ==================================================================
generating_institute      fieldmap tests
product_type              gravity_field
modelname                 XGM2019e_2159_like
earth_gravity_constant    0.3986004415E+15
radius                    0.63781363E+07
max_degree                5540
errors                    no
norm                      fully_normalized
tide_system               tide_free

key     L     M         C                          S
end_of_head ====================================================================
"""
    nz = (model.C != 0.0) | (model.S != 0.0)
    with open(path, "w") as f:
        f.write(head)
        for n in range(model.lmax + 1):  # the reader wants every line: zeros written short
            f.write(
                "".join(
                    f"gfc {n:5d} {m:5d} {model.C[n, m]: .18E} {model.S[n, m]: .18E}\n"
                    if nz[n, m]
                    else f"gfc {n:5d} {m:5d}  0.0  0.0\n"
                    for m in range(n + 1)
                )
            )


@pytest.fixture(scope="module")
def xgm_file(tmp_path_factory):
    """Degree-5540 ICGEM file (orders XGM_ORDERS) and the model read back from it."""
    path = tmp_path_factory.mktemp("xgm") / "XGM2019e_like.gfc"
    write_xgm_like(path, kaula(5540, seed=2019, orders=XGM_ORDERS))
    return path, read_icgem(path)


@pytest.mark.slow
def test_degree5540_icgem_file_vs_mpmath(xgm_file, device):
    """XGM2019e-like file read by the reader: 0°, 89°, 89.999°, ±90°, h = 0 and 20 km."""
    _, model = xgm_file
    assert model.lmax == 5540 and model.C[5540, 5540] != 0.0
    pts = [(0.0, 10.0, 0.0), (0.0, 250.0, 2e4), (89.0, 40.0, 2e4), (89.999, 200.0, 2e4)]
    pts += [(89.999, 20.0, 0.0, INSIDE_TOL), (90.0, 0.0, 0.0, INSIDE_TOL), (-90.0, 0.0, 2e4)]
    eg, ev = compare(model, pts, orders=XGM_ORDERS, device=device)
    assert eg <= 1.0 and ev <= 1.0


@pytest.mark.slow
def test_degree5540_cli_point(xgm_file, tmp_path):
    """``fieldmap point --model FILE`` on the degree-5540 file: finite, as the Python API."""
    path, model = xgm_file
    env = dict(os.environ, FIELDMAP_MODEL_CACHE=str(tmp_path / "cache"))
    res = subprocess.run(
        [sys.executable, "-m", "fieldmap", "point", "--model", str(path), "--quantity", "gravity"]
        + ["--precision", "12", "--device", "cpu"],
        input="0 10 0\n89.999 200 0\n90 0 0\n-90 0 20000\n",
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    rows = np.array([[float(v) for v in line.split()] for line in res.stdout.splitlines()])
    assert rows.shape == (4, 3) and np.all(np.isfinite(rows))
    # equator and -90° at 20 km: ~9.78 m/s²; 89.999° and +90° at h = 0 lie inside the sphere,
    # where this Kaula model's order-1 degrees (q^5540 = 1.2e8) make |g| ~ 2e3 m/s² (true value)
    assert np.all(np.abs(np.linalg.norm(rows[[0, 3]], axis=1) - 9.78) < 0.02)


L_MAX = 10800
ORDERS_10800 = [0, 2, 2000, 5400, 9000, 10000, 10799, 10800]


@pytest.mark.slow
def test_degree10800_orders_vs_mpmath(device):
    """Orders up to 10,800 at 0°, 89°, 89.999°, h = 0 and 20 km vs mpmath (1e-13)."""
    model = kaula(L_MAX, seed=10800, orders=ORDERS_10800, c00_only_zonal=True)
    pts = [(0.0, 10.0, 0.0), (89.0, 40.0, 2e4), (89.999, 200.0, 2e4), (-90.0, 0.0, 0.0, INSIDE_TOL)]
    eg, ev = compare(model, pts, orders=ORDERS_10800, device=device)
    assert eg <= 1.0 and ev <= 1.0
    # the high orders alone, relative to their own size (no C00 to hide behind)
    C, S = model.C.copy(), model.S.copy()
    C[:, :9000], S[:, :9000] = 0.0, 0.0
    hi = SHModel("kaula-10800-high", GM, R, C, S, L_MAX)
    eg, ev = compare(
        hi, [(0.0, 10.0, 0.0, 1e-11), (1.0, 123.0, 2e4, 1e-11)], orders=ORDERS_10800[4:]
    )
    assert eg <= 1.0 and ev <= 1.0


@pytest.mark.slow
def test_degree10800_dense_poles_vs_mpmath(device):
    """Dense degree-10,800 Kaula model on the axis (+90°, −90° at 20 km) vs mpmath (1e-13)."""
    model = kaula(L_MAX, seed=108)
    eg, ev = compare(model, POLES[:2], device=device)
    assert eg <= 1.0 and ev <= 1.0
