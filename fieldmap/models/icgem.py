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
2.4 million lines, loads in a few seconds): token boundaries are found on the byte array,
keywords and degree/order are decoded with vectorised integer arithmetic, and all coefficient
values are parsed by one call of :func:`numpy.fromstring` (:func:`tokenise`,
:func:`parse_values`); a per-token pass runs only to name the token of an error. Plain files are
memory-mapped (:func:`read_bytes`), so the memory held is the coefficient tables plus one chunk
(a degree-5540 file: 0.9 GB, not 6 GB). Each chunk is checked in the order a whole-file check
would take, and the error raised is the one of lowest rank, at its first line: the same for any
chunk size. Static lines go straight into the tables (:class:`_StaticTable`); the few
time-variable lines are kept and assembled at the end (:func:`_epochs`, :func:`_time_variable`).

The module is read top-down: constants; reading the bytes (memory maps, gzip, pipes, binary
data refused), tokenising, ICGEM dates, normalisation and the checks of C̄00 and of the
coefficients' size (also the NGA reader's, :mod:`fieldmap.models.nga`); the header; the
coefficient tables; epochs; the reader and the writer.
"""

from __future__ import annotations

import datetime as _dt
import gzip
import math
import mmap
import os
import re
import stat
import warnings
import zlib
from collections.abc import Iterator
from typing import Any, BinaryIO

import numpy as np

from fieldmap.errors import InputError, ModelFileError
from fieldmap.models.shmodel import SHModel

#: a model file's bytes: read whole, or memory-mapped (:func:`read_bytes`)
Raw = bytes | mmap.mmap

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


# ---------------------------------------- bytes, tokens, dates and the checks the NGA reader shares
#: largest model read from a pipe or device (a regular file of any size is read whole): a
#: degree-2190 ``.gfc`` is 0.3 GB; ``--model /dev/zero`` must not fill the memory
MAX_STREAM_BYTES = 4 * 2**30
_CHUNK = 16 * 2**20
#: bytes read at a time when scanning a whole file (binary check, newline counts)
BLOCK = 16 * 2**20
#: compressed size above which a gzip model file is decompressed, chunk by chunk, into an
#: unnamed temporary file that is then memory-mapped (a degree-5540 ``.gfc.gz`` holds 1 GB of
#: text, a degree-10,800 one 4 GB); smaller ones are decompressed in memory
GZ_IN_MEMORY = 64 * 2**20


def read_bytes(path: str, mapped: bool = False) -> Raw:
    """Return the bytes of a model file, gunzipped if compressed (raises ModelFileError).

    With ``mapped``, a regular uncompressed file comes back as a read-only :class:`mmap.mmap`
    (its pages are the page cache's, not this process's anonymous memory: a degree-10,800 file is
    4 GB), and so does a gzip file larger than :data:`GZ_IN_MEMORY`, decompressed chunk by chunk
    into an unnamed temporary file (:func:`_gunzip_mapped`); smaller gzip data and pipes come
    back as bytes.
    """
    try:
        raw: bytes | mmap.mmap
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode):  # a pipe (``<(zcat ...)``) or a device
                raw = _read_stream(f, path)
            elif mapped and st.st_size > 0 and f.read(2) != b"\x1f\x8b":
                raw = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
            elif mapped and st.st_size > GZ_IN_MEMORY:
                f.seek(0)
                raw = _gunzip_mapped(f, path)
            else:
                f.seek(0)
                raw = f.read()
    except FileNotFoundError:
        raise ModelFileError(f"{path}: no such model file") from None
    except IsADirectoryError:
        raise ModelFileError(f"{path}: is a directory, not a model file") from None
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if raw[:2] == b"\x1f\x8b":
        try:
            raw = gzip.decompress(raw)
        except (EOFError, OSError, zlib.error) as exc:
            raise ModelFileError(f"{path}: truncated or corrupt gzip data ({exc})") from None
    if not len(raw) or re.search(rb"[^ \t\n\r\x0b\x0c]", raw) is None:  # bytes.isspace()
        raise ModelFileError(f"{path}: empty file")
    return raw


def _gunzip_mapped(f: BinaryIO, path: str) -> mmap.mmap:
    """Decompress the gzip file ``f`` chunk by chunk into an unnamed temporary file; map it.

    The memory used is a chunk's, whatever the size of the model (unless the system's
    temporary folder is itself in memory, e.g. a tmpfs); the unnamed temporary file disappears
    when the mapping is closed.
    """
    import tempfile

    try:
        with gzip.GzipFile(fileobj=f, mode="rb") as gz, tempfile.TemporaryFile() as tmp:
            first = True
            while chunk := gz.read(_CHUNK):
                if first:
                    check_text(path, chunk)  # binary data fails at once
                    first = False
                tmp.write(chunk)
            tmp.flush()
            if first:  # nothing inside
                raise ModelFileError(f"{path}: empty file")
            return mmap.mmap(tmp.fileno(), 0, access=mmap.ACCESS_READ)
    except (EOFError, zlib.error, gzip.BadGzipFile) as exc:
        raise ModelFileError(f"{path}: truncated or corrupt gzip data ({exc})") from None
    except OSError as exc:  # e.g. no space left for the decompressed text
        raise ModelFileError(f"{path}: cannot decompress ({exc.strerror or exc})") from None


def release(raw: Raw, lo: int, hi: int) -> None:
    """Drop the pages of ``raw[lo:hi]`` from this process's memory if ``raw`` is a mapping.

    The bytes stay in the page cache and are read again on the next access: only the resident
    size goes down (a file read once, chunk by chunk, then never holds more than a chunk).
    """
    if isinstance(raw, mmap.mmap) and hasattr(mmap, "MADV_DONTNEED"):
        lo -= lo % mmap.PAGESIZE
        hi -= hi % mmap.PAGESIZE
        if hi > lo:
            raw.madvise(mmap.MADV_DONTNEED, lo, hi - lo)


def _read_stream(f: BinaryIO, path: str) -> bytes:
    parts: list[bytes] = []
    size = 0
    while chunk := f.read(_CHUNK):
        if not parts and chunk[:2] != b"\x1f\x8b":
            check_text(path, chunk)  # binary data (e.g. /dev/zero) fails at once
        parts.append(chunk)
        size += len(chunk)
        if size > MAX_STREAM_BYTES:
            raise ModelFileError(f"{path}: stream longer than {MAX_STREAM_BYTES >> 30} GiB")
    return b"".join(parts)


_CONTROL = np.zeros(256, bool)
_CONTROL[[c for c in range(32) if c not in (9, 10, 13)]] = True


def check_text(path: str, raw: Raw, what: str = "an ICGEM text file") -> None:
    """Reject binary data: control bytes other than tab, CR, LF (Latin-1 text is fine).

    ``raw``: bytes or a mapping, read in blocks of ``BLOCK`` bytes (no copy of the whole);
    ``what``: the kind of file expected, for the message.
    """
    size = len(raw)
    for lo in range(0, size, BLOCK):
        b = np.frombuffer(raw, np.uint8, count=min(BLOCK, size - lo), offset=lo)
        low = np.flatnonzero(b < 32)  # newlines, tabs, CRs and any control byte
        ctrl = _CONTROL[b[low]]
        if ctrl.any():
            pos = lo + int(low[np.argmax(ctrl)])
            byte = int(b[pos - lo])
            line = count_newlines(raw, 0, pos) + 1
            raise ModelFileError(f"{path}, line {line}: binary byte 0x{byte:02x}: not {what}")
        del b, low, ctrl
        release(raw, lo, lo + BLOCK)


def count_newlines(raw: Raw, lo: int, hi: int) -> int:
    """Count the newline bytes in ``raw[lo:hi]`` (bytes or a mapping), read in blocks."""
    total = 0
    for a in range(lo, hi, BLOCK):
        b = np.frombuffer(raw, np.uint8, count=min(BLOCK, hi - a), offset=a)
        total += int(np.count_nonzero(b == 10))
    return total


def line_chunks(raw: Raw, offset: int, lines: int) -> Iterator[tuple[int, int, np.ndarray]]:
    """Yield ``(lo, hi, newlines)``: ``raw[offset:]`` cut after every ``lines``-th newline.

    Each piece but the last ends with a newline; the pieces cover ``raw[offset:]`` exactly (none
    when it is empty). ``newlines``: the offsets of the piece's newlines from ``lo``.
    """
    size, pos, width = len(raw), offset, 80 * lines + 4096
    while pos < size:
        while True:
            width = min(width, size - pos)
            win = np.frombuffer(raw, np.uint8, count=width, offset=pos)
            nl = np.flatnonzero(win == 10)
            if nl.size >= lines:
                nl = nl[:lines].copy()
                break
            if pos + width >= size:
                break
            width *= 2
        hi = pos + int(nl[-1]) + 1 if nl.size >= lines else size
        del win
        yield pos, hi, nl
        width = (hi - pos) * 17 // 16 + 4096  # lines of about the same length next
        pos = hi


_WHITESPACE = np.zeros(256, bool)
_WHITESPACE[[9, 10, 13, 32]] = True


def tokenise(
    raw: Raw, offset: int = 0, count: int = -1, newlines: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Split ``raw[offset:offset + count]`` into whitespace-separated tokens (no copy of it).

    ``count`` -1: to the end. Lines are counted from ``offset``; ``newlines``, the offsets of its
    newline bytes from ``offset`` when already known.

    Returns
    -------
    buf : numpy.ndarray of uint8
        Read-only view of the data bytes.
    starts, ends : numpy.ndarray of int
        Byte offsets of each token (``ends`` exclusive).
    tok_line : numpy.ndarray of int
        Data line (0-based) of each token.
    ntok, first : numpy.ndarray of int
        Per line: number of tokens, index of the first token. The position within its line of
        token ``t`` is ``t - first[tok_line[t]]``.
    """
    buf = np.frombuffer(raw, np.uint8, count=count, offset=offset)
    ws = _WHITESPACE[buf]
    edge = np.diff(ws.view(np.int8), prepend=np.int8(1), append=np.int8(1))
    starts = np.flatnonzero(edge == -1)  # whitespace -> text
    ends = np.flatnonzero(edge[1:] == 1) + 1  # text -> whitespace, exclusive
    del ws, edge
    if newlines is None:
        newlines = np.flatnonzero(buf == 10)
    if buf.size == 0 or buf[-1] != 10:  # last line without a newline
        newlines = np.append(newlines, buf.size)
    tok_line = np.searchsorted(newlines, starts)
    ntok = np.bincount(tok_line, minlength=newlines.size)
    first = np.cumsum(ntok) - ntok
    return buf, starts, ends, tok_line, ntok, first


