"""fieldmap: Earth gravity-field maps and strapdown inertial navigation with NVIDIA Warp.

Public API (see the README): models are read with :func:`fieldmap.icgem.read_icgem` or
:func:`fieldmap.models.load_model`; ellipsoids live in :mod:`fieldmap.ellipsoid`.
"""

__version__ = "0.1.0"

from .ellipsoid import GRS80, WGS84, Ellipsoid  # noqa: F401
