"""Every option of every sub-command is honoured or refused, never silently ignored (issue 15).

The walk is table-driven. :data:`OPTIONS` maps each ``(sub-command, option)`` of the parser
built by :func:`fieldmap.cli.build_parser` (nested ones too: ``imu allan``; the choices of
``cache info|clear``) to one or more cases ``(context, extra arguments, expectation)``; a context
is a tiny run (:data:`CONTEXTS`: a 30° map of degree 10, a 10 s flight, a 2 s table1...). The
expectations:

``CHANGES``
    the context run with and without the extra arguments gives different results (exit status,
    stdout, and the files written: JSON and NetCDF contents, file names), timings masked;
``NEUTRAL``
    for options whose promise is to leave the numbers alone (``--device cpu``,
    ``--scheduler threads``, ``--rows-per-block``, ``--no-cache`` with the bundled model):
    the same results (what may differ, such as the "block by block" line of a streamed map, is
    named in the case);
``REFUSED``
    exit status 2, exactly one line on stderr naming the option, nothing on stdout, nothing
    written (neither ``--out`` nor anything in the working folder);
``OUT``
    the files appear in the ``--out`` folder, the same ones as in ``outputs/`` without it;
``ALIAS``
    a hidden spelling (``--truth``) gives what the option it stands for gives;
``GAP``
    an option silently ignored today in a file outside this change: skipped with the file that
    will fix it (the skip says so; remove the entry's ``GAP`` when it is fixed);

and a few checks of their own (``--no-cache``, ``cache info|clear``, ``--version``). Every
parser's ``-h/--help`` is checked by :func:`test_help`. :func:`test_table_covers_every_option`
fails for an option without an entry (or an entry without an option), so a new option must say
what it does here. :func:`test_context_is_reproducible` runs each context twice: what
``CHANGES`` compares is no run-to-run noise.

Everything runs in this process (``fieldmap.cli.main``), each run in a fresh working folder
holding the fixture files; a context's reference run is made once per session. Figures are built
but not rendered to PNG (their file names are compared; rendering is the product tests' job and
took two thirds of the time).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import re
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from fieldmap import cli

ROUTE = "45,7,3000;45.1,7.1,3000"


# ----------------------------------------------------------------------------------- fixtures
def _gfc(lmax: int, seed: int) -> str:
    """Return a Kaula-rule model as ICGEM text (an Earth's GM and radius)."""
    from fieldmap.models.registry import kaula_model

    m = kaula_model(lmax, seed=seed)
    lines = [
        "begin_of_head",
        f"modelname kaula{seed}",
        f"earth_gravity_constant {float(m.gm)!r}",
        f"radius {float(m.radius)!r}",
        f"max_degree {lmax}",
        "norm fully_normalized",
        "errors no",
        "end_of_head",
    ]
    for n in range(lmax + 1):
        for k in range(n + 1):
            lines.append(f"gfc {n} {k} {float(m.C[n, k])!r} {float(m.S[n, k])!r}")
    return "\n".join(lines) + "\n"


def _flight_csv() -> str:
    """Return a straight 30 s flight at 200 m/s, one sample a second."""
    t = np.arange(31.0)
    lat = 45 + np.degrees(200.0 * t / 6.4e6)
    rows = ["time_s,lat_deg,lon_deg,height_m"]
    rows += [f"{a:.17g},{b:.17g},7.0,3000.0" for a, b in zip(t, lat)]
    return "\n".join(rows) + "\n"


def _traffic_csv() -> str:
    """Return an ADS-B log in the traffic library's layout: 20 s of taxi, a climb, a 40 s gap."""
    t = np.arange(150.0)
    speed = np.where(t < 20, 10.0, np.minimum(10.0 + 4.0 * (t - 20), 150.0))
    lat = 45 + np.degrees(np.cumsum(speed) / 6.4e6)
    alt_ft = np.where(t < 30, 1000.0, 1000.0 + 25.0 * np.round(20.0 * (t - 30) / 25.0))
    rows = ["timestamp,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    # the aircraft's own velocities, as the positions fly them (north; kt, ft/min): zeros
    # would contradict the positions, and the log be refused (issue 26)
    gs_kt = speed * 3600.0 / 1852.0
    vr_fpm = np.where(t < 30, 0.0, 1200.0)
    rows += [
        f"2024-05-01T10:{int(s) // 60:02d}:{int(s) % 60:02d}Z,{a:.6f},7.0,{h:.0f},{g:.0f},0,{v:.0f}"
        for s, a, h, g, v in zip(t, lat, alt_ft, gs_kt, vr_fpm)
        if not 80 <= s < 120
    ]
    return "\n".join(rows) + "\n"


@pytest.fixture(scope="module")
def fixtures(tmp_path_factory) -> Path:
    """Folder of the files the contexts name (copied into each run's working folder)."""
    root = tmp_path_factory.mktemp("option-walk-fixtures")
    (root / "kaula.gfc").write_text(_gfc(12, 1))
    (root / "models").mkdir()
    (root / "models" / "kaula.gfc").write_text(_gfc(12, 2))  # another model, same name
    (root / "flight.csv").write_text(_flight_csv())
    (root / "adsb.csv").write_text(_traffic_csv())
    (root / "pts.txt").write_text("-30 100 500\n")
    from fieldmap.models.registry import load_model
    from fieldmap.products.tables.build import build_table
    from fieldmap.products.tables.files import binary_bytes

    m20 = load_model("eigen-6s", lmax=20)
    tab, _ = build_table((19.5, 20.5, 9.5, 10.5), (0, 10), 5.0, model=m20, check_points=10)
    (root / "table.bin").write_bytes(binary_bytes(tab))
    return root


@pytest.fixture(autouse=True)
def _cache_switch_restored():
    """``--no-cache`` switches the parsed-model cache off for the process: switch it back."""
    from fieldmap.models import cache

    before = cache._disabled
    yield
    cache._disabled = before


@pytest.fixture(autouse=True)
def _no_rendering(monkeypatch):
    """Write each PNG as a placeholder: the figure is made, not rendered."""
    import matplotlib.pyplot as plt

    from fieldmap.products import io as products_io

    def placeholder(fig, tmp, dpi):
        plt.close(fig)
        Path(tmp).write_bytes(b"png")

    monkeypatch.setattr(products_io, "_png_to", placeholder)


# ------------------------------------------------------------------------------------ running
@dataclass
class Run:
    """One run of the CLI: exit status, stdout, stderr, folders, the files it wrote."""

    rc: int
    out: str
    err: str
    cwd: Path
    outdir: Path | None
    files: dict = field(default_factory=dict)  # name -> normalised content


class _Stdin(io.StringIO):
    def __init__(self, text: str):
        super().__init__(text)
        self.buffer = io.BytesIO(text.encode())


_counter = [0]


def _workdir(fixtures: Path, tmp: Path) -> Path:
    _counter[0] += 1
    cwd = tmp / f"run{_counter[0]}"
    shutil.copytree(fixtures, cwd)
    return cwd


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def invoke(argv, stdin, fixtures, tmp, monkeypatch) -> Run:
    """Run ``fieldmap ARGV`` in this process from a fresh working folder; snapshot its output."""
    cwd = _workdir(fixtures, tmp)
    outdir = cwd / "out"
    argv = [a.replace("{out}", str(outdir)) for a in argv]
    before = _tree(cwd)
    out, err = io.StringIO(), io.StringIO()
    with monkeypatch.context() as m:
        m.chdir(cwd)
        m.setattr(sys, "stdin", _Stdin(stdin or ""))
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = cli.main(argv)
            except SystemExit as exc:  # argparse: --help, --version, bad values
                rc = exc.code
    run = Run(rc, out.getvalue(), err.getvalue(), cwd, outdir)
    new = sorted(_tree(cwd) - before)
    run.files = {
        name: _content(cwd / name)
        for name in new
        if not any(name.startswith(p + "/") for p in new if p.endswith(".zarr"))
    }
    return run


#: keys of the JSON documents (and of the JSON in NetCDF attributes) holding wall-clock times
VOLATILE = {
    "gravity_eval_seconds", "synthesis_seconds", "propagation_seconds", "gravity_budget_seconds",
    "elapsed_s",
}  # fmt: skip


def _mask(doc):
    if isinstance(doc, dict):
        return {
            k: ("<seconds>" if k in VOLATILE and v is not None else _mask(v))
            for k, v in doc.items()
        }
    if isinstance(doc, list):
        return [_mask(v) for v in doc]
    return doc


def _attr(v):
    if isinstance(v, str) and v.startswith("{"):
        try:
            return _mask(json.loads(v))
        except ValueError:
            return v
    return np.asarray(v).tolist()


def _dataset(ds) -> dict:
    def digest(a):
        a = np.ascontiguousarray(a.values)
        if a.dtype.kind in "OUS":
            return a.tolist()
        return (str(a.dtype), a.shape, hashlib.sha256(a.tobytes()).hexdigest())

    return {
        "vars": {k: (v.dims, digest(v)) for k, v in ds.variables.items()},
        "attrs": {k: _attr(v) for k, v in ds.attrs.items() if k not in ("history",)},
    }


def _content(path: Path):
    """Return what a written file says (not its bytes: no timings, no dates)."""
    import xarray as xr

    if path.is_dir():
        if path.suffix == ".zarr":
            with xr.open_zarr(path) as ds:
                return ("zarr", _dataset(ds))
        return "<dir>"
    if path.suffix == ".json":
        return ("json", _mask(json.loads(path.read_text())))
    if path.suffix == ".nc":
        with xr.open_dataset(path) as ds:
            return ("nc", _dataset(ds.load()))
    if path.suffix == ".csv":
        return ("csv", _csv_mask(path.read_text()))
    if path.suffix == ".png":
        return "<png>"  # drawn from the data compared above
    return ("bytes", hashlib.sha256(path.read_bytes()).hexdigest())


def _csv_mask(text: str) -> str:
    lines = text.splitlines()
    if not lines:
        return text
    head = lines[0].split(",")
    cols = [i for i, h in enumerate(head) if h in VOLATILE]
    if not cols:
        return text
    out = [lines[0]]
    for line in lines[1:]:
        cells = line.split(",")
        for i in cols:
            if i < len(cells) and cells[i] not in ("", "-"):
                cells[i] = "<seconds>"
        out.append(",".join(cells))
    return "\n".join(out)


_TIME = re.compile(r"\b\d+(\.\d+)? s\b")
_VERIFY_MS = re.compile(r"\s+\S+\s+\S+\s+(ok|FAIL|skipped)\s*$", re.M)
_EVAL_S = re.compile(r"\d\.\d\de[+-]\d\d$", re.M)  # table1's last column: CPU seconds


def _stdout(run: Run, kind: str) -> str:
    text = run.out.replace(str(run.cwd), "<cwd>")
    text = "\n".join(ln for ln in text.splitlines() if not ln.startswith("Module "))  # Warp
    if kind == "verify":
        return _VERIFY_MS.sub(r"  <ms> <ms>  \1", text)
    if kind == "timed":
        text = _EVAL_S.sub("<seconds>", text)
    return _TIME.sub("<t> s", text)


def result(run: Run, kind: str) -> dict:
    """Return the comparable result of a run: exit status, normalised stdout, written files."""
    return {"rc": run.rc, "stdout": _stdout(run, kind), "files": run.files}


# ----------------------------------------------------------------------------------- contexts
@dataclass(frozen=True)
class Context:
    """A tiny run: its arguments, its stdin, how its stdout is normalised."""

    argv: tuple
    stdin: str | None = None
    kind: str = "plain"  # stdout normaliser


def _ctx(*argv, stdin=None, kind="plain") -> Context:
    return Context(tuple(argv), stdin, kind)


_MAP = ("--lmax", "10", "--step-deg", "30")
_REGION = ("--lmax", "10", "--step-deg", "10", "--region", "0", "40", "-20", "20")
_OUT = ("--out", "{out}")
_FLIGHT = ("--duration", "10", "--rate", "20", "--lmax", "10", "--models", "j2",
           "--output-dt", "1")  # fmt: skip
_STUDY = ("--duration", "2", "--rate", "20", "--output-dt", "1")
_POINT = "10 20 30\n"
_TABLE = ("--height-km", "0,10", "--max-error-mgal", "2")
_EWH = ("--quantity", "ewh", "--epoch", "2012", "--minus", "eigen-6s")

CONTEXTS = {
    "point": _ctx("point", stdin=_POINT),
    "point-normal": _ctx("point", "--quantity", "normal", stdin=_POINT),
    "point-sigma": _ctx("point", "--quantity", "disturbance-sigma", "--lmax", "20", stdin=_POINT),
    "point-file": _ctx("point", "--model", "kaula.gfc", stdin=_POINT),
    "verify": _ctx("verify", "--lmax", "4", "--points", "5", kind="verify"),
    "map": _ctx("map", *_MAP, "--no-plots", *_OUT),
    "map-plots": _ctx("map", *_MAP, *_OUT),
    "map-region": _ctx("map", *_REGION, "--no-plots", *_OUT),
    "map-anomaly": _ctx("map", *_MAP, "--quantity", "anomaly", "--no-plots", *_OUT),
    "map-geoid": _ctx("map", *_MAP, "--quantity", "geoid", "--no-plots", *_OUT),
    "sweep": _ctx("sweep", *_MAP, "--height-km", "20,50", "--no-plots", *_OUT),
    "sweep-geoid": _ctx("sweep", *_MAP, "--quantity", "geoid", "--no-plots", *_OUT),
    "map-omission": _ctx("map", *_MAP, "--quantity", "omission-sigma", "--no-plots", *_OUT),
    "sweep-omission": _ctx(
        "sweep", *_MAP, "--height-km", "20,50", "--quantity", "omission-sigma", "--no-plots", *_OUT
    ),
    "sweep-plots": _ctx("sweep", *_MAP, "--height-km", "20,50", *_OUT),
    "map-ewh": _ctx("map", *_MAP, *_EWH, "--no-plots", *_OUT),
    "sweep-ewh": _ctx("sweep", *_MAP, *_EWH, "--no-plots", *_OUT),
    "point-ewh": _ctx("point", "--lmax", "10", *_EWH, stdin="10 20 0\n"),
    "sweep-region": _ctx("sweep", *_REGION, "--height-km", "20,50", "--no-plots", *_OUT),
    "sweep-anomaly": _ctx(
        "sweep", *_MAP, "--height-km", "20,50", "--quantity", "anomaly", "--no-plots", *_OUT
    ),
    "truncation": _ctx("truncation", "--step-deg", "30", "--no-plots", *_OUT),
    "truncation-plots": _ctx("truncation", "--step-deg", "30", *_OUT),
    "truncation-region": _ctx("truncation", *_REGION[2:], "--no-plots", *_OUT),
    "truncation-degrees": _ctx(
        "truncation", "--degrees", "4,8", "--lmax", "10", "--step-deg", "30", "--no-plots", *_OUT
    ),
    "flight": _ctx("navsim", "--route", ROUTE, "--speed-mps", "200", *_FLIGHT, *_OUT),
    "flight-imu": _ctx(
        "navsim",
        "--route",
        ROUTE,
        "--speed-mps",
        "200",
        *_FLIGHT,
        "--imu",
        "tactical",
        "--draws",
        "2",
        *_OUT,
    ),  # fmt: skip
    "flight-file": _ctx("navsim", "--trajectory", "flight.csv", *_FLIGHT, *_OUT),
    "flight-log": _ctx("navsim", "--trajectory", "adsb.csv", *_FLIGHT, *_OUT),
    "flight-sh": _ctx(
        "navsim",
        "--route",
        ROUTE,
        "--speed-mps",
        "200",
        *_FLIGHT[:-4],
        "--models",
        "sh8",
        "--output-dt",
        "1",
        *_OUT,
    ),  # fmt: skip
    # table1 (the default study) with the options it uses; timings off: they are noise
    "table1": _ctx("navsim", *_STUDY, "--lmax", "10", "--models", "j2", "--no-timing", *_OUT),
    "table1-timed": _ctx("navsim", *_STUDY, "--lmax", "10", "--models", "j2", *_OUT, kind="timed"),
    # only options every study takes: the default models need a truth of degree 200
    "table3": _ctx("navsim", "--study", "table3", *_STUDY, "--lmax", "200", "--draws", "2", *_OUT),
    "point-table": _ctx("point", "--model", "table:table.bin", stdin=_POINT),
    "table": _ctx("table", *_TABLE, "--region", "5", "6", "40", "41", *_OUT),
    "table-corridor": _ctx("table", *_TABLE, "--corridor", "flight.csv", "--width-km", "20", *_OUT),
    "allan": _ctx("imu", "allan", "--duration", "20", "--rate", "10", *_OUT),
    "allan-ideal": _ctx(
        "imu", "allan", "--imu", "ideal", "--duration", "20", "--rate", "10", *_OUT
    ),
}


# ------------------------------------------------------------------------------- expectations
CHANGES, NEUTRAL, REFUSED, OUT, ALIAS, GAP = "changes", "neutral", "refused", "out", "alias", "gap"
NO_CACHE, CACHE, VERSION, CATALOGUE = "no-cache", "cache", "version", "catalogue"


@dataclass(frozen=True)
class Case:
    """An expectation of one option in one context (see the module docstring)."""

    context: str
    args: tuple = ()
    expect: str = CHANGES
    note: str = ""  # REFUSED: text the line must hold besides the option; ALIAS: the option
    # NEUTRAL: parts of the result that may differ ("stdout", a JSON key)
    ignore: tuple = ()


def C(context, *args, expect=CHANGES, note="", ignore=()) -> Case:
    return Case(context, tuple(args), expect, note, tuple(ignore))


def _maps(cmd: str, height: tuple) -> dict:
    """Return the cases of ``map`` and ``sweep`` (the same options)."""
    ctx, plots, region, anomaly = cmd, f"{cmd}-plots", f"{cmd}-region", f"{cmd}-anomaly"
    return {
        "--model": [C(ctx, "--model", "kaula.gfc")],
        "--lmax": [C(ctx, "--lmax", "8")],
        "--epoch": [C(ctx, "--epoch", "2030")],
        "--model-dir": [C(ctx, "--model-dir", "models", expect=REFUSED, note="bundled")],
        "--gm": [C(ctx, "--gm", "3.986e14", expect=REFUSED)],
        "--radius": [C(ctx, "--radius", "6378137", expect=REFUSED)],
        "--no-cache": [C(ctx, "--no-cache", expect=NEUTRAL)],
        "--tide-system": [
            C(ctx, "--tide-system", "zero_tide"),
            C(
                ctx,
                "--tide-system",
                "zero_tide",
                "--model",
                "kaula.gfc",
                expect=REFUSED,
                note="unknown",
            ),
        ],
        "--quantity": [C(ctx, "--quantity", "anomaly")],
        "--step-deg": [C(ctx, "--step-deg", "45")],
        "--lat-max": [
            C(ctx, "--lat-max", "50"),
            C(region, "--lat-max", "50", expect=REFUSED, note="--region"),
        ],
        "--region": [C(ctx, "--region", "0", "60", "-30", "30")],
        "--ellipsoid": [C(ctx, "--ellipsoid", "GRS80")],
        "--device": [C(ctx, "--device", "cpu", expect=NEUTRAL)],
        "--out": [C(ctx, expect=OUT)],
        "--no-plots": [C(plots, "--no-plots")],
        "--float32": [C(ctx, "--float32")],
        "--height-km": [
            C(ctx, "--height-km", *height),
            C(f"{cmd}-geoid", "--height-km", "30", expect=REFUSED, note="surface"),
        ],
        "--thresholds-mg": [
            C(ctx, "--thresholds-mg", "0.03"),
            C(anomaly, "--thresholds-mg", "0.03", expect=REFUSED),
        ],
        # the streamed product: the same numbers; its JSON names the product file, its report
        # says "block by block"
        "--scheduler": [
            C(ctx, "--scheduler", "threads", expect=NEUTRAL, ignore=("stdout", "product_path"))
        ],
        "--format": [C(ctx, "--format", "zarr")],
        "--rows-per-block": [C(ctx, "--rows-per-block", "1", expect=NEUTRAL)],
        "--percentile-method": [
            C(ctx, "--percentile-method", "exact"),
            C(anomaly, "--percentile-method", "exact", expect=REFUSED, note="--quantity"),
        ],
        "--omission-model": [
            C(f"{cmd}-omission", "--omission-model", "kaula"),
            C(ctx, "--omission-model", "kaula", expect=REFUSED, note="--quantity omission-sigma"),
        ],
        "--minus": [
            C(f"{cmd}-ewh", "--minus", "kaula.gfc"),
            C(ctx, "--minus", "eigen-6s", expect=REFUSED, note="--quantity ewh"),
        ],
    }


OPTIONS: dict[tuple[str, str], list[Case]] = {
    ("", "--version"): [C("point", expect=VERSION)],
    # ------------------------------------------------------------------------------ point
    ("point", "--quantity"): [C("point", "--quantity", "gravity")],
    ("point", "--normal"): [
        C("point-normal", "--normal", "j2"),
        C("point", "--normal", "j2", expect=REFUSED, note="--quantity normal"),
    ],
    ("point", "--model"): [
        C("point", "--model", "kaula.gfc"),
        C("point", "--model", "table:table.bin"),
        C("point-table", "--quantity", "gravity", expect=REFUSED, note="table:FILE"),
    ],
    ("point", "--model-dir"): [
        C("point-file", "--model-dir", "models"),
        C("point", "--model-dir", "models", expect=REFUSED, note="bundled"),
    ],
    ("point", "--gm"): [C("point", "--gm", "3.986e14", expect=REFUSED, note="NGA")],
    ("point", "--radius"): [C("point", "--radius", "6378137", expect=REFUSED, note="NGA")],
    ("point", "--no-cache"): [
        C("point-file", "--no-cache", expect=NO_CACHE),
        C("point-normal", "--no-cache", expect=REFUSED, note="--quantity normal"),
    ],
    ("point", "--lmax"): [
        C("point", "--lmax", "10"),
        C("point-table", "--lmax", "10", expect=REFUSED, note="table:FILE"),
        C("point-normal", "--lmax", "10", expect=REFUSED, note="--quantity normal"),
    ],
    ("point", "--epoch"): [
        C("point", "--epoch", "2030"),
        C("point-sigma", "--epoch", "2030", expect=REFUSED, note="sigma"),
    ],
    ("point", "--device"): [
        C("point", "--device", "cpu", expect=NEUTRAL),
        C("point-table", "--device", "cpu", expect=REFUSED, note="table:FILE"),
        C("point-sigma", "--device", "cpu", expect=REFUSED, note="sigma"),
    ],
    ("point", "--tide-system"): [
        C("point", "--tide-system", "mean_tide"),
        C("point-file", "--tide-system", "mean_tide", expect=REFUSED, note="unknown"),
        C("point-table", "--tide-system", "mean_tide", expect=REFUSED, note="table:FILE"),
        C("point-normal", "--tide-system", "mean_tide", expect=REFUSED, note="--quantity normal"),
    ],
    ("point", "--precision"): [C("point", "--precision", "6")],
    ("point", "--minus"): [
        C("point-ewh", "--minus", "kaula.gfc"),
        C("point", "--minus", "eigen-6s", expect=REFUSED, note="--quantity ewh"),
    ],
    ("point", "--input"): [C("point", "--input", "pts.txt")],
    # ----------------------------------------------------------------------------- verify
    ("verify", "--device"): [C("verify", "--device", "cpu", expect=NEUTRAL)],
    ("verify", "--lmax"): [C("verify", "--lmax", "6")],
    ("verify", "--points"): [C("verify", "--points", "6")],
    # ------------------------------------------------------------------------------ cache
    ("cache", "info"): [C("point-file", expect=CACHE)],
    ("cache", "clear"): [C("point-file", expect=CACHE)],
    ("cache", "models"): [C("point", expect=CATALOGUE)],
    ("cache", "fetch"): [C("point", expect=CATALOGUE)],
    ("cache", "name"): [C("point", expect=CATALOGUE)],
    # ------------------------------------------------------------------------- map, sweep
    **{("map", k): v for k, v in _maps("map", ("30",)).items()},
    **{("sweep", k): v for k, v in _maps("sweep", ("20,30",)).items()},
    # ------------------------------------------------------------------------- truncation
    ("truncation", "--step-deg"): [C("truncation", "--step-deg", "45")],
    ("truncation", "--lat-max"): [
        C("truncation", "--lat-max", "50"),
        C("truncation-region", "--lat-max", "50", expect=REFUSED, note="--region"),
    ],
    ("truncation", "--region"): [C("truncation", "--region", "0", "60", "-30", "30")],
    ("truncation", "--ellipsoid"): [C("truncation", "--ellipsoid", "GRS80")],
    ("truncation", "--device"): [C("truncation", "--device", "cpu", expect=NEUTRAL)],
    ("truncation", "--out"): [C("truncation", expect=OUT)],
    ("truncation", "--no-plots"): [C("truncation-plots", "--no-plots")],
    ("truncation", "--float32"): [C("truncation", "--float32")],
    ("truncation", "--height-km"): [C("truncation", "--height-km", "30")],
    ("truncation", "--orders"): [C("truncation", "--orders", "2")],
    ("truncation", "--scheduler"): [
        C("truncation", "--scheduler", "threads", expect=NEUTRAL),
        C("truncation-degrees", "--scheduler", "threads", expect=REFUSED),
    ],
    ("truncation", "--degrees"): [
        C("truncation", "--degrees", "18"),
        C("truncation-degrees", "--degrees", "4"),
        C("truncation-degrees", "--orders", "2", expect=REFUSED, note="--orders"),
    ],
    ("truncation", "--tolerance-mgal"): [
        C("truncation", "--tolerance-mgal", "50", "--lmax", "10"),
        C("truncation-degrees", "--tolerance-mgal", "50"),
        C("truncation-degrees", "--tolerance-mgal", "0", expect=REFUSED),
    ],
    ("truncation", "--model"): [
        C("truncation-degrees", "--model", "kaula.gfc"),
        C("truncation", "--model", "kaula.gfc", expect=REFUSED, note="--degrees"),
    ],
    ("truncation", "--tide-system"): [
        C("truncation-degrees", "--tide-system", "zero_tide"),  # recorded: the numbers stay
        C("truncation", "--tide-system", "zero_tide", expect=REFUSED, note="--degrees"),
    ],
    ("truncation", "--lmax"): [
        C("truncation-degrees", "--lmax", "9"),
        C("truncation", "--lmax", "9", expect=REFUSED, note="--degrees"),
    ],
    # ----------------------------------------------------------------------------- navsim
    ("navsim", "--study"): [
        C("table3", "--study", "table4"),
        C("flight", "--study", "table1", expect=REFUSED, note="flight"),
    ],
    ("navsim", "--trajectory"): [C("table1", "--trajectory", "flight.csv")],
    ("navsim", "--route"): [
        C("flight-file", "--route", ROUTE, expect=REFUSED, note="not both"),
        C("table1", "--route", ROUTE, "--speed-mps", "200"),
    ],
    ("navsim", "--speed-mps"): [
        C("flight", "--speed-mps", "250"),
        C("flight-file", "--speed-mps", "250", expect=REFUSED, note="--route"),
        C("table1", "--speed-mps", "250", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--imu"): [
        C("flight", "--imu", "tactical"),
        C("table1", "--imu", "tactical", expect=REFUSED, note="--study table1"),
    ],
    ("navsim", "--frame"): [
        C("flight", "--frame", "lci"),
        C("table1", "--frame", "lci", expect=REFUSED, note="--study table1"),
    ],
    ("navsim", "--altitude-aiding"): [
        C("flight", "--altitude-aiding", "baro"),
        C("table3", "--altitude-aiding", "none", expect=REFUSED, note="--study table3"),
    ],
    ("navsim", "--fraction"): [
        C("flight", "--fraction", "0.5"),
        C("table1", "--fraction", "0.5", expect=REFUSED, note="--study table1"),
    ],
    ("navsim", "--omission-model"): [
        C("flight", "--omission-model", "kaula"),
        C("flight", "--omission-model", "none"),
        C("table1", "--omission-model", "kaula", expect=REFUSED, note="--study table1"),
    ],
    ("navsim", "--method"): [
        C("flight", "--method", "covariance"),
        C("table1", "--method", "covariance", expect=REFUSED, note="--study table1"),
    ],
    ("navsim", "--commission"): [
        C("flight", "--commission", "off"),
        C("table1", "--commission", "off", expect=REFUSED, note="--study table1"),
    ],
    ("navsim", "--block-s"): [
        C("flight", "--block-s", "3"),
        C("table1", "--block-s", "3", expect=REFUSED, note="--study table1"),
    ],
    ("navsim", "--models"): [
        C("table1", "--models", "j4"),
        C("flight", "--models", "j4"),
        C("table3", "--models", "j4", expect=REFUSED, note="--study table3"),
        C("table3", "--study", "table4", "--models", "j2", expect=REFUSED, note="SH models"),
        C("flight", "--models", "auto"),
        C("flight", "--models", "j4", "table:table.bin", expect=REFUSED, note="does not cover"),
        C("table1", "--models", "table:table.bin", expect=REFUSED, note="flight studies"),
    ],
    ("navsim", "--nav"): [
        C("table3", "--nav", "j2"),
        C("table1", "--nav", "j2", expect=REFUSED, note="--study table1"),
        C("flight", "--nav", "j2", expect=REFUSED, note="flight"),
    ],
    ("navsim", "--draws"): [
        C("table3", "--draws", "3"),
        C("flight-imu", "--draws", "3"),
        C("table1", "--draws", "3", expect=REFUSED, note="--study table1"),
        C("flight", "--draws", "3", expect=REFUSED, note="ideal"),
    ],
    ("navsim", "--seed"): [
        C("table3", "--seed", "1"),
        C("flight-imu", "--seed", "1"),
        C("table1", "--seed", "1", expect=REFUSED, note="--study table1"),
        C("flight", "--seed", "1", expect=REFUSED, note="ideal"),
    ],
    ("navsim", "--bias-mode"): [
        C("table3", "--bias-mode", "sign"),
        C("table1", "--bias-mode", "sign", expect=REFUSED, note="--study table1"),
        C("flight-imu", "--bias-mode", "gauss", expect=REFUSED, note="flight"),
    ],
    ("navsim", "--rate"): [C("table1", "--rate", "10"), C("flight", "--rate", "10")],
    ("navsim", "--gauss"): [C("table1", "--gauss", "2"), C("flight", "--gauss", "2")],
    ("navsim", "--duration"): [C("table1", "--duration", "3"), C("flight", "--duration", "8")],
    ("navsim", "--truth-model"): [
        C("table1", "--truth-model", "kaula.gfc"),
        C("flight", "--truth-model", "kaula.gfc"),
        C("flight", "--truth-model", "j2", expect=REFUSED, note="--models j2"),
    ],
    # the old name of --truth-model, one letter from --models: refused, naming both
    ("navsim", "--model"): [
        C("table1", "--model", "kaula.gfc", expect=REFUSED, note="--truth-model kaula.gfc"),
        C("flight", "--model", "j2", expect=REFUSED, note="--models j2"),
    ],
    ("navsim", "--truth"): [
        C("table1", "--truth", "kaula.gfc", expect=ALIAS, note="--truth-model")
    ],
    ("navsim", "--lmax"): [C("table1", "--lmax", "8"), C("flight", "--lmax", "8")],
    ("navsim", "--tide-system"): [
        C("table1", "--tide-system", "mean_tide"),
        C("flight", "--tide-system", "mean_tide"),
    ],
    ("navsim", "--truth-degree"): [C("table1", "--truth-degree", "8", expect=ALIAS, note="--lmax")],
    ("navsim", "--output-dt"): [C("table1", "--output-dt", "0.5"), C("flight", "--output-dt", "2")],
    ("navsim", "--no-timing"): [
        C("table1-timed", "--no-timing"),
        C("flight", "--no-timing"),
        C("table3", "--no-timing", expect=REFUSED, note="--study table3"),
    ],
    ("navsim", "--device"): [C("table1", "--device", "cpu", expect=NEUTRAL)],
    ("navsim", "--scheduler"): [
        C("table1", "--scheduler", "threads", expect=NEUTRAL),
        C("flight", "--scheduler", "threads", expect=NEUTRAL),
    ],
    ("navsim", "--out"): [C("table1", expect=OUT)],
    ("navsim", "--no-plots"): [C("table1", "--no-plots"), C("flight", "--no-plots")],
    ("navsim", "--columns"): [
        C("flight-log", "--columns", "time=timestamp,lat=latitude,lon=longitude,alt=altitude"),
        C("flight", "--columns", "time=t,lat=a,lon=b,alt=c", expect=REFUSED, note="--route"),
        C("table1", "--columns", "time=t,lat=a,lon=b,alt=c", expect=REFUSED, note="table1"),
    ],
    ("navsim", "--alt-units"): [
        # feet read as metres: the log's own vertical rates (ft/min) contradict the heights
        C("flight-log", "--alt-units", "m", expect=REFUSED, note="vertical rates"),
        C("flight", "--alt-units", "m", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--height-ref"): [
        C("flight-log", "--height-ref", "ellipsoid"),
        C("table1", "--height-ref", "msl", expect=REFUSED, note="table1"),
    ],
    ("navsim", "--time-format"): [
        # the format the log has (ISO 8601): the same flight, as detected
        C("flight-log", "--time-format", "iso", expect=NEUTRAL),
        C("flight", "--time-format", "iso", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--position-noise-m"): [
        C("flight-log", "--position-noise-m", "40,10"),
        C("flight", "--position-noise-m", "5", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--max-gap-s"): [
        C("flight-log", "--max-gap-s", "30"),
        C("flight", "--max-gap-s", "30", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--vehicle"): [
        # a fighter's envelope (9 g, 50 m/s³) instead of the airliner guessed from the log
        C("flight-log", "--vehicle", "fighter"),
        C("flight", "--vehicle", "glider", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--keep-ground"): [
        # the default now (the whole log is flown): a note on stderr says so
        C("flight-log", "--keep-ground", expect=NEUTRAL),
        C("flight-log", "--keep-ground", "--airborne-only", expect=REFUSED, note="give one"),
        C("flight", "--keep-ground", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--airborne-only"): [
        # the fixture's 20 s of taxi trimmed
        C("flight-log", "--airborne-only"),
        C("flight", "--airborne-only", expect=REFUSED, note="--route"),
    ],
    ("navsim", "--ignore-log-velocities"): [
        # the fixture's ADS-B ground speeds and tracks no longer observe the path
        C("flight-log", "--ignore-log-velocities"),
        C("flight", "--ignore-log-velocities", expect=REFUSED, note="--route"),
        C("flight-log", "--no-smooth", "--ignore-log-velocities", expect=REFUSED, note="smooth"),
    ],
    ("navsim", "--no-smooth"): [
        C("flight-file", "--no-smooth"),
        C("flight", "--no-smooth", expect=REFUSED, note="--route"),
        C("table1", "--no-smooth", expect=REFUSED, note="table1"),
    ],
    ("navsim", "--gravity-rate-hz"): [
        C("flight-sh", "--gravity-rate-hz", "full"),
        C("flight", "--gravity-rate-hz", "1", expect=REFUSED, note="SH navigation"),
        C("table1", "--gravity-rate-hz", "1", expect=REFUSED, note="table1"),
    ],
    ("navsim", "--truth-evaluation"): [
        C("flight", "--truth-evaluation", "full"),
        C("table1", "--truth-evaluation", "full", expect=REFUSED, note="table1"),
    ],
    ("navsim", "--gnss-rate"): [
        C("flight-imu", "--gnss-rate", "1"),
        C("flight", "--gnss-rate", "50", expect=REFUSED, note="above the IMU rate"),
        C("table1", "--gnss-rate", "1", expect=REFUSED, note="table1"),
    ],
    ("navsim", "--gnss-sigma"): [
        C("flight-imu", "--gnss-sigma", "3"),
        C("flight", "--gnss-sigma", "0", expect=REFUSED, note="positive"),
    ],
    ("navsim", "--gnss-velocity-sigma"): [
        C("flight-imu", "--gnss-velocity-sigma", "none"),
        C("flight", "--gnss-velocity-sigma", "fast", expect=REFUSED, note="a number"),
    ],
    ("navsim", "--gnss-bias"): [
        C("flight-imu", "--gnss-bias", "1:300"),
        C("flight", "--gnss-bias", "-1", expect=REFUSED, note=">= 0"),
    ],
    ("navsim", "--gnss-outage"): [
        C("flight-imu", "--gnss-outage", "2:3"),
        C("flight", "--gnss-outage", "8:5", expect=REFUSED, note="ends after the flight"),
        C("flight", "--gnss-outage", "1:3,2:3", expect=REFUSED, note="overlap"),
    ],
    # ------------------------------------------------------------------------------ table
    ("table", "--region"): [
        C("table", "--region", "5", "7", "40", "41"),
        C("table-corridor", "--region", "6", "8", "44", "45"),
        C("table-corridor", "--region", "10", "11", "40", "41", expect=REFUSED, note="overlap"),
        C("table", "--region", "5", "6", "41", "40", expect=REFUSED, note="south < north"),
    ],
    ("table", "--height-km"): [
        C("table", "--height-km", "0,5"),
        C("table", "--height-km", "5,5", expect=REFUSED, note="MIN < MAX"),
    ],
    # the deprecated spelling (a note on stderr) gives what --height-km gives
    ("table", "--heights-km"): [
        C("table", "--heights-km", "0,5", expect=ALIAS, note="--height-km")
    ],
    ("table", "--max-error-mgal"): [
        C("table", "--max-error-mgal", "0.5"),
        C("table", "--max-error-mgal", "-1", expect=REFUSED, note="positive"),
    ],
    ("table", "--budget-mb"): [
        C("table", "--budget-mb", "100", expect=NEUTRAL, ignore=("budget_mb",)),
        C("table", "--budget-mb", "0.0001", expect=REFUSED),
    ],
    ("table", "--corridor"): [
        C("table-corridor", "--corridor", "adsb.csv"),
        C("table", "--corridor", "flight.csv", expect=REFUSED, note="overlap"),
    ],
    ("table", "--width-km"): [
        C("table-corridor", "--width-km", "30"),
        C("table", "--width-km", "30", expect=REFUSED, note="--corridor"),
    ],
    ("table", "--model"): [C("table", "--model", "kaula.gfc")],
    ("table", "--lmax"): [C("table", "--lmax", "60")],
    ("table", "--model-dir"): [C("table", "--model-dir", "models", expect=REFUSED, note="bundled")],
    ("table", "--gm"): [C("table", "--gm", "3.986e14", expect=REFUSED)],
    ("table", "--radius"): [C("table", "--radius", "6378137", expect=REFUSED)],
    ("table", "--no-cache"): [C("table", "--no-cache", expect=NEUTRAL)],
    ("table", "--tide-system"): [C("table", "--tide-system", "mean_tide")],
    ("table", "--device"): [C("table", "--device", "cpu", expect=NEUTRAL)],
    ("table", "--out"): [C("table", expect=OUT)],
    # --------------------------------------------------------------------------- imu allan
    ("imu allan", "--imu"): [C("allan", "--imu", "consumer")],
    ("imu allan", "--duration"): [C("allan", "--duration", "30")],
    ("imu allan", "--rate"): [C("allan", "--rate", "20")],
    ("imu allan", "--seed"): [
        C("allan", "--seed", "1"),
        C("allan-ideal", "--seed", "1", expect=REFUSED, note="ideal"),
    ],
    ("imu allan", "--out"): [C("allan", expect=OUT)],
    ("imu allan", "--no-plots"): [C("allan", "--no-plots")],
}


# ---------------------------------------------------------------------------- the parser walk
def parsers(parser=None, path=()):
    """Yield ``(sub-command path, parser)`` for the top-level parser and every sub-parser."""
    parser = parser or cli.build_parser()
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from parsers(sub, (*path, name))


def walk() -> set[tuple[str, str]]:
    """Every ``(sub-command, option)`` of the CLI; a positional's choices stand for options."""
    found = set()
    for path, parser in parsers():
        cmd = " ".join(path)
        for action in parser._actions:
            if isinstance(action, (argparse._SubParsersAction, argparse._HelpAction)):
                continue  # the sub-commands are walked; every --help is test_help's
            if action.option_strings:
                found.add((cmd, max(action.option_strings, key=len)))
            else:
                found.update((cmd, choice) for choice in action.choices or (action.dest,))
    return found


def test_table_covers_every_option():
    """Each option of each sub-command has an entry, and each entry an option."""
    have, table = walk(), set(OPTIONS)
    assert not have - table, f"options without an entry in OPTIONS: {sorted(have - table)}"
    assert not table - have, f"entries of OPTIONS that are no option: {sorted(table - have)}"
    for key, cases in OPTIONS.items():
        assert cases, key
        for case in cases:
            assert case.context in CONTEXTS, (key, case.context)


@pytest.mark.parametrize("path", [p for p, _ in parsers()], ids=lambda p: " ".join(p) or "fieldmap")
def test_help(path, fixtures, tmp_path, monkeypatch):
    """``-h/--help`` of every parser prints its usage and exits 0."""
    for flag in ("-h", "--help"):
        run = invoke([*path, flag], None, fixtures, tmp_path, monkeypatch)
        assert run.rc == 0, run.err
        assert run.out.startswith(f"usage: {' '.join(('fieldmap', *path))}"), run.out[:200]
        assert not run.files


# --------------------------------------------------------------------------------- the cases
_REFERENCE: dict[str, Run] = {}


def reference(name, fixtures, tmp_path, monkeypatch) -> Run:
    """Return the context's run without the option (made once per session)."""
    if name not in _REFERENCE:
        ctx = CONTEXTS[name]
        run = invoke(list(ctx.argv), ctx.stdin, fixtures, tmp_path, monkeypatch)
        assert run.rc == 0, (name, run.err[-2000:])
        _REFERENCE[name] = run
    return _REFERENCE[name]


def _drop(res: dict, keys) -> dict:
    """``res`` without the parts named in ``keys`` (stdout, JSON keys at any depth)."""
    if "stdout" in keys:
        res = {**res, "stdout": None}

    def strip(doc):
        if isinstance(doc, dict):
            return {k: strip(v) for k, v in doc.items() if k not in keys}
        if isinstance(doc, (list, tuple)):
            return type(doc)(strip(v) for v in doc)
        return doc

    return {**res, "files": strip(res["files"])}


CASES = [
    pytest.param(
        key,
        case,
        id=f"{key[0] or 'fieldmap'} {' '.join(case.args) or key[1]} [{case.context}] {case.expect}",
    )
    for key, cases in OPTIONS.items()
    for case in cases
]


def with_args(argv: list[str], args: list[str], alias: str | None = None) -> list[str]:
    """``argv`` then ``args``; an option of ``args`` that ``argv`` already sets replaces it.

    The CLI refuses an option given twice, so the context's own value (``--lmax 4``) makes
    way for the case's (``--lmax 6``): the option and its values (up to the next ``--``
    token) leave ``argv``, as do those of ``alias``, another spelling of the same option.
    """
    if not args or not args[0].startswith("--"):
        return [*argv, *args]
    names = {args[0].split("=")[0], alias}
    out, skip = [], False
    for tok in argv:
        if tok.startswith("--"):
            skip = tok.split("=")[0] in names
            if skip:
                continue
        elif skip:
            continue
        out.append(tok)
    return [*out, *args]


@pytest.mark.parametrize("key, case", CASES)
def test_option(key, case, fixtures, tmp_path, monkeypatch):
    """The option does what the table says in its context."""
    cmd, option = key
    ctx = CONTEXTS[case.context]
    if case.expect == GAP:
        pytest.skip(case.note)
    argv = with_args(ctx.argv, case.args, case.note if case.expect == ALIAS else None)
    if case.expect == REFUSED:
        run = invoke(argv, ctx.stdin, fixtures, tmp_path, monkeypatch)
        lines = run.err.strip().splitlines()
        assert run.rc == 2, (run.rc, run.err[-2000:])
        assert len(lines) == 1, run.err
        assert option in lines[0] and case.note in lines[0], lines[0]
        assert lines[0].startswith(f"fieldmap {argv[0]}: error: "), lines[0]
        assert run.out == "" and not run.files, (run.out, run.files)
        return
    if case.expect in (NO_CACHE, CACHE):
        return _check_cache(case, key, fixtures, tmp_path, monkeypatch)
    if case.expect == CATALOGUE:
        return _check_catalogue(key, fixtures, tmp_path, monkeypatch)
    if case.expect == VERSION:
        from fieldmap import __version__

        run = invoke([option], None, fixtures, tmp_path, monkeypatch)
        assert run.rc == 0 and run.out.strip() == f"fieldmap {__version__}"
        return
    if case.expect == OUT:
        return _check_out(ctx, fixtures, tmp_path, monkeypatch)
    ref = result(reference(case.context, fixtures, tmp_path, monkeypatch), ctx.kind)
    run = invoke(argv, ctx.stdin, fixtures, tmp_path, monkeypatch)
    assert run.rc == 0, run.err[-2000:]
    got = result(run, ctx.kind)
    if case.expect == CHANGES:
        assert got != ref, f"{option} {case.args[1:]} changed nothing in {case.context}"
    elif case.expect == NEUTRAL:
        assert _drop(got, case.ignore) == _drop(ref, case.ignore)
    elif case.expect == ALIAS:
        spelt = with_args(ctx.argv, [case.note, *case.args[1:]], case.args[0])
        want = result(invoke(spelt, ctx.stdin, fixtures, tmp_path, monkeypatch), ctx.kind)
        assert got == want and got != ref
    else:  # pragma: no cover
        raise AssertionError(case.expect)


def _check_out(ctx, fixtures, tmp_path, monkeypatch):
    """``--out DIR``: the files go to DIR, and only there; without it, to ``outputs/``."""
    argv = list(ctx.argv)
    k = argv.index("--out")
    default = invoke(argv[:k] + argv[k + 2 :], ctx.stdin, fixtures, tmp_path, monkeypatch)
    there = invoke(argv, ctx.stdin, fixtures, tmp_path, monkeypatch)
    assert default.rc == there.rc == 0, (default.err[-2000:], there.err[-2000:])
    into = {n.partition("/")[0] for n in default.files}
    assert into == {"outputs"}, sorted(default.files)
    got = sorted(n for n in there.files if n != "out")
    want = sorted("out" + n[len("outputs") :] for n in default.files if n != "outputs")
    assert got == want and len(got) > 0


def _check_cache(case, key, fixtures, tmp_path, monkeypatch):
    """``--no-cache`` reads and writes no cache entry; ``cache info`` lists, ``clear`` empties."""
    from fieldmap.models import cache as disk_cache

    root = tmp_path / "model-cache"
    monkeypatch.setattr(disk_cache, "cache_dir", lambda: str(root))
    monkeypatch.setattr(disk_cache, "_disabled", False)  # --no-cache turns it off for good
    ctx = CONTEXTS[case.context]

    def entries():
        return len(disk_cache.info(str(root)))

    if case.expect == NO_CACHE:
        without = invoke(list(ctx.argv), ctx.stdin, fixtures, tmp_path, monkeypatch)
        assert without.rc == 0 and entries() == 1, without.err
        shutil.rmtree(root)
        run = invoke(with_args(ctx.argv, case.args), ctx.stdin, fixtures, tmp_path, monkeypatch)
        assert run.rc == 0 and entries() == 0, run.err
        assert result(run, ctx.kind) == result(without, ctx.kind)  # the same numbers
        return
    info = invoke(["cache", "info"], None, fixtures, tmp_path, monkeypatch)
    assert info.rc == 0 and info.out.splitlines()[-1].startswith("0 cached models")
    invoke(list(ctx.argv), ctx.stdin, fixtures, tmp_path, monkeypatch)  # one entry
    info = invoke(["cache", "info"], None, fixtures, tmp_path, monkeypatch)
    assert info.rc == 0 and info.out.splitlines()[-1].startswith("1 cached models"), info.out
    if key[1] == "clear":
        run = invoke(["cache", "clear"], None, fixtures, tmp_path, monkeypatch)
        assert run.rc == 0 and run.out.startswith("removed 1 cached models"), run.out
        assert entries() == 0


def _check_catalogue(key, fixtures, tmp_path, monkeypatch):
    """``cache models`` lists the catalogue; ``fetch`` wants a known NAME; NAME is fetch's only."""
    if key[1] == "models":
        run = invoke(["cache", "models"], None, fixtures, tmp_path, monkeypatch)
        assert run.rc == 0 and "EGM2008" in run.out and "GGM05C" in run.out, run.err
        return
    argv = {"fetch": ["cache", "fetch", "EGM2009"], "name": ["cache", "models", "EGM2008"]}
    run = invoke(argv[key[1]], None, fixtures, tmp_path, monkeypatch)
    lines = run.err.strip().splitlines()
    assert run.rc == 2 and len(lines) == 1 and run.out == "" and not run.files, run.err
    assert ("EGM2008" if key[1] == "fetch" else "'fetch'") in lines[0], lines[0]


@pytest.mark.parametrize("name", sorted(CONTEXTS))
def test_context_is_reproducible(name, fixtures, tmp_path, monkeypatch):
    """A context run twice gives the same result: CHANGES compares no noise."""
    ctx = CONTEXTS[name]
    again = invoke(list(ctx.argv), ctx.stdin, fixtures, tmp_path, monkeypatch)
    ref = reference(name, fixtures, tmp_path, monkeypatch)
    assert result(again, ctx.kind) == result(ref, ctx.kind)
