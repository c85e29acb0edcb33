"""Area-weighted statistics of latitude-longitude maps.

Every node of a grid stands for the area of its cell; on a regular grid that area is
proportional to the band of latitude the node covers (:func:`area_weights`), so
a plain node count would over-weight high latitudes by 1/cos(latitude). Chen et al. (2022) §4.1
quote "the fraction of the total area" above a threshold: that is the area-weighted fraction.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fieldmap.units import MG as MG  # 1 mg = 1e-3 standard gravity (m/s²)
from fieldmap.units import MGAL as MGAL  # 1 mGal = 1e-5 m/s²

DEFAULT_THRESHOLDS_MG = (0.02, 0.05, 0.06, 0.10)
DEFAULT_PERCENTILES = (50.0, 90.0, 99.0)


def area_weights(lat_deg: np.ndarray) -> np.ndarray:
    """Area weight of each latitude row of a grid (any longitude spacing).

    Each node stands for the band between the mid-latitudes to its neighbours (half bands at the
    ends of the grid), whose area on the sphere is proportional to the difference of the sines.

    Parameters
    ----------
    lat_deg : numpy.ndarray
        Ascending latitudes. Units: degrees.

    Returns
    -------
    numpy.ndarray
        Weights, summing to sin(last) - sin(first) (or 1 for a single row).
    """
    lat = np.asarray(lat_deg, dtype=np.float64)
    if lat.size == 1:
        return np.ones(1)
    edges = np.concatenate([[lat[0]], 0.5 * (lat[1:] + lat[:-1]), [lat[-1]]])
    return np.diff(np.sin(np.radians(edges)))


def weights_2d(lat_deg: np.ndarray, nlon: int) -> np.ndarray:
    """Area weight of every node of a (lat, lon) map, normalised to sum 1."""
    w = np.repeat(area_weights(lat_deg)[:, None], nlon, axis=1)
    return w / w.sum()


def weighted_percentiles(values, weights, qs) -> np.ndarray:
    r"""Weighted percentiles: for each q, the smallest value whose cumulative weight reaches q %.

    With the values sorted ascending, :math:`v_{(1)} \le \dots \le v_{(n)}`, and
    :math:`C_k = \sum_{i \le k} w_{(i)}`, the q-th percentile is :math:`v_{(k)}` for the smallest
    k with :math:`C_k \ge q/100 \, C_n` (the "inverted CDF" definition, no interpolation).

    All percentiles come from one pass instead of one sort each: the values are dealt into
    equal-width buckets whose weights are summed (:func:`numpy.bincount`); the bucket where the
    cumulative weight reaches each target is found from those sums, and only the values of
    that bucket are sorted (a crowded bucket is dealt into finer ones first). The result is one
    of the values, the same one a full sort picks (the cumulative sums differ only by rounding,
    ~1e-16 of the total weight).

    Parameters
    ----------
    values : array_like
        Any shape; finite.
    weights : array_like
        Non-negative weights broadcastable to ``values``, with a positive sum.
    qs : sequence of float
        Percentiles, 0..100.

    Returns
    -------
    numpy.ndarray
        One value per ``q``, in the units of ``values``.
    """
    v = np.asarray(values, dtype=np.float64)
    qs = np.atleast_1d(np.asarray(qs, dtype=np.float64))
    lo, hi = float(v.min()), float(v.max())
    if hi == lo:
        return np.full(qs.shape, lo)
    # one buffer for the three temporaries (weights, scaled values, bucket numbers): on some
    # systems fresh memory costs more than the arithmetic (page faults), and a large buffer
    # gets huge pages
    scratch = np.empty((3, v.size))
    w = scratch[0]
    np.copyto(w.reshape(v.shape), np.asarray(weights, dtype=np.float64))
    v = v.ravel()
    nb = int(min(max(v.size // 8, 1), 1 << 16))
    scaled = scratch[1]
    np.subtract(v, lo, out=scaled)
    scaled *= nb / (hi - lo)
    idx = scratch[2].view(np.int64)
    np.copyto(idx, scaled, casting="unsafe")  # truncation: the bucket number
    np.minimum(idx, nb - 1, out=idx)  # v = hi lands on nb by rounding
    cum = np.cumsum(np.bincount(idx, weights=w, minlength=nb))
    out = np.empty(qs.shape)
    for j, q in enumerate(qs):
        target = q / 100.0 * cum[-1]
        b = min(int(np.searchsorted(cum, target, side="left")), nb - 1)
        sel = np.flatnonzero(idx == b)
        out[j] = _pick(v[sel], w[sel], target, cum[b - 1] if b > 0 else 0.0)
    return out


#: Buckets of at most this many values are sorted; larger ones are dealt into buckets again.
_SORT_SIZE = 4096


def _pick(v, w, target, below) -> float:
    """Smallest of ``v`` whose cumulative weight (ascending, after ``below``) reaches ``target``.

    A bucket holding many values (a field crowded near one value, far from an outlier) is dealt
    into finer buckets again, a few times at most, before its values are sorted.
    """
    for _ in range(8):
        lo, hi = float(v.min()), float(v.max())
        scale = v.size // 8 / (hi - lo) if hi > lo else np.inf
        if v.size <= _SORT_SIZE or not np.isfinite(scale):
            break
        nb = v.size // 8
        idx = ((v - lo) * scale).astype(np.intp)
        np.minimum(idx, nb - 1, out=idx)
        cum = below + np.cumsum(np.bincount(idx, weights=w, minlength=nb))
        b = min(int(np.searchsorted(cum, target, side="left")), nb - 1)
        below = cum[b - 1] if b > 0 else below
        sel = np.flatnonzero(idx == b)
        v, w = v[sel], w[sel]
    order = np.argsort(v)
    cw = below + np.cumsum(w[order])
    k = min(int(np.searchsorted(cw, target, side="left")), v.size - 1)
    return float(v[order[k]])


def weighted_percentile(values: np.ndarray, weights: np.ndarray, q: float) -> float:
    """Weighted percentile (0..100): smallest value whose cumulative weight reaches q %.

    One percentile of :func:`weighted_percentiles`.
    """
    return float(weighted_percentiles(values, weights, [q])[0])


def map_statistics(
    modulus_mg: np.ndarray,
    lat_deg: np.ndarray,
    thresholds_mg=DEFAULT_THRESHOLDS_MG,
    percentiles=DEFAULT_PERCENTILES,
) -> dict:
    """Statistics of a modulus map with area weights.

    Every statistic but the extremes weights each node by the area of its cell
    (:func:`area_weights`): the mean, the root mean square, the percentiles and the fractions
    above the thresholds are those of the area, not of the node count.

    Parameters
    ----------
    modulus_mg : numpy.ndarray
        Shape (nlat, nlon). Units: mg.
    lat_deg : numpy.ndarray
        Latitudes of the rows. Units: degrees.
    thresholds_mg : sequence of float
        Units: mg.
    percentiles : sequence of float
        0..100.

    Returns
    -------
    dict
        ``max_mg``, ``min_mg``, ``mean_mg`` (area-weighted), ``rms_mg``, ``p<q>_mg``,
        ``area_fraction_above`` {threshold (str, mg): fraction 0..1}.
    """
    from fieldmap.errors import InputError

    try:
        v = np.asarray(modulus_mg, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("modulus must be a numeric (nlat, nlon) array") from None
    if v.ndim != 2 or v.shape[0] != np.size(lat_deg) or v.size == 0:
        raise InputError(
            f"modulus of shape {v.shape} must be (nlat, nlon) with nlat = {np.size(lat_deg)} "
            "latitudes"
        )
    if not np.all(np.isfinite(v)):
        raise InputError("map holds non-finite values")
    # weights are constant along a row: sum each row first, then weight the row sums
    w_row = area_weights(lat_deg)
    w_row = w_row / (w_row.sum() * v.shape[1])
    out: dict[str, Any] = {
        "max_mg": float(v.max()),
        "min_mg": float(v.min()),
        "mean_mg": float(w_row @ v.sum(axis=1)),
        "rms_mg": float(np.sqrt(w_row @ np.einsum("ij,ij->i", v, v))),
    }
    pct = weighted_percentiles(v, w_row[:, None], percentiles)
    for q, p in zip(percentiles, pct):
        out[f"p{q:g}_mg"] = float(p)
    out["area_fraction_above"] = {
        threshold_key(t): float(w_row @ np.count_nonzero(v > t, axis=1)) for t in thresholds_mg
    }
    return out


def threshold_key(t: float) -> str:
    """JSON key of a threshold in mg, e.g. 0.1 -> "0.1", 0.05 -> "0.05"."""
    return f"{float(t):g}"


def parse_thresholds(values) -> tuple[float, ...]:
    """Validate thresholds (mg): finite, positive, distinct; returned sorted.

    A repeated threshold is an error (as ``--thresholds-mg`` of the CLI), not silently dropped.
    """
    from fieldmap.errors import InputError

    try:
        vals = [float(v) for v in values]
    except (TypeError, ValueError):
        raise InputError(f"thresholds must be numbers in mg, got {values!r}") from None
    if not vals or not all(np.isfinite(v) and v > 0 for v in vals):
        raise InputError(f"thresholds must be positive finite numbers in mg, got {values!r}")
    if len(set(vals)) != len(vals):
        raise InputError(f"thresholds must be distinct: repeated threshold in {vals}")
    return tuple(sorted(vals))
