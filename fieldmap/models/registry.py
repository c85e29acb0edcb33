"""Gravity models by name or path: the bundled EIGEN-6S, user model files, synthetic Kaula models.

``load_model()`` with no argument returns the bundled EIGEN-6S (degree 240, see
``fieldmap/data/README.md``), read through :mod:`importlib.resources`. A catalogue name
(``EGM2008``, ``EIGEN-6C4``..., :mod:`.catalogue`) is downloaded once and verified. A user's
file is recognised by its content (:func:`detect_format`): an ICGEM ``.gfc`` (:mod:`.icgem`), an NGA
plain coefficient file (:mod:`.nga`), or GeographicLib's ``.egm`` + ``.egm.cof`` pair
(:mod:`.egm`; also found by name in ``model_dir`` or GeographicLib's gravity folders,
as ``Gravity -n NAME -d DIR``).

Parsed models are cached in memory, keyed by the file (path, size, modification and change
times), the epoch, the options and the degree read; a truncation of a cached full model is a
cheap copy. A new process finds them in the verified on-disk cache of :mod:`.cache`
(``cache=False`` skips it).
"""

from __future__ import annotations

import gzip
import os
import stat
import threading
import zlib
from collections.abc import Callable
from importlib import resources
from typing import TYPE_CHECKING, Any, TextIO

import numpy as np

from fieldmap.errors import InputError
from fieldmap.models import cache as disk_cache
from fieldmap.models import icgem
from fieldmap.models.icgem import as_degree, parse_epoch, read_icgem
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    import argparse

#: bundled models: lower-case name -> file in fieldmap/data
BUNDLED = {"eigen-6s": "eigen-6s.gfc.gz"}
DEFAULT_MODEL = "eigen-6s"

_cache: dict[tuple[Any, ...], SHModel] = {}
_cache_lock = threading.Lock()
_CACHE_SIZE = 4


def _read_cached(key: tuple[Any, ...], reader: Callable[[], SHModel]) -> SHModel:
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


#: file formats recognised by :func:`detect_format`
FORMATS = ("icgem", "nga", "egm")


def detect_format(path: str | os.PathLike[str]) -> str:
    """Recognise a model file by its content: ``"icgem"``, ``"nga"`` or ``"egm"``.

    ``EGMF-`` on the first line is GeographicLib's metadata (as is a ``.egm.cof`` file name);
    first lines of ``n m C S [σC σS]`` numbers are NGA's header-less format; anything else goes
    to the reader its name suggests (``.egm``: GeographicLib's; else ICGEM's), whose errors
    then say what is missing. A pipe or device is read as ICGEM (its head cannot be sniffed and
    read again), and so is a broken gzip file (the ICGEM reader names the damage).
    """
    from fieldmap.models.nga import looks_like_nga

    path = os.fspath(path)
    if path.endswith(".egm.cof"):
        return "egm"
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            # a pipe (``--model <(zcat f.gz)``) cannot be read twice: only ICGEM comes that way
            return "icgem"
    except OSError:
        return "icgem"
    try:
        with open(path, "rb") as f:
            head = f.read(1 << 16)
        if head[:2] == b"\x1f\x8b":
            with gzip.open(path, "rb") as f:
                head = f.read(1 << 16)
    except (OSError, EOFError, zlib.error):  # gzip.BadGzipFile is an OSError
        return "icgem"  # its reader names the problem
    if head.lstrip().startswith(b"EGMF-"):
        return "egm"
    if b"end_of_head" in head or b"begin_of_head" in head:
        return "icgem"
    if looks_like_nga(head):
        return "nga"
    return "egm" if path.endswith(".egm") else "icgem"


def _in_model_dir(name: str, model_dir: str | os.PathLike[str]) -> str | None:
    """Path of ``model_dir/NAME.egm``, ``model_dir/name`` or ``name`` inside it, or None.

    ``name`` is taken as it is where it is a path (absolute or relative) to a file inside
    ``model_dir``.
    """
    from fieldmap.models.egm import find_egm

    found = find_egm(name, model_dir)
    if found:
        return found
    if not os.path.isabs(name):
        joined = os.path.join(os.fspath(model_dir), name)
        if os.path.exists(joined):
            return joined
    if os.path.exists(name):
        real, top = os.path.realpath(name), os.path.realpath(os.fspath(model_dir))
        try:
            inside = real != top and os.path.commonpath([real, top]) == top
        except ValueError:  # another drive (Windows)
            inside = False
        if inside:
            return name
    return None


