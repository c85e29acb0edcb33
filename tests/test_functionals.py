"""ICGEM's functionals (ζ, classical Δg, δg_sa, T_rr, EWH) against references that share no code.

The normal field of the checks is written here, in mpmath, from the four defining constants of
WGS84 (its zonal series, Heiskanen & Moritz 1967 eqs. 2-90 and 2-92, not fieldmap's
``Ellipsoid.J2n`` or its closed form in ellipsoidal coordinates); derivatives are mpmath's
numerical ones (``mp.diff``) of these potentials; the height anomaly of the classical anomaly is
mpmath's root of U(Q) = W(P) along the ellipsoidal normal. The high-degree point sums its own
fully normalised Legendre recursion in mpmath; GeographicLib's ``Gravity -H`` gives the geoid,
whose difference from ζ is the model's N − ζ term, and with ``Gravity -A`` the radial derivative
−∂T/∂r = Δg + 2T/r at h = 0; EWH is checked on single coefficients
against Wahr et al. (1998) eq. 14 with the load Love numbers of their Table 1.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import mpmath as mp
import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.field import geodesy as gd
from fieldmap.field import water
from fieldmap.field.ellipsoid import WGS84
from fieldmap.grids.spec import GridSpec
from fieldmap.models.geographiclib import gravity_tool, run_gravity_tool, write_egm
from fieldmap.models.registry import kaula_model, load_model
from fieldmap.models.shmodel import SHModel
from fieldmap.models.tide import convert_tide_system

mp.mp.dps = 40
# WGS84's defining constants (NIMA TR8350.2), as printed
A = mp.mpf(6378137)
F = mp.mpf(1 / 298.257223563)  # the float64 flattening every float64 code holds
GM = mp.mpf("3.986004418e14")
OMEGA = mp.mpf("7.292115e-5")
B = A * (1 - F)
E2 = 1 - (B / A) ** 2
EP = mp.sqrt(A * A - B * B) / B
Q0 = ((1 + 3 / EP**2) * mp.atan(EP) - 3 / EP) / 2
M = OMEGA**2 * A**2 * B / GM
J2 = E2 / 3 * (1 - 2 * M * EP / (15 * Q0))  # Heiskanen & Moritz (1967) eq. 2-90
KMAX = 20  # zonal terms J2..J40: (e²)^20 ~ 1e-44


def j2n(k):
    """J_2k of the level ellipsoid, Heiskanen & Moritz (1967) eq. 2-92."""
    return (-1) ** (k + 1) * 3 * E2**k / ((2 * k + 1) * (2 * k + 3)) * (1 - k + 5 * k * J2 / E2)


JN = [j2n(k) for k in range(1, KMAX + 1)]


def u_grav(p, z):
    """Gravitational potential of the level ellipsoid, its zonal series (H&M eq. 2-88)."""
    r = mp.sqrt(p * p + z * z)
    t = z / r
    s = sum(JN[k - 1] * (A / r) ** (2 * k) * mp.legendre(2 * k, t) for k in range(1, KMAX + 1))
    return GM / r * (1 - s)


def u_normal(p, z):
    """Return the normal gravity potential U: gravitational plus centrifugal."""
    return u_grav(p, z) + OMEGA**2 * p * p / 2


def w_point_mass(p, z):
    """Gravity potential of the point mass GM at the centre, with centrifugal."""
    return GM / mp.sqrt(p * p + z * z) + OMEGA**2 * p * p / 2


def grad_norm(f, p, z):
    """|∇f| of an axisymmetric potential f(p, z), numerical derivatives (mpmath)."""
    return mp.sqrt(mp.diff(lambda q: f(q, z), p) ** 2 + mp.diff(lambda q: f(p, q), z) ** 2)


def meridian(lat, h):
    """Distance from the axis p and height z of a geodetic point (mpmath)."""
    phi = mp.radians(mp.mpf(float(lat)))
    n = A / mp.sqrt(1 - E2 * mp.sin(phi) ** 2)
    return (n + h) * mp.cos(phi), (n * (1 - E2) + h) * mp.sin(phi)


def point_mass_model():
    """Return a point mass with WGS84's GM: its T is minus the ellipsoid's zonal series."""
    return SHModel("point mass", float(GM), 6378137.0, np.ones((1, 1)), np.zeros((1, 1)), 0)


def normal_model():
    """Return the level ellipsoid's own field as a model (C̄_2k,0 = −J_2k/√(4k+1)): T = 0."""
    L = 2 * KMAX
    C = np.zeros((L + 1, L + 1))
    C[0, 0] = 1.0
    for k in range(1, KMAX + 1):
        C[2 * k, 0] = float(-JN[k - 1] / mp.sqrt(4 * k + 1))
    return SHModel("normal field", float(GM), float(A), C, np.zeros_like(C), L)


