"""The published values of Chen et al. (2022)'s tables, that the paper study is held against.

Data only (no study code), so that the figures and the reports that print them beside fieldmap's
numbers (:mod:`fieldmap.nav.plots`, :mod:`fieldmap.nav.report`) need not import the study
(:mod:`fieldmap.nav.paper`) that computes them.
"""

from __future__ import annotations

#: Paper values (Chen et al. 2022 Table 1): |δv| m/s, |δp| m, CPU s per gravity evaluation,
#: keyed by our navigation model names (the paper has no exact-normal row).
PAPER_TABLE1 = {
    "j2": (0.742, 387.18, 0.000003),
    "j4": (0.686, 351.28, 0.000003),
    "j6": (0.686, 351.19, 0.000004),
    "sh18": (0.181, 117.52, 0.000214),
    "sh200": (0.060, 35.88, 0.004449),
}
#: Paper values (Chen et al. 2022 Table 3): |δv| m/s, |δp| m per accelerometer group.
PAPER_TABLE3 = {1: (2.033, 1019.98), 2: (0.507, 296.69), 3: (0.667, 344.29), 4: (0.686, 351.19)}
