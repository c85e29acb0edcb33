"""The flight corpus by category: how many pieces meet the corpus test's checks (issue 34).

Flies every piece of ``tests/data/corpus/`` (``manifest.json``; ``--category`` and ``--name``
pick a subset) through :func:`fieldmap.nav.logs.load_flight` with the defaults (pressure
altitudes), as ``tests/test_corpus.py`` does, and judges it with the same checks
(:meth:`corpus_checks.CorpusCheck.corpus_reasons`: ground speed within 5 % of what the aircraft
reported when it flew it, or of the log's robust maximum where that is more, specific force
inside the vehicle class's envelope, 95 % of the span flown, 99 % of the fixes' heights within
3σ). It prints, by category, the pieces that meet them, those that fail
only on their heights, those that fail on speed, force or span, those refused (one line of
:class:`~fieldmap.errors.InputError`) and those that raised anything else; then the pieces whose
verdict disagrees with ``known.json`` (the test's list of exceptions) and the time per hour of
log (the wall time of ``load_flight`` summed over the corpus, over the sum of the logs' spans,
with the processes given running side by side).

Usage::

    python benchmarks/corpus_table.py [--jobs 2] [--json OUT.json] [--before OLD.json]
        [--category calibration ...] [--name munich ...] [--positions-only]

``--json`` writes one row per piece (its verdict, reasons, numbers); ``--before`` reads such a
file from an earlier run and prints each cell as ``before → now``. ``--positions-only`` flies
each piece written without its velocity columns (``groundspeed``, ``track``,
``vertical_rate``: positions and altitudes alone, as IGC, GPX and many ADS-B exports come) and
judges it against the piece as it is, whose reported speeds it did not see; ``known.json``
(the exceptions of the test, which flies the pieces whole) is not compared then.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter, defaultdict
from multiprocessing import get_context
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "tests" / "data" / "corpus"
sys.path.insert(0, str(ROOT / "tests"))

#: the verdicts, in the table's column order
VERDICTS = ("meets", "heights", "other", "refused", "error")
HEADINGS = ("meet", "fail only heights", "fail speed, force or span", "refused", "errors")


def fly(piece: dict[str, str], positions: bool = False) -> dict[str, Any]:
    """Fly one piece and judge it; a JSON-ready row (``positions``: ``--positions-only``)."""
    warnings.simplefilter("ignore")
    from corpus_checks import CORPUS_MIN_WITHIN, check_piece, positions_only

    from fieldmap.errors import InputError
    from fieldmap.nav.logs import load_flight

    path = CORPUS / piece["category"] / f"{piece['name']}.csv.gz"
    row: dict[str, Any] = {"name": piece["name"], "category": piece["category"]}
    try:
        with tempfile.TemporaryDirectory() as tmp:
            source = positions_only(path, Path(tmp)) if positions else path
            t0 = time.perf_counter()
            _, cf = load_flight(source, height_ref="pressure")
    except InputError as e:
        return row | {"verdict": "refused", "reasons": [str(e)]}
    except Exception as e:  # noqa: BLE001 - an internal error is a verdict here
        return row | {
            "verdict": "error",
            "reasons": [f"{type(e).__name__}: {e}"],
            "traceback": traceback.format_exc(),
        }
    seconds = time.perf_counter() - t0
    rep = cf.report
    chk = check_piece(
        path,
        cf.samples,
        sigma_h=max(rep["fit"]["sigma_v_m"], 1.0),
        height_time_sigma=rep["fit"]["height_time_sigma_s"],
    )
    reasons = chk.corpus_reasons(envelope=tuple(rep["vehicle"]["load_factor_g"]))
    heights = chk.heights_within < CORPUS_MIN_WITHIN
    verdict = "meets" if not reasons else "heights" if heights and len(reasons) == 1 else "other"
    return row | {
        "verdict": verdict,
        "reasons": reasons,
        "vehicle": rep["vehicle"]["class"],
        "seconds": seconds,
        "span_h": chk.log_span_s / 3600.0,
        "speed_ratio": chk.speed_ratio,
        "speed_ratio_p995": chk.speed_ratio_p995,
        "specific_force_g": [chk.flown.specific_force_min_g, chk.flown.specific_force_max_g],
        "heights_within": chk.heights_within,
        "sigma_h_m": chk.sigma_h_m,
        "height_time_sigma_s": chk.height_time_sigma_s,
        "horizontal_offset_median_m": chk.horizontal_offset_median_m,
        "horizontal_offset_p95_m": chk.horizontal_offset_p95_m,
        "position_sigma_m": rep["channels"]["position"]["noise_sigma"],
    }


def table(rows: list[dict[str, Any]], before: dict[str, dict[str, Any]] | None) -> str:
    """Return the markdown table by category (``before → now`` where an earlier run is given)."""
    now: dict[str, Counter[str]] = defaultdict(Counter)
    old: dict[str, Counter[str]] = defaultdict(Counter)
    for r in rows:
        for cat in (r["category"], "all"):
            now[cat][r["verdict"]] += 1
            now[cat]["pieces"] += 1
            if before is not None and r["name"] in before:
                old[cat][before[r["name"]]["verdict"]] += 1
    cats = sorted(c for c in now if c != "all") + ["all"]
    lines = [
        "| category | pieces | " + " | ".join(HEADINGS) + " |",
        "|---" * (2 + len(HEADINGS)) + "|",
    ]
    for c in cats:
        cells = [
            f"{old[c][v]} → {now[c][v]}" if before is not None else str(now[c][v]) for v in VERDICTS
        ]
        name = f"**{c}**" if c == "all" else c
        lines.append(f"| {name} | {now[c]['pieces']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--json", type=Path, help="write one row per piece to this file")
    ap.add_argument("--before", type=Path, help="an earlier --json file to compare with")
    ap.add_argument("--category", action="append", help="only these categories (repeatable)")
    ap.add_argument("--name", action="append", help="only these pieces (repeatable)")
    ap.add_argument(
        "--positions-only",
        action="store_true",
        help="fly each piece without its velocity columns (judged against the piece)",
    )
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error(f"--jobs must be at least 1, not {args.jobs}")
    pieces = json.loads((CORPUS / "manifest.json").read_text())["pieces"]
    pieces = [
        p
        for p in pieces
        if (not args.category or p["category"] in args.category)
        and (not args.name or p["name"] in args.name)
    ]
    if not pieces:
        print("corpus_table: no corpus piece matches --category/--name", file=sys.stderr)
        return 2
    if args.json is not None and not os.access(args.json.parent, os.W_OK):
        print(f"corpus_table: --json {args.json}: its folder is not writable", file=sys.stderr)
        return 2
    before = None
    if args.before is not None:
        try:
            before = {r["name"]: r for r in json.loads(args.before.read_text())}
        except (OSError, ValueError, KeyError, TypeError) as e:
            print(f"corpus_table: --before {args.before}: {e}", file=sys.stderr)
            return 2
    # the largest logs first, so that the processes finish together
    pieces.sort(key=lambda p: -(CORPUS / p["category"] / f"{p['name']}.csv.gz").stat().st_size)
    flight = functools.partial(fly, positions=args.positions_only)
    if args.jobs == 1:
        rows = [flight(p) for p in pieces]
    else:
        # spawned, not forked: a fork of a process whose thread pools hold locks can hang
        with get_context("spawn").Pool(args.jobs) as pool:
            rows = pool.map(flight, pieces, chunksize=1)
    rows.sort(key=lambda r: (r["category"], r["name"]))
    print(table(rows, before))
    n = len(rows)
    meets = sum(r["verdict"] == "meets" for r in rows)
    print(f"\nmeet the checks: {meets} of {n} ({100.0 * meets / n:.1f} %)")
    known = {} if args.positions_only else json.loads((CORPUS / "known.json").read_text())
    listed_meeting = [r["name"] for r in rows if r["name"] in known and r["verdict"] == "meets"]
    unlisted = [
        r["name"]
        for r in rows
        if r["name"] not in known and r["verdict"] in ("heights", "other", "error")
    ]
    if not args.positions_only:
        print(
            f"in known.json: {sum(r['name'] in known for r in rows)}; of them meeting now: "
            f"{listed_meeting or 'none'}; failing, not listed: {unlisted or 'none'}"
        )
    for r in rows:
        if r["verdict"] == "error":
            print(f"error: {r['category']}/{r['name']}: {r['reasons'][0]}")
    if before is not None:
        changed = [
            f"{r['name']} ({before[r['name']]['verdict']} → {r['verdict']})"
            for r in rows
            if r["name"] in before and before[r["name"]]["verdict"] != r["verdict"]
        ]
        print(f"verdicts changed: {', '.join(changed) or 'none'}")
    flown = [r for r in rows if "seconds" in r]
    hours = sum(r["span_h"] for r in flown)
    if hours > 0:
        seconds = sum(r["seconds"] for r in flown)
        print(
            f"time per hour of log: {seconds / hours:.2f} s ({seconds:.0f} s over "
            f"{hours:.0f} h, {args.jobs} processes)"
        )
    if args.json is not None:
        try:
            args.json.write_text(json.dumps(rows, indent=1) + "\n")
        except OSError as e:
            print(f"corpus_table: --json {args.json}: {e}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
