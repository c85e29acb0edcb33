"""Point synthesis above degree 2700 (issue 17): the extended-range path against mpmath.

The mpmath synthesis below is written for these tests and shares nothing with the kernels or
the NumPy reference: it runs the plain fully normalised column recursion of P̄nm in 30-digit
arithmetic (mpmath's exponent range is unbounded, so nothing under- or overflows at any degree
or latitude), differentiates the recursion itself for dP̄nm/dφ (d/dφ of ``a t P_{n−1}`` is
``a (u P_{n−1} + t dP_{n−1}/dφ)``) and carries P̄nm/u as its own recursion (seeded with
``u^(m−1)``) for the east component, finite on the axis. The rotation to ECEF is written out here.

Cost control (pure-Python mpmath, ~3e-5 s per degree of one order and point): one call serves
all the points of a model, with the recursion factors and coefficients of each order made once
and the degree sums taken as exact dot products (``mp.fdot``); every column stops at its
highest non-zero coefficient; on the axis (u = 0) the orders above 1 are zero and skipped; near
the poles a dense model is summed in increasing m until three orders in a row add less than
1e-24 of the sums (P̄nm falls off like (n u/2)^m/m!); elsewhere the models keep a few orders
only (all degrees of each) and the kernel evaluates the same models. Results are compared with
1e-13 of |g| (and of |V|).
"""

from __future__ import annotations

import mmap
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
from fieldmap.models.shmodel import SHModel
from fieldmap.reference import sh as ref

GM, R = 3.986004415e14, 6378136.3


def lazy_zeros(n: int) -> np.ndarray:
    """(n, n) float64 zeros whose memory is allocated only where written, 4 KiB at a time.

    ``np.zeros`` asks the kernel for 2 MiB pages on large arrays (transparent huge pages): one
    column written then allocates and clears the whole array (1.9 GB for C and S at degree
    10,800). An anonymous ``mmap`` maps small pages, and pages never written read as zero.
    """
    return np.frombuffer(mmap.mmap(-1, n * n * 8), dtype=np.float64).reshape(n, n)


def kaula(lmax: int, seed: int, orders=None, c00_only_zonal: bool = False) -> SHModel:
    """Kaula-rule model (σ_n = 1e-5/n², C00 = 1, C20 = −4.84165e-4, degree 1 zero).

    ``orders``: keep only these orders (all their degrees); the other coefficients stay zero
    (:func:`lazy_zeros`: pages that are never written cost no memory). ``c00_only_zonal``: the
    zonal column holds C00 and C20 only.
    """
    rng = np.random.default_rng(seed)
    L = int(lmax)
    sig = np.zeros(L + 1)
    sig[2:] = 1e-5 / np.arange(2, L + 1, dtype=np.float64) ** 2
    C = np.zeros((L + 1, L + 1)) if orders is None else lazy_zeros(L + 1)
    S = np.zeros((L + 1, L + 1)) if orders is None else lazy_zeros(L + 1)
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


def _column_tops(model: SHModel, orders=None) -> list[int]:
    """Highest degree with a non-zero C or S in each order m.

    −1 where the column is zero or, with ``orders``, not among them.
    """
    if orders is not None:
        tops = [-1] * (model.lmax + 1)
        for m in orders:
            nz = np.flatnonzero((model.C[:, m] != 0.0) | (model.S[:, m] != 0.0))
            tops[m] = int(nz[-1]) if nz.size else -1
        return tops
    nz = model.C != 0.0
    nz |= model.S != 0.0
    return [int(v) for v in np.where(nz.any(axis=0), model.lmax - np.argmax(nz[::-1], axis=0), -1)]


