"""Degree-2190 synthesis against an independent mpmath evaluation (30 significant digits).

The mpmath code below shares nothing with the kernels: plain (unscaled) fully normalised ALF column
recursions in arbitrary precision (mpmath has no underflow), latitude derivatives from
differentiating the recursion itself, P̄nm/u from a third recursion seeded with u^{m−1}, and the
spherical-to-ECEF rotation written out here.

Cost control (pure-Python mpmath runs ~1e5 operations per second): near the poles P̄nm(t) falls off
like (n u / 2)^m / m!, so the columns are summed in increasing m until three consecutive columns
contribute less than 1e-22 of the result (for u ≤ 1.8e-3, n ≤ 2190 this happens before m ≈ 40, for
88° before m ≈ 150, and the remaining terms decrease monotonically). At mid latitudes all orders
matter, so there the model keeps only a set of orders spread over 0..2190 (all degrees of each), and
the kernel evaluates exactly the same model.
"""

import mpmath as mp
import numpy as np
import pytest

from fieldmap.field import sh as fsh
from fieldmap.models.registry import kaula_model
from fieldmap.models.shmodel import SHModel
from fieldmap.reference import sh as ref

GM, R = 3.986004415e14, 6378136.3
L = 2190


def kaula_orders(lmax, seed, orders):
    """Kaula model with only the orders ``orders`` (and C00, C20) kept."""
    model = kaula_model(lmax, seed=seed)
    drop = ~np.isin(np.arange(lmax + 1), orders)
    C, S = model.C.copy(), model.S.copy()
    C[:, drop], S[:, drop] = 0.0, 0.0
    C[0, 0], C[2, 0] = model.C[0, 0], model.C[2, 0]
    return SHModel(model.name + "-orders", GM, R, C, S, lmax, source="synthetic")


def mp_gravitation(model, x, y, z, orders=None, tol=mp.mpf("1e-22")):
    """Gravitation (ECEF, as mpf) of ``model`` at the ECEF point (x, y, z), mpmath only."""
    mp.mp.dps = 30
    x, y, z = mp.mpf(float(x)), mp.mpf(float(y)), mp.mpf(float(z))
    rho = mp.sqrt(x * x + y * y)
    r = mp.sqrt(rho * rho + z * z)
    t, u = z / r, rho / r
    lam = mp.atan2(y, x)
    q = mp.mpf(float(model.radius)) / r
    lmax = model.lmax
    qpow = [mp.mpf(1)]
    for _ in range(lmax):
        qpow.append(qpow[-1] * q)
    sums = {"V": mp.mpf(0), "R": mp.mpf(0), "N": mp.mpf(0), "E": mp.mpf(0)}
    sect = mp.mpf(1)  # P̄mm / u^m
    quiet = 0
    for m in range(lmax + 1):
        if m == 1:
            sect = mp.sqrt(3)
        elif m > 1:
            sect *= mp.sqrt(mp.mpf(2 * m + 1) / (2 * m))
        if orders is not None and m not in orders:
            continue
        cm, sm = mp.cos(m * lam), mp.sin(m * lam)
        # three recursions in n: P = P̄nm, D = dP̄nm/dφ, W = P̄nm/u (m >= 1)
        um1 = u ** (m - 1) if m >= 1 else mp.mpf(0)
        P2, P1 = mp.mpf(0), sect * u**m
        D2, D1 = mp.mpf(0), (-m * t * sect * um1 if m >= 1 else mp.mpf(0))
        W2, W1 = mp.mpf(0), sect * um1
        col = [mp.mpf(0)] * 4
        for n in range(m, lmax + 1):
            if n > m:
                a = mp.sqrt(mp.mpf((2 * n - 1) * (2 * n + 1)) / ((n - m) * (n + m)))
                b = mp.sqrt(
                    mp.mpf((2 * n + 1) * (n + m - 1) * (n - m - 1))
                    / ((n - m) * (n + m) * (2 * n - 3))
                )
                P = a * t * P1 - b * P2
                D = a * (u * P1 + t * D1) - b * D2  # d/dφ of the recursion: dt/dφ = u
                W = a * t * W1 - b * W2
                P2, P1, D2, D1, W2, W1 = P1, P, D1, D, W1, W
            c = mp.mpf(float(model.C[n, m]))
            s = mp.mpf(float(model.S[n, m]))
            if c == 0 and s == 0:
                continue
            A = (c * cm + s * sm) * qpow[n]
            col[0] += A * P1
            col[1] += (n + 1) * A * P1
            col[2] += A * D1
            col[3] += m * (s * cm - c * sm) * qpow[n] * W1
        sums["V"] += col[0]
        sums["R"] += col[1]
        sums["N"] += col[2]
        sums["E"] += col[3]
        size = max(abs(v) for v in col)
        ref_size = max(abs(sums["R"]), abs(sums["N"]), abs(sums["E"]))
        quiet = quiet + 1 if size < tol * ref_size else 0
        if orders is None and quiet >= 3 and m > 2:
            break
    k = mp.mpf(float(model.gm)) / (r * r)
    g_up, g_n, g_e = -k * sums["R"], k * sums["N"], k * sums["E"]
    cl, sl = mp.cos(lam), mp.sin(lam)
    h = u * g_up - t * g_n
    return [h * cl - g_e * sl, h * sl + g_e * cl, t * g_up + u * g_n], m


