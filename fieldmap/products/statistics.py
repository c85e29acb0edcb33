"""Area-weighted statistics of latitude-longitude maps, whole or folded from blocks.

Every node of a grid stands for the area of its cell; on a regular grid that area is
proportional to the band of latitude the node covers (:func:`area_weights`), so
a plain node count would over-weight high latitudes by 1/cos(latitude). Chen et al. (2022) §4.1
quote "the fraction of the total area" above a threshold: that is the area-weighted fraction.

A whole map's statistics are :func:`map_statistics`. The block engine
(:mod:`fieldmap.products.engine`) folds per-block partial results in block order
(:class:`OrderedFold`): maximum, minimum, area-weighted sums for the mean and RMS, area above
each threshold. The sums are kept per latitude row and added exactly at the end
(``math.fsum``), and the histogram holds whole-number weights whose float64 sums are exact
(:func:`histogram_weights`): every executor and every block size gives the same bits.
Percentiles come from a mergeable histogram of the area weight over bins of the modulus read
from its float64 bits: the exponent and the leading ``HIST_MANTISSA_BITS`` bits of the mantissa
(``HIST_BINS`` bins over ``HIST_RANGE_MG``, each at most ``2**-12`` of its lower edge wide; a
shift of the bits, no logarithm). The bin holding the percentile is exact and its centre is
returned, within a relative ``PERCENTILE_RTOL`` (``2**-13``) of :func:`weighted_percentile`.
The signed quantities (anomaly, deflection, geoid, potential) have extrema and weighted sums
per variable (:func:`scalar_partial`).

One layout, one vocabulary: every statistic is of the modulus (or of a quantity's variable),
named ``<statistic>_<unit>`` (``max_mg``, ``mean_mg``, ``rms_mg``, ``p50_mg``...); a product
at one height carries them as attributes, a stack (heights, orders, degrees) as variables on
its stacking dimension under the same names.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.errors import InputError

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


def weighted_percentiles(values: ArrayLike, weights: ArrayLike, qs: ArrayLike) -> np.ndarray:
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


def _pick(v: np.ndarray, w: np.ndarray, target: float, below: float) -> float:
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
    thresholds_mg: Sequence[float] = DEFAULT_THRESHOLDS_MG,
    percentiles: Sequence[float] = DEFAULT_PERCENTILES,
) -> dict[str, Any]:
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


def parse_thresholds(values: Iterable[float | str]) -> tuple[float, ...]:
    """Validate thresholds (mg): finite, positive, distinct; returned sorted.

    A repeated threshold is an error (as ``--thresholds-mg`` of the CLI), not silently dropped.
    """
    try:
        vals = [float(v) for v in values]
    except (TypeError, ValueError):
        raise InputError(f"thresholds must be numbers in mg, got {values!r}") from None
    if not vals or not all(np.isfinite(v) and v > 0 for v in vals):
        raise InputError(f"thresholds must be positive finite numbers in mg, got {values!r}")
    if len(set(vals)) != len(vals):
        raise InputError(f"thresholds must be distinct: repeated threshold in {vals}")
    return tuple(sorted(vals))


#: Leading mantissa bits of the modulus that select its histogram bin (with the exponent).
HIST_MANTISSA_BITS = 12
_SHIFT = 52 - HIST_MANTISSA_BITS
#: Range of the histogram of the modulus (mg), powers of two: values outside fall into the end bins.
HIST_RANGE_MG = (2.0**-40, 2.0**14)
_BITS_LO = int(np.array(HIST_RANGE_MG[0]).view(np.int64)) >> _SHIFT
#: Number of histogram bins (54 octaves of 2**12 bins).
HIST_BINS = (int(np.array(HIST_RANGE_MG[1]).view(np.int64)) >> _SHIFT) - _BITS_LO
#: Largest relative error of a percentile: half a bin of relative width 2**-12 (1.2e-4).
PERCENTILE_RTOL = 2.0 ** -(HIST_MANTISSA_BITS + 1)


#: How the percentiles of a map are computed (``percentile_method=``): ``"histogram"``, from
#: per-block mergeable histograms (the default: the same bits on every executor and sink),
#: or ``"exact"``, the weighted percentiles of the whole map (products returned in memory).
PERCENTILE_METHODS = ("histogram", "exact")


def check_percentile_method(method: str) -> str:
    """Return ``method`` if it is one of :data:`PERCENTILE_METHODS`, else raise InputError."""
    if method not in PERCENTILE_METHODS:
        raise InputError(
            f"percentile_method must be one of {', '.join(PERCENTILE_METHODS)}, got {method!r}"
        )
    return method


def _hist_index(v: np.ndarray) -> np.ndarray:
    """Histogram bin of each (finite, non-negative) modulus: a shift of its float64 bits."""
    k = (np.ascontiguousarray(v, dtype=np.float64).view(np.int64) >> _SHIFT) - _BITS_LO
    return np.clip(k, 0, HIST_BINS - 1)


def _bin_centre(k: int) -> float:
    """Middle of histogram bin ``k`` (mg)."""
    lo, hi = (np.array([k + _BITS_LO, k + 1 + _BITS_LO], dtype=np.int64) << _SHIFT).view(np.float64)
    return float(0.5 * (lo + hi))


def histogram_weights(row_weights: np.ndarray, nlon: int) -> np.ndarray:
    """Area weights of the rows as whole numbers, for the histogram (float64 holding integers).

    Each row's weight is scaled so that the weights of all ``nrows * nlon`` nodes of a layer sum
    to at most 2**53: every sum of them in float64 is then exact, whatever the order of the
    additions, so the histogram (and the percentiles) do not depend on how the rows are grouped
    into blocks. The rounding changes a weight by at most half a unit, a relative 1e-8 or less
    on a 1e8-node map (immaterial beside the bins' 2**-12).
    """
    w = np.asarray(row_weights, dtype=np.float64)
    scale = float(2**53 // (max(1, w.size) * max(1, int(nlon))))
    return np.floor(w / w.max() * scale + 0.5)


def _rows(v: np.ndarray) -> np.ndarray:
    """Per-row sums of a (rows, nlon) block: each row summed alone, in its own order."""
    return np.ascontiguousarray(v, dtype=np.float64).sum(axis=1)


def block_partial(
    modulus_mg: np.ndarray,
    row_weights: np.ndarray,
    thresholds: Sequence[float],
    hist_weights: np.ndarray | None = None,
) -> dict[str, Any]:
    """Partial statistics of one block: extrema, per-row weighted sums, weighted histogram.

    ``row_weights`` are the (unnormalised) area weights of the block's rows
    (:func:`area_weights` of the whole grid, taken at the rows) and
    ``hist_weights`` the same as whole numbers (:func:`histogram_weights`, default from
    ``row_weights``). The sums are kept per row and added exactly (``math.fsum``) when the
    statistics are finished, so nothing depends on the blocks' sizes or order. Parts of the
    rows are reduced on the CPU threads and joined exactly (the same partial for any split).
    """
    from fieldmap.grids.longitude import map_rows

    v = np.ascontiguousarray(modulus_mg, dtype=np.float64)
    if hist_weights is None:
        hist_weights = histogram_weights(row_weights, v.shape[1])
    rw, hw = np.asarray(row_weights), np.asarray(hist_weights)
    parts = map_rows(lambda a, b: rows_partial(v[a:b], rw[a:b], thresholds, hw[a:b]), len(v), 32)
    return joined_partials(parts, len(thresholds))


def joined_partials(parts: list, nthresholds: int) -> dict:
    """Join the partials of the parts of a block's rows (in row order) into the block's."""
    if any(p is None for p in parts):
        raise InputError("map holds non-finite values")
    vmax, vmin = max(p[0] for p in parts), min(p[1] for p in parts)
    lo = _hist_lo(vmin)
    if len(parts) == 1:
        hist = parts[0][6]
    else:
        hist = np.zeros(_bin(vmax) - lo + 1)
        for p in parts:  # whole numbers below 2**53: exact in any order
            o = p[2] - lo
            hist[o : o + p[6].size] += p[6]
    nz = np.flatnonzero(hist)

    def joined(i: int, j: int | None = None) -> list[np.ndarray]:
        return [np.concatenate([p[i] if j is None else p[i][j] for p in parts])]

    return {
        "max": vmax,
        "min": vmin,
        "sw": joined(3),
        "sw2": joined(4),
        "above": [joined(5, j) for j in range(nthresholds)],
        "hist": ((nz + lo).astype(np.int32), hist[nz]),
    }


def _bin(x: float) -> int:
    """Histogram bin of one float (:func:`_hist_index` of a scalar, without an array)."""
    k = (struct.unpack("=q", struct.pack("=d", x))[0] >> _SHIFT) - _BITS_LO
    return min(max(k, 0), HIST_BINS - 1)


def _hist_lo(vmin: float) -> int:
    """Return the first histogram bin counted: the minimum's, or 0."""
    # the bins of the non-negative moduli are monotonic in their values: only those from the
    # minimum's to the maximum's are counted (negative values fall into bin 0, as in
    # _hist_index)
    return _bin(vmin) if vmin > 0 else 0


def rows_partial(
    v: np.ndarray, row_weights: np.ndarray, thresholds: Sequence[float], hist_weights: np.ndarray
) -> tuple[float, float, int, np.ndarray, np.ndarray, list[np.ndarray], np.ndarray] | None:
    """Return the partial of rows ``v``, or None if a value is not finite.

    (max, min, bin ``lo`` of the minimum, per-row weighted sums of v and v², per-row areas above
    each threshold, weighted histogram of the bins ``lo`` to the maximum's).
    """
    vmax, vmin = float(v.max()), float(v.min())  # NaN propagates, inf is caught
    if not (math.isfinite(vmax) and math.isfinite(vmin)):
        return None
    lo, hi = _hist_lo(vmin), _bin(vmax)
    flag = np.empty(v.shape, dtype=bool)  # one buffer for every threshold
    # counts of whole rows of bytes: uint16 holds them, and sums bytes faster than int64
    count = np.uint16 if v.shape[1] < 2**16 else np.int64
    above = []
    for t in thresholds:
        np.greater(v, t, out=flag)
        above.append(row_weights * np.add.reduce(flag.view(np.uint8), axis=1, dtype=count))
    k = v.view(np.int64) >> _SHIFT
    k -= _BITS_LO + lo
    if lo == 0 or hi == HIST_BINS - 1:  # values out of the range (or negative): clip them
        np.clip(k, 0, hi - lo, out=k)
    w = np.repeat(hist_weights, v.shape[1])
    hist = np.bincount(k.ravel(), weights=w, minlength=hi - lo + 1)
    return vmax, vmin, lo, row_weights * _rows(v), row_weights * _rows(v * v), above, hist


def scalar_partial(v: np.ndarray, row_weights: np.ndarray) -> dict:
    """Partial statistics of a signed quantity on one block: extrema and per-row weighted sums."""
    if not np.all(np.isfinite(v)):
        raise InputError("map holds non-finite values")
    return {
        "min": float(v.min()),
        "max": float(v.max()),
        "sw": [row_weights * _rows(v)],
        "sw2": [row_weights * _rows(v * v)],
    }


def _fold_sums(a: dict, p: dict) -> None:
    a["min"] = min(a["min"], p["min"])
    a["max"] = max(a["max"], p["max"])
    a["sw"] = a["sw"] + p["sw"]
    a["sw2"] = a["sw2"] + p["sw2"]


def merge_partials(acc: dict | None, part: dict) -> dict:
    """Fold one block's partial statistics into the running total (any order: exact sums)."""
    if "vars" in part:  # signed quantities: extrema and sums per variable
        if acc is None:
            return {"vars": {k: dict(v) for k, v in part["vars"].items()}}
        for k, p in part["vars"].items():
            _fold_sums(acc["vars"][k], p)
        return acc
    if acc is None:
        return {**part, "above": [list(a) for a in part["above"]], "hist": [part["hist"]]}
    _fold_sums(acc, part)
    acc["above"] = [a + b for a, b in zip(acc["above"], part["above"])]
    acc["hist"] = acc["hist"] + [part["hist"]]  # added up in finish_statistics
    return acc


def _merged_histogram(parts: list) -> tuple[np.ndarray, np.ndarray]:
    """(bins, weights) of the non-empty bins of the sum of sparse histograms, bins ascending.

    The weights are whole numbers below 2**53 (:func:`histogram_weights`): exact in any order.
    """
    if len(parts) == 1:  # one block's: its bins are distinct, ascending, non-empty
        return parts[0][0].astype(np.int64), parts[0][1]
    bins = np.concatenate([p[0] for p in parts]).astype(np.int64)
    weights = np.concatenate([p[1] for p in parts])
    if bins.size == 0:
        return bins, weights
    lo = int(bins.min())
    h = np.bincount(bins - lo, weights=weights)
    nz = np.flatnonzero(h)
    return nz + lo, h[nz]


def _fsum(parts: list) -> float:
    """Exactly rounded sum of the per-row terms (independent of their order and grouping)."""
    return math.fsum(np.concatenate(parts).tolist())


def finish_statistics(
    acc: dict[str, Any],
    total_weight: float,
    thresholds: Sequence[float],
    percentiles: Sequence[float],
) -> dict[str, Any]:
    """Statistics in the form of :func:`map_statistics`.

    For the signed quantities: {variable: {"min", "max", "mean", "rms"}}, the form of
    :func:`fieldmap.products.variables.quantity_statistics_fields`.
    """
    if "vars" in acc:
        return {
            k: {
                "min": a["min"],
                "max": a["max"],
                "mean": _fsum(a["sw"]) / total_weight,
                "rms": math.sqrt(_fsum(a["sw2"]) / total_weight),
            }
            for k, a in acc["vars"].items()
        }

    out = {
        "max_mg": acc["max"],
        "min_mg": acc["min"],
        "mean_mg": _fsum(acc["sw"]) / total_weight,
        "rms_mg": math.sqrt(_fsum(acc["sw2"]) / total_weight),
    }
    # the cumulative weight of all bins steps up only at the non-empty ones: the first bin
    # where it reaches a target > 0 is a non-empty bin (a target <= 0: bin 0)
    bins, weights = _merged_histogram(acc["hist"])
    cw = np.cumsum(weights)
    total = float(cw[-1]) if cw.size else 0.0
    for q in percentiles:
        target = q / 100.0 * total
        j = int(np.searchsorted(cw, target, side="left"))
        if target <= 0:
            k = 0
        elif j < bins.size:
            k = int(bins[j])
        else:
            k = HIST_BINS - 1
        out[f"p{q:g}_mg"] = _bin_centre(k)
    out["area_fraction_above"] = {
        threshold_key(t): _fsum(a) / total_weight for t, a in zip(thresholds, acc["above"])
    }
    return out


class OrderedFold:
    """Fold partial statistics in block order whatever order they arrive in."""

    def __init__(self, nlayers: int):
        self.acc: list[dict | None] = [None] * nlayers
        self._next = 0
        self._waiting: dict[int, tuple[int, dict]] = {}

    def add(self, index: int, layer: int, part: dict) -> None:
        """Record block ``index``'s partial; fold every block now in sequence."""
        self._waiting[index] = (layer, part)
        while self._next in self._waiting:
            lay, p = self._waiting.pop(self._next)
            self.acc[lay] = merge_partials(self.acc[lay], p)
            self._next += 1