POINTS = [  # lat, lon, h
    (90.0, 0.0, 0.0),
    (-90.0, 33.0, 5.0e4),
    (0.0, -75.0, 0.0),
    (0.0, 10.0, 1.0e5),
    (45.0, 120.0, 1.0e3),
    (-33.3, -160.0, 2.0e4),
    (71.0, 250.0, 8.0e3),
    (-89.99, 15.0, 0.0),
]


def test_constants_are_wgs84():
    """The mpmath normal field here is WGS84's (J2 as published, fieldmap's constants)."""
    assert (WGS84.a, WGS84.f, WGS84.GM, WGS84.omega) == (
        float(A),
        float(F),
        float(GM),
        float(OMEGA),
    )
    assert float(J2) == pytest.approx(1.082629821313e-3, rel=1e-9)  # TR8350.2 Table 3.3 (C20)


def test_point_mass_closed_forms():
    """ζ, classical Δg, δg_sa and T_rr of a point mass: T = GM/r − U_grav, all in mpmath.

    The point mass is far from the ellipsoid's field (ζ up to 7 km, Δg up to 3000 mGal), so
    the checks see every term; the tolerances are the float64 rounding of the sums.
    """
    model = point_mass_model()
    lat, lon, h = (np.array(c) for c in zip(*POINTS))
    zeta = gd.height_anomaly(lat, lon, model=model)
    dg_cl = gd.classical_anomaly(lat, lon, h, model=model)
    dg_sa = gd.disturbance_sa(lat, lon, h, model=model)
    trr = gd.second_radial_derivative(lat, lon, h, model=model)
    for k, (la, _, hh) in enumerate(POINTS):
        # ζ on the ellipsoid: T(h = 0) / |γ(h = 0)| (Bruns)
        p0, z0 = meridian(la, 0)
        t0 = w_point_mass(p0, z0) - u_normal(p0, z0)
        zeta_mp = t0 / grad_norm(u_normal, p0, z0)
        assert abs(zeta[k] - float(zeta_mp)) < 1e-8, (k, zeta[k], zeta_mp)
        # −∂T/∂r and ∂²T/∂r² along the geocentric radius of P
        p, z = meridian(la, hh)
        r = mp.sqrt(p * p + z * z)

        def t_along(rr, p=p, z=z, r=r):
            return w_point_mass(p * rr / r, z * rr / r) - u_normal(p * rr / r, z * rr / r)

        assert abs(dg_sa[k] - float(-mp.diff(t_along, r) * 1e5)) < 1e-7, k
        assert abs(trr[k] - float(mp.diff(t_along, r, 2) * 1e9)) < 1e-8, k
        # classical: Q on the normal at h − ζ with U(Q) = W(P), Δg = |∇W(P)| − |∇U(Q)|
        wp_ = w_point_mass(p, z)
        phi = mp.radians(mp.mpf(float(la)))

        def f(zz, phi=phi, p=p, z=z, wp_=wp_):
            return u_normal(p - zz * mp.cos(phi), z - zz * mp.sin(phi)) - wp_

        zz = mp.findroot(f, t_along(r) / grad_norm(u_normal, p, z))
        pq, zq = p - zz * mp.cos(phi), z - zz * mp.sin(phi)
        dg_mp = (grad_norm(w_point_mass, p, z) - grad_norm(u_normal, pq, zq)) * 1e5
        assert abs(dg_cl[k] - float(dg_mp)) < 1e-6, (k, dg_cl[k], dg_mp)
    # the signals are large: the checks are not of zeros
    assert np.abs(zeta).max() > 1e3 and np.abs(dg_cl).max() > 1e3 and np.abs(trr).max() > 1.0


