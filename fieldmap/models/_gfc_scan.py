"""Bulk NumPy tokeniser for the data section of ICGEM ``.gfc`` files (used by :mod:`.icgem`).

The data section (2.4 million lines for a degree-2190 model) is never split into Python
strings: token boundaries are found on the byte array, keywords and degree/order are decoded
with vectorised integer arithmetic, and all coefficient values are parsed by one call of
:func:`numpy.fromstring` on a copy of the bytes where every other token has been blanked.
Only when that parse fails does a per-token Python pass run, to name the offending token.
Also here: reading the bytes (gzip, pipes, binary data refused), ICGEM time stamps to decimal
years, and unnormalised coefficients to fully normalised ones.
"""

from __future__ import annotations

import datetime as _dt
import gzip
import math
import os
import stat
import warnings
import zlib

import numpy as np

from fieldmap.errors import ModelFileError

#: largest model read from a pipe or device (a regular file of any size is read whole): a
#: degree-2190 ``.gfc`` is 0.3 GB; ``--model /dev/zero`` must not fill the memory
MAX_STREAM_BYTES = 4 * 2**30
_CHUNK = 16 * 2**20


def read_bytes(path) -> bytes:
    """Return the bytes of a model file, gunzipped if compressed (raises ModelFileError)."""
    try:
        with open(path, "rb") as f:
            if stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                raw = f.read()
            else:  # a pipe (``<(zcat ...)``) or a device
                raw = _read_stream(f, path)
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
    if not raw or raw.isspace():
        raise ModelFileError(f"{path}: empty file")
    return raw


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


def check_text(path, raw: bytes) -> None:
    """Reject binary data: control bytes other than tab, CR, LF (Latin-1 text is fine)."""
    b = np.frombuffer(raw, np.uint8)
    ctrl = _CONTROL[b]
    if ctrl.any():
        pos = int(np.argmax(ctrl))
        line = raw.count(b"\n", 0, pos) + 1
        raise ModelFileError(
            f"{path}, line {line}: binary byte 0x{b[pos]:02x}: not an ICGEM text file"
        )


_WHITESPACE = np.zeros(256, bool)
_WHITESPACE[[9, 10, 13, 32]] = True


def tokenise(raw: bytes, offset: int = 0):
    """Split the data section ``raw[offset:]`` into whitespace-separated tokens (no copy of it).

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
    buf = np.frombuffer(raw, np.uint8, offset=offset)
    ws = _WHITESPACE[buf]
    edge = np.diff(ws.view(np.int8), prepend=np.int8(1), append=np.int8(1))
    starts = np.flatnonzero(edge == -1)  # whitespace -> text
    ends = np.flatnonzero(edge[1:] == 1) + 1  # text -> whitespace, exclusive
    del ws, edge
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
    """Divide by the normalisation N̄nm = sqrt((2 − δm0)(2n+1)(n−m)!/(n+m)!)."""
    nmax = C.shape[0] - 1
    n = np.arange(nmax + 1, dtype=float)
    norm = np.zeros_like(C)
    col = np.sqrt(2.0 * n + 1.0)  # m = 0
    for m in range(nmax + 1):
        if m > 0:  # N̄n,m = N̄n,m−1 / sqrt((n+m)(n−m+1)), times sqrt(2) from m=0 to m=1
            with np.errstate(divide="ignore", invalid="ignore"):
                col = col / np.sqrt((n + m) * (n - m + 1.0)) * (math.sqrt(2.0) if m == 1 else 1)
        norm[m:, m] = col[m:]
    tiny = (norm[np.tril_indices(nmax + 1)] == 0) | ~np.isfinite(norm[np.tril_indices(nmax + 1)])
    if tiny.any():
        raise ModelFileError(f"{path}: unnormalized coefficients beyond the float64 range")
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(norm > 0, C / norm, 0.0), np.where(norm > 0, S / norm, 0.0)


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


def first_outsize(C, S):
    """Return ``(n, m, value)`` of the first coefficient too large to be physical, else None.

    Fully normalised coefficients of a real body are far below 1 in size beyond degree 0
    (Kaula's rule: about 1e-5/n²) and C̄00 is 1 by definition; a value beyond 1 is a unit or
    normalisation error, and one beyond 1e150 overflows the synthesis.
    """
    big = (np.abs(C) > 1.0) | (np.abs(S) > 1.0)
    if not big.any():
        return None
    n, m = (int(v[0]) for v in np.nonzero(big))
    value = C[n, m] if abs(C[n, m]) > 1.0 else S[n, m]
    return n, m, float(value)
