"""Flight logs as tables: CSV text, pandas ``DataFrame``, xarray ``Dataset``, mappings of arrays.

:func:`csv_table` and :func:`object_table` give a header, a getter of a column's cells and the
line (record) number of each row; :func:`numbers` and :func:`times` turn cells into floats and
seconds (numbers, epoch seconds or milliseconds, ISO 8601 text, a ``strptime`` pattern) and
refuse anything else with its line and column. Used by :func:`fieldmap.nav.readers.read_track`.
"""

from __future__ import annotations

import csv
import re
from datetime import datetime

import numpy as np

from fieldmap.errors import InputError
from fieldmap.nav.readers_parsed import _EMPTY, HINT, _utc
from fieldmap.nav.spelling import keyword


def numbers(cells, where, name: str) -> np.ndarray:
    """Floats of a column: empty cells NaN, anything else that is no number refused."""
    arr = np.asarray(cells)
    try:
        out = arr.astype(np.float64)
    except (TypeError, ValueError):
        out = np.empty(len(arr))
        for i, c in enumerate(arr):
            s = str(c).strip()
            try:
                out[i] = np.nan if c is None or s.lower() in _EMPTY else float(s)
            except ValueError:
                raise InputError(f"{where(i)} column {name}: {s!r} is not a number") from None
    bad = np.flatnonzero(np.isinf(out))
    if bad.size:
        raise InputError(f"{where(bad[0])} column {name}: {out[bad[0]]} is not finite")
    return out


def _iso(s: str) -> float:
    """Epoch seconds of ISO 8601 text (``Z`` and any number of decimals also on Python 3.10)."""
    s = s[:-1] + "+00:00" if s[-1:] in "Zz" else s
    s = re.sub(r"(\.\d+)", lambda m: (m[1] + "00000")[:7], s, count=1) if "." in s[10:] else s
    return _utc(datetime.fromisoformat(s))


def times(cells, where, name: str, fmt: str | None) -> tuple[np.ndarray, bool, str | None]:
    """Return times in seconds, whether they are absolute, and a note on how they were read.

    Numbers without ``fmt`` are seconds as given, epoch seconds above 1e8, epoch milliseconds
    above 1e11 (the median): the last is a guess of their units, and the note says so. Epoch
    times beyond the years 1..9999 are refused with the line, the column and how they were read.
    """
    arr = np.asarray(cells)
    if arr.dtype.kind == "M":
        if np.isnat(arr).any():
            raise InputError(f"{where(np.flatnonzero(np.isnat(arr))[0])} column {name}: empty time")
        t = (arr.astype("datetime64[ns]") - np.datetime64(0, "ns")) / np.timedelta64(1, "s")
        return t.astype(np.float64), True, None
    kinds = {"s": 1.0, "epoch": 1.0, "epoch_ms": 1e-3}
    first = next((str(c) for c in arr if str(c).strip().lower() not in _EMPTY), "")
    numeric = fmt in kinds or (fmt is None and _isnum(first))
    out = np.empty(len(arr))
    for i, c in enumerate(arr):
        s = str(c).strip()
        if s.lower() in _EMPTY or s == "NaT":
            raise InputError(f"{where(i)} column {name}: empty time")
        try:
            if isinstance(c, datetime):
                out[i] = _utc(c)
            elif numeric:
                out[i] = float(s)
            elif fmt and "%" in fmt:
                out[i] = _utc(datetime.strptime(s, fmt))
            else:
                out[i] = _iso(s)
        except ValueError:
            what = "a number" if numeric else f"a time ({fmt or 'ISO 8601'})"
            raise InputError(f"{where(i)} column {name}: {s!r} is not {what}") from None
    if not numeric:
        return out, True, None
    med = float(np.median(np.abs(out)))
    if fmt == "epoch_ms" or (fmt is None and med > 1e11):
        how = "epoch milliseconds" + (f" ({GUESS_MS})" if fmt is None else "")
        _check_epoch(out * 1e-3, out, where, name, how)
        return out * 1e-3, True, f"times read as {how}"
    if fmt == "epoch" or (fmt is None and med > 1e8):
        _check_epoch(out, out, where, name, "epoch seconds")
        return out, True, "times read as epoch seconds (UTC)"
    return out, False, None


#: how the guess of epoch milliseconds is said in notes and messages
GUESS_MS = "guessed from their size: above 1e11"
#: epoch seconds of 0001-01-01 and 10000-01-01 UTC: the years a date can name
_EPOCH_MIN, _EPOCH_MAX = -62_135_596_800.0, 253_402_300_800.0


def _check_epoch(t: np.ndarray, raw: np.ndarray, where, name: str, how: str) -> None:
    """Refuse epoch times ``t`` (s) outside the years 1..9999, naming the first and the units."""
    bad = np.flatnonzero((t < _EPOCH_MIN) | (t >= _EPOCH_MAX))
    if bad.size:
        i = int(bad[0])
        when = "before the year 1" if t[i] < _EPOCH_MIN else "after the year 9999"
        fmt = keyword("time_format")
        tip = f": give their units with {fmt} (s, epoch, epoch_ms)" if fmt else ""
        raise InputError(f"{where(i)} column {name}: {raw[i]:.17g} read as {how} is {when}{tip}")


def _isnum(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def csv_table(text: str, source: str):
    """Header, getter of a column's cells and line numbers of a CSV text."""
    header, hline, rows, lines = None, 0, [], []
    body = [(k, s) for k, s in enumerate(text.splitlines(), 1) if s.strip() and s[:1] != "#"]
    if not body:
        raise InputError(f"{source}: empty flight log (no header, no samples)")
    hline, first = body[0]
    delim = next((d for d in (",", "\t", ";") if d in first), ",")
    header = [c.strip() for c in next(csv.reader([first], delimiter=delim))]
    if all(_isnum(c) for c in header if c):
        raise InputError(
            f"{source} line {hline}: numbers where the header row naming the columns should be "
            f"(a flight log needs one; {HINT})"
        )
    for (k, _), cells in zip(body[1:], csv.reader((s for _, s in body[1:]), delimiter=delim)):
        if len(cells) != len(header):
            raise InputError(
                f"{source} line {k}: {len(cells)} fields, the header (line {hline}) has "
                f"{len(header)}"
            )
        rows.append(cells)
        lines.append(k)
    if not rows:
        raise InputError(f"{source}: a header (line {hline}) but no samples")
    return header, lambda j: [r[j] for r in rows], np.asarray(lines, dtype=np.int64)


def object_table(obj, source: str):
    """Header, getter and record numbers of a DataFrame, Dataset or mapping of arrays."""
    if hasattr(obj, "data_vars"):
        obj = {str(k): obj[k].values for k in obj.variables if obj[k].ndim == 1}
    elif hasattr(obj, "columns") and getattr(obj.index, "name", None) not in (None, *obj.columns):
        obj = obj.reset_index()  # a DataFrame indexed by its (named) time column
    if not hasattr(obj, "keys"):
        raise InputError(f"{source}: not a DataFrame, Dataset or mapping of arrays")
    header = [str(k) for k in obj.keys()]
    cols = {str(k): np.asarray(obj[k]).ravel() for k in obj.keys()}
    n = max((c.size for c in cols.values()), default=0)
    if n == 0:
        raise InputError(f"{source}: no samples")
    for k, c in cols.items():
        if c.size != n:
            raise InputError(f"{source} column {k}: {c.size} values, other columns have {n}")
    return header, lambda j: cols[header[j]], np.arange(1, n + 1, dtype=np.int64)
