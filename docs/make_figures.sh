#!/bin/sh
# The figures of README.md and of the landing page of the docs, made by fieldmap itself:
#   sh docs/make_figures.sh            (from the repository root, after `make map`)
# 1. the global disturbance map at 20 km of `make map` (its isolines PNG);
# 2. the error figure of a short flight study along a two-leg route (navigation-grade IMU).
# The PNGs are reduced to 256 colours (Pillow, installed with matplotlib) to stay small.
set -eu
BIN=${BIN:-.venv/bin}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
"$BIN/fieldmap" map --height-km 20 --step-deg 1 --out "$TMP/map"
"$BIN/fieldmap" navsim --route "47,8,500;48.5,12,11000" --speed-mps 230 --imu navigation \
    --models j2,j4,exact,sh --draws 5 --rate 100 --out "$TMP/flight"
"$BIN/python" - "$TMP" <<'PY'
import sys
from pathlib import Path

from PIL import Image

tmp = Path(sys.argv[1])
for src, dst in (
    (next((tmp / "map").glob("*_isolines.png")), "map_20km.png"),
    (tmp / "flight" / "navsim_flight.png", "flight_errors.png"),
):
    img = Image.open(src).convert("RGB")
    img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(
        Path("docs/_static") / dst, optimize=True
    )
    print("docs/_static/" + dst)
PY