def test_normal_field_gives_zeros():
    """The ellipsoid's own field as a model: T = 0, so ζ, Δg_cl, δg_sa, T_rr are 0.

    The classical anomaly is then |γ(P)| − |γ(P)| (ζ = 0): a check of the ζ solver too.
    """
    model = normal_model()
    rng = np.random.default_rng(28)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, 40)))
    lon = rng.uniform(-180, 180, 40)
    h = rng.uniform(0, 1e5, 40)
    lat[:2] = [90.0, -90.0]
    assert np.abs(gd.height_anomaly(lat, lon, model=model)).max() < 1e-9  # m
    assert np.abs(gd.classical_anomaly(lat, lon, h, model=model)).max() < 1e-7  # mGal
    assert np.abs(gd.disturbance_sa(lat, lon, h, model=model)).max() < 1e-7  # mGal
    assert np.abs(gd.second_radial_derivative(lat, lon, h, model=model)).max() < 1e-7  # E


# --------------------------------------------------------------------------------------------
# one high-degree point in mpmath

L_HIGH = 2190
ORDERS = [0, 1, 2, 3, 100, 1000, 2000, 2190]


def sparse_model():
    """Degree-2190 Kaula model with the orders ORDERS only (and its C00, C20)."""
    model = kaula_model(L_HIGH, seed=28)
    drop = ~np.isin(np.arange(L_HIGH + 1), ORDERS)
    C, S = model.C.copy(), model.S.copy()
    C[:, drop], S[:, drop] = 0.0, 0.0
    return SHModel("kaula-orders", model.gm, model.radius, C, S, L_HIGH, source="synthetic")


def mp_sums(model, lat, lon, h):
    r"""T, −∂T/∂r, ∂²T/∂r² (geocentric r) of model − normal field at a geodetic point, mpmath.

    The normal zonals (this module's J_2k, rescaled to the model's GM and radius) are
    subtracted from the model's C̄_2k,0, C̄00 is left out (degree0=False); then
    :math:`\sum_n w_n (R/r)^n \sum_m \bar P_{nm}(\sin\psi)(C\cos m\lambda +
    S\sin m\lambda)` with w_n = 1, n + 1, (n + 1)(n + 2) and the plain column recursion.
    """
    p, z = meridian(lat, h)
    r = mp.sqrt(p * p + z * z)
    t, u = z / r, p / r
    lam = mp.radians(mp.mpf(float(lon)))
    gm, radius = mp.mpf(float(model.gm)), mp.mpf(float(model.radius))
    q = radius / r
    C = {}
    for n in range(model.lmax + 1):
        for m in ORDERS:
            if m <= n and (model.C[n, m] or model.S[n, m]):
                C[n, m] = (mp.mpf(float(model.C[n, m])), mp.mpf(float(model.S[n, m])))
    C.pop((0, 0), None)
    for k in range(1, KMAX + 1):
        c, s = C.get((2 * k, 0), (mp.mpf(0), mp.mpf(0)))
        C[2 * k, 0] = (c + GM / gm * (A / radius) ** (2 * k) * JN[k - 1] / mp.sqrt(4 * k + 1), s)
    sums = [mp.mpf(0)] * 3
    sect = mp.mpf(1)  # P̄mm / u^m
    for m in range(model.lmax + 1):
        if m == 1:
            sect = mp.sqrt(3)
        elif m > 1:
            sect *= mp.sqrt(mp.mpf(2 * m + 1) / (2 * m))
        if m not in ORDERS:
            continue
        cm, sm = mp.cos(m * lam), mp.sin(m * lam)
        p2, p1 = mp.mpf(0), sect * u**m
        for n in range(m, model.lmax + 1):
            if n > m:
                a = mp.sqrt(mp.mpf((2 * n - 1) * (2 * n + 1)) / ((n - m) * (n + m)))
                b = mp.sqrt(
                    mp.mpf((2 * n + 1) * (n + m - 1) * (n - m - 1))
                    / ((n - m) * (n + m) * (2 * n - 3))
                )
                p2, p1 = p1, a * t * p1 - b * p2
            if (n, m) in C:
                c, s = C[n, m]
                term = (c * cm + s * sm) * q**n * p1
                sums[0] += term
                sums[1] += (n + 1) * term
                sums[2] += (n + 1) * (n + 2) * term
    return gm / r * sums[0], gm / r**2 * sums[1], gm / r**3 * sums[2]


