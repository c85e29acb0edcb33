r"""Reader (and a small writer) for ICGEM ``.gfc`` spherical-harmonic gravity-field files.

Format: Barthelmes & Förste, "The ICGEM-format" (GFZ Potsdam, 2011 revision), with the time-variable
lines of ICGEM 1.0 and the ``icgem2.0`` piecewise variant (``format icgem2.0`` in the header).

* Free text (any bytes, e.g. Latin-1) may precede ``begin_of_head``; header lines ``key value`` end
  with ``end_of_head``. Required keys: ``earth_gravity_constant``, ``radius``, ``max_degree``;
  ``norm`` (``fully_normalized`` default, or ``unnormalized``), ``tide_system``, ``errors``,
  ``modelname`` are optional.
* Data lines ``gfc n m C S [sC sS]``; time-variable (ICGEM 1.0) ``gfct n m C S [sC sS] t0``,
  ``trnd``/``dot n m C S [sC sS]`` (per year), ``acos``/``asin n m C S [sC sS] period`` (years).
  For a coefficient with reference epoch t0 the value at epoch t is

  .. math::
      G(t) = G_{gfct} + \dot G\,(t-t_0) + \sum_p \left[A_p\cos\frac{2\pi(t-t_0)}{p}
             + B_p\sin\frac{2\pi(t-t_0)}{p}\right]

  (the rule quoted in EIGEN-6S's own header). Default epoch: each coefficient's t0, where the
  ``acos`` terms still count (cos 0 = 1). In ``icgem2.0`` files every time-variable line carries
  its validity interval ``t0 t1`` (before the period) and the epoch must be given.
* Times ``yyyymmdd[.hhmm]`` are converted to decimal years: year + elapsed fraction of that year.
* Fortran ``D`` exponents are accepted; ``.gz`` files are detected by their magic bytes.

The data section is tokenised with NumPy in chunks of ``CHUNK_LINES`` lines (a degree-2190 file,
2.4 million lines, loads in a few seconds, :mod:`fieldmap.models._gfc_scan`); a per-line pass runs
only to name the line of an error. Plain files are memory-mapped, so the memory held is the
coefficient tables plus one chunk (a degree-5540 file: 0.9 GB, not 6 GB). Each chunk is checked
in the order a whole-file check would take, and the error raised is the one of lowest rank, at
its first line: the same for any chunk size. Static lines go straight into the tables
(:class:`fieldmap.models._gfc_terms.StaticTable`); the few time-variable lines are kept and
assembled at the end (:mod:`fieldmap.models._gfc_terms`).
"""

from __future__ import annotations

import gzip
import os
import re

import numpy as np

from fieldmap.errors import InputError, ModelFileError
from fieldmap.models import _gfc_scan as scan
from fieldmap.models._gfc_header import header_number as _header_number
from fieldmap.models._gfc_header import parse_header as _parse_header
from fieldmap.models._gfc_scan import decimal_year  # public here
from fieldmap.models._gfc_scan import unnormalized_to_full as _unnormalized_to_full
from fieldmap.models._gfc_terms import KIND_NAME as _KIND_NAME
from fieldmap.models._gfc_terms import StaticTable
from fieldmap.models._gfc_terms import epochs as _epochs
from fieldmap.models._gfc_terms import fail as _fail
from fieldmap.models._gfc_terms import negative_sigma as _negative_sigma
from fieldmap.models._gfc_terms import sigma_columns as _sigma_columns
from fieldmap.models._gfc_terms import time_variable as _time_variable
from fieldmap.models.shmodel import SHModel

