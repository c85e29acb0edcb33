"""Random tracks, a Kaula-rule random SH model and along-track statistics.

Shared by ``tests/test_omission.py`` and ``benchmarks/bench_omission.py``; none of it comes from
:mod:`fieldmap.field.omission` (the check compares that module with the point engine and with
direct Legendre sums written here).
"""

from __future__ import annotations

import numpy as np

from fieldmap.models.shmodel import SHModel

GM, RADIUS = 3.986004415e14, 6378136.46  # the bundled EIGEN-6S header


def kaula_model(lo: int, hi: int, seed: int) -> SHModel:
    """Random fully normalised coefficients of degrees lo..hi, each of σ = 1e-5/n² (Kaula)."""
    rng = np.random.default_rng(seed)
    n = np.arange(hi + 1, dtype=np.float64)
    sig = np.zeros(hi + 1)
    sig[lo:] = 1e-5 / n[lo:] ** 2
    lower = np.tril(np.ones((hi + 1, hi + 1), dtype=bool))
    C = rng.standard_normal((hi + 1, hi + 1)) * sig[:, None] * lower
    S = rng.standard_normal((hi + 1, hi + 1)) * sig[:, None] * lower
    S[:, 0] = 0.0
    return SHModel("kaula-random", GM, RADIUS, C, S, hi, source="synthetic")


def kaula_potential_variances(n: np.ndarray) -> np.ndarray:
    """Kaula's c_n of T at r = R: (GM/R)² (2n+1) 1e-10 / n⁴, (m²/s²)²."""
    return (GM / RADIUS) ** 2 * (2 * n + 1.0) * 1e-10 / n**4


def tracks(ntracks: int, npts: int, spacing_m: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Great-circle tracks from uniform random starts, uniform random azimuths: (lat, lon) deg.

    Shape ``(ntracks, npts)``; consecutive points ``spacing_m`` apart on the sphere of radius R.
    """
    rng = np.random.default_rng(seed)
    lat0 = np.arcsin(2 * rng.random(ntracks) - 1)[:, None]
    lon0 = 2 * np.pi * rng.random(ntracks)[:, None]
    az = 2 * np.pi * rng.random(ntracks)[:, None]
    d = np.arange(npts)[None, :] * spacing_m / RADIUS
    lat = np.arcsin(np.sin(lat0) * np.cos(d) + np.cos(lat0) * np.sin(d) * np.cos(az))
    lon = lon0 + np.arctan2(
        np.sin(az) * np.sin(d) * np.cos(lat0), np.cos(d) - np.sin(lat0) * np.sin(lat)
    )
    lon = (np.degrees(lon) + 180.0) % 360.0 - 180.0
    return np.degrees(lat), lon


def sh_ned(model: SHModel, lat: np.ndarray, lon: np.ndarray, h: float) -> np.ndarray:
    """δg = ∇T (north, east, down; m/s²) of ``model`` by the point engine, on r = R + h.

    Spherical points and frames, as the degree-variance models (the ellipsoid would put the
    poles 21 km inside R, where a degree-2190 field is continued downwards).
    """
    from fieldmap.field.sh import sh_gravitation

    phi, lam = np.radians(lat.ravel()), np.radians(lon.ravel())
    r = RADIUS + h
    x = np.stack([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)], axis=-1)
    g = np.asarray(sh_gravitation(model, *(r * x.T), device="cpu")).reshape(-1, 3)
    north = np.stack([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)], -1)
    east = np.stack([-np.sin(lam), np.cos(lam), np.zeros_like(lam)], -1)
    out = np.stack([np.sum(g * north, -1), np.sum(g * east, -1), -np.sum(g * x, -1)], axis=-1)
    return out.reshape(lat.shape + (3,))


def half_length(rho: np.ndarray, spacing_m: float) -> float:
    """Distance at which a correlation function (at lags 0, 1, ... spacings) first falls to ½."""
    k = int(np.argmax(rho < 0.5))
    if k == 0:
        return float("nan")
    frac = (rho[k - 1] - 0.5) / (rho[k - 1] - rho[k])
    return (k - 1 + frac) * spacing_m


def track_stats(ned: np.ndarray, spacing_m: float, maxlag: int) -> dict[str, float]:
    """Along-track variance and half-correlation length of δg down and horizontal.

    ``ned``: (ntracks, npts, 3), zero-mean fields. Horizontal pools north and east.
    """
    out = {}
    for name, comps in (("down", [2]), ("horizontal", [0, 1])):
        f = ned[..., comps]
        var = float(np.mean(f * f))
        cov = np.array([np.mean(f[:, k:] * f[:, : f.shape[1] - k]) for k in range(maxlag + 1)])
        out[f"var_{name}"] = var
        out[f"length_{name}"] = half_length(cov / cov[0], spacing_m)
    return out


def legendre_stats(
    c: np.ndarray, n: np.ndarray, h: float, spacing_m: float, maxlag: int
) -> dict[str, float]:
    """Compute the same statistics from the degree variances: direct Legendre sums.

    Down: Σ c_n ((n+1)/r)² q^(2n+2) P_n(cos θ); horizontal (one component, pooled over
    azimuths): ½ Σ c_n n(n+1)/r² q^(2n+2) P_n(cos θ), the trace of the horizontal covariance
    (exact at θ = 0, to O(θ²) beyond).
    """
    r = RADIUS + h
    w = c * np.exp((2 * n + 2) * np.log(RADIUS / r)) / r**2
    theta = np.arange(maxlag + 1) * spacing_m / RADIUS
    t = np.cos(theta)
    nmax = int(n.max())
    p_prev, p = np.ones_like(t), t.copy()
    cov_d, cov_h = np.zeros_like(t), np.zeros_like(t)
    index = {int(k): i for i, k in enumerate(n)}
    for k in range(1, nmax + 1):
        if k in index:
            i = index[k]
            cov_d += w[i] * (k + 1.0) ** 2 * p
            cov_h += 0.5 * w[i] * k * (k + 1.0) * p
        p_prev, p = p, ((2 * k + 1) * t * p - k * p_prev) / (k + 1)
    return {
        "var_down": float(cov_d[0]),
        "length_down": half_length(cov_d / cov_d[0], spacing_m),
        "var_horizontal": float(cov_h[0]),
        "length_horizontal": half_length(cov_h / cov_h[0], spacing_m),
    }
