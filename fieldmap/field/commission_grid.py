r"""Commission error on grids: the σ of :mod:`fieldmap.field.commission` at every node, by rows.

On a circle of latitude (one geodetic latitude and height: one geocentric t, u, r) the basis
function of :math:`\bar C_{nm}` is :math:`b_{nm}\cos m\lambda` and that of :math:`\bar S_{nm}`
is :math:`b_{nm}\sin m\lambda` (the east component: :math:`\mp\sin`/:math:`\cos`), with
:math:`b_{nm}` fixed on the row. The diagonal propagation of the point module,
:math:`\sigma^2 = \sum b^2(\sigma_C^2\cos^2 m\lambda + \sigma_S^2\sin^2 m\lambda)`, therefore
folds over n once per row,

.. math::
    \sigma^2(\lambda) = \sum_m A_m\cos^2 m\lambda + B_m\sin^2 m\lambda,\qquad
    A_m = \sum_n b_{nm}^2\sigma^2_{C,nm},\; B_m = \sum_n b_{nm}^2\sigma^2_{S,nm},

and the longitudes cost one (nlon × (L+1)) product: O(L²) per row instead of O(L²) per node.
Same basis values and Legendre rows (:func:`fieldmap.field.legendre.legendre_rows`) as the point
function; ``tests/test_commission.py`` checks the two against each other at the nodes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.commission import MGAL, disturbance_basis
from fieldmap.field.ellipsoid import Ellipsoid, get_ellipsoid
from fieldmap.field.legendre import legendre_rows
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec

#: map quantity -> (point quantity, variables)
GRID_QUANTITIES = {
    "disturbance-sigma": ("disturbance", ("sigma_east", "sigma_north", "sigma_up")),
    "anomaly-sigma": ("anomaly", ("anomaly_sigma",)),
    "geoid-sigma": ("geoid", ("geoid_sigma",)),
}


def grid_commission(
    model: SHModel, grid: GridSpec, quantity: str, *, ellipsoid: Ellipsoid | str
) -> dict[str, np.ndarray]:
    """σ of δg (east, north, up; mGal), Δg (mGal) or N (m, at h = 0) on every node of ``grid``.

    ``model`` must carry ``sigma_c`` and ``sigma_s`` (already truncated). Returns
    {variable: array ``grid.shape``} with the variables of :data:`GRID_QUANTITIES`.
    """
    if quantity not in GRID_QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(GRID_QUANTITIES)}, got {quantity!r}")
    if model.sigma_c is None or model.sigma_s is None:
        raise InputError(
            f"model {model.name} carries no coefficient standard deviations (sigma C, sigma S):"
            " the commission error needs an ICGEM file with sigma columns"
        )
    ellipsoid = get_ellipsoid(ellipsoid)
    what, names = GRID_QUANTITIES[quantity]
    heights = np.zeros(1) if what == "geoid" else np.asarray(grid.heights, dtype=np.float64)
    lam = np.radians(np.asarray(grid.lon, dtype=np.float64))
    L = model.lmax
    mm = np.arange(L + 1, dtype=np.float64)
    cos2 = np.cos(np.outer(lam, mm)) ** 2  # (nlon, L+1)
    sin2 = 1.0 - cos2
    out = {name: np.empty((heights.size, grid.lat.size, grid.lon.size)) for name in names}
    for k, h in enumerate(heights):
        x, _, z = frames.geodetic_to_ecef(grid.lat, np.zeros_like(grid.lat), h, ellipsoid)
        rho = np.abs(x)
        r = np.hypot(rho, z)
        var = _row_variances(model, z / r, rho / r, r, np.radians(grid.lat), what)
        for c, name in enumerate(names):
            a, b = var[c]
            # σ²(row, λ) = Σ_m A cos² mλ + B sin² mλ, one row at a time: a product over
            # several rows could sum in another order for another block size (not the same bits)
            v = np.stack([cos2 @ a[i] + sin2 @ b[i] for i in range(a.shape[0])])
            if what == "geoid":
                from fieldmap.field.normal import somigliana

                gamma0 = np.asarray(somigliana(grid.lat, ellipsoid=ellipsoid), dtype=np.float64)
                out[name][k] = np.sqrt(v * (model.gm / r[:, None]) ** 2) / gamma0[:, None]
            else:
                out[name][k] = np.sqrt(v * (model.gm / r[:, None] ** 2) ** 2) * MGAL
    return out


def _row_variances(
    model: SHModel,
    t: NDArray[np.float64],
    u: NDArray[np.float64],
    r: NDArray[np.float64],
    phi: NDArray[np.float64],
    what: str,
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """Return [(A, B) per component]: weights of cos² mλ and sin² mλ per row and order."""
    L = model.lmax
    nrow = t.size
    mm = np.arange(L + 1, dtype=np.float64)
    sc2, ss2 = np.asarray(model.sigma_c) ** 2, np.asarray(model.sigma_s) ** 2
    q2 = (model.radius / r) ** 2
    disturbance = what == "disturbance"
    ncomp = 3 if disturbance else 1
    A = np.zeros((ncomp, nrow, L + 1))
    B = np.zeros((ncomp, nrow, L + 1))
    delta = phi - np.arctan2(t, u)  # geodetic minus geocentric latitude
    cd, sd = np.cos(delta)[:, None], np.sin(delta)[:, None]
    qn2 = np.ones(nrow)[:, None]
    for n, P, PU in legendre_rows(t, u, L):
        k = slice(0, n + 1)
        if not disturbance:
            f = (n - 1.0) if what == "anomaly" else 1.0
            w = qn2 * (f * f) * P * P
            A[0, :, k] += w * sc2[n, k]
            B[0, :, k] += w * ss2[n, k]
        else:
            east, north, up = disturbance_basis(n, P, PU, t, mm[k], cd, sd)
            east = qn2 * east**2  # basis ∓ sin mλ for C, cos mλ for S
            A[0, :, k] += east * ss2[n, k]
            B[0, :, k] += east * sc2[n, k]
            for c, b in ((1, north), (2, up)):
                w = qn2 * b * b
                A[c, :, k] += w * sc2[n, k]
                B[c, :, k] += w * ss2[n, k]
        qn2 = qn2 * q2[:, None]
    return [(A[c], B[c]) for c in range(ncomp)]