_KEYS = {"gfc": 0, "gfct": 1, "trnd": 2, "dot": 2, "acos": 3, "asin": 4}
# allowed number of value fields after "key n m", per kind, for (icgem1.0, icgem2.0): C S, up to
# four sigmas (errors "calibrated_and_formal"), then t0 (gfct), the period (acos/asin), and in
# icgem2.0 the validity interval t0 t1 of every time-variable line
_NFIELDS = {
    0: (range(2, 7), range(2, 7)),
    1: (range(3, 8), range(4, 9)),
    2: (range(2, 7), range(4, 9)),
    3: (range(3, 8), range(5, 10)),
    4: (range(3, 8), range(5, 10)),
}
#: data lines parsed at a time (35 MB of text and some 300 MB of token tables for a dense file,
#: issue 17); the result, errors included, does not depend on it
CHUNK_LINES = 1 << 19
# errors found chunk by chunk, by rank: 0 unknown keyword, 1 short line, 2 degree/order, 3-7
# field count (by kind), 8 m > n, 9 n > max_degree, 10 bad number, 11 unparsed, 12 period, 13
# negative σ; the whole-file check order, so the first line of the lowest rank found is raised
_NONE = 99
_TV_FIELDS = ("line", "kind", "n", "m", "c", "s", "sc", "ss", "has", "last", "prev", "third")
#: version of this reader, part of the key of the on-disk cache (bump when output changes)
READER_VERSION = 3  # 2: sigma_c, sigma_s kept; 3: C00 far from 1, negative σ refused
#: largest degree held in memory (Earth2014 goes to 10800; C and S then take 1.9 GB)
MAX_DEGREE = 10800
_NORMS = {
    "fully_normalized": True,
    "fully_normalised": True,
    "unnormalized": False,
    "unnormalised": False,
}


# ----------------------------------------------------------------------------------- epochs
def parse_epoch(epoch) -> float | None:
    """Return an epoch as a decimal year.

    Parameters
    ----------
    epoch : float, str or None
        A decimal year (``2010.5``), or a string ``YYYY-MM-DD[THH:MM]``, ``YYYYMMDD`` or a
        decimal year. Units: year.
    """
    if epoch is None:
        return None
    if isinstance(epoch, bytes):
        epoch = epoch.decode("latin-1")
    if isinstance(epoch, (bool, np.bool_)) or not isinstance(epoch, (str, int, float, np.number)):
        raise InputError(f"bad epoch {epoch!r}: use a decimal year (2010.5) or a date YYYY-MM-DD")
    if isinstance(epoch, str):
        s = epoch.strip()
        m = re.fullmatch(r"(\d{4})-?(\d{2})-?(\d{2})(?:[T ](\d{2}):(\d{2}))?", s)
        try:
            if m:
                y, mo, d, hh, mm = (int(g) if g else 0 for g in m.groups())
                epoch = decimal_year(y, mo, d, hh, mm)
            else:
                epoch = float(s)
        except ValueError:
            raise InputError(
                f"bad epoch {epoch!r}: use a decimal year (2010.5) or a date YYYY-MM-DD"
            ) from None
    epoch = float(epoch)
    if not (1900.0 <= epoch <= 2200.0):
        raise InputError(f"epoch {epoch} is not a decimal year between 1900 and 2200")
    return epoch


def as_degree(lmax, what: str = "lmax") -> int | None:
    """Return ``lmax`` as an int (None stays None); raise :class:`InputError` if not a degree.

    Accepts integers, integral floats (``240.0``) and integer strings; rejects booleans,
    fractions, NaN, inf and anything else. The range is the caller's to check.
    """
    if lmax is None:
        return None
    try:
        value = int(lmax)
        ok = not isinstance(lmax, (bool, np.bool_)) and float(lmax) == value
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise InputError(f"{what} must be an integer degree, got {lmax!r}")
    return value