def mp_synthesis(model: SHModel, points, orders=None, tol="1e-24"):
    """Potential and gravitation (ECEF) of ``model`` at each (x, y, z) of ``points``, 30 digits.

    Returns a list of ``(V, [gx, gy, gz])`` as mpf, one per point. ``orders``: sum these orders
    only (None: all, in increasing m, stopping for a point when three orders in a row add less
    than ``tol`` of its sums). Per order, the recursion factors and the coefficients (mpf) are
    made once for all points; per point, the column runs from its seed and the degree sums are
    exact dot products (``mp.fdot``) of the coefficients with q^n P̄nm, q^n dP̄nm/dφ.
    """
    mp.mp.dps = 30
    geo = []  # r, t, u, λ, q per point
    for x, y, z in points:
        x, y, z = mp.mpf(float(x)), mp.mpf(float(y)), mp.mpf(float(z))
        rho = mp.sqrt(x * x + y * y)
        r = mp.sqrt(rho * rho + z * z)
        geo.append((r, z / r, rho / r, mp.atan2(y, x), mp.mpf(float(model.radius)) / r))
    tops = _column_tops(model, orders)
    qpow = []
    for g in geo:
        qp = [mp.mpf(1)]
        for _ in range(max(tops)):
            qp.append(qp[-1] * g[4])
        qpow.append(qp)
    sums = [[mp.mpf(0)] * 4 for _ in geo]  # V, radial, north, east
    quiet = [0] * len(geo)
    done = [False] * len(geo)
    tol = mp.mpf(tol)
    sect = mp.mpf(1)  # P̄mm / u^m
    for m in range(model.lmax + 1):
        if m == 1:
            sect = mp.sqrt(3)
        elif m > 1:
            sect *= mp.sqrt(mp.mpf(2 * m + 1) / (2 * m))
        if (orders is not None and m not in orders) or all(done):
            continue
        top = tops[m]
        a = [mp.mpf(0)] * (top + 1)
        b = [mp.mpf(0)] * (top + 1)
        for n in range(m + 1, top + 1):
            a[n] = mp.sqrt(mp.mpf((2 * n - 1) * (2 * n + 1)) / ((n - m) * (n + m)))
            if n - m >= 2:
                b[n] = mp.sqrt(
                    mp.mpf((2 * n + 1) * (n + m - 1) * (n - m - 1))
                    / ((n - m) * (n + m) * (2 * n - 3))
                )
        keep = [n for n in range(m, top + 1) if model.C[n, m] != 0.0 or model.S[n, m] != 0.0]
        c = [mp.mpf(float(model.C[n, m])) for n in keep]
        s = [mp.mpf(float(model.S[n, m])) for n in keep]
        c1 = [(n + 1) * v for n, v in zip(keep, c)]
        s1 = [(n + 1) * v for n, v in zip(keep, s)]
        for i, (r, t, u, lam, q) in enumerate(geo):
            if done[i]:
                continue
            # m = 0: recursion of P itself; m >= 1: of W = P/u (P = u W), and of D = dP/dφ
            if m == 0:
                W1, D1 = mp.mpf(1), mp.mpf(0)
            else:
                um1 = u ** (m - 1)
                W1, D1 = sect * um1, -m * t * sect * um1
            W2 = D2 = mp.mpf(0)
            qn_w, qn_d = [], []  # q^n W, q^n D at the degrees in keep
            if W1 == 0 and D1 == 0:  # on the axis (u = 0) every order m >= 2 is zero
                qn_w = qn_d = [mp.mpf(0)] * len(keep)
            else:
                k = 0
                for n in range(m, top + 1):
                    if n > m:
                        P1 = W1 if m == 0 else u * W1
                        W = a[n] * t * W1 - b[n] * W2
                        D = a[n] * (u * P1 + t * D1) - b[n] * D2
                        W2, W1, D2, D1 = W1, W, D1, D
                    if k < len(keep) and keep[k] == n:
                        qn_w.append(qpow[i][n] * W1)
                        qn_d.append(qpow[i][n] * D1)
                        k += 1
            cm, sm = mp.cos(m * lam), mp.sin(m * lam)
            vc, vs = mp.fdot(c, qn_w), mp.fdot(s, qn_w)
            rc, rs = mp.fdot(c1, qn_w), mp.fdot(s1, qn_w)
            cV, cR = vc * cm + vs * sm, rc * cm + rs * sm
            if m > 0:
                cV, cR = u * cV, u * cR
            cN = mp.fdot(c, qn_d) * cm + mp.fdot(s, qn_d) * sm
            cE = m * (vs * cm - vc * sm)
            acc = sums[i]
            acc[0], acc[1], acc[2], acc[3] = acc[0] + cV, acc[1] + cR, acc[2] + cN, acc[3] + cE
            size = max(abs(cV), abs(cR), abs(cN), abs(cE))
            small = size < tol * max(abs(acc[1]), abs(acc[2]), abs(acc[3]))
            quiet[i] = quiet[i] + 1 if small else 0
            if orders is None and quiet[i] >= 3 and m > 2:
                done[i] = True
    out = []
    for (r, t, u, lam, _), (sV, sR, sN, sE) in zip(geo, sums):
        k = mp.mpf(float(model.gm)) / r
        g_up, g_n, g_e = -k / r * sR, k / r * sN, k / r * sE
        cl, sl = mp.cos(lam), mp.sin(lam)
        h = u * g_up - t * g_n
        out.append((k * sV, [h * cl - g_e * sl, h * sl + g_e * cl, t * g_up + u * g_n]))
    return out


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
    keys = [(model.name, None if orders is None else tuple(orders), p[:3]) for p in points]
    todo = [i for i, key in enumerate(keys) if key not in _MP]
    for i, (V_mp, g_mp) in zip(todo, mp_synthesis(model, [pts[i] for i in todo], orders)):
        _MP[keys[i]] = (float(V_mp), np.array([float(c) for c in g_mp]))
    eg = ev = 0.0
    for i, p in enumerate(points):
        tol = p[3] if len(p) > 3 else 1e-13
        V_mp, g_mp = _MP[keys[i]]
        assert np.all(np.isfinite(g[i])) and np.isfinite(v[i])
        err_g = float(np.linalg.norm(g[i] - g_mp) / np.linalg.norm(g_mp))
        err_v = abs(v[i] - V_mp) / abs(V_mp)
        print(f"{model.name} {p[:3]}: g {err_g:.2e}, V {err_v:.2e} (tolerance {tol:.0e})")
        eg, ev = max(eg, err_g / tol), max(ev, err_v / tol)
    return eg, ev


