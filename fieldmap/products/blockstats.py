"""Statistics of the block engine: per-block partial results combined exactly, in block order.

Maximum, minimum, area-weighted sums for the mean and RMS, area above each threshold, per
block, folded in block order (:class:`OrderedFold`). The sums are kept per latitude row and
added exactly at the end (``math.fsum``), and the histogram holds whole-number weights whose
float64 sums are exact (:func:`histogram_weights`): every executor and every block size gives
the same bits.
Percentiles come from a mergeable histogram of the area weight over bins of the modulus read
from its float64 bits: the exponent and the leading ``HIST_MANTISSA_BITS`` bits of the mantissa
(``HIST_BINS`` bins over ``HIST_RANGE_MG``, each at most ``2**-12`` of its lower edge wide; a
shift of the bits, no logarithm). The bin holding the percentile is exact and its centre is
returned, within a relative ``PERCENTILE_RTOL`` (``2**-13``) of the weighted percentile of
:func:`fieldmap.products.stats.weighted_percentile`. The signed quantities (anomaly,
deflection, geoid, potential) have extrema and weighted sums per variable
(:func:`scalar_partial`).
"""

from __future__ import annotations

import math
import struct

import numpy as np

from fieldmap.errors import InputError

__all__ = [
    "HIST_BINS",
    "HIST_MANTISSA_BITS",
    "HIST_RANGE_MG",
    "PERCENTILE_METHODS",
    "PERCENTILE_RTOL",
    "check_percentile_method",
    "disturbance_partial",
    "OrderedFold",
    "block_partial",
    "finish_statistics",
    "histogram_weights",
    "merge_partials",
    "scalar_partial",
]

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


def check_percentile_method(method) -> str:
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
    modulus_mg: np.ndarray, row_weights: np.ndarray, thresholds, hist_weights=None
) -> dict:
    """Partial statistics of one block: extrema, per-row weighted sums, weighted histogram.

    ``row_weights`` are the (unnormalised) area weights of the block's rows
    (:func:`fieldmap.products.stats.area_weights` of the whole grid, taken at the rows) and
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
    parts = map_rows(lambda a, b: _rows_partial(v[a:b], rw[a:b], thresholds, hw[a:b]), len(v), 32)
    return _joined(parts, len(thresholds))


def disturbance_partial(vec: np.ndarray, units: str, row_weights, thresholds, hist_weights):
    """Convert a block's m/s² vector in place and take its statistics, in one pass over the rows.

    The variables of :func:`fieldmap.products.cf.vector_vars` with ``overwrite=True`` and the
    statistics of :func:`block_partial` of their ``modulus_mg``, the same bits: each part of
    the rows (on the CPU threads) is converted (:func:`fieldmap.products.cf.convert_rows`) and
    reduced while it is in the cache.

    Returns
    -------
    (dict, dict)
        {name: (rows, nlon) array} of east, north, up, modulus, modulus_mg, and the partial.
    """
    from fieldmap.grids.longitude import map_rows
    from fieldmap.products.cf import convert_rows
    from fieldmap.units import get_unit

    scale = get_unit(units).si
    comps = np.moveaxis(vec, -1, 0)
    mods = np.empty((2, *comps.shape[1:]))
    rw, hw = np.asarray(row_weights), np.asarray(hist_weights)

    def part(a, b):
        convert_rows(comps, comps, mods, scale, a, b)
        return _rows_partial(mods[1, a:b], rw[a:b], thresholds, hw[a:b])

    parts = map_rows(part, comps.shape[1], 32)
    names = ("east", "north", "up", "modulus", "modulus_mg")
    return dict(zip(names, (*comps, *mods))), _joined(parts, len(thresholds))


def _joined(parts: list, nthresholds: int) -> dict:
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

    def joined(i, j=None):
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


def _rows_partial(v: np.ndarray, row_weights, thresholds, hist_weights):
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


def finish_statistics(acc: dict, total_weight: float, thresholds, percentiles) -> dict:
    """Statistics in the form of :func:`fieldmap.products.stats.map_statistics`.

    For the signed quantities: {variable: {"min", "max", "mean", "rms"}}, the form of
    :func:`fieldmap.products.quantity_maps.statistics_fields`.
    """
    from fieldmap.products.stats import threshold_key

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