def _resolve_path(name: str, model_dir: str | os.PathLike[str] | None) -> str:
    """Path of a model given by path, or by GeographicLib name in ``model_dir``."""
    from fieldmap.models.egm import default_gravity_dirs, find_egm

    if model_dir is not None and (found := _in_model_dir(name, model_dir)):
        return found
    if os.path.exists(name):
        if model_dir is not None:  # refused, not ignored
            raise InputError(
                f"{name} is a file path, not a model in model_dir {os.fspath(model_dir)} "
                "(which is for GeographicLib model names): read it without model_dir"
            )
        return name
    found = None if model_dir is not None else find_egm(name)
    if found:
        return found
    from fieldmap.models import catalogue

    listed = None if model_dir is not None else catalogue.lookup(name)
    if listed is not None:  # downloaded once, verified (one line if it cannot be)
        return catalogue.fetch(listed)
    where = (
        f"nor {name}.egm in {os.fspath(model_dir)}"
        if model_dir is not None
        else f"nor a GeographicLib model in {', '.join(default_gravity_dirs())}"
    )
    raise InputError(
        f"unknown model {name!r}: not a bundled model ({', '.join(BUNDLED)}), "
        f"not a catalogue model ({', '.join(catalogue.names())}), not an existing file, {where}"
    )


def load_model(
    name_or_path: str | os.PathLike[str] | bytes | SHModel | None = "eigen-6s",
    lmax: int | None = None,
    epoch: float | str | None = None,
    *,
    model_dir: str | os.PathLike[str] | None = None,
    gm: float | None = None,
    radius: float | None = None,
    cache: bool = True,
    tide_system: str | None = None,
) -> SHModel:
    """Return a spherical-harmonic gravity model.

    Parameters
    ----------
    name_or_path : str or os.PathLike or SHModel or None
        A bundled model name (``"eigen-6s"``, case-insensitive); a catalogue name
        (``"EGM2008"``, :mod:`fieldmap.models.catalogue`: downloaded once, verified); the path
        of an ICGEM ``.gfc`` or ``.gfc.gz`` file, of an NGA coefficient file (EGM96, EGM2008)
        or of a GeographicLib ``.egm`` file; a GeographicLib model name (``egm2008``) found in
        ``model_dir`` or in GeographicLib's gravity folders (before the catalogue); or an
        :class:`SHModel` (returned, truncated to ``lmax`` if given). None: the default model
        (EIGEN-6S).
    lmax : int, optional
        Truncation degree; default: the model's full degree.
    epoch : float or str, optional
        Epoch of the time-variable terms (decimal year or ``'YYYY-MM-DD'``). Units: year.
        Default: each coefficient's reference epoch. Refused for a static model (an NGA or
        ``.egm`` file, an ICGEM file without time-variable lines), where it would do nothing.
    model_dir : str or os.PathLike, optional
        Folder of GeographicLib models (``Gravity -d``): ``name_or_path`` is then looked up as
        ``model_dir/NAME.egm`` first, then as a path relative to it; refused for the path of a
        file outside it (it would do nothing).
    gm, radius : float, optional
        Units: m³/s², m. GM and reference radius of an NGA coefficient file (which has none);
        default: NGA's values for EGM84/EGM96/EGM2008 named in the file name. Refused for
        other formats, which carry their own.
    cache : bool
        Use the on-disk cache of parsed coefficients (:mod:`fieldmap.models.cache`).
    tide_system : {"tide_free", "zero_tide", "mean_tide"}, optional
        Convert the model to this permanent-tide system (:mod:`fieldmap.models.tide`); default:
        the system of the file.

    Returns
    -------
    SHModel

    Raises
    ------
    InputError
        Unknown name, missing file, ``lmax`` not a non-negative integer or above the model's
        degree, bad epoch or one given for a static model, ``model_dir`` that does nothing,
        unknown tide system, or one asked of a model whose own is unknown.
    ModelFileError
        Malformed model file.

    Examples
    --------
    >>> from fieldmap.models.registry import load_model
    >>> model = load_model("eigen-6s", lmax=36)
    >>> model.lmax, model.nominal_degree
    (36, 240)
    >>> model  # doctest: +ELLIPSIS
    SHModel('EIGEN-6S', degree=36 (of 240), GM=3.986004415e+14 m3/s2, a=6378136.46 m, ...)
    """
    if tide_system is None:
        return _load(name_or_path, lmax, epoch, model_dir, gm, radius, cache)
    from fieldmap.models.tide import check_tide_system, convert_tide_system

    target = check_tide_system(tide_system)  # before the file is read: a typo costs nothing
    model = _load(name_or_path, lmax, epoch, model_dir, gm, radius, cache)
    return convert_tide_system(model, target)