@pytest.mark.slow
def test_high_degree_point_vs_mpmath():
    """ζ, δg_sa and T_rr at degree 2190 against mpmath (30+ digits), at h = 0 and 10 km.

    Measured: 0 m, 3e-12 mGal, 1e-11 E (float64 summation of the kernels).
    """
    model = sparse_model()
    for lat, lon, h in ((37.0, 123.0, 0.0), (-4.0, 301.0, 1.0e4)):
        t, dsa, trr = mp_sums(model, lat, lon, h)
        assert abs(trr) * 1e9 > 0.1  # Eötvös: not a zero
        got_sa = gd.disturbance_sa([lat], [lon], [h], model=model)[0]
        got_rr = gd.second_radial_derivative([lat], [lon], [h], model=model)[0]
        assert abs(got_sa - float(dsa * 1e5)) < 1e-9, (got_sa, dsa * 1e5)
        assert abs(got_rr - float(trr * 1e9)) < 1e-9, (got_rr, trr * 1e9)
        if h == 0.0:
            p0, z0 = meridian(lat, 0)
            zeta = t / grad_norm(u_normal, p0, z0)
            got = gd.height_anomaly([lat], [lon], model=model)[0]
            assert abs(got - float(zeta)) < 1e-9, (got, zeta)


# --------------------------------------------------------------------------------------------
# GeographicLib: Gravity -H is ζ plus the model's N − ζ term

needs_tool = pytest.mark.skipif(
    gravity_tool() is None, reason="GeographicLib's Gravity (geographiclib-tools) missing"
)


@needs_tool
def test_geoid_minus_height_anomaly_is_the_n_minus_zeta_term(tmp_path):
    """``Gravity -H`` − ζ = HeightOffset + the correction series (here C̄20, C̄22), closed form.

    GeographicLib sums the correction on the unit sphere at the point's geocentric direction.
    """
    model = load_model("eigen-6s", lmax=36)
    corr = SHModel("corr", 1.0, 1.0, np.zeros((3, 3)), np.zeros((3, 3)), 2)
    corr.C[2, 0], corr.C[2, 2] = 0.3, -0.2
    offset = -0.41
    name = write_egm(model, tmp_path, name="zeta", correction=corr, height_offset=offset)
    rng = np.random.default_rng(7)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, 60)))
    lon = rng.uniform(-180, 180, 60)
    lat[:2] = [90.0, -90.0]
    tool = run_gravity_tool(np.c_[lat, lon, 0 * lat], tmp_path, name, "geoid", precision=12)
    zeta = gd.height_anomaly(lat, lon, model=model)
    # the geocentric direction of the ellipsoid point (written out here)
    phi = np.radians(lat)
    psi = np.arctan((1 - float(E2)) * np.tan(phi))
    psi[np.abs(lat) == 90.0] = phi[np.abs(lat) == 90.0]
    t, u = np.sin(psi), np.cos(psi)
    n_minus_zeta = (
        offset
        + 0.3 * math.sqrt(5) * (3 * t * t - 1) / 2
        - 0.2 * 3 * math.sqrt(5 / 12) * u * u * np.cos(2 * np.radians(lon))
    )
    assert np.abs(n_minus_zeta - offset).max() > 0.2
    np.testing.assert_allclose(tool[:, 0] - zeta, n_minus_zeta, rtol=0, atol=1e-6)  # m