def _scan_chunk(path, raw, piece, base, ctx, best):
    """Check and parse the data lines ``base`` on, in ``raw[lo:hi]``.

    ``piece``: lo, hi and the offsets of the newlines from lo. Returns ``(rank, error, nlines,
    data)``: the first failed check of rank below ``best`` (the whole-file order of the checks,
    each at its first line: chunks come in line order), or ``_NONE``; the number of lines; and,
    when all checks pass, ``(content lines, static gfc lines for StaticTable.add, time-variable
    lines as _TV_FIELDS, whether the chunk has time-variable lines of any degree)`` (None:
    nothing kept).
    """
    nhead, nmax, lmax, v2 = ctx
    lo, hi, newlines = piece
    buf, starts, ends, tok_line, ntok, first = scan.tokenise(raw, lo, hi - lo, newlines)
    li = np.flatnonzero(ntok > 0)  # data lines with content
    nlines, f0 = ntok.size, first[li]

    def line_of(mask):
        return nhead + base + int(li[np.flatnonzero(mask)[0]]) + 1

    def text_of(t):
        return buf[starts[t] : ends[t]].tobytes().decode("latin-1")

    kind = scan.keyword_kinds(buf, starts[f0], ends[f0], _KEYS)
    if (kind < 0).any():
        k = np.flatnonzero(kind < 0)[0]
        return (
            0,
            _fail(path, line_of(kind < 0), f"unknown keyword {text_of(f0[k])!r}"),
            nlines,
            None,
        )
    short = ntok[li] < 3
    if best > 1 and short.any():
        why = "expected 'key n m C S ...', line too short"
        return 1, _fail(path, line_of(short), why), nlines, None
    if best <= 2:
        return _NONE, None, nlines, None
    n, ok_n = scan.small_ints(buf, starts[f0 + 1], ends[f0 + 1])
    m, ok_m = scan.small_ints(buf, starts[f0 + 2], ends[f0 + 2])
    if not (ok_n & ok_m).all():
        k = np.flatnonzero(~(ok_n & ok_m))[0]
        what = f"bad degree/order {text_of(f0[k] + 1)!r} {text_of(f0[k] + 2)!r}"
        return 2, _fail(path, line_of(~(ok_n & ok_m)), what), nlines, None
    nf = ntok[li] - 3
    checks = [
        (kind == kd) & ((nf < ok[v2].start) | (nf >= ok[v2].stop)) for kd, ok in _NFIELDS.items()
    ]
    checks += [m > n, n > nmax]
    for rank, bad in enumerate(checks, start=3):
        if rank >= best:
            return _NONE, None, nlines, None
        if bad.any():
            k = np.flatnonzero(bad)[0]
            if rank < 8:
                ok = _NFIELDS[rank - 3][v2]
                why = (
                    f"'{_KIND_NAME[rank - 3]}' line with {nf[k]} values"
                    f" (expected {ok.start} to {ok.stop - 1})"
                )
            else:
                why = "order m > degree n" if rank == 8 else f"degree above max_degree {nmax}"
                why += f" (n={n[k]}, m={m[k]})"
            return rank, _fail(path, line_of(bad), why), nlines, None
    if best <= 10:
        return _NONE, None, nlines, None
    keep, any_tv = n <= lmax, bool((kind >= 1).any())
    if not keep.any():
        return _NONE, None, nlines, (li.size, None, None, any_tv)
    keep_line = np.zeros(ntok.size, bool)
    keep_line[li[keep]] = True
    vals, bad_tok = scan.parse_values(buf, starts, ends, tok_line, first, keep_line)
    if vals is None and bad_tok < 0:  # pragma: no cover - NumPy and float() disagree
        return 11, ModelFileError(f"{path}: could not parse the coefficient values"), nlines, None
    if vals is None:
        bad_line = nhead + base + int(tok_line[bad_tok]) + 1
        return 10, _fail(path, bad_line, f"bad number {text_of(bad_tok)!r}"), nlines, None
    lines, kind, n, m, nf = base + li[keep], kind[keep], n[keep], m[keep], nf[keep]
    off = np.cumsum(nf) - nf
    c, s = vals[off], vals[off + 1]
    sc, ss, has_sig = _sigma_columns(vals, off, nf, kind, v2)
    last, prev = vals[off + nf - 1], vals[off + nf - 2]
    bad = (kind >= 3) & ~(last > 0)
    if bad.any() and best > 12:
        at = nhead + int(lines[bad][0]) + 1
        return 12, _fail(path, at, "period must be positive"), nlines, None
    if best <= 12:
        return _NONE, None, nlines, None
    neg = _negative_sigma(vals, off, nf, kind, v2)
    if neg.any() and best > 13:
        at = nhead + int(lines[neg][0]) + 1
        return 13, _fail(path, at, "a standard deviation (σ column) is negative"), nlines, None
    if best <= 13:
        return _NONE, None, nlines, None
    g, tv = kind == 0, kind >= 1
    third = vals[np.maximum(off[tv] + nf[tv] - 3, 0)]
    static = (lines[g], n[g], m[g], c[g], s[g], sc[g], ss[g], has_sig[g])
    tvs = [a[tv] for a in (lines, kind, n, m, c, s, sc, ss, has_sig, last, prev)] + [third]
    return _NONE, None, nlines, (li.size, static, tvs, any_tv)


