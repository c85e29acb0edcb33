"""Statistics of the block engine: per-block partial results combined exactly, in block order.

Maximum, minimum, area-weighted sums for the mean and RMS, area above each threshold, per
block, folded in block order (:class:`OrderedFold`) so that every executor gives the same bits.
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

import numpy as np

from fieldmap.errors import InputError

__all__ = [
    "HIST_BINS",
    "HIST_MANTISSA_BITS",
    "HIST_RANGE_MG",
    "PERCENTILE_RTOL",
    "OrderedFold",
    "block_partial",
    "finish_statistics",
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


def _hist_index(v: np.ndarray) -> np.ndarray:
    """Histogram bin of each (finite, non-negative) modulus: a shift of its float64 bits."""
    k = (np.ascontiguousarray(v, dtype=np.float64).view(np.int64) >> _SHIFT) - _BITS_LO
    return np.clip(k, 0, HIST_BINS - 1)


def _bin_centre(k: int) -> float:
    """Middle of histogram bin ``k`` (mg)."""
    lo, hi = (np.array([k + _BITS_LO, k + 1 + _BITS_LO], dtype=np.int64) << _SHIFT).view(np.float64)
    return float(0.5 * (lo + hi))


def block_partial(modulus_mg: np.ndarray, row_weights: np.ndarray, thresholds) -> dict:
    """Partial statistics of one block: extrema, weighted sums, weighted histogram.

    ``row_weights`` are the (unnormalised) area weights of the block's rows
    (:func:`fieldmap.products.stats.area_weights` of the whole grid, taken at the rows).
    """
    v = modulus_mg
    if not np.all(np.isfinite(v)):
        raise InputError("map holds non-finite values")
    w = np.repeat(row_weights, v.shape[1])
    return {
        "max": float(v.max()),
        "min": float(v.min()),
        "sw": float(row_weights @ v.sum(axis=1)),
        "sw2": float(row_weights @ (v * v).sum(axis=1)),
        "above": [float(row_weights @ (v > t).sum(axis=1)) for t in thresholds],
        "hist": _sparse(np.bincount(_hist_index(v.ravel()), weights=w, minlength=HIST_BINS)),
    }


def scalar_partial(v: np.ndarray, row_weights: np.ndarray) -> dict:
    """Partial statistics of a signed quantity on one block: extrema and weighted sums."""
    if not np.all(np.isfinite(v)):
        raise InputError("map holds non-finite values")
    return {
        "min": float(v.min()),
        "max": float(v.max()),
        "sw": float(row_weights @ v.sum(axis=1)),
        "sw2": float(row_weights @ (v * v).sum(axis=1)),
    }


def _sparse(h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(bins, weights) of the non-empty bins: a block touches few of them, and travels light."""
    nz = np.flatnonzero(h)
    return nz.astype(np.int32), h[nz]


def merge_partials(acc: dict | None, part: dict) -> dict:
    """Fold one block's partial statistics into the running total (call in block order)."""
    if "vars" in part:  # signed quantities: extrema and sums per variable
        if acc is None:
            return {"vars": {k: dict(v) for k, v in part["vars"].items()}}
        for k, p in part["vars"].items():
            a = acc["vars"][k]
            a["min"] = min(a["min"], p["min"])
            a["max"] = max(a["max"], p["max"])
            a["sw"] += p["sw"]
            a["sw2"] += p["sw2"]
        return acc
    if acc is None:
        acc = {**part, "above": list(part["above"]), "hist": np.zeros(HIST_BINS)}
        acc["hist"][part["hist"][0]] = part["hist"][1]
        return acc
    acc["max"] = max(acc["max"], part["max"])
    acc["min"] = min(acc["min"], part["min"])
    acc["sw"] += part["sw"]
    acc["sw2"] += part["sw2"]
    acc["above"] = [a + b for a, b in zip(acc["above"], part["above"])]
    acc["hist"][part["hist"][0]] += part["hist"][1]  # distinct bins: no repeated index
    return acc


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
                "mean": a["sw"] / total_weight,
                "rms": math.sqrt(a["sw2"] / total_weight),
            }
            for k, a in acc["vars"].items()
        }

    out = {
        "max_mg": acc["max"],
        "min_mg": acc["min"],
        "mean_mg": acc["sw"] / total_weight,
        "rms_mg": math.sqrt(acc["sw2"] / total_weight),
    }
    cw = np.cumsum(acc["hist"])
    for q in percentiles:
        k = int(np.searchsorted(cw, q / 100.0 * cw[-1], side="left"))
        k = min(k, HIST_BINS - 1)
        out[f"p{q:g}_mg"] = _bin_centre(k)
    out["area_fraction_above"] = {
        threshold_key(t): a / total_weight for t, a in zip(thresholds, acc["above"])
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
