"""Gravity-field models: readers, the SH model type, bundled and synthetic models.

``icgem`` reads ICGEM ``.gfc`` files (``nga`` NGA coefficient files, ``egm`` GeographicLib's
``.egm`` models), ``shmodel`` holds :class:`SHModel`, ``registry`` resolves a name or path to a
model (bundled EIGEN-6S, Kaula-rule synthetics) with an in-process cache, ``catalogue`` downloads
models by name (EGM2008, ...) once and verifies them, ``tide`` converts a model between the
permanent-tide systems, and ``geographiclib`` writes a model in GeographicLib's ``.egm`` format
and runs its ``Gravity`` tool.
"""
