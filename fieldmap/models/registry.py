"""Gravity models by name or path: the bundled EIGEN-6S, user ICGEM files, synthetic Kaula models.

``load_model()`` with no argument returns the bundled EIGEN-6S (degree 240, see
``fieldmap/data/README.md``), read through :mod:`importlib.resources`. Parsed models are cached in
memory, keyed by the file (path, size, modification time), the epoch and the degree read; a
truncation of a cached full model is a cheap copy.
"""

from __future__ import annotations

import os
import threading
from importlib import resources

import numpy as np

from fieldmap.errors import InputError
from fieldmap.models.icgem import as_degree, parse_epoch, read_icgem
from fieldmap.models.shmodel import SHModel

#: bundled models: lower-case name -> file in fieldmap/data
BUNDLED = {"eigen-6s": "eigen-6s.gfc.gz"}
DEFAULT_MODEL = "eigen-6s"

_cache: dict = {}
_cache_lock = threading.Lock()
_CACHE_SIZE = 4


def _read_cached(key, reader) -> SHModel:
    with _cache_lock:
        if key in _cache:
            return _cache[key]
    model = reader()
    with _cache_lock:
        _cache[key] = model
        while len(_cache) > _CACHE_SIZE:
            _cache.pop(next(iter(_cache)))
    return model


def clear_cache() -> None:
    """Forget every parsed model held in memory."""
    with _cache_lock:
        _cache.clear()


def load_model(name_or_path="eigen-6s", lmax: int | None = None, epoch=None) -> SHModel:
    """Return a spherical-harmonic gravity model.

    Parameters
    ----------
    name_or_path : str or os.PathLike or SHModel or None
        A bundled model name (``"eigen-6s"``, case-insensitive), the path of an ICGEM ``.gfc`` or
        ``.gfc.gz`` file, or an :class:`SHModel` (returned, truncated to ``lmax`` if given).
        None: the default model (EIGEN-6S).
    lmax : int, optional
        Truncation degree; default: the model's full degree.
    epoch : float or str, optional
        Epoch of the time-variable terms (decimal year or ``'YYYY-MM-DD'``). Units: year.
        Default: each coefficient's reference epoch.

    Returns
    -------
    SHModel

    Raises
    ------
    InputError
        Unknown name, missing file, ``lmax`` not a non-negative integer or above the model's
        degree, bad epoch.
    ModelFileError
        Malformed model file.
    """
    lmax = as_degree(lmax)
    if name_or_path is None:
        name_or_path = DEFAULT_MODEL
    if isinstance(name_or_path, SHModel):
        return _truncate(name_or_path, lmax)
    t = parse_epoch(epoch)
    if isinstance(name_or_path, bytes):
        name_or_path = os.fsdecode(name_or_path)
    if not isinstance(name_or_path, (str, os.PathLike)):
        raise InputError(
            f"model must be a bundled model name, a file path or an SHModel, got {name_or_path!r}"
        )
    name = os.fspath(name_or_path)
    bundled = BUNDLED.get(str(name).strip().lower())
    if bundled:
        key: tuple = ("bundled", bundled, t)

        def reader():
            ref = resources.files("fieldmap.data").joinpath(bundled)
            with resources.as_file(ref) as path:
                model = read_icgem(path, epoch=t)
            return _with_source(model, f"fieldmap/data/{bundled} (bundled)")

        return _truncate(_read_cached(key, reader), lmax)
    if not os.path.exists(name):
        raise InputError(
            f"unknown model {name!r}: not a bundled model ({', '.join(BUNDLED)}) "
            "nor an existing file"
        )
    st = os.stat(name)
    key = ("file", os.path.realpath(name), st.st_size, st.st_mtime_ns, t)
    with _cache_lock:
        full = _cache.get(key + (None,))
    if full is not None:
        return _truncate(full, lmax)
    # read only the degrees needed (the reader skips the numbers of higher degrees)
    part = None if lmax is None else int(lmax)
    return _read_cached(key + (part,), lambda: _earth(read_icgem(name, lmax=part, epoch=t)))


#: accepted GM and reference radius of a user's model file: within 2 % of WGS84's (every
#: Earth model on ICGEM is within 1e-6); others (Moon, Mars, unit errors) make the
#: disturbance against the WGS84/GRS80 normal field meaningless. Units: m³/s², m.
EARTH_GM = (0.98 * 3.986004418e14, 1.02 * 3.986004418e14)
EARTH_RADIUS = (0.98 * 6378137.0, 1.02 * 6378137.0)


def _earth(model: SHModel) -> SHModel:
    """Return ``model`` if its GM and radius are an Earth model's; else raise InputError."""
    if not (
        EARTH_GM[0] <= model.gm <= EARTH_GM[1]
        and EARTH_RADIUS[0] <= model.radius <= EARTH_RADIUS[1]
    ):
        raise InputError(
            f"{model.source}: GM {model.gm:g} m³/s² and radius {model.radius:g} m are not an "
            "Earth model's (fieldmap compares with the WGS84/GRS80 normal field)"
        )
    return model


def _with_source(model: SHModel, source: str) -> SHModel:
    from dataclasses import replace

    return replace(model, source=source)


def _truncate(model: SHModel, lmax) -> SHModel:
    if lmax is None or int(lmax) == model.lmax:
        return model
    if int(lmax) > model.lmax:
        raise InputError(f"lmax {lmax} exceeds the degree {model.lmax} of model {model.name}")
    return model.truncated(int(lmax))


def kaula_model(
    lmax: int, seed: int = 0, gm: float = 3.986004415e14, radius: float = 6378136.3
) -> SHModel:
    """Return a synthetic model with random coefficients following Kaula's rule.

    Each C̄nm, S̄nm (n ≥ 2) is drawn from a normal distribution of standard deviation
    σn = 1e-5 / n² (Kaula 1966); C̄00 = 1, degree 1 is zero (origin at the centre of mass),
    S̄n0 = 0 and C̄20 = −4.84165e-4, as for the Earth. Deterministic for a given seed.

    Parameters
    ----------
    lmax : int
        Maximum degree (≥ 0).
    seed : int
        Seed of :func:`numpy.random.default_rng`.
    gm : float
        Units: m³/s². Gravitational constant of the model (default: EIGEN-6C4's).
    radius : float
        Units: m. Reference radius of the model (default: EIGEN-6C4's).
    """
    lmax = int(lmax)
    if lmax < 0:
        raise InputError(f"lmax must be >= 0, got {lmax}")
    rng = np.random.default_rng(seed)
    n = np.arange(lmax + 1, dtype=float)
    sigma = np.zeros(lmax + 1)
    sigma[2:] = 1e-5 / n[2:] ** 2
    lower = np.tri(lmax + 1, dtype=bool)
    C = np.where(lower, rng.standard_normal((lmax + 1, lmax + 1)) * sigma[:, None], 0.0)
    S = np.where(lower, rng.standard_normal((lmax + 1, lmax + 1)) * sigma[:, None], 0.0)
    S[:, 0] = 0.0
    C[0, 0] = 1.0
    if lmax >= 2:
        C[2, 0] = -4.84165e-4
    return SHModel(
        name=f"kaula-{lmax}-seed{seed}",
        gm=float(gm),
        radius=float(radius),
        C=C,
        S=S,
        max_degree=lmax,
        tide_system="unknown",
        epoch=None,
        source="synthetic",
    )
