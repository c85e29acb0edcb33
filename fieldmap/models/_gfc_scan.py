"""Bulk NumPy tokeniser for the data section of ICGEM ``.gfc`` files (used by :mod:`.icgem`).

The data section (2.4 million lines for a degree-2190 model) is never split into Python
strings: token boundaries are found on the byte array, keywords and degree/order are decoded
with vectorised integer arithmetic, and all coefficient values are parsed by one call of
:func:`numpy.fromstring` on a copy of the bytes where every other token has been blanked.
Only when that parse fails does a per-token Python pass run, to name the offending token.
:func:`line_chunks` cuts the data into pieces of whole lines for :func:`tokenise` (the ICGEM
reader's memory stays bounded: issue 17). Also here: reading the bytes (memory-mapped, gzip,
pipes, binary data refused), ICGEM time stamps to decimal years, unnormalised coefficients
to fully normalised ones (in place), and the checks of C̄00 and of the coefficients' size that
the ICGEM and NGA readers share.
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

import numpy as np

from fieldmap.errors import ModelFileError

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


def read_bytes(path, mapped: bool = False) -> bytes | mmap.mmap:
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


def _gunzip_mapped(f, path) -> mmap.mmap:
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


def release(raw, lo: int, hi: int) -> None:
    """Drop the pages of ``raw[lo:hi]`` from this process's memory if ``raw`` is a mapping.

    The bytes stay in the page cache and are read again on the next access: only the resident
    size goes down (a file read once, chunk by chunk, then never holds more than a chunk).
    """
    if isinstance(raw, mmap.mmap) and hasattr(mmap, "MADV_DONTNEED"):
        lo -= lo % mmap.PAGESIZE
        hi -= hi % mmap.PAGESIZE
        if hi > lo:
            raw.madvise(mmap.MADV_DONTNEED, lo, hi - lo)


def _read_stream(f, path) -> bytes:
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


def check_text(path, raw, what: str = "an ICGEM text file") -> None:
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


def count_newlines(raw, lo: int, hi: int) -> int:
    """Count the newline bytes in ``raw[lo:hi]`` (bytes or a mapping), read in blocks."""
    total = 0
    for a in range(lo, hi, BLOCK):
        b = np.frombuffer(raw, np.uint8, count=min(BLOCK, hi - a), offset=a)
        total += int(np.count_nonzero(b == 10))
    return total


def line_chunks(raw, offset: int, lines: int):
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


def tokenise(raw, offset: int = 0, count: int = -1, newlines=None):
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


def small_ints(buf, s, e):
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


def keyword_kinds(buf, s, e, keys: dict):
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


def parse_values(buf, starts, ends, tok_line, first, keep_line):
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
        text = buf[starts[t] : ends[t]].tobytes().decode("latin-1")
        try:
            ok = math.isfinite(float(text.replace("D", "E").replace("d", "e")))
        except ValueError:
            ok = False
        if not ok:
            return None, int(t)
    return None, -1  # pragma: no cover - fromstring and float() disagree


def unnormalized_to_full(C, S, path):
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


def c00_problem(C) -> str | None:
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


def degree1_problem(C, S) -> tuple[int, int, str] | None:
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


def first_outsize(C, S):
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
