"""Area-weighted statistics of latitude-longitude maps.

Every node of a grid stands for the area of its cell; on a regular grid that area is
proportional to the band of latitude the node covers (:func:`area_weights`), so
a plain node count would over-weight high latitudes by 1/cos(latitude). Chen et al. (2022) §4.1
quote "the fraction of the total area" above a threshold: that is the area-weighted fraction.
"""

from __future__ import annotations

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


def weighted_percentile(values: np.ndarray, weights: np.ndarray, q: float) -> float:
    """Weighted percentile (0..100): smallest value whose cumulative weight reaches q %."""
    v = np.asarray(values, dtype=np.float64).ravel()
    w = np.asarray(weights, dtype=np.float64).ravel()
    order = np.argsort(v, kind="stable")
    cw = np.cumsum(w[order])
    k = int(np.searchsorted(cw, q / 100.0 * cw[-1], side="left"))
    return float(v[order[min(k, v.size - 1)]])


def map_statistics(
    modulus_mg: np.ndarray,
    lat_deg: np.ndarray,
    thresholds_mg=DEFAULT_THRESHOLDS_MG,
    percentiles=DEFAULT_PERCENTILES,
) -> dict:
    """Statistics of a modulus map with area weights.

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
    w = weights_2d(lat_deg, v.shape[1])
    out = {
        "max_mg": float(v.max()),
        "min_mg": float(v.min()),
        "mean_mg": float(np.sum(w * v)),
        "rms_mg": float(np.sqrt(np.sum(w * v * v))),
    }
    for q in percentiles:
        out[f"p{q:g}_mg"] = weighted_percentile(v, w, q)
    out["area_fraction_above"] = {threshold_key(t): float(np.sum(w[v > t])) for t in thresholds_mg}
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
