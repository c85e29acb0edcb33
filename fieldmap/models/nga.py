"""Reader for NGA's plain coefficient files of EGM84, EGM96 and EGM2008.

NGA distributes its Earth Gravity Models as text files without a header, one coefficient per line
(e.g. ``EGM2008_to2190_TideFree``, ``EGM96`` / ``egm96_to360.ascii``)::

    n  m  C̄nm  S̄nm  [σC̄nm  σS̄nm]

fully normalised, with Fortran ``D`` or ``E`` exponents, degree 0 and 1 lines usually absent
(then C̄00 = 1 and degree 1 is zero; a C̄00 line far from 1 is refused). The files carry
neither GM nor the reference radius: they are taken from the model's name in the file name
(:data:`KNOWN`, NGA's published constants) or must be given (``gm``, ``radius``); the model's
``header["constants"]`` says which were used.

The file is tokenised in bulk with NumPy (:mod:`fieldmap.models.icgem`), so EGM2008's
2.4 million lines parse in seconds; a per-token pass runs only to name the line of an error.
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np

from fieldmap.errors import InputError, ModelFileError
from fieldmap.models import icgem
from fieldmap.models.shmodel import SHModel

#: version of this reader, part of the key of the on-disk cache (bump when output changes)
READER_VERSION = 3  # 2: the sigma columns are kept; 3: C00 far from 1 refused

#: NGA's published constants: lower-case name found in the file name -> (name, GM m³/s², R m).
#: EGM2008: Pavlis et al. (2012), J. Geophys. Res. 117, B04406 (GM 3986004.415e8, a 6378136.3);
#: EGM96: Lemoine et al. (1998), NASA/TP-1998-206861 (GM 3986004.418e8, a 6378137);
#: EGM84: DMA TR8350.2 (1987) (GM 3986004.418e8, a 6378137), as GeographicLib's .egm files.
KNOWN = {
    "egm2008": ("EGM2008", 3.986004415e14, 6378136.3),
    "egm08": ("EGM2008", 3.986004415e14, 6378136.3),
    "egm96": ("EGM96", 3.986004418e14, 6378137.0),
    "egm84": ("EGM84", 3.986004418e14, 6378137.0),
}
#: most lines probed by :func:`looks_like_nga`
_PROBE_LINES = 5
_NUMBER = re.compile(rb"^[+-]?(\d+\.?\d*|\.\d+)([EeDd][+-]?\d+)?$")
_MAX_DEGREE = 10800


def looks_like_nga(head: bytes) -> bool:
    """Tell whether the first non-blank lines of ``head`` are ``n m C S [σC σS]`` number lines."""
    lines = [ln for ln in head.splitlines()[:50] if ln.strip()][:_PROBE_LINES]
    if not lines:
        return False
    for ln in lines[: max(1, len(lines) - 1)]:  # the last line of a probe may be cut
        tok = ln.split()
        if len(tok) not in (4, 6) or not (tok[0].isdigit() and tok[1].isdigit()):
            return False
        if not all(_NUMBER.match(t) for t in tok[2:]):
            return False
    return True


def known_constants(path: str | os.PathLike[str]) -> tuple[str, float, float] | None:
    """``(name, GM, radius)`` of a known NGA model named in the file name, else None."""
    base = os.path.basename(os.fspath(path)).lower().replace("-", "").replace("_", "")
    for key, val in KNOWN.items():
        if key in base:
            return val
    return None


def _fail(path: str | os.PathLike[str], line: int | None, msg: str) -> ModelFileError:
    return ModelFileError(f"{path}, line {line}: {msg}" if line else f"{path}: {msg}")


def read_nga(
    path: str | os.PathLike[str],
    lmax: int | None = None,
    *,
    gm: float | None = None,
    radius: float | None = None,
) -> SHModel:
    """Read an NGA coefficient file (``n m C S [σC σS]`` lines) into an :class:`SHModel`.

    Parameters
    ----------
    path : str or os.PathLike
        The file (plain or gzip-compressed).
    lmax : int, optional
        Keep degrees 0..lmax (default: the highest degree in the file).
    gm : float, optional
        Units: m³/s². GM of the model; default: NGA's value for a model named in the file name.
    radius : float, optional
        Units: m. Reference radius; default as ``gm``.

    Returns
    -------
    SHModel
        ``header["constants"]`` tells where GM and the radius came from.

    Raises
    ------
    ModelFileError
        Malformed file (the message names the file and the line).
    InputError
        GM or radius unknown (not a known model name and not given), or ``lmax`` beyond the file.
    """
    path = os.fspath(path)
    known = known_constants(path)
    if (gm is None or radius is None) and known is None:
        raise InputError(
            f"{path}: an NGA coefficient file carries no GM nor radius and its name is not one "
            f"of {', '.join(sorted({v[0] for v in KNOWN.values()}))}: give both (--gm, --radius)"
        )
    for key, val in (("gm", gm), ("radius", radius)):
        if val is not None and not (math.isfinite(val) and val > 0):
            raise InputError(f"{key} must be a positive number, got {val!r}")
    kn = known or ("", math.nan, math.nan)  # known is set wherever gm or radius is missing
    used_gm = float(gm if gm is not None else kn[1])
    used_radius = float(radius if radius is not None else kn[2])
    how = (
        "given"
        if gm is not None and radius is not None
        else f"{kn[0]}'s published values, recognised from the file name"
        if gm is None and radius is None
        else f"given, the other from {kn[0]}'s published values"
    )
    raw = icgem.read_bytes(path)
    icgem.check_text(path, raw, "an NGA coefficient file")
    buf, starts, ends, tok_line, ntok, first = icgem.tokenise(raw, 0)
    li = np.flatnonzero(ntok > 0)
    if li.size == 0:
        raise _fail(path, 0, "no coefficient lines")
    ncol = int(ntok[li[0]])
    bad = (ntok[li] != ncol) | ((ncol != 4) & (ncol != 6))
    if bad.any():
        k = int(li[np.flatnonzero(bad)[0]])
        raise _fail(
            path, k + 1, f"expected 4 or 6 fields 'n m C S [sigmaC sigmaS]', got {int(ntok[k])}"
        )
    ints, ok = icgem.small_ints(buf, starts[first[li]], ends[first[li]])
    ints_m, ok_m = icgem.small_ints(buf, starts[first[li] + 1], ends[first[li] + 1])
    bad = ~(ok & ok_m)
    if bad.any():
        raise _fail(path, int(li[np.flatnonzero(bad)[0]]) + 1, "degree and order must be integers")
    n, m = ints, ints_m
    vals = _values(path, buf, starts, ends, tok_line, first, li, ncol)
    bad = m > n
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise _fail(path, int(li[k]) + 1, f"order {int(m[k])} above the degree {int(n[k])}")
    N = int(n.max())
    if N > _MAX_DEGREE:
        k = int(np.argmax(n))
        raise _fail(path, int(li[k]) + 1, f"degree {N} is above {_MAX_DEGREE}")
    if lmax is None:
        lmax = N
    lmax = int(lmax)
    if not 0 <= lmax <= N:
        raise InputError(f"lmax {lmax} is outside 0..{N}, the degree range of {path}")
    key = n * (N + 1) + m
    order = np.argsort(key, kind="stable")
    dup = np.flatnonzero(np.diff(key[order]) == 0)
    if dup.size:
        k = int(order[dup[0] + 1])
        raise _fail(path, int(li[k]) + 1, f"second line for n={int(n[k])} m={int(m[k])}")
    present = np.zeros((N + 1, N + 1), bool)
    present[n, m] = True
    missing = np.argwhere(np.tri(N + 1, dtype=bool) & ~present)
    missing = missing[missing[:, 0] >= 2]
    if missing.size:
        raise _fail(path, 0, f"no line for n={missing[0, 0]} m={missing[0, 1]}")
    C = np.zeros((N + 1, N + 1))
    S = np.zeros((N + 1, N + 1))
    C[0, 0] = 1.0
    C[n, m] = vals[:, 0]
    S[n, m] = vals[:, 1]
    if np.any(S[:, 0] != 0.0):
        k = int(np.flatnonzero((m == 0) & (vals[:, 1] != 0.0))[0])
        raise _fail(path, int(li[k]) + 1, "S̄n0 must be 0")
    sigma_c = sigma_s = None
    if ncol == 6:  # NGA's σC, σS columns (EGM96, EGM2008), kept as the ICGEM reader keeps them
        bad = vals[:, 2:] < 0.0
        if bad.any():
            k = int(np.flatnonzero(bad.any(axis=1))[0])
            raise _fail(path, int(li[k]) + 1, "a coefficient's standard deviation is negative")
        sigma_c = np.zeros((N + 1, N + 1))
        sigma_s = np.zeros((N + 1, N + 1))
        sigma_c[n, m] = vals[:, 2]
        sigma_s[n, m] = vals[:, 3]
        sigma_s[:, 0] = 0.0
        sigma_c = np.ascontiguousarray(sigma_c[: lmax + 1, : lmax + 1])
        sigma_s = np.ascontiguousarray(sigma_s[: lmax + 1, : lmax + 1])
    if (why := icgem.c00_problem(C)) is not None:  # not 1: the file has a degree-0 line
        k = int(np.flatnonzero((n == 0) & (m == 0))[0])
        raise _fail(path, int(li[k]) + 1, why)
    if (one := icgem.degree1_problem(C, S)) is not None:
        k = int(np.flatnonzero((n == 1) & (m == one[1]))[0])
        raise _fail(path, int(li[k]) + 1, one[2])
    big = icgem.first_outsize(C, S)
    if big is not None:
        k = int(np.flatnonzero((n == big[0]) & (m == big[1]))[0])
        raise _fail(path, int(li[k]) + 1, f"coefficient {big[2]:g} is not a normalised one")
    name = known[0] if known else os.path.basename(path)
    low = os.path.basename(path).lower()
    tide = "tide_free" if "tidefree" in low else "zero_tide" if "zerotide" in low else "unknown"
    constants = f"GM {used_gm!r} m³/s², radius {used_radius!r} m ({how})"
    return SHModel(
        name=name,
        gm=used_gm,
        radius=used_radius,
        C=np.ascontiguousarray(C[: lmax + 1, : lmax + 1]),
        S=np.ascontiguousarray(S[: lmax + 1, : lmax + 1]),
        nominal_degree=N,
        tide_system=tide,
        epoch=None,
        source=path,
        header={"format": "nga", "constants": constants},
        sigma_c=sigma_c,
        sigma_s=sigma_s,
    )


def _values(
    path: str | os.PathLike[str],
    buf: np.ndarray,
    starts: np.ndarray,
    ends: np.ndarray,
    tok_line: np.ndarray,
    first: np.ndarray,
    li: np.ndarray,
    ncol: int,
) -> np.ndarray:
    """Return the C, S (and σC, σS) columns of every line, shape (lines, 2 or 4)."""
    pos = np.arange(starts.size) - first[tok_line]
    keep_tok = pos >= 2
    mark = np.zeros(buf.size + 1, np.int8)
    mark[starts[keep_tok]] = 1
    mark[ends[keep_tok]] = -1
    work = np.where(np.cumsum(mark[:-1], dtype=np.int8) > 0, buf, np.uint8(32))
    del mark
    work[(work == 68) | (work == 100)] = 69  # Fortran D exponent -> E
    text = work.tobytes()
    del work
    vals = None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            vals = np.fromstring(text, sep=" ")
        except (ValueError, DeprecationWarning):
            vals = None
    nval = ncol - 2
    if vals is not None and vals.size == li.size * nval and np.isfinite(vals).all():
        return vals.reshape(li.size, nval)
    for t in np.flatnonzero(keep_tok):  # slow path, only to name the line
        tok = buf[starts[t] : ends[t]].tobytes()
        ok = bool(_NUMBER.match(tok))
        if ok:
            ok = math.isfinite(float(tok.replace(b"D", b"E").replace(b"d", b"e")))
        if not ok:
            shown = tok.decode("latin-1")
            raise _fail(path, int(tok_line[t]) + 1, f"{shown!r} is not a finite number")
    raise _fail(path, 0, "could not parse the coefficient values")  # pragma: no cover


def write_nga(path: str | os.PathLike[str], model: SHModel, exponent: str = "D") -> None:
    """Write ``model`` (degrees 2..lmax) as an NGA plain coefficient file, for tests.

    Parameters
    ----------
    path : str or os.PathLike
        Output file.
    model : SHModel
        Fully normalised coefficients.
    exponent : {"D", "E"}
        Exponent letter (NGA's EGM2008 file uses Fortran ``D``).
    """
    nn, mm = np.tril_indices(model.lmax + 1)
    keep = nn >= 2
    nn, mm = nn[keep], mm[keep]
    order = np.lexsort((mm, nn))
    zero = np.zeros_like(model.C)
    sc = zero if model.sigma_c is None else model.sigma_c
    ss = zero if model.sigma_s is None else model.sigma_s
    with open(path, "w", encoding="ascii") as f:
        for a, b, c, d, e, g in zip(
            nn[order].tolist(),
            mm[order].tolist(),
            model.C[nn, mm][order].tolist(),
            model.S[nn, mm][order].tolist(),
            sc[nn, mm][order].tolist(),
            ss[nn, mm][order].tolist(),
        ):
            f.write(
                f"{a:5d}{b:5d} {c:23.16E} {d:23.16E} {e:15.10E} {g:15.10E}\n".replace("E", exponent)
            )
