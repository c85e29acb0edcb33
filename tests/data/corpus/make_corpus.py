"""Regenerate the flight corpus of this folder from an installed ``traffic`` package (issue 34).

Usage (from the repository root; run by hand, not in CI)::

    pip install traffic==2.13 "pandas<2.3"
    python tests/data/corpus/make_corpus.py

What it writes (``README.md`` beside this script says why and under which licence):

- ``<category>/<name>.csv.gz``: one piece of one flight. Every sample file of the per-flight
  categories below (:data:`CATEGORIES`) is split by aircraft (``icao24``) and where its times
  leave a gap of more than 30 min (:data:`GAP_S`); a piece of fewer than 50 fixes (rows with
  latitude, longitude and an altitude: :data:`MIN_FIXES`) is left out. Of the pieces of the
  large collections (:data:`COLLECTIONS`, split the same way) 100 are drawn
  (:data:`N_DRAWN`) with ``numpy.random.default_rng(34)``, each written under the
  collection's name as category.
- ``manifest.json``: one entry per piece: ``name``, ``category``, ``kind`` (``sample`` or
  ``collection``), ``source`` (the sample file under ``traffic/data/samples``), ``icao24``,
  ``callsign`` (the most frequent one), ``rows``, ``start`` (UTC), ``duration_s`` (last minus
  first time), ``gs_p995_m_s`` (the 99.5th percentile, NumPy's linear interpolation, of the
  piece's ``groundspeed`` column in m/s: the log's robust maximum ground speed; null where the
  piece has none), ``file_bytes``.

Each piece keeps the log as it was recorded: every row of that aircraft between the gaps, in
the file's order (a file in reverse time order stays so), at its own rate (nothing resampled,
smoothed or removed), in ``traffic``'s CSV layout, which
:func:`fieldmap.nav.logs.read.read_track` recognises: ``timestamp`` (ISO 8601 UTC; whole
seconds in every sample of traffic 2.13), ``icao24``, ``callsign``, ``latitude``,
``longitude`` (degrees), ``altitude`` (barometric, ft), ``geoaltitude`` (geometric, ft),
``groundspeed`` (kt), ``track`` (degrees), ``vertical_rate`` (ft/min), and an ADS-B emitter
``category`` column where a sample has one (none in traffic 2.13); a column that is empty
throughout a piece is left out. The numbers are the samples' own values: a column whose values
are all whole numbers is written without a decimal point, any other as the shortest text that
reads back to the same float64 (the digits the source has). The gzip header holds no file name
or time, so a rerun writes the same bytes.

Left out of ``traffic/data/samples`` (:data:`NOT_USED`): files that are not flight logs in
this layout (raw Mode S messages, a FlightRadar24 API response, a readsb trace, the
fuel-flow study without positions, airspaces).
"""

from __future__ import annotations

import gzip
import io
import json
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import traffic

#: per-flight sample categories (folders of traffic/data/samples): every piece is kept
CATEGORIES = (
    "ambulances", "calibration", "featured", "firefighting", "gliders", "military", "noisy",
    "onground", "surveillance", "surveys", "tv_relay",
)  # fmt: skip
#: large collections (traffic/data/samples/collections/<name>.json.gz): N_DRAWN pieces drawn
COLLECTIONS = ("quickstart", "savan", "switzerland")
#: sample folders not used, and why
NOT_USED = {
    "airspaces": "airspace shapes, no flight",
    "dump1090": "raw Mode S messages (binary)",
    "rs1090": "raw Mode S messages, one decoded message a row (positions and velocities apart)",
    "readsb": "a readsb trace (its own JSON layout)",
    "fr24": "FlightRadar24 API responses (not OpenSky data, their own terms)",
    "performance": "a fuel-flow study without latitude or longitude",
}
#: a gap longer than this starts a new piece (s)
GAP_S = 1800.0
#: a piece with fewer fixes (rows with latitude, longitude and an altitude) is left out
MIN_FIXES = 50
#: pieces drawn from the collections, and the seed
N_DRAWN, SEED = 100, 34
#: the columns kept, in this order, when the sample has them
COLUMNS = (
    "timestamp", "icao24", "callsign", "latitude", "longitude", "altitude", "geoaltitude",
    "groundspeed", "track", "vertical_rate", "category",
)  # fmt: skip
KT = 1852.0 / 3600.0

HERE = Path(__file__).parent
SAMPLES = Path(traffic.__file__).parent / "data" / "samples"


@dataclass(frozen=True)
class Piece:
    """One entry of ``manifest.json`` (see the module docstring)."""

    name: str
    category: str
    kind: str
    source: str
    icao24: str
    callsign: str | None
    rows: int
    start: str
    duration_s: float
    gs_p995_m_s: float | None
    file_bytes: int


def read_sample(path: Path) -> pd.DataFrame:
    """Return one sample file as its rows, in file order (``_row``: the row's position)."""
    df = pd.read_json(path, dtype={"icao24": str, "callsign": str}, precise_float=True)
    df = df[[c for c in COLUMNS if c in df.columns]].copy()
    df["_t"] = pd.to_datetime(df["timestamp"], utc=True)
    df["_row"] = np.arange(len(df))
    return df