def read_icgem(path, lmax: int | None = None, epoch=None) -> SHModel:
    """Read an ICGEM ``.gfc`` (or ``.gfc.gz``) file into a fully normalised :class:`SHModel`.

    Parameters
    ----------
    path : str or os.PathLike
        The model file (plain or gzip-compressed).
    lmax : int, optional
        Keep degrees 0..lmax only (lines of higher degree are skipped before their numbers are
        parsed). Default: the file's ``max_degree``.
    epoch : float or str, optional
        Epoch for the time-variable terms, a decimal year or ``'YYYY-MM-DD'``. Units: year.
        Default: each coefficient's own reference epoch t0 (required for ``icgem2.0`` files).

    Returns
    -------
    SHModel
        Coefficients C, S indexed ``[n, m]``. Missing degree 0 and 1 lines default to
        C00 = 1 and zero degree-1 terms (centre of mass at the origin); any other missing
        coefficient is an error, and so is a C00 far from 1 or a negative σ.

    Raises
    ------
    ModelFileError
        Malformed file; the message names the file and the line.
    InputError
        ``lmax`` above the file's ``max_degree``, a bad or out-of-range epoch, an epoch for a
        static file (no time-variable lines: it would change nothing), or no epoch for an
        ``icgem2.0`` file with time-variable lines.
    """
    try:
        path = os.fspath(path)
    except TypeError:
        raise InputError(f"model file must be a path, got {path!r}") from None
    lmax = as_degree(lmax)
    raw = scan.read_bytes(path, mapped=True)
    scan.check_text(path, raw)
    header, where, offset, nhead = _parse_header(path, raw)
    gm = _header_number(path, header, where, "earth_gravity_constant")
    radius = _header_number(path, header, where, "radius")
    nmax = _header_number(path, header, where, "max_degree", integer=True)
    norm = (header.get("norm", "fully_normalized").split() or ["fully_normalized"])[0].lower()
    if norm not in _NORMS:
        raise _fail(
            path,
            where["norm"],
            f"unknown normalisation {norm!r} (expected fully_normalized or unnormalized)",
        )
    v2 = (header.get("format", "").split() or [""])[0].lower().startswith("icgem2")
    if lmax is None:
        lmax = nmax
    if not 0 <= lmax <= nmax:
        raise InputError(f"lmax {lmax} is outside 0..{nmax}, the degree range of {path}")
    lmax, t = int(lmax), parse_epoch(epoch)
    if lmax > MAX_DEGREE:
        raise InputError(f"{path}: degree {lmax} is above {MAX_DEGREE}; pass a smaller lmax")

    errors = (header.get("errors", "").split() or [""])[0].lower()
    table = StaticTable(lmax, len(raw), sigma=errors != "no")
    best, err, content, base, parts, any_tv = _NONE, None, 0, 0, [], False
    for lo, hi, newlines in scan.line_chunks(raw, offset, CHUNK_LINES):
        ctx = (nhead, nmax, lmax, v2)
        rank, exc, nlines, data = _scan_chunk(path, raw, (lo, hi, newlines), base, ctx, best)
        if rank < best:
            best, err = rank, exc
        if best == _NONE and data is not None:
            content += data[0]
            any_tv |= data[3]
            if data[1] is not None:
                table.add(*data[1])
                parts.append(data[2])
        if best == 0:  # nothing can come before an unknown keyword
            break
        base += nlines
        scan.release(raw, lo, hi)
    if err is not None:
        raise err
    if content == 0:
        raise _fail(path, nhead, "no coefficient lines after end_of_head (truncated file?)")
    if v2 and t is None and any_tv:
        raise InputError(f"{path} is an icgem2.0 (piecewise time-variable) model: give an epoch")
    if t is not None and not any_tv:  # refused, not ignored: the user expects it to act
        raise InputError(
            f"{path} is a static model (no time-variable gfct/trnd/acos/asin lines), so an epoch"
            f" (--epoch {t:.10g}) changes nothing in it; leave the epoch out"
        )
    v2 = v2 and any_tv  # a static icgem2.0 file: no intervals to choose from
    lines, kind, n, m, c, s, sc, ss, has_sig, last, prev, third = (
        np.concatenate([p[k] for p in parts]) if parts else np.zeros(0, np.int64)
        for k in range(len(_TV_FIELDS))
    )
    lines, kind, n, m, c, s, sc, ss, has_sig, t0, period = _epochs(
        path, nhead, v2, t, (lines, kind, n, m, c, s, sc, ss, has_sig, last, prev, third)
    )
    g = kind == 1
    C, S, sig = table.finish(
        path, nhead, lines[g], n[g], m[g], c[g], s[g], sc[g], ss[g], has_sig[g]
    )
    idx = n * (n + 1) // 2 + m
    eval_epoch = _time_variable(path, lines, kind, n, m, idx, c, s, t0, period, t, v2, C, S, nhead)
    if not _NORMS[norm]:
        C, S = _unnormalized_to_full(C, S, path)
        if sig is not None:
            sig = _unnormalized_to_full(sig[0], sig[1], path)

    def first_line(cn, cm):  # file line of the first data line of coefficient (cn, cm)
        at = [int(x) for x in lines[(n == cn) & (m == cm)]]
        if (k := table.first_line(cn, cm)) is not None:
            at.append(k)
        return nhead + min(at) + 1

    if (why := scan.c00_problem(C)) is not None:  # not 1: C00 was given (its default is 1)
        raise _fail(path, first_line(0, 0), why)
    if (one := scan.degree1_problem(C, S)) is not None:
        raise _fail(path, first_line(one[0], one[1]), one[2])
    if (big := scan.first_outsize(C, S)) is not None:
        bn, bm, v = big
        why = f"coefficient n={bn} m={bm} is {v:.3g}: beyond 1 in size, not a gravity model"
        raise _fail(path, first_line(bn, bm), why)
    name = header.get("modelname", "").strip() or os.path.basename(path).split(".")[0]
    return SHModel(
        name=name,
        gm=gm,
        radius=radius,
        C=C,
        S=S,
        nominal_degree=nmax,
        tide_system=(header.get("tide_system", "unknown").split() or ["unknown"])[0].lower(),
        epoch=eval_epoch,
        source=path,
        header=header,
        sigma_c=None if sig is None else sig[0],
        sigma_s=None if sig is None else sig[1],
    )


