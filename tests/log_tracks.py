"""A raw track built in a test: :class:`fieldmap.nav.logs.read.RawTrack` with a test's defaults.

The conditioning's tests build their logs' truth themselves and hand the samples to
:func:`fieldmap.nav.logs.condition.condition` as the reader would: heights above the
ellipsoid, a line per sample from line 2 (a header on line 1) unless given.
"""

from __future__ import annotations

import numpy as np

from fieldmap.nav.logs.read import RawTrack


def raw_track(
    t: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    h: np.ndarray,
    lines: np.ndarray | None = None,
    *,
    source: str = "synthetic.csv",
    category: str | None = None,
) -> RawTrack:
    """Return the samples as a :class:`RawTrack` (heights above the ellipsoid)."""
    t = np.asarray(t, dtype=np.float64)
    lines = np.arange(t.size) + 2 if lines is None else np.asarray(lines)
    return RawTrack(t, lat, lon, h, lines, source, "ellipsoid", category=category)