@needs_tool
def test_disturbance_sa_from_gravity_a_and_h(tmp_path):
    """At h = 0, −∂T/∂r = Δg + 2T/r with Δg of ``Gravity -A`` and T = N γ0 of ``Gravity -H``.

    The model file has no N − ζ terms, so ``Gravity -H`` is T/γ0; γ0 = |∇U| on the ellipsoid and
    r come from this module's mpmath normal field. Measured: 2e-12 mGal.
    """
    model = load_model("eigen-6s", lmax=60)
    name = write_egm(model, tmp_path, name="plain")
    rng = np.random.default_rng(11)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, 40)))
    lon = rng.uniform(-180, 180, 40)
    lat[:2] = [90.0, -90.0]
    pts = np.c_[lat, lon, 0 * lat]
    dg = run_gravity_tool(pts, tmp_path, name, "anomaly", precision=12)[:, 0]  # mGal
    n = run_gravity_tool(pts, tmp_path, name, "geoid", precision=12)[:, 0]  # m
    expect = []
    for k in range(lat.size):
        p, z = meridian(lat[k], 0)
        gam0 = grad_norm(u_normal, p, z)
        expect.append(float(dg[k] + 2e5 * n[k] * gam0 / mp.sqrt(p * p + z * z)))
    got = gd.disturbance_sa(lat, lon, 0 * lat, model=model)
    assert np.abs(got).max() > 30.0
    np.testing.assert_allclose(got, expect, rtol=0, atol=1e-6)  # mGal


# --------------------------------------------------------------------------------------------
# grids = points


def test_grids_equal_points(device):
    """Each functional on a grid (one Legendre pass per row) equals its point function."""
    model = load_model("eigen-6s", lmax=60)
    lat = np.array([-90.0, -30.0, 0.0, 30.0, 60.0, 89.0])
    lon = np.arange(-180.0, 180.0, 30.0)
    grid = GridSpec(lat=lat, lon=lon, heights=np.array([0.0, 2.0e4]), step_deg=30.0)
    H, LA, LO = np.meshgrid(grid.heights, lat, lon, indexing="ij")
    for quantity, func, atol in (
        ("anomaly-classical", gd.classical_anomaly, 1e-8),  # mGal
        ("disturbance-sa", gd.disturbance_sa, 1e-9),  # mGal
        ("trr", gd.second_radial_derivative, 1e-9),  # E
    ):
        got = gd.grid_quantities(model, grid, quantity, device=device)
        (values,) = got.values()
        np.testing.assert_allclose(values, func(LA, LO, H, model=model, device=device), atol=atol)
    za = gd.grid_quantities(model, grid, "height-anomaly", device=device)["height_anomaly"]
    assert za.shape == (1, lat.size, lon.size)
    np.testing.assert_allclose(za[0], gd.height_anomaly(LA[0], LO[0], model=model), atol=1e-9)
    diff = water.field_difference(
        load_model("eigen-6s", lmax=50, epoch=2012.0), load_model("eigen-6s", lmax=50)
    )
    ewh = water.grid_ewh(diff, grid, device=device)["ewh"]
    assert ewh.shape == (1, lat.size, lon.size) and np.abs(ewh).max() > 0.05  # m
    expect = water.equivalent_water_height(LA[0], LO[0], model=diff, device=device)
    np.testing.assert_allclose(ewh[0], expect, rtol=0, atol=1e-12)


def test_quantity_maps_carry_definitions():
    """quantity_map of each functional: units, ICGEM name, Barthelmes' sections in the product."""
    from fieldmap.products.maps import quantity_map

    for quantity, name, units in (
        ("height-anomaly", "height_anomaly", "m"),
        ("anomaly-classical", "anomaly_classical", "mGal"),
        ("disturbance-sa", "disturbance_sa", "mGal"),
        ("trr", "trr", "1e-9 s-2"),
    ):
        ds = quantity_map(quantity, lmax=12, step_deg=30.0)
        assert ds[name].attrs["units"] == units
        assert "ICGEM" in ds[name].attrs["long_name"]
        assert "Barthelmes 2013" in ds.attrs["definition"]


# --------------------------------------------------------------------------------------------
# equivalent water height

#: Wahr, Molenaar & Bryan (1998) Table 1: load Love numbers k'_n (PREM)
WAHR_TABLE = {2: -0.303, 3: -0.194, 10: -0.069, 20: -0.051, 100: -0.014, 200: -0.007}


def test_love_numbers():
    """Table 1 of Wahr et al. (1998) at its degrees, linear between them, 1/n above 200."""
    k = water.love_numbers(400)
    for n, kn in WAHR_TABLE.items():
        assert k[n] == kn
    assert k[25] == pytest.approx((-0.051 - 0.040) / 2, abs=1e-15)  # between 20 and 30
    assert k[11] == pytest.approx((-0.069 - 0.064) / 2, abs=1e-15)  # between 10 and 12
    assert k[400] == pytest.approx(-0.007 / 2, abs=1e-15)  # n k'_n held at -1.4


