"""Independent NumPy reference implementations, written for clarity rather than speed.

Each Warp kernel in :mod:`fieldmap.kernels` has a counterpart here; the tests compare the two.
"""
