"""Flight-log formats for :mod:`fieldmap.nav.readers`: CSV and tables, GPX 1.1, NMEA 0183, IGC.

:func:`load_text` reads a log (gzip undone, files that are certainly no flight log refused) and
tells its kind; each reader returns a :class:`~fieldmap.nav.readers_parsed.Parsed` (raw
columns, file order, the line of each fix) that :func:`fieldmap.nav.readers.read_track` turns
into a :class:`~fieldmap.nav.readers.RawTrack`. The readers live in one module per family:

- :mod:`fieldmap.nav.readers_tables`: CSV text, DataFrames, Datasets and mappings of arrays;
- :mod:`fieldmap.nav.readers_gnss`: GPX 1.1, NMEA 0183 and IGC (their specifications there);
- :mod:`fieldmap.nav.readers_parsed`: the :class:`~fieldmap.nav.readers_parsed.Parsed` record
  and the helpers they share.

Their names are re-exported here.
"""

from __future__ import annotations

import gzip
import re
import zlib
from pathlib import Path

from fieldmap.errors import InputError
from fieldmap.nav.readers_gnss import read_gpx as read_gpx
from fieldmap.nav.readers_gnss import read_igc as read_igc
from fieldmap.nav.readers_gnss import read_nmea as read_nmea
from fieldmap.nav.readers_parsed import DAY as DAY
from fieldmap.nav.readers_parsed import HINT as HINT
from fieldmap.nav.readers_parsed import Parsed as Parsed
from fieldmap.nav.readers_parsed import iso_utc as iso_utc
from fieldmap.nav.readers_tables import csv_table as csv_table
from fieldmap.nav.readers_tables import numbers as numbers
from fieldmap.nav.readers_tables import object_table as object_table
from fieldmap.nav.readers_tables import times as times

#: magic bytes of files that are certainly no flight log
_MAGIC = {
    b"\x89PNG": "a PNG image",
    b"%PDF": "a PDF document",
    b"PK\x03\x04": "a ZIP archive",
    b"\xff\xd8\xff": "a JPEG image",
    b"CDF\x01": "a NetCDF file (use fieldmap.nav.flight.read_flight)",
    b"\x89HDF": "an HDF5/NetCDF4 file (use fieldmap.nav.flight.read_flight)",
}


def load_text(path: Path) -> tuple[str, str]:
    """Text of a flight log (gzip undone) and its kind: ``csv``, ``gpx``, ``nmea`` or ``igc``."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the flight log ({exc.strerror})") from None
    if data[:2] == b"\x1f\x8b":
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError, zlib.error) as exc:
            raise InputError(f"{path}: broken gzip file ({exc})") from None
    if not data.strip():
        raise InputError(f"{path}: empty flight log")
    for magic, what in _MAGIC.items():
        if data.startswith(magic):
            raise InputError(f"{path}: not a flight log ({what})")
    if b"\x00" in data[:65536]:
        raise InputError(f"{path}: not a text flight log (binary data)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    suffix = "".join(s for s in path.suffixes[-2:] if s.lower() != ".gz").lower()
    head = [s.strip() for s in text[:20000].splitlines() if s.strip()][:50]
    if suffix == ".gpx" or head[0].startswith("<"):
        return text, "gpx"
    nmea = sum(1 for s in head if re.search(r"\$[A-Z]{5},", s))
    if suffix in (".nmea", ".nma") or nmea >= max(1, len(head) // 2):
        return text, "nmea"
    if suffix == ".igc" or (head[0].startswith("A") and any(s.startswith("HF") for s in head)):
        return text, "igc"
    return text, "csv"