def pieces(df: pd.DataFrame) -> list[tuple[str, int, pd.DataFrame]]:
    """Split by aircraft and at gaps over :data:`GAP_S`: ``(icao24, index, rows)`` in file order.

    The gaps are those of the times in order (a stable sort, so repeated times keep the file's
    order); each piece's rows are then written in the file's order. ``index`` counts every piece
    of that aircraft from 1, short ones included, so a name does not change with
    :data:`MIN_FIXES`.
    """
    out = []
    for icao, rows in df.groupby("icao24", sort=True):
        ordered = rows.sort_values("_t", kind="stable")
        gap = ordered["_t"].diff().dt.total_seconds() > GAP_S
        for k, (_, part) in enumerate(ordered.groupby(gap.cumsum().to_numpy()), start=1):
            out.append((str(icao), k, part.sort_values("_row")))
    return out


def fixes(part: pd.DataFrame) -> int:
    """Return the number of rows with a latitude, a longitude and an altitude."""
    alt = part["altitude"].notna()
    if "geoaltitude" in part:
        alt |= part["geoaltitude"].notna()
    return int((part["latitude"].notna() & part["longitude"].notna() & alt).sum())


def csv_bytes(part: pd.DataFrame) -> bytes:
    """Return the gzip-compressed CSV of one piece (see the module docstring)."""
    df = part[[c for c in COLUMNS if c in part.columns]].copy()
    whole = bool((part["_t"].dt.microsecond == 0).all())
    df["timestamp"] = part["_t"].dt.strftime("%Y-%m-%dT%H:%M:%S" + ("Z" if whole else ".%fZ"))
    for c in list(df.columns):
        if c == "timestamp":
            continue
        v = df[c]
        if v.isna().all():
            df = df.drop(columns=c)
        elif pd.api.types.is_float_dtype(v):
            x = v.dropna().to_numpy()
            if np.all(x == np.round(x)) and np.all(np.abs(x) < 2**53):
                df[c] = v.astype("Int64")
    text = df.to_csv(index=False, lineterminator="\n")
    buf = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=buf, mtime=0, compresslevel=9) as gz:
        gz.write(text.encode())
    return buf.getvalue()


def write(part: pd.DataFrame, category: str, kind: str, name: str, source: str) -> Piece:
    """Write one piece and return its manifest entry."""
    data = csv_bytes(part)
    out = HERE / category / f"{name}.csv.gz"
    out.parent.mkdir(exist_ok=True)
    out.write_bytes(data)
    gs = part["groundspeed"].to_numpy(float) * KT if "groundspeed" in part else np.array([])
    gs = gs[np.isfinite(gs)]
    calls = part["callsign"].dropna() if "callsign" in part else pd.Series([], dtype=str)
    t = part["_t"]
    return Piece(
        name=name,
        category=category,
        kind=kind,
        source=source,
        icao24=str(part["icao24"].iloc[0]),
        callsign=str(calls.mode().iloc[0]).strip() if len(calls) else None,
        rows=len(part),
        start=t.min().strftime("%Y-%m-%dT%H:%M:%SZ"),
        duration_s=float((t.max() - t.min()).total_seconds()),
        gs_p995_m_s=round(float(np.percentile(gs, 99.5)), 3) if gs.size else None,
        file_bytes=len(data),
    )


def piece_name(stem: str, icao: str, k: int, n_aircraft: int, n_pieces: int) -> str:
    """``stem``, ``_icao24`` where the file holds several aircraft, ``_k`` where it was split."""
    name = stem if n_aircraft == 1 else f"{stem}_{icao}"
    return name if n_pieces == 1 else f"{name}_{k:02d}"


def main() -> None:
    """Rewrite every piece and the manifest."""
    print(f"traffic {traffic.__version__}, pandas {pd.__version__}")
    for sub in (*CATEGORIES, *COLLECTIONS):
        if (HERE / sub).is_dir():
            shutil.rmtree(HERE / sub)
    entries: list[Piece] = []
    for category in CATEGORIES:
        for path in sorted((SAMPLES / category).glob("*.json.gz")):
            df = read_sample(path)
            parts = pieces(df)
            n_ac = df["icao24"].nunique()
            per_ac = {icao: sum(p[0] == icao for p in parts) for icao, _, _ in parts}
            for icao, k, part in parts:
                if fixes(part) < MIN_FIXES:
                    continue
                name = piece_name(path.name[:-8], icao, k, n_ac, per_ac[icao])
                src = f"{category}/{path.name}"
                entries.append(write(part, category, "sample", name, src))
        print(f"{category}: {sum(e.category == category for e in entries)} pieces")
    pool = []
    for coll in COLLECTIONS:
        path = SAMPLES / "collections" / f"{coll}.json.gz"
        df = read_sample(path)
        parts = pieces(df)
        per_ac = {icao: sum(p[0] == icao for p in parts) for icao, _, _ in parts}
        for icao, k, part in parts:
            if fixes(part) >= MIN_FIXES:
                name = piece_name(coll, icao, k, 2, per_ac[icao])
                pool.append((coll, name, part))
    drawn = np.sort(np.random.default_rng(SEED).choice(len(pool), N_DRAWN, replace=False))
    print(f"collections: {len(pool)} pieces, {N_DRAWN} drawn")
    for i in drawn:
        coll, name, part = pool[int(i)]
        entries.append(write(part, coll, "collection", name, f"collections/{coll}.json.gz"))
    manifest = {
        "traffic": traffic.__version__,
        "gap_s": GAP_S,
        "min_fixes": MIN_FIXES,
        "seed": SEED,
        "pieces": [asdict(e) for e in entries],
    }
    (HERE / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    total = sum(e.file_bytes for e in entries)
    print(f"{len(entries)} pieces, {sum(e.rows for e in entries)} rows, {total / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
