"""NumPy reference of the omitted field's realisations, independent of ``kernels/omission.py``.

Written for clarity, vectorised over points and waves (the kernel loops over the waves of one
point); the waves and their physics are :mod:`fieldmap.field.omission`'s.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def wave_sum(
    waves: dict[str, NDArray[np.float64]],
    lat: NDArray[np.float64],
    lon: NDArray[np.float64],
    h: NDArray[np.float64],
    radius: float,
) -> NDArray[np.float64]:
    """δg (north, east, down; m/s²) of every draw's waves at a chunk of points: (draws, P, 3).

    ``waves``: :meth:`fieldmap.field.omission.Omission.waves`; ``lat``, ``lon`` (deg) and ``h``
    (m) 1-D; spherical coordinates, r = ``radius`` + h.
    """
    phi, lam = np.radians(lat)[:, None], np.radians(lon)[:, None]
    sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
    x = (cp * cl, cp * sl, sp)  # unit position vector
    north = (-sp * cl, -sp * sl, cp)
    east = (-sl, cl, np.zeros_like(sl))
    r = (radius + h)[:, None]
    log_q = np.log(radius / r)
    out = np.empty((waves["degree"].shape[0], lat.size, 3))
    for d in range(out.shape[0]):
        n = waves["degree"][d][None, :]
        p = waves["pole"][d]
        px, py, pz = p[None, :, 0], p[None, :, 1], p[None, :, 2]
        cos_psi = x[0] * px + x[1] * py + x[2] * pz
        pn = north[0] * px + north[1] * py + north[2] * pz  # p = cosψ x + pn n + pe e
        pe = east[0] * px + east[1] * py + east[2] * pz
        sin_psi = np.hypot(pn, pe)
        psi = np.arctan2(sin_psi, cos_psi)
        nu = np.sqrt(n * (n + 1.0))
        arg = nu * psi + waves["phase"][d][None, :]
        a = waves["amplitude"][d][None, :] * np.exp((n + 1.0) * log_q) / r  # A (R/r)^(n+1) / r
        down = a * (n + 1.0) * np.cos(arg)
        # ∇_h T = (1/r) dT/dψ e_ψ, e_ψ·north = -pn/sinψ, e_ψ·east = -pe/sinψ
        with np.errstate(invalid="ignore", divide="ignore"):
            hor = np.where(sin_psi > 0.0, a * nu * np.sin(arg) / sin_psi, 0.0)
        out[d, :, 0] = np.sum(hor * pn, axis=1)
        out[d, :, 1] = np.sum(hor * pe, axis=1)
        out[d, :, 2] = np.sum(down, axis=1)
    return out
