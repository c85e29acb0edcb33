"""Benchmark: the flight corpus flown by fieldmap and smoothed by ``traffic``'s KalmanSmoother6D.

For each piece of ``tests/data/corpus/`` (``manifest.json``; ``--category`` and ``--limit``
pick a subset) it prints one line: the log's robust maximum ground speed (the 99.5th
percentile of its ``groundspeed`` column), then for each method the largest ground speed,
``x rep`` (the largest ratio of the path's ground speed to what the aircraft reported when it
flew it, the corpus test's speed rule: ``CorpusCheck.speed_ratio``), the specific-force range
of its path, ``off95`` (the 95th percentile over the log's fixes of
their horizontal distance from the path at their stamped times: where the path flies; a
measure, not a rule: where a log's positions carry time errors, part of it is along the
track, the fixes re-timed) and the wall time it took, and fieldmap's verdict by issue 34's
rules: ``clean``, ``suspect`` (ground speed over 1.05 × the log's robust maximum, specific
force outside 0.3..1.8 g, less than 90 % of the log flown; the reasons follow), ``refused``
(an :class:`~fieldmap.errors.InputError`: its one line follows) or ``error`` (any other
exception: its type and message). ``log sf g`` is the load-factor range the log's own
velocities report (ground speed, track and vertical rate differenced over ±10 s; the 0.5th
and 99.5th percentiles) and each method's ``dev`` the 95th percentile of its path's departure
from it, differenced alike (``corpus_checks.force_against_log``): the log reports no specific
force, but it reports the velocities it was flown at. Medians and counts at the end (the
pieces where fieldmap's speed is no further from the reports than traffic's, its specific
force no further from 1 g, and no further from the log's own); ``--csv FILE`` writes every
number.

The two methods, on the same file:

- fieldmap: ``load_flight(path, height_ref="pressure")`` with the default
  :class:`~fieldmap.nav.logs.condition.Conditioning` (reading included in its time).
- traffic: the CSV read with pandas (``read_csv``, the same file), the fixes kept (rows with
  latitude, longitude and altitude: those fieldmap reads), then as ``traffic``'s docs use the
  smoother (``flight.compute_xy(proj).filter(KalmanSmoother6D())``, ``proj`` the Lambert
  conformal projection centred on the flight, ``Flight.projection("lcc")``) and back to
  latitude and longitude (``compute_latlon_from_xy``). The smoother takes the log at its own
  rate: it steps 1 s per row whatever the rate, so on sparse or gappy logs its path flies
  far faster than the log (``--traffic-resample 1s`` resamples first with
  ``Flight.resample("1s")``, as traffic's users often do, so that its step is the rows'
  spacing). Its first row must be complete (a NaN there makes every state NaN): empty
  velocity cells of the first rows are back-filled, later ones left empty (the smoother
  rejects them, as designed); a velocity column the log lacks is made from the log's own
  finite differences (ground speed and track from the projected positions,
  vertical rate from the altitude). Its heights are the smoothed barometric altitude with the
  geoid height fieldmap's reader applies to the same fixes. Reading included in its time.

Both paths are measured with one yardstick, ``tests/corpus_checks.py``: the quintic ECEF spline
through the samples (what :class:`~fieldmap.nav.trajectory.FlightTrajectory` flies); the
traffic path's rows sharing a timestamp are averaged first. ``gs col`` is the largest value of
traffic's own ``groundspeed`` output (its velocity state).

Usage::

    python benchmarks/bench_corpus.py [--category calibration ...] [--name guatemala ...]
        [--limit N] [--csv FILE] [--sigma-h 7.62] [--no-traffic | --no-fieldmap]
        [--traffic-resample 1s]

Needs ``pip install traffic==2.13 "pandas<2.3"`` (not a dependency of fieldmap); without it,
one line and exit status 2.
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
import sys
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "tests" / "data" / "corpus"
sys.path.insert(0, str(ROOT / "tests"))

from corpus_checks import (  # noqa: E402
    FORCE_WINDOW_S,
    SPECIFIC_FORCE_RANGE,
    SPEED_FACTOR,
    PathKinematics,
    check_piece,
    force_against_log,
)

from fieldmap.nav.trajectory import FlightSamples  # noqa: E402

FT, KT = 0.3048, 1852.0 / 3600.0
#: pieces whose real specific force leaves 0.3..1.8 g (issue 34: the parabolic flights reach
#: 0 g at the tops and up to 2.2 g at the pull-ups), with the envelope they are checked against
ENVELOPES = {"zero_gravity": (0.0, 2.2)}


class _Skipped(Exception):
    """fieldmap not run (``--no-fieldmap``)."""


@dataclass
class Row:
    """One piece's numbers (the CSV's columns)."""

    name: str
    category: str
    rows: int
    hours: float
    reported_gs: float | None
    fm_status: str = ""
    fm_reason: str = ""
    fm_gs: float | None = None
    fm_gs_local: float | None = None
    fm_sf_min: float | None = None
    fm_sf_max: float | None = None
    fm_sf_dev: float | None = None
    fm_flown: float | None = None
    fm_heights_within: float | None = None
    fm_worst_dh: float | None = None
    fm_worst_dh_line: int | None = None
    fm_off50: float | None = None
    fm_off95: float | None = None
    fm_s: float | None = None
    tr_status: str = ""
    tr_gs: float | None = None
    tr_gs_col: float | None = None
    tr_gs_local: float | None = None
    tr_sf_min: float | None = None
    tr_sf_max: float | None = None
    tr_sf_dev: float | None = None
    log_sf_min: float | None = None
    log_sf_max: float | None = None
    tr_off50: float | None = None
    tr_off95: float | None = None
    tr_s: float | None = None
    extra: dict = field(default_factory=dict)


def traffic_path(
    path: Path, geoid: tuple[np.ndarray, np.ndarray], resample: str | None = None
) -> tuple[Any, float]:
    """Smooth one piece with KalmanSmoother6D; return ((t, lat, lon, h, gs_col_max, t0), seconds).

    ``t`` from 0 at ``t0`` (the first output row's epoch seconds).

    ``resample`` (``"1s"``): ``Flight.resample`` first (linear interpolation of every column,
    the projected positions included), so that the smoother's 1 s step is the rows' spacing.
    """
    import pandas as pd
    from traffic.algorithms.filters.kalman import KalmanSmoother6D
    from traffic.core import Flight

    t0 = time.perf_counter()
    df = pd.read_csv(path, dtype={"icao24": str, "callsign": str})
    df["timestamp"] = pd.to_datetime(df["timestamp"], utc=True)
    df = df[df["latitude"].notna() & df["longitude"].notna() & df["altitude"].notna()]
    df = df.sort_values("timestamp", kind="stable").reset_index(drop=True)
    flight = Flight(df)
    proj = flight.projection("lcc")
    flight = flight.compute_xy(proj)
    d = flight.data
    ts = (d["timestamp"] - d["timestamp"].iloc[0]).dt.total_seconds().to_numpy()
    with np.errstate(divide="ignore", invalid="ignore"):
        if "groundspeed" not in d or "track" not in d:
            vx = np.gradient(d["x"].to_numpy(), ts)
            vy = np.gradient(d["y"].to_numpy(), ts)
            ok = np.isfinite(vx) & np.isfinite(vy)
            d = d.assign(
                groundspeed=np.where(ok, np.hypot(vx, vy) / KT, np.nan),
                track=np.where(ok, np.degrees(np.arctan2(vx, vy)) % 360.0, np.nan),
            )
        if "vertical_rate" not in d:
            vz = np.gradient(d["altitude"].to_numpy(float), ts) * 60.0
            d = d.assign(vertical_rate=np.where(np.isfinite(vz), vz, np.nan))
    for c in ("groundspeed", "track", "vertical_rate"):
        first = d[c].first_valid_index()
        if first is not None and first > 0:
            d.loc[: first - 1, c] = d.loc[first, c]
    flight = Flight(d)
    if resample:
        flight = flight.resample(resample)
    out = flight.filter(KalmanSmoother6D()).compute_latlon_from_xy(proj).data
    sec = time.perf_counter() - t0
    t = (out["timestamp"] - out["timestamp"].iloc[0]).dt.total_seconds().to_numpy()
    g = pd.DataFrame(
        {
            "t": t,
            "lat": out["latitude"].to_numpy(float),
            "lon": out["longitude"].to_numpy(float),
            "alt": out["altitude"].to_numpy(float) * FT,
        }
    )
    g = g.groupby("t", sort=True).mean().reset_index()
    t_abs = out["timestamp"].iloc[0].timestamp() + g["t"].to_numpy()
    h = g["alt"].to_numpy() + np.interp(t_abs, *geoid)
    gs_col = float(np.nanmax(out["groundspeed"].to_numpy(float))) * KT
    t0_epoch = float(out["timestamp"].iloc[0].timestamp())
    return (g["t"].to_numpy(), g["lat"].to_numpy(), g["lon"].to_numpy(), h, gs_col, t0_epoch), sec


def geoid_of(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(epoch seconds, ellipsoidal height - barometric altitude) of the fixes fieldmap reads."""
    import gzip

    from fieldmap.nav.logs.read import read_track

    log = read_track(path, height_ref="pressure", alt_units="ft")
    with gzip.open(path, "rt") as f:
        rows = list(csv.DictReader(f))
    # the fixes with an altitude of their own (a row without one has no geoid height here)
    has = np.ones(log.t.size, bool) if log.no_height is None else ~log.no_height
    alt = np.array([float(rows[int(n) - 2]["altitude"]) * FT for n in log.lines[has]])
    t, h = log.t[has], log.h[has]
    order = np.argsort(t, kind="stable")
    return t[order], (h - alt)[order]


def run_piece(
    entry: dict,
    sigma_h: float,
    with_traffic: bool,
    with_fieldmap: bool = True,
    resample: str | None = None,
) -> Row:
    """Fly one piece both ways (or one)."""
    from fieldmap.errors import InputError
    from fieldmap.nav.logs import load_flight

    path = CORPUS / entry["category"] / f"{entry['name']}.csv.gz"
    row = Row(
        entry["name"], entry["category"], entry["rows"], entry["duration_s"] / 3600.0,
        entry["gs_p995_m_s"],
    )  # fmt: skip
    t0 = time.perf_counter()
    try:
        if not with_fieldmap:
            raise _Skipped
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, cf = load_flight(path, height_ref="pressure")
        row.fm_s = time.perf_counter() - t0
        c = check_piece(path, cf.samples, sigma_h=sigma_h)
        why = c.suspect(ENVELOPES.get(entry["name"], SPECIFIC_FORCE_RANGE))
        f = c.flown
        row.fm_status, row.fm_reason = ("suspect", "; ".join(why)) if why else ("clean", "")
        row.fm_gs, row.fm_sf_min, row.fm_sf_max = (
            f.max_ground_speed_m_s, f.specific_force_min_g, f.specific_force_max_g,
        )  # fmt: skip
        row.fm_gs_local = c.speed_ratio
        row.fm_flown, row.fm_heights_within = c.flown_fraction, c.heights_within
        row.fm_worst_dh, row.fm_worst_dh_line = c.worst_height_offset_m, c.worst_height_line
        row.fm_off50, row.fm_off95 = c.horizontal_offset_median_m, c.horizontal_offset_p95_m
        fa = force_against_log(path, cf.samples)
        if fa.rows:
            row.fm_sf_dev, row.log_sf_min, row.log_sf_max = (
                fa.departure_p95_g, fa.log_min_g, fa.log_max_g,
            )  # fmt: skip
    except _Skipped:
        row.fm_s = None
    except InputError as exc:
        row.fm_s = time.perf_counter() - t0
        row.fm_status, row.fm_reason = "refused", str(exc).splitlines()[0]
    except Exception as exc:  # noqa: BLE001 - the benchmark counts internal errors
        row.fm_s = time.perf_counter() - t0
        row.fm_status, row.fm_reason = "error", f"{type(exc).__name__}: {exc}".splitlines()[0]
    if with_traffic:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                (t, lat, lon, h, gs_col, t0), row.tr_s = traffic_path(
                    path, geoid_of(path), resample
                )
            samples = FlightSamples(t, lat, lon, h, None, "traffic", np.zeros(t.size, int), t0)
            c = check_piece(path, samples, sigma_h=sigma_h)
            k: PathKinematics = c.flown
            row.tr_status = "ok"
            row.tr_gs, row.tr_gs_col = k.max_ground_speed_m_s, gs_col
            row.tr_gs_local = c.speed_ratio
            row.tr_sf_min, row.tr_sf_max = k.specific_force_min_g, k.specific_force_max_g
            row.tr_off50, row.tr_off95 = c.horizontal_offset_median_m, c.horizontal_offset_p95_m
            fa = force_against_log(path, samples)
            if fa.rows:
                row.tr_sf_dev, row.log_sf_min, row.log_sf_max = (
                    fa.departure_p95_g, fa.log_min_g, fa.log_max_g,
                )  # fmt: skip
        except Exception as exc:  # noqa: BLE001 - a failure of the peer is a result too
            row.tr_status = f"error {type(exc).__name__}: {exc}".splitlines()[0]
    return row


def _f(x: float | None, fmt: str) -> str:
    return "-" if x is None or not np.isfinite(x) else format(x, fmt)


def line(r: Row) -> str:
    """One printed line."""
    fm = (
        f"{_f(r.fm_gs, '6.0f')} {_f(r.fm_gs_local, '5.2f')} "
        f"{_f(r.fm_sf_min, '5.2f')}..{_f(r.fm_sf_max, '<6.2f')} {_f(r.fm_sf_dev, '5.2f')} "
        f"{_f(r.fm_off95, '6.0f')} {_f(r.fm_s, '6.1f')}"
    )
    tr = (
        f"{_f(r.tr_gs, '6.0f')} {_f(r.tr_gs_local, '5.2f')} {_f(r.tr_gs_col, '6.0f')} "
        f"{_f(r.tr_sf_min, '5.2f')}.."
        f"{_f(r.tr_sf_max, '<6.2f')} {_f(r.tr_sf_dev, '5.2f')} "
        f"{_f(r.tr_off95, '6.0f')} {_f(r.tr_s, '6.1f')}"
    )
    tail = f"{r.fm_status}{': ' + r.fm_reason if r.fm_reason else ''}"
    if r.tr_status and r.tr_status != "ok":
        tail += f" | traffic {r.tr_status}"
    head = f"{r.category + '/' + r.name:42s} {r.rows:6d} {r.hours:5.2f}"
    log = f"{_f(r.log_sf_min, '5.2f')}..{_f(r.log_sf_max, '<6.2f')}"
    return f"{head} {_f(r.reported_gs, '6.0f'):>6s} {log} | {fm} | {tr} | {tail}"


def main(argv: list[str] | None = None) -> int:
    """Fly the corpus (or a subset) and print one line per piece, then medians."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--category", action="append", help="only these categories (repeatable)")
    ap.add_argument("--name", action="append", help="only these pieces (repeatable)")
    ap.add_argument("--limit", type=int, help="at most this many pieces")
    ap.add_argument("--csv", type=Path, help="write every number to this CSV file")
    ap.add_argument("--sigma-h", type=float, default=7.62, help="height σ of a fix (m)")
    ap.add_argument("--no-traffic", action="store_true", help="fieldmap only")
    ap.add_argument("--no-fieldmap", action="store_true", help="traffic only")
    ap.add_argument(
        "--traffic-resample",
        metavar="RULE",
        help="resample the log (traffic's Flight.resample, e.g. 1s) before the smoother",
    )
    args = ap.parse_args(argv)
    if not args.no_traffic:
        try:
            import traffic  # noqa: F401
            from traffic.algorithms.filters.kalman import KalmanSmoother6D  # noqa: F401
        except ImportError:
            print('bench_corpus: traffic is not installed (pip install traffic==2.13 "pandas<2.3")')
            return 2
    entries = json.loads((CORPUS / "manifest.json").read_text())["pieces"]
    if args.category:
        entries = [e for e in entries if e["category"] in args.category]
    if args.name:
        entries = [e for e in entries if e["name"] in args.name]
    if args.limit is not None:
        entries = entries[: args.limit]
    print(
        f"{'piece':42s} {'rows':>6s} {'hours':>5s} {'gs995':>6s} {'log sf g':>12s} | "
        f"{'fm gs':>6s} {'x rep':>5s} {'fm sf g':>12s} {'dev':>5s} {'off95':>6s} {'fm s':>6s} | "
        f"{'tr gs':>6s} {'x rep':>5s} {'gs col':>6s} {'tr sf g':>12s} {'dev':>5s} {'off95':>6s} "
        f"{'tr s':>6s} | "
        "fieldmap"
    )
    rows: list[Row] = []
    writer = None
    out = open(args.csv, "w", newline="") if args.csv else None
    try:
        for e in entries:
            r = run_piece(
                e, args.sigma_h, not args.no_traffic, not args.no_fieldmap, args.traffic_resample
            )
            rows.append(r)
            print(line(r), flush=True)
            if out is not None:
                d = {k: v for k, v in vars(r).items() if k != "extra"}
                if writer is None:
                    writer = csv.DictWriter(out, fieldnames=list(d))
                    writer.writeheader()
                writer.writerow(d)
                out.flush()
    finally:
        if out is not None:
            out.close()
    summary(rows)
    return 0


def summary(rows: list[Row]) -> None:
    """Medians and counts."""

    def med(xs: list[float | None]) -> str:
        v = [x for x in xs if x is not None and np.isfinite(x)]
        return f"{statistics.median(v):.3g}" if v else "-"

    n = len(rows)
    states = ("clean", "suspect", "refused", "error")
    counts = {s: sum(r.fm_status == s for r in rows) for s in states}
    print(f"\n{n} pieces: " + ", ".join(f"{v} {k}" for k, v in counts.items()))
    flown = [r for r in rows if r.fm_gs is not None]
    both = [r for r in flown if r.tr_gs is not None]
    fm_ratio = [r.fm_gs / r.reported_gs for r in flown if r.fm_gs and r.reported_gs]
    tr_ratio = [r.tr_gs / r.reported_gs for r in rows if r.tr_gs and r.reported_gs]
    print(f"median ground speed / reported: fieldmap {med(fm_ratio)}, traffic {med(tr_ratio)}")
    paired = [r for r in both if r.fm_gs_local is not None and r.tr_gs_local is not None]
    no_further = sum(r.fm_gs_local <= max(r.tr_gs_local, SPEED_FACTOR) for r in paired)
    print(
        f"ground speed against the reports where it is flown (x rep): fieldmap within "
        f"{SPEED_FACTOR} or no further than traffic on {no_further} of {len(paired)} pieces; "
        f"within {SPEED_FACTOR}: fieldmap {sum(r.fm_gs_local <= SPEED_FACTOR for r in paired)}, "
        f"traffic {sum(r.tr_gs_local <= SPEED_FACTOR for r in paired)}"
    )
    loads = [r for r in both if None not in (r.fm_sf_min, r.fm_sf_max, r.tr_sf_min, r.tr_sf_max)]

    def off_1g(lo: float | None, hi: float | None) -> float:
        assert lo is not None and hi is not None  # (loads has both)
        return max(abs(lo - 1.0), abs(hi - 1.0))

    calmer = sum(
        off_1g(r.fm_sf_min, r.fm_sf_max) <= off_1g(r.tr_sf_min, r.tr_sf_max) for r in loads
    )
    print(
        "specific force: fieldmap's largest departure from 1 g no larger than traffic's on "
        f"{calmer} of {len(loads)} pieces"
    )
    devs = [r for r in both if r.fm_sf_dev is not None and r.tr_sf_dev is not None]
    closer = sum(r.fm_sf_dev <= r.tr_sf_dev for r in devs)
    print(
        "specific force against the log's own velocities (dev: the 95th percentile of "
        f"|n_path - n_log|, both differenced over ±{FORCE_WINDOW_S:.0f} s): fieldmap no further "
        f"than traffic on {closer} of {len(devs)} pieces; median dev (g): fieldmap "
        f"{med([r.fm_sf_dev for r in devs])}, traffic {med([r.tr_sf_dev for r in devs])}"
    )
    print(
        f"median specific force max (g): fieldmap {med([r.fm_sf_max for r in flown])}, "
        f"traffic {med([r.tr_sf_max for r in rows])}; min: fieldmap "
        f"{med([r.fm_sf_min for r in flown])}, traffic {med([r.tr_sf_min for r in rows])}"
    )
    print(
        f"median time per piece (s): fieldmap {med([r.fm_s for r in rows])}, traffic "
        f"{med([r.tr_s for r in rows])}; per hour of log: fieldmap "
        f"{med([r.fm_s / r.hours for r in rows if r.fm_s and r.hours > 0])}, traffic "
        f"{med([r.tr_s / r.hours for r in rows if r.tr_s and r.hours > 0])}"
    )
    print(
        "median horizontal offset from the fixes (m; median, 95th percentile per piece): "
        f"fieldmap {med([r.fm_off50 for r in flown])}, {med([r.fm_off95 for r in flown])}; "
        f"traffic {med([r.tr_off50 for r in rows])}, {med([r.tr_off95 for r in rows])}"
    )
    print(f"pieces flown by both: {len(both)}")


if __name__ == "__main__":
    sys.exit(main())