# ---------------------------------------------------------------------------------- fast


def test_limits_points_and_grids():
    """Points and grids accept degree > 2700 (extended range); the table struct refuses it."""
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
    out = synthesize(big, grid, device="cpu")  # the extended-range grid pass (test_grid_xrange)
    assert np.all(np.isfinite(out))
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
#
# Cost and memory (~70 s on 2 CPU cores): the degree-5540 ICGEM file (15.4 M lines) is parsed
# once per session, ~30 s and ~6 GB at the reader's peak (its per-token index arrays), and the
# CLI finds it in the parsed-model cache; mpmath runs once per model for all its points; the
# structs of the extended-range path (0.25 GB at degree 5540, 0.93 GB at 10,800: packed
# coefficients) are dropped after each test (:func:`_drop_kernel_models`), sparse models take
# memory only for their non-zero columns (:func:`lazy_zeros`), and the dense model lives only as
# long as the tests that use it (class-scoped fixtures).

POLES = [(90.0, 0.0, 0.0, INSIDE_TOL), (-90.0, 0.0, 2e4), (89.999, 30.0, 0.0, INSIDE_TOL)]


def _drop_kernel_models() -> None:
    """Forget the device structs and packed coefficients of fieldmap.field.sh (its caches)."""
    with fsh._cache_lock:
        fsh._cache.clear()
        fsh._coefs.clear()


@pytest.fixture
def free_structs():
    """Drop the cached device structs after the test (see :func:`_drop_kernel_models`)."""
    yield
    _drop_kernel_models()


XGM_ORDERS = [0, 1, 2770, 5000, 5539, 5540]


