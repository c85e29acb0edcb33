"""Gravity-field models: readers, the SH model type, bundled and synthetic models.

``icgem`` reads ICGEM ``.gfc`` files, ``shmodel`` holds :class:`SHModel`, ``registry`` resolves a
name or path to a model (bundled EIGEN-6S, Kaula-rule synthetics) with an in-process cache, and
``geographiclib`` writes a model in GeographicLib's ``.egm`` format.
"""
