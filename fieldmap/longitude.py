"""Longitude sums of a grid row: sum_m (A_m cos m lon + B_m sin m lon) at every node.

Regular longitudes lon0 + k 360/L go through a real inverse FFT of length L (orders m >= L fold
onto m mod L exactly on the nodes); any other longitudes through a direct-sum Warp kernel
(:func:`fieldmap.kernels.grid.longitude_sum_kernel`). Used by :func:`fieldmap.grid.synthesize`.
"""

from __future__ import annotations

import numpy as np


def _regular_period(lon_deg: np.ndarray) -> int | None:
    """Number L of nodes on the full circle if the longitudes are lon0 + k*360/L, else None.

    More than L nodes are allowed (a grid holding both 0 and 360 deg): they wrap around.
    """
    if lon_deg.size < 2:
        return None
    step = (lon_deg[-1] - lon_deg[0]) / (lon_deg.size - 1)
    if step <= 0:
        return None
    period = 360.0 / step
    nper = int(round(period))
    if abs(period - nper) > 1e-8 * period or nper > 2**22:
        return None
    k = np.arange(lon_deg.size)
    if np.max(np.abs(lon_deg - (lon_deg[0] + k * 360.0 / nper))) > 1e-9:
        return None
    return nper


def longitude_sums(W: np.ndarray, lon_deg: np.ndarray, device: str = "cpu") -> np.ndarray:
    """Evaluate Re(sum_m W[..., m] e^{i m lon}) at every longitude.

    Parameters
    ----------
    W : numpy.ndarray
        Complex, shape (..., nm): W_m = A_m - i B_m for the series sum A_m cos + B_m sin.
    lon_deg : numpy.ndarray
        Longitudes. Units: degrees.
    device : str
        Warp device for the direct-sum fallback (irregular longitudes).

    Returns
    -------
    numpy.ndarray
        Real, shape (..., nlon).
    """
    lon_deg = np.asarray(lon_deg, dtype=np.float64)
    lead, nm = W.shape[:-1], W.shape[-1]
    W = W.reshape(-1, nm)
    nper = _regular_period(lon_deg)
    if nper is not None:
        import scipy.fft

        # rotate so that node k sits at k * 2 pi / L, then alias orders m -> m mod L (exact there)
        Z = W
        if lon_deg[0] != 0.0:
            Z = W * np.exp(1j * np.radians(lon_deg[0]) * np.arange(nm))
        if nm > nper:
            nfold = -(-nm // nper)
            F = np.zeros((W.shape[0], nfold * nper), dtype=np.complex128)
            F[:, :nm] = Z
            F = F.reshape(W.shape[0], nfold, nper).sum(axis=1)
        else:
            F = Z
        # Re(sum_j F_j w^jk) by a real inverse FFT of half length: X_0 = Re F_0,
        # X_j = (F_j + conj F_{L-j}) / 2 for 0 < j < L/2, X_{L/2} = Re F_{L/2} (even L)
        half = nper // 2
        X = np.zeros((W.shape[0], half + 1), dtype=np.complex128)
        nlow = min(F.shape[1], half + 1)
        X[:, :nlow] = F[:, :nlow]
        X[:, 1:] *= 0.5
        if F.shape[1] > half + 1:
            jj = np.arange(half + 1, F.shape[1])
            X[:, nper - jj] += 0.5 * np.conj(F[:, half + 1:])
        X[:, 0] = X[:, 0].real
        if nper % 2 == 0 and nlow == half + 1:
            X[:, half] = F[:, half].real
        out = scipy.fft.irfft(X, n=nper, axis=-1, norm="forward", workers=-1)
        # nodes beyond one turn (e.g. both 0 and 360 deg) repeat earlier ones
        out = out[:, : lon_deg.size] if lon_deg.size <= nper else out[:, np.arange(lon_deg.size) % nper]
        return np.ascontiguousarray(out).reshape(*lead, lon_deg.size)
    return _direct_sums(W, lon_deg, device).reshape(*lead, lon_deg.size)


def _direct_sums(W: np.ndarray, lon_deg: np.ndarray, device: str) -> np.ndarray:
    import warp as wp

    from . import _warp
    from .kernels import grid as kgrid

    from .grid import _load

    _load(device)
    nser, nm = W.shape
    ab = np.stack([W.real, -W.imag], axis=-1)
    coef = wp.array(np.ascontiguousarray(ab), dtype=wp.vec2d, device=device)
    lon = wp.array(np.radians(lon_deg), dtype=wp.float64, device=device)
    out = wp.zeros((nser, lon_deg.size), dtype=wp.float64, device=device)
    _warp.launch_chunked(
        kgrid.longitude_sum_kernel, nser * lon_deg.size,
        [coef, lon, nm, lon_deg.size, out], device,
    )
    return out.numpy()