def write_xgm_like(path, model: SHModel) -> None:
    """ICGEM file with an XGM2019e-style header, every (n, m) line (15.4 M at degree 5540).

    The reader wants a line for every coefficient: zeros are written ``gfc n m 0 0``, the others
    with the shortest decimals that read back to the same doubles (``repr``); 0.27 GB in all.
    """
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
    zero = [f" {m} 0 0\n" for m in range(model.lmax + 1)]
    nz = (model.C != 0.0) | (model.S != 0.0)
    with open(path, "w") as f:
        f.write(head)
        for n in range(model.lmax + 1):
            row = zero[: n + 1]
            for m in np.flatnonzero(nz[n, : n + 1]):
                row[m] = f" {m} {float(model.C[n, m])!r} {float(model.S[n, m])!r}\n"
            key = f"gfc {n}"
            f.write(key + key.join(row))


@pytest.fixture(scope="class")
def xgm_file(tmp_path_factory):
    """Write the degree-5540 file (orders XGM_ORDERS) and read it back, for TestXGMFile.

    Read through :func:`fieldmap.load_model` with a model cache of its own: the parsed
    coefficients are stored there, and the CLI test loads them from it instead of parsing the
    15.4 M lines again (~30 s, ~6 GB peak). Yields ``(path, model, cache folder)``.
    """
    from fieldmap import config
    from fieldmap.models.registry import load_model

    path = tmp_path_factory.mktemp("xgm") / "XGM2019e_like.gfc"
    cache_root = str(tmp_path_factory.mktemp("xgm-cache"))
    written = kaula(5540, seed=2019, orders=XGM_ORDERS)
    write_xgm_like(path, written)
    saved = os.environ.get("FIELDMAP_MODEL_CACHE")
    os.environ["FIELDMAP_MODEL_CACHE"] = cache_root
    config.reload()
    try:
        model = load_model(path)
    finally:
        if saved is None:
            os.environ.pop("FIELDMAP_MODEL_CACHE")
        else:
            os.environ["FIELDMAP_MODEL_CACHE"] = saved
        config.reload()
    assert np.array_equal(model.C, written.C) and np.array_equal(model.S, written.S)
    del written
    yield path, model, cache_root
    _drop_kernel_models()


class TestXGMFile:
    """A degree-5540 ICGEM file: the reader at max_degree 5540, the kernel, the CLI."""

    @pytest.mark.slow
    def test_degree5540_icgem_file_vs_mpmath(self, xgm_file, device, free_structs):
        """XGM2019e-like file read by the reader: 0°, 89°, 89.999°, ±90°, h = 0 and 20 km."""
        _, model, _ = xgm_file
        assert model.lmax == 5540 and model.C[5540, 5540] != 0.0
        pts = [(0.0, 10.0, 0.0), (0.0, 250.0, 2e4), (89.0, 40.0, 2e4), (89.999, 200.0, 2e4)]
        pts += [(89.999, 20.0, 0.0, INSIDE_TOL), (90.0, 0.0, 0.0, INSIDE_TOL), (-90.0, 0.0, 2e4)]
        eg, ev = compare(model, pts, orders=XGM_ORDERS, device=device)
        assert eg <= 1.0 and ev <= 1.0

    @pytest.mark.slow
    def test_degree5540_cli_point(self, xgm_file):
        """``fieldmap point --model FILE`` on the degree-5540 file: finite, as the Python API.

        The child process is given the fixture's model cache, which holds the parsed file: it
        hashes the file, finds the entry and loads the coefficients (memory-mapped); a parse
        would have stored a second entry.
        """
        from fieldmap.models import cache as disk_cache

        path, _, cache_root = xgm_file
        entries = disk_cache.info(cache_root)
        assert len(entries) == 1 and entries[0]["files"] == [os.path.realpath(path)], entries
        env = dict(os.environ, FIELDMAP_MODEL_CACHE=cache_root)
        res = subprocess.run(
            [sys.executable, "-m", "fieldmap", "point", "--model", str(path)]
            + ["--quantity", "gravity", "--precision", "12", "--device", "cpu"],
            input="0 10 0\n89.999 200 0\n90 0 0\n-90 0 20000\n",
            capture_output=True,
            text=True,
            env=env,
            timeout=300,
        )
        assert res.returncode == 0, res.stderr
        assert disk_cache.info(cache_root) == entries  # read from the cache, not parsed again
        rows = np.array([[float(v) for v in line.split()] for line in res.stdout.splitlines()])
        assert rows.shape == (4, 3) and np.all(np.isfinite(rows))
        # equator and -90° at 20 km: ~9.78 m/s²; 89.999° and +90° at h = 0 lie inside the
        # sphere, where this Kaula model's order-1 degrees (q^5540 = 1.2e8) make |g| ~ 2e3 m/s²
        # (true value)
        assert np.all(np.abs(np.linalg.norm(rows[[0, 3]], axis=1) - 9.78) < 0.02)


