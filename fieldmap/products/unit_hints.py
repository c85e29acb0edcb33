"""Warnings for a map whose numbers suggest a unit typed wrong: computed, but said.

Two slips give maps that are legal but say nothing (issue 36's trials):

- metres typed into a km option: ``height_km=20000`` (a flight at 20 km) maps the field
  20,000 km up, whose largest disturbance (7e-5 mg) is 0.06 % of the colour scale that the
  thresholds set (0 to 0.12 mg): a blank map, and no threshold reached;
- mGal typed as mg: ``thresholds_mg=(20, 50)`` is 980 times the thresholds meant; no node
  reaches them, the area fractions are 0 % and the threshold maps are empty.

:func:`check_disturbance` warns (:class:`fieldmap.errors.UnitWarning`, a ``UserWarning``) at
most once per option, at the first height that shows the slip, naming it; the command line
prints it as one line on stderr.
A threshold just above a map's largest value is an answer, not a slip: only thresholds at least
:data:`FAR` times the largest value are reported, and a map is blank when its largest value is
under :data:`BLANK` of the colour scale's top (1.2 times the largest threshold, the top of the
disturbance maps' scale in :mod:`fieldmap.products.plots`).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Sequence
from typing import Any

from fieldmap.errors import UnitWarning
from fieldmap.products.statistics import threshold_key
from fieldmap.units import MG, MGAL

#: A threshold this many times the map's largest value is far beyond the data.
FAR = 10.0
#: A map whose largest value is under this fraction of its colour scale's top looks blank.
BLANK = 0.01
#: Heights from which metres typed as km are likely (a height of 1,000 km and more). Units: km.
METRES_AS_KM_FROM = 1000.0
#: The top of a disturbance map's colour scale, in units of its largest threshold.
SCALE_OVER_THRESHOLD = 1.2


def check_disturbance(
    stats: Sequence[dict[str, Any]], thresholds_mg: Sequence[float], heights_m: Iterable[float]
) -> None:
    """Warn of a disturbance map (or each height of a sweep) that looks like a unit slip.

    Parameters
    ----------
    stats : sequence of dict
        Per height, :func:`fieldmap.products.statistics.map_statistics`'s ``max_mg`` and
        ``area_fraction_above`` {threshold key: fraction}.
    thresholds_mg : sequence of float
        Units: mg.
    heights_m : sequence of float
        Units: m.
    """
    if not thresholds_mg:
        return
    top = SCALE_OVER_THRESHOLD * max(thresholds_mg)
    said: set[str] = set()
    for st, h in zip(stats, heights_m):
        km = float(h) / 1e3
        largest = float(st["max_mg"])
        fractions = st["area_fraction_above"]
        missed = [t for t in thresholds_mg if fractions[threshold_key(t)] == 0.0]
        far = [t for t in missed if t >= FAR * largest]
        blank = largest < BLANK * max(top, largest)
        where = f"at h = {km:g} km the largest |δg| is {largest:.2g} mg"
        if blank and km >= METRES_AS_KM_FROM:  # a height slip explains the empty thresholds
            if "height_km" in said:
                continue
            detail = (
                f"{where}, {100 * largest / top:.2g} % of the colour scale (0 to {top:g} mg, "
                f"from the thresholds): the map looks blank and no threshold is reached; were "
                f"metres meant ({km:g} m = {km / 1e3:g} km)?"
            )
            _warn("height_km", f"{km:g}", detail)
            said.add("height_km")
        elif far and "thresholds_mg" not in said:
            shown = ", ".join(f"{t:g}" for t in far)
            as_mg = ", ".join(f"{t * MGAL / MG:.3g}" for t in far)
            detail = (
                f"no node reaches {shown} mg ({where}): the area above is 0 %"
                + (" and the map is blank on its colour scale" if blank else "")
                + f"; were mGal meant ({shown} mGal = {as_mg} mg)?"
            )
            _warn("thresholds_mg", ", ".join(f"{t:g}" for t in thresholds_mg), detail)
            said.add("thresholds_mg")


def _warn(param: str, value: str, detail: str) -> None:
    warnings.warn(UnitWarning(param, value, detail), stacklevel=_caller_level())


def _caller_level() -> int:
    """Return the stacklevel of the first frame outside fieldmap (the user's call)."""
    import os
    import sys
    from types import FrameType

    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    frame: FrameType | None = sys._getframe(2)  # warnings.warn is called from _warn
    level = 2
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package):
        frame, level = frame.f_back, level + 1
    return level
