"""Shared settings of the example scripts.

The examples reproduce Chen et al. (2022) §4 at full size by default. The test suite runs them
small through environment variables:

- ``FIELDMAP_EXAMPLE_STEP``: grid step in degrees (default 1, as the paper; Fig. 10: 0.025)
- ``FIELDMAP_EXAMPLE_LMAX``: model degree (default: EIGEN-6S full degree 240)
- ``FIELDMAP_EXAMPLE_OUT``: output folder (default ``outputs/examples``)
"""

import os
from pathlib import Path


def step(default: float = 1.0) -> float:
    """Grid step in degrees."""
    return float(os.environ.get("FIELDMAP_EXAMPLE_STEP", default))


def lmax():
    """Model degree, or None for the full degree."""
    v = os.environ.get("FIELDMAP_EXAMPLE_LMAX")
    return int(v) if v else None


def out_dir() -> Path:
    """Folder of the figures (created)."""
    from fieldmap.products.io import prepare_out_dir

    return prepare_out_dir(os.environ.get("FIELDMAP_EXAMPLE_OUT", "outputs/examples"))