@pytest.fixture(scope="class")
def dense5540():
    """Dense degree-5540 Kaula model, for TestDense5540 (freed after it)."""
    yield kaula(5540, seed=5540)
    _drop_kernel_models()


class TestDense5540:
    """A dense degree-5540 Kaula model (0.5 GB) against mpmath and the NumPy reference."""

    @pytest.mark.slow
    def test_degree5540_dense_poles_vs_mpmath(self, dense5540, device, free_structs):
        """All orders on the axis, +90° (h = 0, inside the sphere) and −90° (20 km), vs mpmath.

        On the axis (u = 0) only orders 0 and 1 contribute: the kernel skips every order above
        1 there and gives the same bits for the model's orders 0 and 1 alone (checked here; the
        degree-10,800 test on the axis relies on it).
        """
        eg, ev = compare(dense5540, POLES[:2], device=device)
        assert eg <= 1.0 and ev <= 1.0
        C, S = lazy_zeros(5541), lazy_zeros(5541)
        C[:, :2], S[:, :2] = dense5540.C[:, :2], dense5540.S[:, :2]
        low = SHModel("kaula-5540-orders-0-1", GM, R, C, S, 5540)
        x, y, z = (np.array(c) for c in zip(*[ecef(*p[:3]) for p in POLES[:2]]))
        for f in (fsh.sh_gravitation, fsh.sh_potential):
            want = f(dense5540, x, y, z, device=device)
            assert f(low, x, y, z, device=device).tobytes() == want.tobytes()

    @pytest.mark.slow
    def test_degree5540_dense_vs_reference(self, dense5540, device, free_structs):
        """Kernel vs the NumPy X-number reference, all orders, equator to pole (1e-13)."""
        pts = [(0.0, 0.0, 0.0), (89.0, -30.0, 2e4), (89.999, 30.0, 0.0, INSIDE_TOL)]
        x, y, z = (np.array(c) for c in zip(*[ecef(*p[:3]) for p in pts]))
        g = fsh.sh_gravitation(dense5540, x, y, z, device=device)
        v = fsh.sh_potential(dense5540, x, y, z, device=device)
        # ref.potential and ref.gravitation_ecef in one pass of the reference
        v_ref, ge, gn, gu = ref.spherical_gradient(dense5540, x, y, z)
        lam, phi = np.arctan2(y, x), np.arctan2(z, np.hypot(x, y))
        east = np.stack([-np.sin(lam), np.cos(lam), np.zeros_like(lam)], axis=-1)
        north = np.stack(
            [-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)], axis=-1
        )
        up = np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)
        g_ref = ge[:, None] * east + gn[:, None] * north + gu[:, None] * up
        tol = np.array([p[3] if len(p) > 3 else 1e-13 for p in pts])
        assert np.all(np.linalg.norm(g - g_ref, axis=-1) / np.linalg.norm(g_ref, axis=-1) <= tol)
        assert np.all(np.abs(v - v_ref) / np.abs(v_ref) <= tol)

    @pytest.mark.slow
    def test_degree5540_dense_grid_vs_points(self, dense5540, device, free_structs):
        """The extended-range grid pass = the point path (checked above) on rows pole to pole.

        Rows -90°, -60°, 0°, 45°, 60°, 75°, 89°, 89.75°, 90° at two longitudes, 20 km: 1e-13 of
        |g|; and the field of degrees 3..5540 alone (C00 and C20 removed) to 1e-13 of its
        largest value on the rows up to 75° (2e-17 m/s² measured). Near the poles a point at
        20 km still lies inside the reference sphere (q^5540 = 3.3 at the poles) and the degree
        sums cancel: there the point path, the NumPy reference and mpmath differ by ~1e-13 m/s²
        among themselves (1e-14 of |g|), which the first check covers.
        """
        from fieldmap.field.gravity import gravitation
        from fieldmap.grids.synthesis import GridSpec, synthesize
        from fieldmap.grids.tables import _cache as grid_table_cache

        lat = np.array([-90.0, -60.0, 0.0, 45.0, 60.0, 75.0, 89.0, 89.75, 90.0])
        lon = np.array([10.0, 137.5])
        grid = GridSpec(lat, lon, np.array([2e4]), 0.25)
        la, lo = np.meshgrid(lat, lon, indexing="ij")
        out = synthesize(dense5540, grid, quantity="gravitation", device=device)[0]
        pts = gravitation(la, lo, 2e4, model=dense5540, device=device)
        g = np.linalg.norm(pts, axis=-1)
        assert np.max(np.linalg.norm(out - pts, axis=-1) / g) <= 1e-13
        C, S = dense5540.C.copy(), dense5540.S.copy()
        C[0, 0] = C[2, 0] = 0.0
        anom = SHModel("kaula-5540-anomalous", GM, R, C, S, 5540)
        mid = np.abs(lat) <= 75.0
        grid = GridSpec(lat[mid], lon, np.array([2e4]), 0.25)
        out = synthesize(anom, grid, quantity="gravitation", device=device)[0]
        pts = gravitation(la[mid], lo[mid], 2e4, model=anom, device=device)
        assert np.max(np.abs(out - pts)) <= 1e-13 * np.max(np.abs(pts))
        del anom, C, S
        grid_table_cache.clear()