def ecef(lat_deg, lon_deg, h):
    """Spherical-latitude point at radius R + h (exactly on the axis at ±90°)."""
    phi, lam = np.radians(lat_deg), np.radians(lon_deg)
    r = 6378137.0 + h
    if abs(lat_deg) == 90.0:
        return 0.0, 0.0, np.sign(lat_deg) * r
    return r * np.cos(phi) * np.cos(lam), r * np.cos(phi) * np.sin(lam), r * np.sin(phi)


POLAR = [
    (88.0, 200.0, 5.0e3),
    (89.9, 30.0, 0.0),
    (89.99, -120.0, 2.0e4),
    (-89.99, 75.0, 0.0),
    (90.0, 0.0, 0.0),
    (-90.0, 0.0, 1.0e3),
]
ORDERS = [0, 1, 2, 3, 10, 100, 500, 1000, 1500, 2000, 2189, 2190]
MIDLAT = [(37.0, 123.0, 0.0), (-4.0, 301.0, 1.0e4)]


@pytest.fixture(scope="module")
def dense():
    """Dense degree-2190 Kaula model."""
    return kaula_model(L, seed=2190)


@pytest.fixture(scope="module")
def sparse():
    """Degree-2190 Kaula model restricted to the orders ORDERS."""
    return kaula_orders(L, seed=2191, orders=ORDERS)


_MP_CACHE = {}  # (model name, point) -> mpmath result, shared by the device parametrisations


def _check(model, points, device, orders=None):
    worst = 0.0
    for lat, lon, h in points:
        x, y, z = ecef(lat, lon, h)
        g = fsh.sh_gravitation(model, x, y, z, device=device)
        key = (model.name, lat, lon, h)
        if key not in _MP_CACHE:
            g_mp, _ = mp_gravitation(model, x, y, z, orders=orders)
            _MP_CACHE[key] = np.array([float(v) for v in g_mp])
        g_mp = _MP_CACHE[key]
        assert np.all(np.isfinite(g))
        worst = max(worst, np.linalg.norm(g - g_mp) / np.linalg.norm(g_mp))
    return worst


@pytest.mark.slow
def test_degree2190_polar_vs_mpmath(dense, device):
    """Dense model near and at the poles vs mpmath, 1e-12 relative."""
    assert _check(dense, POLAR, device) <= 1e-12


@pytest.mark.slow
def test_degree2190_midlatitude_orders_vs_mpmath(sparse, device):
    """Orders up to 2190 at mid and low latitude vs mpmath, 1e-12 relative."""
    assert _check(sparse, MIDLAT, device, orders=ORDERS) <= 1e-12


@pytest.mark.slow
def test_degree2190_dense_vs_reference(dense, device):
    """All orders at degree 2190: kernel vs the NumPy X-number reference at mixed latitudes."""
    pts = [
        ecef(lat, lon, h)
        for lat, lon, h in [
            (0.0, 0.0, 0.0),
            (23.0, 45.0, 2e4),
            (-51.0, 190.0, 1e5),
            (70.0, -10.0, 0.0),
            (89.9, 30.0, 0.0),
            (-89.99, 75.0, 0.0),
            (90.0, 0.0, 0.0),
        ]
    ]
    x, y, z = (np.array(c) for c in zip(*pts))
    g = fsh.sh_gravitation(dense, x, y, z, device=device)
    g_ref = ref.gravitation_ecef(dense, x, y, z)
    err = np.linalg.norm(g - g_ref, axis=-1) / np.linalg.norm(g_ref, axis=-1)
    assert np.max(err) <= 1e-12


@pytest.mark.slow
def test_degree2190_high_part_vs_mpmath(sparse, device):
    """Degrees 1000..2190 only, relative to their own (1e-5 m/s²) size, up to 60° latitude.

    Float64 rounding of t = sin φ moves the point by ~1e-16/u rad, i.e. ~n·1e-16 relative for
    a degree-n field away from the poles; 1e-12 leaves an order of magnitude above that floor.
    """
    C, S = sparse.C.copy(), sparse.S.copy()
    C[:1000], S[:1000] = 0.0, 0.0
    hi = SHModel("kaula-1000-2190", GM, R, C, S, L)
    assert _check(hi, MIDLAT + [(60.0, 10.0, 0.0)], device, orders=ORDERS) <= 1e-12