def _load(
    name_or_path: str | os.PathLike[str] | bytes | SHModel | None,
    lmax: int | None,
    epoch: float | str | None,
    model_dir: str | os.PathLike[str] | None,
    gm: float | None,
    radius: float | None,
    cache: bool,
) -> SHModel:
    """:func:`load_model` before any tide-system conversion."""
    lmax = as_degree(lmax)
    if name_or_path is None:
        name_or_path = DEFAULT_MODEL
    if isinstance(name_or_path, SHModel):
        if epoch is not None:  # its coefficients are fixed: an epoch cannot be applied now
            t = parse_epoch(epoch)
            have = name_or_path.epoch
            if have is None or t is None or abs(t - have) > 1e-9:
                raise InputError(
                    f"epoch {epoch} cannot be applied to the model object {name_or_path.name!r} "
                    f"(its coefficients are fixed, epoch {have if have is not None else 'unset'}):"
                    " pass the model file's name or path with epoch=, or load_model(..., epoch=)"
                )
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
    if bundled and (gm is not None or radius is not None):
        raise InputError(f"{name} has its own GM and radius; --gm/--radius are for NGA files only")
    if bundled:
        key: tuple = ("bundled", bundled, t)

        def reader() -> SHModel:
            # through the on-disk cache as a user's file (parsing the .gz costs ~0.1 s a start)
            # through the fieldmap package: importing fieldmap.data would run one more module
            ref = resources.files("fieldmap").joinpath("data").joinpath(bundled)
            with resources.as_file(ref) as path:
                read, variant = _reader("icgem", str(path), t, None, None)
                model = disk_cache.cached_read([str(path)], variant, None, read, enabled=cache)
            return _with_source(model, f"fieldmap/data/{bundled} (bundled)")

        return _truncate(_read_cached(key, reader), lmax)
    name = _resolve_path(name, model_dir)
    fmt = detect_format(name)
    if fmt != "nga" and (gm is not None or radius is not None):
        raise InputError(
            f"{name}: GM and radius are given by the {fmt} file itself; --gm/--radius are for "
            "NGA coefficient files only"
        )
    if t is not None and fmt != "icgem":  # refused, not ignored (the ICGEM reader sees its own)
        what = "an NGA coefficient file" if fmt == "nga" else "a GeographicLib .egm model"
        raise InputError(
            f"{name} is {what}, static (no time-variable terms), so an epoch"
            f" (--epoch {t:.10g}) changes nothing in it; leave the epoch out"
        )
    paths = [name[:-4] if name.endswith(".egm.cof") else name]
    if fmt == "egm":
        paths.append(paths[0] + ".cof")
    # read only the degrees needed (the readers skip or slice the higher degrees)
    part = None if lmax is None else int(lmax)
    parse, variant = _reader(fmt, paths[0], t, gm, radius)
    try:  # the change time too: an edit in place with the modification time set back changes it
        stamp = tuple((s.st_size, s.st_mtime_ns, s.st_ctime_ns) for s in map(os.stat, paths))
    except OSError:  # e.g. no .egm.cof: the reader names the problem (its metadata first)
        return _earth(parse(part))
    # the variant: an NGA file's name is part of what it means (two links to one file, named
    # EGM96 and EGM2008, are two models)
    key = ("file", os.path.realpath(paths[0]), stamp, t, fmt, gm, radius, variant)
    with _cache_lock:
        full = _cache.get(key + (None,))
    if full is not None:
        return _truncate(full, lmax)

    def read() -> SHModel:
        model = disk_cache.cached_read(paths, variant, part, parse, enabled=cache)
        # an entry made from a copy of the file elsewhere: this path is the source
        return _earth(model if model.source == paths[0] else _with_source(model, paths[0]))

    return _read_cached(key + (part,), read)


