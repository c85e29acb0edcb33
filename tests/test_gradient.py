"""Gradient tensor ∂g_i/∂x_j (issue 18), checked against paths that share no code with it.

Closed form of a point mass, Laplace's equation (trace 0, or 2ω² with the centrifugal term),
symmetry, and the free-air gradient of normal gravity from the height derivative of
``normal_gravity``'s magnitude. Models are truncated at degree 60 to stay fast.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import fieldmap
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84
from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
from fieldmap.field.gradient import (
    EOTVOS,
    gradient_asymmetry,
    gradient_invariants,
    gradient_tensor,
)
from fieldmap.field.normal import normal_gravity
from fieldmap.models.registry import load_model
from fieldmap.models.shmodel import SHModel

#: 2ω² of WGS84 in Eötvös (≈ 10.635 E): the trace of a gravity tensor incl. centrifugal
TWO_OMEGA2 = 2.0 * WGS84.omega**2 / EOTVOS


def _points(n=12, seed=3, hmax=1e5):
    rng = np.random.default_rng(seed)
    lat = np.r_[np.degrees(np.arcsin(rng.uniform(-1, 1, n))), 90.0, -90.0, 0.0]
    lon = np.r_[rng.uniform(-180, 180, n), 0.0, 33.0, -120.0]
    h = np.r_[rng.uniform(0.0, hmax, n), 0.0, 500.0, 0.0]
    return lat, lon, h


@pytest.fixture(scope="module")
def model60():
    return load_model("eigen-6s", lmax=60)


def test_point_mass_closed_form():
    """Only C00: T_ij = GM (3 x_i x_j − r² δ_ij) / r⁵ (ECEF), and its rotation to ENU/NED."""
    pm = SHModel("point mass", WGS84.GM, 6378137.0, np.ones((1, 1)), np.zeros((1, 1)), 0)
    lat, lon, h = _points(hmax=1e6)
    x, y, z = geodetic_to_ecef(lat, lon, h)
    r = np.stack([x, y, z], axis=-1)
    rn = np.linalg.norm(r, axis=-1)[:, None, None]
    want = WGS84.GM * (3 * r[:, :, None] * r[:, None, :] - rn**2 * np.eye(3)) / rn**5 / EOTVOS
    got = gradient_tensor(lat, lon, h, model=pm, quantity="gravitation", frame="ecef")
    asym = gradient_asymmetry(lat, lon, h, model=pm, quantity="gravitation")
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-5)  # |T| up to 3100 E
    assert np.all(asym < 1e-5)
    c = C_e_to_enu(lat, lon)
    want_enu = c @ want @ np.swapaxes(c, -1, -2)
    enu = gradient_tensor(lat, lon, h, model=pm, quantity="gravitation")
    np.testing.assert_allclose(enu, want_enu, rtol=0, atol=1e-5)
    ned = gradient_tensor(lat, lon, h, model=pm, quantity="gravitation", frame="ned")
    p = np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1]])
    np.testing.assert_allclose(ned, p @ want_enu @ p.T, rtol=0, atol=1e-5)
    # at the poles and the equator up is radial: +2GM/r³ along it (≈ +3086 E at the surface),
    # -GM/r³ horizontally
    r1 = rn[-3:, 0, 0]
    np.testing.assert_allclose(enu[-3:, 2, 2], 2 * WGS84.GM / r1**3 / EOTVOS, rtol=0, atol=1e-5)
    np.testing.assert_allclose(enu[-3:, 0, 0], -WGS84.GM / r1**3 / EOTVOS, rtol=0, atol=1e-5)


@pytest.mark.parametrize(
    "quantity, trace",
    [("gravitation", 0.0), ("disturbance", 0.0), ("gravity", TWO_OMEGA2), ("normal", TWO_OMEGA2)],
)
def test_laplace_and_symmetry(model60, quantity, trace):
    """Trace = 0 outside the masses (2ω² with the centrifugal term); the tensor is symmetric."""
    lat, lon, h = _points()
    asym = gradient_asymmetry(lat, lon, h, model=model60, quantity=quantity)
    assert asym.shape == lat.shape and np.all(asym < 1e-5), asym.max()
    for frame in ("enu", "ned", "ecef"):
        t = gradient_tensor(lat, lon, h, model=model60, quantity=quantity, frame=frame)
        assert t.shape == (lat.size, 3, 3)
        np.testing.assert_allclose(np.trace(t, axis1=-2, axis2=-1), trace, rtol=0, atol=1e-5)
        np.testing.assert_array_equal(t, np.swapaxes(t, -1, -2))
    assert trace == 0.0 or abs(trace - 10.635) < 1e-3


@pytest.mark.parametrize("normal", ["exact", "j2", "j4", "j6"])
def test_normal_free_air_gradient(normal):
    """At the equator and the poles, d|γ|/dh = −T_uu ≈ −3086 E (0.3086 mGal/m).

    Independent path: a central difference of the magnitude of ``normal_gravity`` along the
    height (10 m steps, truncation ~1e-9 relative).
    """
    lat = np.array([0.0, 90.0, -90.0, 0.0])
    lon = np.array([0.0, 0.0, 45.0, 100.0])
    h0 = np.array([0.0, 0.0, 0.0, 10e3])
    dh = 10.0
    mag = [
        np.linalg.norm(normal_gravity(lat, lon, h0 + s, normal=normal), axis=-1) for s in (dh, -dh)
    ]
    want = (mag[0] - mag[1]) / (2 * dh) / EOTVOS
    t = gradient_tensor(lat, lon, h0, quantity=f"normal:{normal}")
    np.testing.assert_allclose(-t[:, 2, 2], want, rtol=1e-3)
    assert np.all(np.abs(want[:3] + 3086.0) < 15.0)  # free-air gradient at h = 0
    # the vertical of normal gravity at the equator/poles: no east/north-up coupling
    np.testing.assert_allclose(t[:, :2, 2], 0.0, atol=1e-4)


def test_disturbance_is_model_minus_normal(model60):
    lat, lon, h = _points(6)
    g = gradient_tensor(lat, lon, h, model=model60, quantity="gravity")
    n = gradient_tensor(lat, lon, h, quantity="normal")
    d = gradient_tensor(lat, lon, h, model=model60, quantity="disturbance")
    np.testing.assert_allclose(d, g - n, rtol=0, atol=2e-5)
    assert np.abs(d).max() < 100.0  # degree-60 disturbance gradients: a few E


def test_shapes_and_refusals(model60):
    t = gradient_tensor([[10.0, 20.0]], 30.0, 0.0, model=model60, quantity="gravitation")
    assert t.shape == (1, 2, 3, 3)
    assert gradient_tensor([], [], [], quantity="normal").shape == (0, 3, 3)
    with pytest.raises(InputError, match="quantity"):
        gradient_tensor(0.0, 0.0, 0.0, model=model60, quantity="potential")
    with pytest.raises(InputError, match="frame"):
        gradient_tensor(0.0, 0.0, 0.0, model=model60, frame="xyz")
    with pytest.raises(InputError, match="applies to quantity normal or disturbance"):
        gradient_tensor(0.0, 0.0, 0.0, model=model60, quantity="gravity:j2")
    with pytest.raises(InputError, match="unknown normal-gravity model 'j3'"):
        gradient_tensor(0.0, 0.0, 0.0, model=model60, quantity="disturbance:j3")
    with pytest.raises(InputError):
        gradient_tensor(91.0, 0.0, 0.0, quantity="normal")
    assert "gradient_tensor" in fieldmap.__all__
    assert fieldmap.gradient_tensor is gradient_tensor


def _run(args, stdin):
    return subprocess.run(
        [sys.executable, "-m", "fieldmap", *args],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ},
    )


def test_cli_gradient(model60):
    """``fieldmap point --quantity gradient|gradient-disturbance``: 9 numbers, ENU row-major, E."""
    lat, lon, h = np.array([[45.0, 10.0, 1000.0], [0.0, -75.5, 20e3], [90.0, 0.0, 0.0]]).T
    stdin = "".join(
        f"{a!r} {b!r} {c!r}\n" for a, b, c in zip(lat.tolist(), lon.tolist(), h.tolist())
    )
    for q, what in (("gradient", "gravity"), ("gradient-disturbance", "disturbance")):
        out = _run(["point", "--quantity", q, "--lmax", "60", "--precision", "9"], stdin)
        assert out.returncode == 0, out.stderr
        got = np.array([[float(v) for v in line.split()] for line in out.stdout.splitlines()])
        want = gradient_tensor(lat, lon, h, model=model60, quantity=what).reshape(-1, 9)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-8)
    out = _run(["point", "--quantity", "gradient-invariants", "--lmax", "60", "--precision", "9"],
               stdin)  # fmt: skip
    assert out.returncode == 0, out.stderr
    got = np.array([[float(v) for v in line.split()] for line in out.stdout.splitlines()])
    t = gradient_tensor(lat, lon, h, model=model60, quantity="gravitation")
    inv = gradient_invariants(t)
    want = np.stack([inv[k] for k in ("I1", "I2", "eig_1", "eig_2", "eig_3")], axis=-1)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-8)
    out = _run(["point", "--quantity", "gradient", "--lmax", "60"], "1 2 3\n")
    assert len(out.stdout.split()) == 9 and len(out.stdout.split()[0].split(".")[1]) == 3
    out = _run(["point", "--quantity", "gradient", "--normal", "j2"], "1 2 3\n")
    assert out.returncode == 2 and out.stdout == ""
    assert len(out.stderr.strip().splitlines()) == 1 and "--normal" in out.stderr


@pytest.mark.skipif(
    __import__("fieldmap.models.geographiclib", fromlist=["x"]).gravity_tool() is None,
    reason="GeographicLib's Gravity (geographiclib-tools) missing",
)
def test_tensor_equals_central_differences_of_geographiclib_gravity(model60, tmp_path):
    """T = ∂g/∂x by 1 m central differences of GeographicLib's ``Gravity -G`` vector (≲ 0.05 E)."""
    from fieldmap.models.geographiclib import run_gravity_tool, write_egm

    name = write_egm(model60, tmp_path)
    lat = np.array([30.0, -45.0, 70.0, 0.0, 89.5])
    lon = np.array([105.0, 20.0, -60.0, 0.0, 10.0])
    h = np.array([1000.0, 20e3, 5000.0, 0.0, 3000.0])
    p0 = np.stack(geodetic_to_ecef(lat, lon, h, WGS84), -1)
    step = 1.0
    disp = np.concatenate([p0[:, None, :] + s * step * np.eye(3)[None] for s in (1.0, -1.0)], 1)
    pts = disp.reshape(-1, 3)  # (n * 6, 3): +x +y +z -x -y -z per point
    from fieldmap.field.frames import ecef_to_geodetic

    la, lo, hh = ecef_to_geodetic(pts[:, 0], pts[:, 1], pts[:, 2], WGS84)
    g_enu = run_gravity_tool(np.c_[la, lo, hh], tmp_path, name, "gravity", precision=15)
    g = np.einsum("nij,ni->nj", C_e_to_enu(la, lo), g_enu).reshape(len(lat), 6, 3)  # ECEF
    d = (g[:, :3] - g[:, 3:]) / (2.0 * step)  # [n, j, i] = ∂g_i/∂x_j
    t_ecef = np.swapaxes(d, 1, 2) / EOTVOS
    c = C_e_to_enu(lat, lon)
    want = c @ t_ecef @ np.swapaxes(c, -1, -2)
    got = gradient_tensor(lat, lon, h, model=model60, quantity="gravity")
    assert np.abs(want).max() > 1000.0
    np.testing.assert_allclose(got, want, rtol=0, atol=0.05)