def small_ints(buf: np.ndarray, s: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parse short unsigned decimal integers at byte ranges [s, e); return (values, ok)."""
    length = e - s
    ok = (length >= 1) & (length <= 6)
    val = np.zeros(s.size, np.int64)
    for k in range(6):
        act = k < length
        d = buf[np.minimum(s + k, buf.size - 1)].astype(np.int64) - 48
        ok &= ~act | ((d >= 0) & (d <= 9))
        val = np.where(act, val * 10 + d, val)
    return val, ok


def keyword_kinds(
    buf: np.ndarray, s: np.ndarray, e: np.ndarray, keys: dict[str, int]
) -> np.ndarray:
    """Map keyword tokens (case-insensitive, at most 4 letters) to ``keys[name]``; -1 if unknown."""
    length = e - s
    code = np.zeros(s.size, np.int64)
    for k in range(4):
        byte = buf[np.minimum(s + k, buf.size - 1)].astype(np.int64) | 0x20  # lower case
        code |= np.where(k < length, byte, 0) << (8 * k)
    kind = np.full(s.size, -1, np.int64)
    for name, kd in keys.items():
        ref = sum(ord(c) << (8 * k) for k, c in enumerate(name))
        kind[(code == ref) & (length == len(name))] = kd
    return kind


def parse_values(
    buf: np.ndarray,
    starts: np.ndarray,
    ends: np.ndarray,
    tok_line: np.ndarray,
    first: np.ndarray,
    keep_line: np.ndarray,
) -> tuple[np.ndarray | None, int | None]:
    """Parse every value token (all but the first three) of the kept lines in one pass.

    Returns
    -------
    values : numpy.ndarray or None
        The numbers in token order (Fortran ``D`` exponents accepted), None on failure.
    bad : int or None
        Index of the first token that is not a finite number (None on success).
    """
    keep_tok = keep_line[tok_line] & (np.arange(starts.size) - first[tok_line] >= 3)
    if not keep_tok.any():
        return np.zeros(0), None
    mark = np.zeros(buf.size + 1, np.int8)
    mark[starts[keep_tok]] = 1  # starts sit on text, ends on whitespace: never the same byte
    mark[ends[keep_tok]] = -1
    work = np.where(np.cumsum(mark[:-1], dtype=np.int8) > 0, buf, np.uint8(32))
    del mark
    work[(work == 68) | (work == 100)] = 69  # Fortran D exponent -> E
    text = work.tobytes()  # np.fromstring wants read-only bytes
    del work
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        try:
            vals = np.fromstring(text, sep=" ")  # text mode: not deprecated
        except (ValueError, DeprecationWarning):
            vals = None
    if vals is not None and vals.size == keep_tok.sum() and np.isfinite(vals).all():
        return vals, None
    for t in np.flatnonzero(keep_tok):  # slow path, only to name the token
        token = buf[starts[t] : ends[t]].tobytes().decode("latin-1")
        try:
            ok = math.isfinite(float(token.replace("D", "E").replace("d", "e")))
        except ValueError:
            ok = False
        if not ok:
            return None, int(t)
    return None, -1  # pragma: no cover - fromstring and float() disagree


def unnormalized_to_full(C: np.ndarray, S: np.ndarray, path: str) -> tuple[np.ndarray, np.ndarray]:
    """Divide by the normalisation N̄nm = sqrt((2 − δm0)(2n+1)(n−m)!/(n+m)!), in place.

    Column by column (no (L+1)² temporaries: a degree-10,800 table is 0.9 GB); returns C, S.
    """
    nmax = C.shape[0] - 1
    n = np.arange(nmax + 1, dtype=float)
    col = np.sqrt(2.0 * n + 1.0)  # m = 0
    for m in range(nmax + 1):
        if m > 0:  # N̄n,m = N̄n,m−1 / sqrt((n+m)(n−m+1)), times sqrt(2) from m=0 to m=1
            with np.errstate(divide="ignore", invalid="ignore"):
                col = col / np.sqrt((n + m) * (n - m + 1.0)) * (math.sqrt(2.0) if m == 1 else 1)
        if ((col[m:] == 0) | ~np.isfinite(col[m:])).any():
            raise ModelFileError(f"{path}: unnormalized coefficients beyond the float64 range")
        C[m:, m] /= col[m:]
        S[m:, m] /= col[m:]
    return C, S


def decimal_year(year: int, month: int, day: int, hour: int = 0, minute: int = 0) -> float:
    """Return the decimal year of a calendar date (year + elapsed fraction of that year)."""
    t = _dt.datetime(year, month, day, hour, minute)
    y0, y1 = _dt.datetime(year, 1, 1), _dt.datetime(year + 1, 1, 1)
    return year + (t - y0).total_seconds() / (y1 - y0).total_seconds()


def yyyymmdd(value: float) -> float:
    """Decimal year of an ICGEM time stamp ``yyyymmdd[.hhmm]`` given as a float."""
    date = int(math.floor(value))
    hhmm = int(round((value - date) * 1e4))
    return decimal_year(date // 10000, (date // 100) % 100, date % 100, hhmm // 100, hhmm % 100)


#: accepted C̄00 of a model file: 1 ± C00_BAND. GM carries the mass, so C̄00 is 1 by definition,
#: and real models give 1. A file with C̄00 = 0 is a residual field (one model minus another, a
#: de-aliasing product) or lost its degree-0 term, and gives a "disturbance" of ~980,000 mGal;
#: 2 or 0.5 are scale slips. The band is the 2 % that ``fieldmap.models.registry.EARTH_GM``
#: allows GM (GM·C̄00 is the central term of the field): wide of any real model, and what lies
#: outside it is no model of a body's whole field.
C00_BAND = 0.02


def c00_problem(C: np.ndarray) -> str | None:
    """Return why the C̄00 of ``C`` is no gravity model's (outside 1 ± C00_BAND), else None."""
    c00 = float(C[0, 0])
    if abs(c00 - 1.0) <= C00_BAND:
        return None
    return (
        f"C00 is {c00:.9g}, not 1 (within {C00_BAND:g}): the degree-0 term of a gravity model is 1,"
        " GM carrying the mass (a residual field or a lost degree-0 line?)"
    )


#: Largest accepted |C̄10|, |C̄11|, |S̄11|. The degree-1 terms are the centre of mass's offset
#: from the origin (C̄10 = z/(√3 R)): zero in the geocentric frame of every gravity model, a
#: few 1e-10 for a frame centred elsewhere by centimetres. 1e-3 is an offset of ~11 km; a file
#: beyond it has its lines out of place (e.g. 0.5 at n=1 gave a "disturbance" of 842,722 mGal).
DEGREE1_MAX = 1e-3


def degree1_problem(C: np.ndarray, S: np.ndarray) -> tuple[int, int, str] | None:
    """Return ``(n, m, why)`` if a degree-1 coefficient exceeds :data:`DEGREE1_MAX`, else None."""
    if C.shape[0] < 2:
        return None
    for m, v in ((0, C[1, 0]), (1, C[1, 1]), (1, S[1, 1])):
        if abs(v) > DEGREE1_MAX:
            return (
                1,
                m,
                f"degree-1 coefficient n=1 m={m} is {float(v):.3g}: a geocentric gravity model "
                f"has (near) 0 there (|value| <= {DEGREE1_MAX:g}, a centre of mass within "
                "~11 km of the origin)",
            )
    return None


def first_outsize(C: np.ndarray, S: np.ndarray) -> tuple[int, int, float] | None:
    """Return ``(n, m, value)`` of the first coefficient too large to be physical, else None.

    Fully normalised coefficients of a real body are far below 1 in size beyond degree 0
    (Kaula's rule: about 1e-5/n²); a value beyond 1 is a unit or normalisation error, and one
    beyond 1e150 overflows the synthesis. C̄00 is not looked at (:func:`c00_problem` checks it).
    """
    rows = max(1, BLOCK // (8 * max(C.shape[1], 1)))  # row blocks: no full-size temporaries
    for r in range(0, C.shape[0], rows):
        big = (np.abs(C[r : r + rows]) > 1.0) | (np.abs(S[r : r + rows]) > 1.0)
        if r == 0:
            big[0, 0] = abs(S[0, 0]) > 1.0
        if big.any():
            n, m = (int(v[0]) for v in np.nonzero(big))
            n += r
            value = C[n, m] if abs(C[n, m]) > 1.0 else S[n, m]
            return n, m, float(value)
    return None


# --------------------------------------------------------------------------------------- the header
def _parse_header(path: str, raw: Raw) -> tuple[dict[str, str], dict[str, int], int, int]:
    """Return (header dict, {key: line}, offset of the data, number of lines before the data)."""
    m_end = re.search(rb"^[ \t]*end_of_head\b.*$", raw, re.M)
    if not m_end:
        raise ModelFileError(f"{path}: no 'end_of_head' line (not an ICGEM .gfc file?)")
    head = raw[: m_end.end()]  # bytes (a copy when raw is a mapping), the header and before
    m_beg = re.search(rb"^[ \t]*begin_of_head\b.*$", head[: m_end.start()], re.M)
    head_start = m_beg.end() if m_beg else 0
    first_line = head.count(b"\n", 0, head_start) + 1
    header, where = {}, {}
    text = head[head_start : m_end.start()].decode("latin-1")
    for k, line in enumerate(text.split("\n")):
        parts = line.split(None, 1)
        if not parts:
            continue
        key = parts[0].lower()
        if key not in header:
            header[key] = parts[1].strip() if len(parts) > 1 else ""
            where[key] = first_line + k
    where["end_of_head"] = head.count(b"\n", 0, m_end.start()) + 1
    # ".*$" stops at the newline ending the end_of_head line, or at the end of the file
    offset = min(m_end.end() + 1, len(raw))
    nhead = head.count(b"\n") + 1
    return header, where, offset, nhead


def _header_number(
    path: str, header: dict[str, str], where: dict[str, int], key: str, integer: bool = False
) -> float:
    """Return the number of header ``key`` (a positive float, or a count with ``integer``)."""
    if key not in header:
        raise _fail(path, where["end_of_head"], f"header key '{key}' is missing before end_of_head")
    text = header[key].split()[0] if header[key].split() else ""
    try:
        val = float(text.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise _fail(path, where[key], f"header '{key}': bad number {text!r}") from None
    if not math.isfinite(val) or val <= (-1 if integer else 0) or (integer and val != int(val)):
        raise _fail(path, where[key], f"header '{key}': invalid value {text!r}")
    return int(val) if integer else val


# ------------------------------------------------------------------------------- coefficient tables
#: keyword of each kind of data line (the kinds of ``fieldmap.models.icgem``'s keywords)
_KIND_NAME = ("gfc", "gfct", "trnd", "acos", "asin")


def _fail(path: str, line: int | None, msg: str) -> ModelFileError:
    """Return the :class:`ModelFileError` of ``msg`` at ``line`` of ``path`` (no line: the file)."""
    where = f"{path}, line {line}" if line else f"{path}"
    return ModelFileError(f"{where}: {msg}")


def _times(path: str, values: np.ndarray, lines: np.ndarray, nhead: int) -> np.ndarray:
    """Decimal years of ICGEM time stamps ``yyyymmdd[.hhmm]`` (one per data line)."""
    uniq, inv = np.unique(values, return_inverse=True)
    out = np.empty(uniq.size)
    for k, v in enumerate(uniq):
        try:
            out[k] = yyyymmdd(float(v))
        except (ValueError, OverflowError):
            line = nhead + int(lines[np.flatnonzero(inv == k)[0]]) + 1
            raise _fail(path, line, f"bad time stamp {v!r} (expected yyyymmdd[.hhmm])") from None
    return out[inv]


def _epochs(
    path: str, nhead: int, v2: bool, t: float | None, cols: tuple[np.ndarray, ...]
) -> tuple[np.ndarray, ...]:
    """Return the time-variable lines' epochs t0; in icgem2.0, only the lines valid at ``t``.

    ``cols``: line, kind, n, m, c, s, σc, σs, has σ, and the last three values of each line.
    Returns the first nine (icgem2.0: the lines valid at ``t`` only), t0 and the period.
    """
    lines, kind, n, m, c, s, sc, ss, has_sig, last, prev, third = cols
    period = np.where(kind >= 3, last, 1.0)
    t0 = np.zeros(kind.size)
    if v2:  # gfct/trnd: ... t0 t1; acos/asin: ... t0 t1 period
        assert t is not None  # read_icgem asks an icgem2.0 file with such lines for an epoch
        t0 = _times(path, np.where(kind >= 3, third, prev), lines, nhead)
        t1 = _times(path, np.where(kind >= 3, prev, last), lines, nhead)
        active = (t0 <= t) & (t < t1)
        gct = kind == 1
        has_gfct = np.unique(n[gct] * (n[gct] + 1) // 2 + m[gct])
        act_gfct = np.unique(n[gct & active] * (n[gct & active] + 1) // 2 + m[gct & active])
        if has_gfct.size != act_gfct.size:
            lo, hi = t0[gct].min(), t1[gct].max()
            raise InputError(
                f"epoch {t:.4f} is outside the validity intervals of {path}"
                f" ({lo:.4f} to {hi:.4f}) for some coefficients"
            )
        lines, kind, n, m, c, s, sc, ss, has_sig, t0, period = (
            a[active] for a in (lines, kind, n, m, c, s, sc, ss, has_sig, t0, period)
        )
    elif (kind == 1).any():  # icgem1.0: t0 on the gfct line
        g = kind == 1
        t0[g] = _times(path, last[g], lines[g], nhead)
    return lines, kind, n, m, c, s, sc, ss, has_sig, t0, period


def _duplicates(path: str, keys: np.ndarray, lines: np.ndarray, nhead: int, what: str) -> None:
    """Raise the error of the first line whose key repeats an earlier one's (``what``: its kind)."""
    order = np.argsort(keys, kind="stable")
    dup = np.flatnonzero(keys[order][1:] == keys[order][:-1])
    if dup.size:
        later = order[dup + 1]
        k = later[np.argmin(lines[later])]
        first = lines[order[dup[np.argmin(lines[later])]]]
        raise _fail(
            path,
            nhead + int(lines[k]) + 1,
            f"duplicate {what} (first given on line {nhead + int(first) + 1})",
        )


class _StaticTable:
    """C, S (and σC, σS) of the static lines, filled chunk by chunk (:meth:`add`, :meth:`finish`).

    Besides the (lmax+1)² tables it keeps, per coefficient (packed index n(n+1)/2 + m), the data
    line of its first static line: the duplicate and gap checks name the same lines as a check
    of the whole file at once would. Chunks come in line order.
    """

    def __init__(self, lmax: int, nbytes: int, sigma: bool = True) -> None:
        self.C = np.zeros((lmax + 1, lmax + 1))
        self.S = np.zeros((lmax + 1, lmax + 1))
        self.SC: np.ndarray | None = None
        self.SS: np.ndarray | None = None
        self.sigma = sigma  # False: header "errors no", σ columns ignored
        dtype = np.uint32 if nbytes < 2**32 - 1 else np.int64  # a line index < its byte offset
        self.none = np.iinfo(dtype).max
        self.line = np.full((lmax + 1) * (lmax + 2) // 2, self.none, dtype)
        self.repeat: tuple[int, int] | None = (
            None  # (line, key) of the first static line repeating a coefficient
        )

    def _sigmas(
        self, n: np.ndarray, m: np.ndarray, sc: np.ndarray, ss: np.ndarray, has: np.ndarray
    ) -> None:
        if self.sigma and has.any():
            if self.SC is None or self.SS is None:  # both, at the first σ
                self.SC, self.SS = np.zeros_like(self.C), np.zeros_like(self.C)
            self.SC[n[has], m[has]], self.SS[n[has], m[has]] = sc[has], ss[has]

    def add(
        self,
        lines: np.ndarray,
        n: np.ndarray,
        m: np.ndarray,
        c: np.ndarray,
        s: np.ndarray,
        sc: np.ndarray,
        ss: np.ndarray,
        has: np.ndarray,
    ) -> None:
        """Enter static lines (data line indices ``lines``, increasing, after earlier chunks')."""
        idx = n * (n + 1) // 2 + m
        self.C[n, m], self.S[n, m] = c, s
        self._sigmas(n, m, sc, ss, has)
        seen = self.line[idx] != self.none  # given by an earlier chunk
        if not seen.any():
            self.line[idx] = lines
            if (self.line[idx] == lines).all():
                return
        order = np.argsort(idx, kind="stable")  # a coefficient given twice: first lines kept
        first = np.ones(idx.size, bool)
        first[1:] = idx[order][1:] != idx[order][:-1]
        is_first = np.zeros(idx.size, bool)
        is_first[order[first]] = True
        new = is_first & ~seen
        self.line[idx[new]] = lines[new]
        rep = seen | ~is_first
        if rep.any() and self.repeat is None:
            k = int(np.flatnonzero(rep)[0])
            self.repeat = (int(lines[k]), int(idx[k]))

    def finish(
        self,
        path: str,
        nhead: int,
        lines: np.ndarray,
        n: np.ndarray,
        m: np.ndarray,
        c: np.ndarray,
        s: np.ndarray,
        sc: np.ndarray,
        ss: np.ndarray,
        has: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
        """Enter the gfct lines (kept, active), check duplicates and gaps; return C, S, σ."""
        idx = n * (n + 1) // 2 + m
        rep = [self.repeat] if self.repeat is not None else []
        if idx.size:  # a gfct line after or before gfc lines of its coefficient, or twice
            given = np.unique(idx[self.line[idx] != self.none])
            keys = np.concatenate([given, idx])
            at = np.concatenate([self.line[given].astype(np.int64), lines])
            order = np.lexsort((at, keys))
            later = np.flatnonzero(keys[order][1:] == keys[order][:-1]) + 1
            if later.size:
                k = order[later[np.argmin(at[order[later]])]]
                rep.append((int(at[k]), int(keys[k])))
        if rep:
            line, key = min(rep)
            known = [int(self.line[key])] if self.line[key] != self.none else []
            first = min(known + [int(v) for v in lines[idx == key]])
            raise _fail(
                path,
                nhead + line + 1,
                f"duplicate coefficient (first given on line {nhead + first + 1})",
            )
        self.C[n, m], self.S[n, m] = c, s
        self.line[idx] = lines
        self._sigmas(n, m, sc, ss, has)
        if self.line[0] == self.none:
            self.C[0, 0] = 1.0
        present = self.line != self.none
        miss = present.size
        if present.size > 3:  # degrees 0 and 1 may be omitted (C00 = 1, origin at the centre)
            miss = 3 + int(np.argmin(present[3:])) if not present[3:].all() else miss
        if miss < present.size:
            miss_n = (math.isqrt(8 * miss + 1) - 1) // 2
            miss_m = miss - miss_n * (miss_n + 1) // 2
            if not present[:miss].any():
                raise ModelFileError(f"{path}: no line for n={miss_n} m={miss_m}")
            last = int(np.max(self.line[:miss][present[:miss]]))
            top = present.size - 1 - int(np.argmax(present[::-1]))
            why = "file truncated?" if miss > top else "degree gap"
            raise _fail(
                path,
                nhead + last + 1,
                f"no line for n={miss_n} m={miss_m} after this one ({why})",
            )
        sig = None
        if self.SC is not None and self.SS is not None and (self.SC.any() or self.SS.any()):
            sig = (self.SC, self.SS)
        return self.C, self.S, sig

    def first_line(self, n: int, m: int) -> int | None:
        """Return the data line of the static line of (n, m), or None."""
        v = self.line[n * (n + 1) // 2 + m]
        return None if v == self.none else int(v)


def _time_variable(
    path: str,
    lines: np.ndarray,
    kind: np.ndarray,
    n: np.ndarray,
    m: np.ndarray,
    idx: np.ndarray,
    c: np.ndarray,
    s: np.ndarray,
    t0: np.ndarray,
    period: np.ndarray,
    t: float | None,
    v2: bool,
    C: np.ndarray,
    S: np.ndarray,
    nhead: int,
) -> float | None:
    """Add trend and periodic terms at epoch ``t`` (None: each coefficient's t0)."""
    tv = kind >= 2
    ref = np.full(int(idx.max(initial=0)) + 1, np.nan)
    g = kind == 1
    ref[idx[g]] = t0[g]
    tref = t0 if v2 else ref[idx]
    orphan = tv & np.isnan(tref)
    if orphan.any():
        k = np.flatnonzero(orphan)[0]
        raise _fail(
            path,
            nhead + int(lines[k]) + 1,
            f"'{_KIND_NAME[kind[k]]}' for n={n[k]} m={m[k]} without a 'gfct' line",
        )
    for kd, what in ((2, "trend"), (3, "acos term"), (4, "asin term")):
        sel = kind == kd
        if sel.any():
            keys = idx[sel] * 4096.0 + (period[sel] if kd >= 3 else 0.0)
            _duplicates(path, keys, lines[sel], nhead, what)
    dt = (t - tref) if t is not None else np.zeros(idx.size)
    factor = np.select(
        [kind == 2, kind == 3, kind == 4],
        [dt, np.cos(2 * np.pi * dt / period), np.sin(2 * np.pi * dt / period)],
        0.0,
    )
    np.add.at(C, (n[tv], m[tv]), factor[tv] * c[tv])
    np.add.at(S, (n[tv], m[tv]), factor[tv] * s[tv])
    if t is not None:
        return t
    epochs = np.unique(t0[g])
    return float(epochs[0]) if epochs.size == 1 else None


# number of fields after "C S [sigmas]" per kind (gfc, gfct, trnd, acos, asin): icgem1.0, icgem2.0
_EXTRA = (np.array([0, 1, 0, 1, 1]), np.array([0, 2, 2, 3, 3]))


def _sigma_columns(
    vals: np.ndarray, off: np.ndarray, nf: np.ndarray, kind: np.ndarray, v2: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return σC, σS of each data line and whether the line has them.

    The first pair of σ columns is taken: the calibrated one of ``calibrated_and_formal`` files.
    """
    nsig = nf - 2 - _EXTRA[int(bool(v2))][kind]
    has = nsig >= 2
    sc = np.where(has, vals[np.minimum(off + 2, vals.size - 1)], 0.0)
    ss = np.where(has, vals[np.minimum(off + 3, vals.size - 1)], 0.0)
    return sc, ss, has


def _negative_sigma(
    vals: np.ndarray, off: np.ndarray, nf: np.ndarray, kind: np.ndarray, v2: bool
) -> np.ndarray:
    """Tell, per data line, whether one of its σ columns (up to four) is negative.

    A standard deviation is never negative: such a file is malformed (NGA's reader refuses it
    too), and taking its absolute value would only hide the error.
    """
    nsig = nf - 2 - _EXTRA[int(bool(v2))][kind]
    bad = np.zeros(off.size, bool)
    for j in range(int(nsig.max(initial=0))):
        sel = nsig > j
        bad[sel] |= vals[off[sel] + 2 + j] < 0.0
    return bad


# --------------------------------------------------------------------------- epochs and the reader
def parse_epoch(epoch: Any) -> float | None:
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


def as_degree(lmax: Any, what: str = "lmax") -> int | None:
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


def _scan_chunk(
    path: str,
    raw: Raw,
    piece: tuple[int, int, np.ndarray],
    base: int,
    ctx: tuple[int, int, int, bool],
    best: int,
) -> tuple[int, Exception | None, int, tuple[Any, ...] | None]:
    """Check and parse the data lines ``base`` on, in ``raw[lo:hi]``.

    ``piece``: lo, hi and the offsets of the newlines from lo. Returns ``(rank, error, nlines,
    data)``: the first failed check of rank below ``best`` (the whole-file order of the checks,
    each at its first line: chunks come in line order), or ``_NONE``; the number of lines; and,
    when all checks pass, ``(content lines, static gfc lines for _StaticTable.add, time-variable
    lines as _TV_FIELDS, whether the chunk has time-variable lines of any degree)`` (None:
    nothing kept).
    """
    nhead, nmax, lmax, v2 = ctx
    lo, hi, newlines = piece
    buf, starts, ends, tok_line, ntok, first = tokenise(raw, lo, hi - lo, newlines)
    li = np.flatnonzero(ntok > 0)  # data lines with content
    nlines, f0 = ntok.size, first[li]

    def line_of(mask: np.ndarray) -> int:
        return nhead + base + int(li[np.flatnonzero(mask)[0]]) + 1

    def text_of(t: Any) -> str:
        return buf[starts[t] : ends[t]].tobytes().decode("latin-1")

    kind = keyword_kinds(buf, starts[f0], ends[f0], _KEYS)
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
    n, ok_n = small_ints(buf, starts[f0 + 1], ends[f0 + 1])
    m, ok_m = small_ints(buf, starts[f0 + 2], ends[f0 + 2])
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
    vals, bad_tok = parse_values(buf, starts, ends, tok_line, first, keep_line)
    if (
        vals is None and bad_tok is not None and bad_tok < 0
    ):  # pragma: no cover - NumPy and float() disagree
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


def read_icgem(
    path: str | os.PathLike[str], lmax: int | None = None, epoch: float | str | None = None
) -> SHModel:
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
    raw = read_bytes(path, mapped=True)
    check_text(path, raw)
    header, where, offset, nhead = _parse_header(path, raw)
    gm = _header_number(path, header, where, "earth_gravity_constant")
    radius = _header_number(path, header, where, "radius")
    nmax = int(_header_number(path, header, where, "max_degree", integer=True))
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
    table = _StaticTable(lmax, len(raw), sigma=errors != "no")
    best, err, content, base, parts, any_tv = _NONE, None, 0, 0, [], False
    for lo, hi, newlines in line_chunks(raw, offset, CHUNK_LINES):
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
        release(raw, lo, hi)
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
        C, S = unnormalized_to_full(C, S, path)
        if sig is not None:
            sig = unnormalized_to_full(sig[0], sig[1], path)

    def first_line(cn: int, cm: int) -> int:  # file line of the first data line of (cn, cm)
        at = [int(x) for x in lines[(n == cn) & (m == cm)]]
        if (k := table.first_line(cn, cm)) is not None:
            at.append(k)
        return nhead + min(at) + 1

    if (why := c00_problem(C)) is not None:  # not 1: C00 was given (its default is 1)
        raise _fail(path, first_line(0, 0), why)
    if (one := degree1_problem(C, S)) is not None:
        raise _fail(path, first_line(one[0], one[1]), one[2])
    if (big := first_outsize(C, S)) is not None:
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


def write_icgem(path: str | os.PathLike[str], model: SHModel, preamble: str = "") -> None:
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