def _p_bar(n, m, x):
    """Fully normalised P̄nm(x) (no Condon–Shortley phase): closed-form sectoral, column recursion.

    P̄mm = √((2 − δ_m0)(2m + 1)!)/(2^m m!) u^m (u = √(1 − x²)), then the three-term recursion
    in n of the associated Legendre functions, normalised (mpmath, 40 digits).
    """
    x = mp.mpf(x)
    u = mp.sqrt(1 - x * x)
    norm = mp.sqrt((2 - (m == 0)) * (2 * n + 1) * mp.factorial(n - m) / mp.factorial(n + m))
    # unnormalised P_mm = (2m - 1)!! u^m, P_m+1,m = x (2m + 1) P_mm, then Bonnet's recursion
    p_prev, p = mp.mpf(0), mp.fac2(2 * m - 1) * u**m
    for k in range(m + 1, n + 1):
        p_prev, p = p, ((2 * k - 1) * x * p - (k + m - 1) * p_prev) / (k - m)
    return norm * p


@pytest.mark.parametrize(
    ("n", "m", "kn"),
    [(2, 0, -0.303), (25, 0, -0.0455), (7, 3, -0.081), (300, 5, -0.007 * 200 / 300)],
)
def test_ewh_single_coefficient(n, m, kn):
    """EWH of one changed coefficient: a ρ_e (2n+1) / (3 ρ_w (1 + k'_n)) ΔC P̄nm(sin φ) cos mλ.

    Wahr et al. (1998) eq. 14 over ρ_w = 1000 kg/m³, ρ_e = 5517 kg/m³; k'_n as printed in their
    Table 1 (interpolated by hand here for n = 25, and 200 k'_200 / n above 200).
    """
    base = kaula_model(max(n, 8), seed=n)
    dc, ds = 3e-10, -2e-10
    C, S = base.C.copy(), base.S.copy()
    C[n, m] += dc
    if m:
        S[n, m] += ds
    changed = SHModel("changed", base.gm, base.radius, C, S, base.lmax)
    lat = np.array([90.0, 61.0, 12.5, 0.0, -45.0, -88.0])
    lon = np.array([0.0, 10.0, -120.0, 77.7, 200.0, 33.0])
    got = water.equivalent_water_height(lat, lon, model=changed, reference=base)
    scale = base.radius * 5517.0 * (2 * n + 1) / (3 * 1000.0 * (1 + kn))
    for k in range(lat.size):
        phi, lam = math.radians(lat[k]), math.radians(lon[k])
        pbar = float(_p_bar(n, m, mp.sin(mp.mpf(phi))))
        expect = scale * pbar * (dc * math.cos(m * lam) + ds * math.sin(m * lam) * (m > 0))
        assert got[k] == pytest.approx(expect, rel=1e-9, abs=1e-15), (k, got[k], expect)
    assert np.abs(got).max() > 1e-4  # m: not zeros


def test_field_difference_constants_and_tide():
    """A field re-expressed in other GM and radius, or another tide system, differs by nothing."""
    model = load_model("eigen-6s", lmax=40)
    gm2, r2 = model.gm * 1.001, model.radius * 1.0001
    n = np.arange(41)[:, None]
    scale = (model.gm / gm2) * (model.radius / r2) ** n
    other = SHModel("other", gm2, r2, model.C * scale, model.S * scale, 40, model.tide_system)
    diff = water.field_difference(model, other)
    assert np.abs(diff.C).max() < 1e-18 and np.abs(diff.S).max() < 1e-18
    assert np.abs(water.equivalent_water_height([10.0, -50.0], [0.0, 99.0], model=diff)).max() < (
        1e-6
    )
    # degree 0 is no load: two fields that differ in C̄00 only have no EWH
    c00 = model.C.copy()
    c00[0, 0] = 1.0 + 3e-9
    mass = SHModel("mass", model.gm, model.radius, c00, model.S, 40, model.tide_system)
    assert water.equivalent_water_height([10.0], [0.0], model=mass, reference=model)[0] == 0.0
    # another tide system: converted to the model's first (the permanent tide is no mass)
    assert model.tide_system == "tide_free"
    zero = convert_tide_system(other, "zero_tide")
    assert zero.C[2, 0] != other.C[2, 0]
    diff_zero = water.field_difference(model, zero)
    assert np.abs(diff_zero.C).max() < 1e-18 and np.abs(diff_zero.S).max() < 1e-18
    assert "converted from zero_tide to tide_free" in diff_zero.source


