"""Warp kernels and device functions of fieldmap (installed as ``fieldmap.kernels``).

This package holds Warp code only: ``@wp.func``, ``@wp.kernel`` and ``@wp.struct``. It never imports
``fieldmap`` (imports go fieldmap -> kernels), does no I/O and parses no arguments.
"""