L_MAX = 10800
ORDERS_10800 = [0, 2, 2000, 5400, 9000, 10000, 10799, 10800]


@pytest.mark.slow
def test_degree10800_orders_vs_mpmath(device, free_structs):
    """Orders up to 10,800 at 0°, 89°, 89.999°, h = 0 and 20 km vs mpmath (1e-13)."""
    model = kaula(L_MAX, seed=10800, orders=ORDERS_10800, c00_only_zonal=True)
    pts = [(0.0, 10.0, 0.0), (89.0, 40.0, 2e4), (89.999, 200.0, 2e4), (-90.0, 0.0, 0.0, INSIDE_TOL)]
    eg, ev = compare(model, pts, orders=ORDERS_10800, device=device)
    assert eg <= 1.0 and ev <= 1.0
    # the high orders alone, relative to their own size (no C00 to hide behind)
    _drop_kernel_models()
    C, S = lazy_zeros(L_MAX + 1), lazy_zeros(L_MAX + 1)
    for m in ORDERS_10800[4:]:
        C[m:, m], S[m:, m] = model.C[m:, m], model.S[m:, m]
    del model
    hi = SHModel("kaula-10800-high", GM, R, C, S, L_MAX)
    eg, ev = compare(
        hi, [(0.0, 10.0, 0.0, 1e-11), (1.0, 123.0, 2e4, 1e-11)], orders=ORDERS_10800[4:]
    )
    assert eg <= 1.0 and ev <= 1.0


@pytest.mark.slow
def test_degree10800_poles_vs_mpmath(device, free_structs):
    """Degree 10,800 on the axis (+90° at h = 0, −90° at 20 km) vs mpmath (1e-13).

    Orders 0 and 1 dense (all degrees), the others zero: on the axis no other order
    contributes, and the kernel gives the same bits as for a dense model
    (:meth:`TestDense5540.test_degree5540_dense_poles_vs_mpmath`) without its 1.9 GB.
    """
    model = kaula(L_MAX, seed=108, orders=[0, 1])
    eg, ev = compare(model, POLES[:2], orders=[0, 1], device=device)
    assert eg <= 1.0 and ev <= 1.0
