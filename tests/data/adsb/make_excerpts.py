"""Regenerate the ADS-B excerpts of this folder from an installed ``traffic`` package.

Usage (from the repository root, with ``pip install traffic==2.13`` in the environment)::

    python tests/data/adsb/make_excerpts.py

Each excerpt is one whole sample flight of ``traffic/data/samples/`` (every row, in file order,
nothing smoothed, sorted or removed), reduced to the columns the tests read and written as a
gzip-compressed CSV in the ``traffic`` layout that ``fieldmap.nav.logs.read.read_track``
recognises: ``timestamp`` as ISO 8601 UTC text (the samples hold whole seconds), the numbers as
pandas writes them (shortest round-trip text, so every value reads back bit for bit), an empty
cell for a missing value. The gzip header carries no file name and no time, so a rerun writes
the same bytes.
"""

from __future__ import annotations

import gzip
import io
from pathlib import Path

import pandas as pd
import traffic

#: sample (folder/name under traffic/data/samples, without .json.gz)
SAMPLES = (
    "featured/elal747",  # Boeing 747, 5 h 51 min long-haul, 10 s reporting gaps
    "featured/qantas747",  # Boeing 747, 3 h, 10 s gaps
    "noisy/noisy_landing",  # A320 family, descent and landing at Zurich, baro and geo altitude
    "noisy/noisy_takeoff",  # take-off and climb, an onground column
    "noisy/noisy_time_issue",  # 2 h 21 min, a 116 s gap, stale and jumping positions
    "calibration/munich",  # 4 h 15 min calibration flight around Munich
    "gliders/sisteron",  # glider, 6 h 22 min with a 71 min gap
    "gliders/cevennes",  # glider, 6 h 43 min with a 28 min gap
    "military/inflight_refuelling",  # 2 h 53 min, 1 Hz, racetrack orbits
)
#: the columns kept, when the sample has them (the rest: squawk, origin, alert, roll, TAS, ...)
COLUMNS = (
    "timestamp", "icao24", "callsign", "latitude", "longitude", "altitude", "geoaltitude",
    "groundspeed", "track", "vertical_rate",
)  # fmt: skip

HERE = Path(__file__).parent


def excerpt(name: str) -> bytes:
    """Return the gzip-compressed CSV excerpt of one sample."""
    src = Path(traffic.__file__).parent / "data" / "samples" / f"{name}.json.gz"
    df = pd.read_json(src, dtype={"icao24": str, "callsign": str}, precise_float=True)
    df = df[[c for c in COLUMNS if c in df.columns]].copy()
    df["timestamp"] = pd.to_datetime(df["timestamp"], utc=True).dt.strftime("%Y-%m-%dT%H:%M:%SZ")
    text = df.to_csv(index=False, lineterminator="\n")
    buf = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=buf, mtime=0, compresslevel=9) as gz:
        gz.write(text.encode())
    return buf.getvalue()


def main() -> None:
    """Write every excerpt next to this script."""
    print(f"traffic {traffic.__version__}")
    for name in SAMPLES:
        out = HERE / (name.split("/")[-1] + ".csv.gz")
        out.write_bytes(excerpt(name))
        print(f"{out.name}: {out.stat().st_size} bytes")


if __name__ == "__main__":
    main()