def write_icgem(path, model: SHModel, preamble: str = "") -> None:
    """Write ``model`` as a static ICGEM file (``gfc`` lines, fully normalised; gzip if ``.gz``).

    Parameters
    ----------
    path : str or os.PathLike
        Output file.
    model : SHModel
        Coefficients to write (degrees 0..model.lmax); with ``model.sigma_c``/``sigma_s`` the lines
        carry the two σ columns (header ``errors calibrated``).
    preamble : str
        Free text written before ``begin_of_head``.
    """
    head = [
        preamble.rstrip("\n"),
        "begin_of_head",
        "product_type  gravity_field",
        f"modelname  {model.name}",
        f"earth_gravity_constant  {model.gm!r}",
        f"radius  {model.radius!r}",
        f"max_degree  {model.lmax}",
        "norm  fully_normalized",
        f"tide_system  {model.tide_system}",
        f"errors  {'calibrated' if model.sigma_c is not None else 'no'}",
        "end_of_head",
    ]
    nn, mm = np.tril_indices(model.lmax + 1)
    order = np.lexsort((mm, nn))
    cols = [nn[order].tolist(), mm[order].tolist()]
    for a in (model.C, model.S, model.sigma_c, model.sigma_s):
        if a is not None:
            cols.append(a[nn, mm][order].tolist())
    fmt = "gfc {:5d} {:5d}" + " {:+.16e}" * (len(cols) - 2) + "\n"
    body = "".join(fmt.format(*row) for row in zip(*cols))
    text = ("\n".join(head).lstrip("\n") + "\n" + body).encode("latin-1")
    opener = gzip.open if os.fspath(path).endswith(".gz") else open
    with opener(path, "wb") as f:
        f.write(text)