def test_ewh_of_one_field_is_refused(tmp_path):
    """EWH of a static (or any single) model: one line, exit 2, nothing written."""
    from fieldmap.products.maps import quantity_map

    static = kaula_model(10, seed=1)
    with pytest.raises(InputError, match="change of the field"):
        water.equivalent_water_height([0.0], [0.0], model=static)
    with pytest.raises(InputError, match="change of the field"):
        quantity_map("ewh", model=static, step_deg=30.0)
    out = tmp_path / "out"
    env = {**os.environ}
    for args in (
        ["map", "--quantity", "ewh", "--step-deg", "30", "--out", str(out)],
        ["map", "--quantity", "trr", "--minus", "eigen-6s", "--step-deg", "30", "--out", str(out)],
    ):
        run = subprocess.run(
            [sys.executable, "-m", "fieldmap", *args],
            capture_output=True,
            text=True,
            timeout=300,
            env=env,
        )
        assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1, run.stderr
        assert "Traceback" not in run.stderr and not out.exists()
    run = subprocess.run(
        [sys.executable, "-m", "fieldmap", "point", "--quantity", "ewh"],
        input="10 20 0\n",
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
    )
    assert run.returncode == 2 and run.stdout == "" and "--minus" in run.stderr


def test_cli_ewh_and_functionals(tmp_path):
    """``fieldmap point`` prints the API's values; ``map --quantity ewh --minus`` writes its map."""
    import xarray as xr

    text = "45 10 0\n-30 150 0\n"
    env = {**os.environ}

    def cli(args, stdin=""):
        return subprocess.run(
            [sys.executable, "-m", "fieldmap", *args],
            input=stdin,
            capture_output=True,
            text=True,
            timeout=300,
            env=env,
        )

    lat, lon = np.array([45.0, -30.0]), np.array([10.0, 150.0])
    m60 = load_model("eigen-6s", lmax=60)
    for quantity, expect in (
        ("height-anomaly", gd.height_anomaly(lat, lon, model=m60)),
        ("trr", gd.second_radial_derivative(lat, lon, 0 * lat, model=m60)),
    ):
        run = cli(["point", "--quantity", quantity, "--lmax", "60", "--precision", "10"], text)
        assert run.returncode == 0, run.stderr
        np.testing.assert_allclose([float(v) for v in run.stdout.split()], expect, atol=1e-9)
    run = cli(["point", "--quantity", "height-anomaly", "--lmax", "60"], "45 10 100\n")
    assert run.returncode == 1 and "h must be 0" in run.stdout
    a, b = load_model("eigen-6s", lmax=50, epoch=2012.0), load_model("eigen-6s", lmax=50)
    args = ["--quantity", "ewh", "--lmax", "50", "--epoch", "2012", "--minus", "eigen-6s"]
    run = cli(["point", *args, "--precision", "10"], text)
    assert run.returncode == 0, run.stderr
    expect = water.equivalent_water_height(lat, lon, model=a, reference=b)
    np.testing.assert_allclose([float(v) for v in run.stdout.split()], expect, atol=1e-9)
    out = tmp_path / "out"
    run = cli(["map", *args, "--step-deg", "30", "--no-plots", "--out", str(out)])
    assert run.returncode == 0, run.stderr
    with xr.open_dataset(next(out.glob("*.nc"))) as ds:
        LA, LO = np.meshgrid(ds["latitude"].values, ds["longitude"].values, indexing="ij")
        expect = water.equivalent_water_height(LA, LO, model=a, reference=b)
        np.testing.assert_allclose(ds["ewh"].values, expect, rtol=0, atol=1e-12)
        assert ds["ewh"].attrs["units"] == "m" and "Wahr" in ds.attrs["definition"]
