"""Gradient tensor by central differences of the gravity vector: the reference of the synthesis.

:func:`central_difference_tensor` returns T[i, j] = ∂g_i/∂x_j (Eötvös) of the model's gravity,
gravitation, disturbance or normal gravity from fieldmap's float64 gravity *vector* in ECEF
(:func:`fieldmap.field.sh.sh_gravitation`, :func:`fieldmap.field.normal.normal_gravitation_ecef`,
centrifugal ω²(x, y, 0)), all 12 displaced points of every input point in one batched launch: it
shares no code with the tensor synthesis (:mod:`fieldmap.kernels.grid_tensor`). The step is
h = 1 m along each ECEF axis, with one Richardson step (steps h and 2h):

    D(s) = (g(x + s e_j) − g(x − s e_j)) / 2s,    ∂g/∂x_j = (4 D(h) − D(2h)) / 3,

whose truncation error, O(h⁴ ∂⁵V), is negligible for degrees up to ~2000 (wavelengths ≥ 20 km);
the roundoff of float64 gravity (~1e-15 m/s² over 2 m) is ~1e-15 s⁻² = 1e-6 E. The tensor is
symmetrised, (T + Tᵀ)/2; the removed antisymmetric part, max |T − Tᵀ|/2 per point, is returned
too, as a check of the differencing. The ECEF tensor is rotated to ENU with the rotation C at
the geodetic point, C T Cᵀ, and to NED by reordering (north, east, −up). This was fieldmap
0.3's ``gradient_tensor``; it costs 12 point evaluations per node.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fieldmap.field import frames
from fieldmap.field.ellipsoid import Ellipsoid
from fieldmap.field.legendre import legendre_rows
from fieldmap.models.shmodel import SHModel

#: Finite-difference step along each ECEF axis (the second step is twice this). Units: m.
STEP = 1.0
#: 1 Eötvös. Units: s⁻².
EOTVOS = 1e-9
#: ENU -> NED reordering (north, east, -up)
_ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _vector_ecef(
    quantity: str,
    model: SHModel | None,
    normal: str,
    ell: Ellipsoid,
    device: str | None,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
) -> np.ndarray:
    """Return the gravity vector of ``quantity`` at ECEF points (flat arrays), ECEF. Units: m/s²."""
    from fieldmap.field.normal import normal_gravitation_ecef

    if quantity == "normal":
        g = normal_gravitation_ecef(x, y, z, normal=normal, ellipsoid=ell, device=device)
    else:
        from fieldmap.field.sh import sh_gravitation

        assert model is not None  # loaded for every quantity but normal
        g = sh_gravitation(model, x, y, z, device=device)
        if quantity == "disturbance":
            g = g - normal_gravitation_ecef(x, y, z, normal=normal, ellipsoid=ell, device=device)
    if quantity in ("gravity", "normal"):
        g = g + frames.centrifugal_ecef(x, y, z, ell.omega)
    return g


def spherical_tensor(
    model: SHModel,
    lat_deg: NDArray[np.float64],
    lon_deg: NDArray[np.float64],
    h_m: NDArray[np.float64],
    ell: Ellipsoid,
) -> NDArray[np.float64]:
    """Gravitation tensor (s⁻²) of ``model`` in geodetic ENU at points off the poles, (n, 3, 3).

    See the module docstring. ``lat_deg``, ``lon_deg``, ``h_m`` flat arrays (degrees, m).
    """
    x, y, z = frames.geodetic_to_ecef(lat_deg, lon_deg, h_m, ell)
    rho = np.hypot(x, y)
    r = np.hypot(rho, z)
    t, u = z / r, rho / r
    lam = np.arctan2(y, x)
    q = model.radius / r
    L = model.lmax
    names = ("V", "r", "rr", "p", "rp", "pp", "l", "rl", "pl", "ll")
    acc = {k: np.zeros_like(r) for k in names}
    for nn, P, PU in legendre_rows(t, u, L):
        # P̄_{nn, m+1} of the identity is in the same row (P̄_{nn, nn+1} = 0)
        m = np.arange(nn + 1, dtype=np.float64)
        zcol = np.zeros((P.shape[0], 1))
        Pn = np.concatenate([P, zcol], axis=1)
        mm = np.arange(nn + 2, dtype=np.float64)
        ee = np.sqrt(np.maximum((nn - mm) * (nn + mm + 1), 0.0))
        ee[0] = np.sqrt(nn * (nn + 1) / 2.0)
        e = ee[:-1]
        tu = (t / u)[:, None]
        # first derivative for m = 0..nn+1 (the last is 0), then the second for m = 0..nn
        d1 = -mm * tu * Pn
        d1[:, :-1] += e * Pn[:, 1:]
        d2 = -m / u[:, None] * PU - m * tu * d1[:, :-1] + e * d1[:, 1:]
        c = model.C[nn, : nn + 1]
        s = model.S[nn, : nn + 1]
        cm = np.cos(np.outer(lam, m))
        sm = np.sin(np.outer(lam, m))
        f = c * cm + s * sm  # (N, m)
        fl = m * (s * cm - c * sm)  # ∂f/∂λ
        fll = -(m**2) * f
        k = model.gm / r * q**nn
        P0, D1 = Pn[:, :-1], d1[:, :-1]
        acc["V"] += k * np.sum(P0 * f, axis=1)
        acc["r"] += -(nn + 1) / r * k * np.sum(P0 * f, axis=1)
        acc["rr"] += (nn + 1) * (nn + 2) / r**2 * k * np.sum(P0 * f, axis=1)
        acc["p"] += k * np.sum(D1 * f, axis=1)
        acc["rp"] += -(nn + 1) / r * k * np.sum(D1 * f, axis=1)
        acc["pp"] += k * np.sum(d2 * f, axis=1)
        acc["l"] += k * np.sum(P0 * fl, axis=1)
        acc["rl"] += -(nn + 1) / r * k * np.sum(P0 * fl, axis=1)
        acc["pl"] += k * np.sum(D1 * fl, axis=1)
        acc["ll"] += k * np.sum(P0 * fll, axis=1)
    a = acc
    T = np.empty((r.size, 3, 3))
    T[:, 2, 2] = a["rr"]
    T[:, 1, 1] = a["pp"] / r**2 + a["r"] / r
    T[:, 0, 0] = a["ll"] / (r * u) ** 2 + a["r"] / r - t * a["p"] / (r**2 * u)
    T[:, 1, 2] = T[:, 2, 1] = a["rp"] / r - a["p"] / r**2
    T[:, 0, 2] = T[:, 2, 0] = a["rl"] / (r * u) - a["l"] / (r**2 * u)
    T[:, 0, 1] = T[:, 1, 0] = a["pl"] / (r**2 * u) + t * a["l"] / (r * u) ** 2
    gc = frames.C_e_to_enu(np.degrees(np.arctan2(z, rho)), np.degrees(lam))  # geocentric
    gd = frames.C_e_to_enu(lat_deg, lon_deg)
    T_ecef = np.swapaxes(gc, -1, -2) @ T @ gc
    return gd @ T_ecef @ np.swapaxes(gd, -1, -2)


def central_difference_tensor(
    lat: NDArray[np.float64],
    lon: NDArray[np.float64],
    h: NDArray[np.float64],
    model: SHModel | None,
    quantity: str,
    ell: Ellipsoid,
    frame: str,
    device: str | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return the tensor (E) and its asymmetry (E) at geodetic points, by central differences.

    ``lat``, ``lon``, ``h``: checked geodetic coordinates of one shape (degrees, degrees, m);
    ``quantity`` one of ``gravity``, ``gravitation``, ``disturbance``, ``normal``, the last two
    with a normal field after a colon (``"normal:j4"``, a name of
    :data:`fieldmap.field.normal.NORMAL_MODELS`; default ``exact``); ``frame`` ``enu``,
    ``ned`` or ``ecef``. Returns shapes ``lat.shape + (3, 3)`` and ``lat.shape``.
    """
    quantity, _, normal = quantity.partition(":")
    normal = normal or "exact"
    shape = lat.shape
    if lat.size == 0:
        return np.zeros(shape + (3, 3)), np.zeros(shape)
    x, y, z = (np.ravel(v) for v in frames.geodetic_to_ecef(lat, lon, h, ell))
    p0 = np.stack([x, y, z], axis=-1)  # (n, 3)
    # displaced points: axis j, offsets (+h, -h, +2h, -2h) -> (3, 4, n, 3)
    offsets = np.array([STEP, -STEP, 2 * STEP, -2 * STEP])
    eye = np.eye(3)
    pts = p0[None, None, :, :] + offsets[None, :, None, None] * eye[:, None, None, :]
    flat = pts.reshape(-1, 3)
    g = _vector_ecef(quantity, model, normal, ell, device, flat[:, 0], flat[:, 1], flat[:, 2])
    g = g.reshape(3, 4, -1, 3)
    d1 = (g[:, 0] - g[:, 1]) / (2 * STEP)  # (j, n, i)
    d2 = (g[:, 2] - g[:, 3]) / (4 * STEP)
    d = (4.0 * d1 - d2) / 3.0
    t = np.transpose(d, (1, 2, 0)) / EOTVOS  # (n, i, j)
    asym = np.max(np.abs(t - np.swapaxes(t, -1, -2)), axis=(-1, -2)) / 2.0
    t = (t + np.swapaxes(t, -1, -2)) / 2.0
    if frame != "ecef":
        c = frames.C_e_to_enu(lat.ravel(), lon.ravel())
        t = c @ t @ np.swapaxes(c, -1, -2)
        if frame == "ned":
            t = _ENU_TO_NED @ t @ _ENU_TO_NED.T
        t = (t + np.swapaxes(t, -1, -2)) / 2.0  # exactly symmetric after the rotation too
    return t.reshape(shape + (3, 3)), asym.reshape(shape)