def _reader(
    fmt: str, path: str, t: float | None, gm: float | None, radius: float | None
) -> tuple[Callable[[int | None], SHModel], str]:
    """Return ``(reader(lmax) -> SHModel, cache variant string)`` of a format.

    An NGA file's variant holds the file's name: the reader takes GM, the radius, the tide
    system and the name from it (a copy of ``EGM96`` named ``EGM2008`` or ``mine`` is another
    model, or none). Other formats' variants hold no name, so the bundled model read from a
    zip import (a new temporary name each run) keeps hitting its entry.
    """
    if fmt == "nga":  # each reader is imported when a file is of its format
        from fieldmap.models import nga

        named = f"|file={os.path.basename(path)!r}"
        variant = f"nga-v{nga.READER_VERSION}|gm={gm!r}|radius={radius!r}{named}"
        return (lambda L: nga.read_nga(path, lmax=L, gm=gm, radius=radius)), variant
    if fmt == "egm":
        from fieldmap.models import egm

        variant = f"egm-v{egm.READER_VERSION}"
        return (lambda L: egm.read_egm(path, lmax=L)), variant
    variant = f"icgem-v{icgem.READER_VERSION}|epoch={t!r}"
    return (lambda L: read_icgem(path, lmax=L, epoch=t)), variant


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


def _truncate(model: SHModel, lmax: int | None) -> SHModel:
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
        nominal_degree=lmax,
        tide_system="unknown",
        epoch=None,
        source="synthetic",
    )


def model_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`load_model` from the model-file options of the CLI.

    ``args`` is the namespace parsed with the options of
    ``fieldmap.cli.model_options.add_model_options`` (``--model-dir``, ``--gm``, ``--radius``,
    ``--no-cache``, ``--tide-system``); a missing attribute counts as its default.

    ``--no-cache`` also stops the cache of recursion tables for this process. ``--model-dir``
    with a bundled model name (read from the package, never from that folder) or with the path
    of a file outside that folder (read from where it is) is refused: it would do nothing.
    """
    model_dir, model = getattr(args, "model_dir", None), getattr(args, "model", None)
    if model_dir is not None and str(model).strip().lower() in BUNDLED:
        raise InputError(
            f"--model-dir applies to GeographicLib model names and files, not to the bundled "
            f"{model} (give --model NAME of a model in {model_dir})"
        )
    if model_dir is not None and os.path.exists(str(model)):
        if _in_model_dir(str(model), model_dir) is None:
            raise InputError(
                f"--model-dir {model_dir} does nothing for --model {model}: a file path, read "
                f"where it is, not a GeographicLib model in {model_dir} (leave out --model-dir)"
            )
    if getattr(args, "no_cache", False):
        disk_cache.disable()
    tide_system = getattr(args, "tide_system", None)
    if tide_system is not None:
        from fieldmap.models.tide import check_tide_system

        tide_system = check_tide_system(tide_system)
    return {
        "model_dir": getattr(args, "model_dir", None),
        "gm": getattr(args, "gm", None),
        "radius": getattr(args, "radius", None),
        "cache": not getattr(args, "no_cache", False),
        "tide_system": tide_system,
    }


def announce(model: SHModel, stream: TextIO | None = None) -> None:
    """Tell the user (stderr) which GM and radius an NGA file was read with, and a conversion.

    A model converted to another tide system (:func:`load_model` ``tide_system=``) is one line
    naming both systems and the change of C̄20.
    """
    import sys

    header = model.header if isinstance(model.header, dict) else {}
    note = header.get("constants")
    if note:
        print(f"fieldmap: {model.source}: {note}", file=stream or sys.stderr)
    origin = header.get("tide_origin")
    if origin and origin["system"] != model.tide_system:
        from fieldmap.models.tide import conversion_note

        print(f"fieldmap: {model.name}: {conversion_note(model)}", file=stream or sys.stderr)


#: the prefix of a compensation table given as a model name, ``"table:FILE"``
TABLE_PREFIX = "table:"


def table_path(model: object) -> str | None:
    """Return the FILE of a ``"table:FILE"`` model name (case kept), else None."""
    if isinstance(model, str) and model.strip().lower().startswith(TABLE_PREFIX):
        name = model.strip()[len(TABLE_PREFIX) :]
        if not name:
            raise InputError("table: needs a file name (table:FILE)")
        return name
    return None
