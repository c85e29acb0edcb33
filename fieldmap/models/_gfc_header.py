"""The header of an ICGEM ``.gfc`` file (used by :mod:`.icgem`).

``key value`` lines up to ``end_of_head``, after ``begin_of_head`` and any free text before it;
errors name the file and the line.
"""

from __future__ import annotations

import math
import re

from fieldmap.errors import ModelFileError
from fieldmap.models._gfc_terms import fail


def parse_header(path, raw):
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


def header_number(path, header, where, key, integer=False):
    """Return the number of header ``key`` (a positive float, or a count with ``integer``)."""
    if key not in header:
        raise fail(path, where["end_of_head"], f"header key '{key}' is missing before end_of_head")
    text = header[key].split()[0] if header[key].split() else ""
    try:
        val = float(text.replace("D", "E").replace("d", "e"))
    except ValueError:
        raise fail(path, where[key], f"header '{key}': bad number {text!r}") from None
    if not math.isfinite(val) or val <= (-1 if integer else 0) or (integer and val != int(val)):
        raise fail(path, where[key], f"header '{key}': invalid value {text!r}")
    return int(val) if integer else val
