"""Longitude sums of a grid row: sum_m (A_m cos m lon + B_m sin m lon) at every node.

Regular longitudes lon0 + k 360/L go through inverse FFTs of length L, two real series per
complex transform (orders m >= L fold onto m mod L exactly on the nodes); any other longitudes
through a direct-sum Warp kernel (:func:`fieldmap.kernels.grid.longitude_sum_kernel`). Used by
:func:`fieldmap.grids.synthesis.synthesize`.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def regular_period(lon_deg: np.ndarray) -> int | None:
    """Return L if the longitudes are lon0 + k*360/L (k = 0, 1, ...), else None.

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


def longitude_sums(
    W: np.ndarray, lon_deg: np.ndarray, device: str = "cpu", out: np.ndarray | None = None
) -> np.ndarray:
    """Evaluate Re(sum_m W[..., m] e^{i m lon}) at every longitude.

    Parameters
    ----------
    W : numpy.ndarray
        Complex, shape (..., nm): W_m = A_m - i B_m for the series sum A_m cos + B_m sin.
    lon_deg : numpy.ndarray
        Longitudes. Units: degrees.
    device : str
        Warp device for the direct-sum fallback (irregular longitudes).
    out : numpy.ndarray, optional
        Real array of shape (..., nlon) to fill (may be a view into a larger buffer).

    Returns
    -------
    numpy.ndarray
        Real, shape (..., nlon) (``out`` when given).
    """
    lon_deg = np.asarray(lon_deg, dtype=np.float64)
    lead, nm = W.shape[:-1], W.shape[-1]
    nlon = lon_deg.size
    # the series of one item (the last-but-one axis: the components of one grid row) are
    # transformed together and with nothing else, so a row's values never depend on which
    # rows share its block: the same bits for any blocking (see the pairing below)
    group = W.shape[-2] if W.ndim >= 2 else 1
    W = W.reshape(-1, nm)
    ns = W.shape[0]
    if out is None:
        out = np.empty((*lead, nlon))
    res = out.reshape(ns, nlon)  # a view for the contiguous buffers the callers pass
    nper = regular_period(lon_deg)
    if nper is None:
        res[...] = _direct_sums(W, lon_deg, device)
        return out
    import scipy.fft

    # rotate so that node k sits at k * 2 pi / L, then alias orders m -> m mod L (exact there)
    F = W
    if lon_deg[0] != 0.0:
        F = W * np.exp(1j * np.radians(lon_deg[0]) * np.arange(nm))
    if nm > nper:
        nfold = -(-nm // nper)
        G = np.zeros((ns, nfold * nper), dtype=np.complex128)
        G[:, :nm] = F
        F = G.reshape(ns, nfold, nper).sum(axis=1)
    # Two real series per complex inverse FFT: with P = F_a + i F_b, M = F_a - i F_b (both
    # zero from order nF on), z_k = Re(sum F_a w^jk) + i Re(sum F_b w^jk) is the inverse DFT of
    # Z_j = (P_j + conj M_{-j}) / 2 (indices mod L). The tail of Z holds conj M reversed.
    nF = F.shape[1]
    if group % 2:  # pair the series of one item only: pad each item with a zero series
        F3 = np.zeros((ns // group, group + 1, nF), dtype=F.dtype)
        F3[:, :group] = F.reshape(-1, group, nF)
        F = F3.reshape(-1, nF)
    Fa, Fb = F[0::2], F[1::2]
    Z = np.zeros((Fa.shape[0], nper), dtype=np.complex128)
    Z[:, :nF] = Fa + 1j * Fb
    if nF > 1:
        Z[:, nper - nF + 1 :] += np.conj(Fa[:, :0:-1] - 1j * Fb[:, :0:-1])
    Z[:, 0] += np.conj(Fa[:, 0] - 1j * Fb[:, 0])
    Z *= 0.5
    z = scipy.fft.ifft(Z, axis=-1, norm="forward", workers=-1, overwrite_x=True)
    g2 = group + group % 2
    zz = np.empty((z.shape[0] * 2, nper))  # the series in the padded order, then unpadded
    zz[0::2] = z.real
    zz[1::2] = z.imag
    zz = zz.reshape(-1, g2, nper)[:, :group].reshape(ns, nper)
    # nodes beyond one turn (e.g. both 0 and 360 deg) repeat earlier ones
    for k0 in range(0, nlon, nper):
        k1 = min(nlon, k0 + nper)
        res[:, k0:k1] = zz[:, : k1 - k0]
    if not np.shares_memory(res, out):
        out[...] = res.reshape(out.shape)
    return out


def _direct_sums(W: np.ndarray, lon_deg: np.ndarray, device: str) -> np.ndarray:
    import warp as wp

    from fieldmap import _warp
    from fieldmap.kernels import grid as kgrid

    _warp.init()  # launch_chunked compiles the module once, before its threads launch
    nser, nm = W.shape
    ab = np.stack([W.real, -W.imag], axis=-1)
    coef: Any = wp.array(np.ascontiguousarray(ab), dtype=wp.vec2d, device=device)
    lon: Any = wp.array(np.radians(lon_deg), dtype=wp.float64, device=device)
    out = wp.zeros((nser, lon_deg.size), dtype=wp.float64, device=device)
    _warp.launch_chunked(
        kgrid.longitude_sum_kernel,
        nser * lon_deg.size,
        [coef, lon, nm, lon_deg.size, out],
        device,
    )
    return out.numpy()
