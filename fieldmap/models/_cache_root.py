"""The folder of the on-disk model cache (:mod:`fieldmap.models.cache`), refused if it is a file.

A cache folder that cannot be written only costs the speed-up (the model still loads), as the
cache's docstring says. A path that is a file, or lies under one (``FIELDMAP_MODEL_CACHE`` set to
a file by mistake), is a misconfiguration: every use of the cache then reports it in one line,
rather than ``fieldmap cache info`` listing "0 cached models" in it and every run parsing the
model file again in silence.
"""

from __future__ import annotations

import os

from fieldmap.errors import InputError


def usable(root: str) -> str:
    """Return ``root``, refused if it is no folder.

    :class:`InputError` if ``root``, or the nearest existing path above it, is not a folder (a
    missing folder is fine: the cache creates it).
    """
    probe = os.path.abspath(root)
    while not os.path.lexists(probe):
        parent = os.path.dirname(probe)
        if parent == probe:
            return root
        probe = parent
    if os.path.isdir(probe):
        return root
    same = probe == os.path.abspath(root)
    why = "is not a folder" if same else f"cannot be made ({probe} is not a folder)"
    raise InputError(
        f"model cache folder {root} {why}: set FIELDMAP_MODEL_CACHE to a folder (or read models "
        "without the cache, --no-cache)"
    )
