"""Defects of real flight logs (a fuzzing review of fieldmap.nav.logs.read): each one line or read.

Every variant is built here from one real log, the ADS-B log of a glider over the Alps
(``tests/data/adsb/sisteron.csv.gz``: the ``traffic`` package's ``gliders/sisteron``, 1605 rows
at about 8 s, a late stretch of 6 rows 326 s back at line 505 and gaps of up to 71 min), written
as the CSV it is and as the IGC, NMEA 0183 and GPX file a recorder of that flight would write. A
variant has one defect; the standard it is held to:

- bad input: one :class:`~fieldmap.errors.InputError` line naming the file (and the line, and
  ``param`` where an option is concerned); a non-zero exit of ``fieldmap navsim``;
- a local defect of a real log (one cut, glitched or repeated line): that line dropped and
  named in the notes, the rest read exactly as without it; refused only when nothing is left.
"""

from __future__ import annotations

import csv
import gzip
import subprocess
import sys
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.nav.logs import load_flight
from fieldmap.nav.logs.read import read_track

ADSB = Path(__file__).parent / "data" / "adsb"
FT, KT = 0.3048, 1852.0 / 3600.0
#: the navsim options of a quick run (tests/test_bad_flight_input.py)
FAST = ["--lmax", "20", "--models", "j4", "--rate", "10", "--no-timing"]
#: the GNSS altitude the IGC and NMEA variants give: the pressure altitude + this (m)
GNSS_ABOVE = 52.0


@pytest.fixture(scope="module")
def text() -> str:
    """Return the real log's CSV text (traffic layout; row k on line k + 2)."""
    with gzip.open(ADSB / "sisteron.csv.gz", "rt") as f:
        return f.read()


@pytest.fixture(scope="module")
def rows(text) -> list[dict[str, str]]:
    return list(csv.DictReader(text.splitlines()))


def when(row: dict[str, str], shift: timedelta = timedelta(0)) -> datetime:
    return datetime.fromisoformat(row["timestamp"].replace("Z", "+00:00")) + shift


def write(path: Path, lines: list[str]) -> Path:
    path.write_text("\n".join(lines) + "\n")
    return path


def one_line(exc: pytest.ExceptionInfo) -> str:
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


# --------------------------------------------------------------------------- the formats


def igc_dm(v: float, width: int, hemi: str) -> str:
    """IGC ``DDMMmmm`` (``DDDMMmmm``): degrees, minutes and thousandths, and the hemisphere."""
    d, m = int(abs(v)), round((abs(v) - int(abs(v))) * 60000)
    d, m = (d + 1, 0) if m == 60000 else (d, m)
    return f"{d:0{width}d}{m:05d}{hemi[int(v < 0)]}"


def igc_alt(a: float) -> str:
    a = round(a)
    return f"-{-a:04d}" if a < 0 else f"{a:05d}"


def b_record(row: dict[str, str], shift: timedelta = timedelta(0), gnss: bool = True) -> str:
    press = float(row["altitude"]) * FT
    lat, lon = float(row["latitude"]), float(row["longitude"])
    g = igc_alt(press + GNSS_ABOVE) if gnss else "00000"
    return (
        f"B{when(row, shift):%H%M%S}{igc_dm(lat, 2, 'NS')}{igc_dm(lon, 3, 'EW')}A"
        f"{igc_alt(press)}{g}"
    )


#: IGC header: B record k on line k + 4
IGC_HEAD = ["AXXX001 fieldmap test", "HFDTE230519", "HFALGALTGPS:ELL"]


def igc(rows, shift: timedelta = timedelta(0)) -> list[str]:
    return IGC_HEAD + [b_record(r, shift) for r in rows]


def nmea(body: str) -> str:
    """Return an NMEA 0183 sentence with its checksum: XOR of the bytes between $ and *."""
    cs = 0
    for ch in body:
        cs ^= ord(ch)
    return f"${body}*{cs:02X}"


def nmea_dm(v: float, width: int, hemi: str) -> str:
    d, m = int(abs(v)), round((abs(v) - int(abs(v))) * 60.0, 4)
    d, m = (d + 1, 0.0) if m >= 60.0 else (d, m)
    return f"{d:0{width}d}{m:07.4f},{hemi[int(v < 0)]}"


def nmea_lines(rows, date: str | None = None) -> list[str]:
    """RMC (line 2k + 1) and GGA (line 2k + 2) of row k; ``date``: every RMC's, if given."""
    out = []
    for r in rows:
        t = when(r)
        pos = f"{nmea_dm(float(r['latitude']), 2, 'NS')},{nmea_dm(float(r['longitude']), 3, 'EW')}"
        v = f"{float(r['groundspeed']):.1f},{float(r['track']):.1f}"
        out.append(nmea(f"GPRMC,{t:%H%M%S}.00,A,{pos},{v},{date or f'{t:%d%m%y}'},,,A"))
        alt = float(r["altitude"]) * FT
        out.append(nmea(f"GPGGA,{t:%H%M%S}.00,{pos},1,08,0.9,{alt:.1f},M,{GNSS_ABOVE},M,,"))
    return out


GPX_HEAD = [
    '<?xml version="1.0" encoding="UTF-8"?>',
    '<gpx version="1.1" creator="fieldmap test" xmlns="http://www.topografix.com/GPX/1/1" '
    'xmlns:gpxtpx="http://www.garmin.com/xmlschemas/TrackPointExtension/v2">',
    "<trk><trkseg>",
]


def trkpt(row: dict[str, str], time: str | None = None, speed: str | None = None) -> str:
    """One ``<trkpt>`` on one line; ``time``, ``speed``: other text for its time and speed."""
    t = f"{when(row):%Y-%m-%dT%H:%M:%SZ}" if time is None else time
    sp = f"{float(row['groundspeed']) * KT:.2f}" if speed is None else speed
    ext = (
        f"<extensions><gpxtpx:TrackPointExtension><gpxtpx:speed>{sp}</gpxtpx:speed>"
        f"<gpxtpx:course>{row['track']}</gpxtpx:course></gpxtpx:TrackPointExtension></extensions>"
    )
    return (
        f'<trkpt lat="{row["latitude"]}" lon="{row["longitude"]}">'
        f"<ele>{float(row['altitude']) * FT:.1f}</ele><time>{t}</time>{ext}</trkpt>"
    )


def gpx(points: list[str]) -> list[str]:
    """Return a GPX 1.1 track: point k on line k + 4."""
    return GPX_HEAD + points + ["</trkseg></trk>", "</gpx>"]


def same_but(track, base, dropped: list[int], h_atol: float = 0.0) -> None:
    """Assert that ``track`` is ``base`` without its samples ``dropped``.

    Heights to ``h_atol``: the geoid heights are interpolated between nodes along the track,
    which a dropped sample moves by millimetres.
    """
    keep = np.setdiff1d(np.arange(len(base)), dropped)
    for name in ("t", "lat", "lon"):
        np.testing.assert_array_equal(getattr(track, name), getattr(base, name)[keep])
    np.testing.assert_allclose(track.h, base.h[keep], rtol=0, atol=h_atol)


def noted(track, *words: str) -> str:
    """Return the note holding all of ``words``."""
    found = [n for n in track.notes if all(w in n for w in words)]
    assert found, (words, track.notes)
    return found[0]


# --------------------------------------------------------------------------- empty, encodings


@pytest.mark.parametrize(
    "name, data",
    [
        ("bom.igc", b"\xef\xbb\xbf"),
        ("bom.csv", b"\xef\xbb\xbf\n"),
        ("separators.csv", b"\x1c\x1d\n"),  # ASCII separators: white space to Python
        ("nbsp.gpx.txt", b"\xa0\xa0\n"),  # Latin-1 no-break spaces
    ],
)
def test_white_space_only_is_an_empty_log(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(InputError, match=r"empty flight log") as e:
        read_track(path)
    assert one_line(e).startswith(str(path))


def test_white_space_before_the_log_is_read(tmp_path, text):
    """30,000 spaces, or 25,000 blank lines, before a CSV: read as the CSV (lines shifted)."""
    base = read_track(write(tmp_path / "base.csv", [text.rstrip("\n")]))
    spaces = read_track(write(tmp_path / "spaces.csv", [" " * 30_000, text.rstrip("\n")]))
    blank = read_track(write(tmp_path / "blank.csv", [""] * 25_000 + [text.rstrip("\n")]))
    for track, shift in ((spaces, 1), (blank, 25_000)):
        same_but(track, base, [])
        np.testing.assert_array_equal(track.lines, base.lines + shift)


@pytest.mark.parametrize("kind", ["csv", "igc", "gpx"])
def test_utf16_with_a_byte_order_mark_is_text(tmp_path, rows, text, kind):
    """A spreadsheet's "Unicode text" (UTF-16 with its BOM) was refused as binary data."""
    lines = {
        "csv": text.splitlines(),
        "igc": igc(rows[:300]),
        "gpx": gpx([trkpt(r) for r in rows[:300]]),
    }
    utf8 = write(tmp_path / f"utf8.{kind}", lines[kind])
    utf16 = tmp_path / f"utf16.{kind}"
    utf16.write_bytes(utf8.read_text().encode("utf-16"))
    base, track = read_track(utf8), read_track(utf16)
    same_but(track, base, [])
    np.testing.assert_array_equal(track.lines, base.lines)


def test_a_directory_is_named_so(tmp_path):
    folder = tmp_path / "flight.igc"
    folder.mkdir()
    with pytest.raises(InputError, match=r"flight.igc: a directory, not a flight log") as e:
        read_track(folder)
    one_line(e)
    with pytest.raises(InputError, match=r"flight.igc: a directory, not a flight file"):
        load_flight(folder)


# --------------------------------------------------------------------------- times of day


def test_igc_real_log_has_no_time_fault(tmp_path, rows):
    """The real log's late stretch (6 rows 326 s back, line 505) is order's, not a time fault."""
    track = read_track(write(tmp_path / "base.igc", igc(rows)))
    assert len(track) == len(rows) and track.notes[0] == f"IGC: {len(rows)} B fixes"
    assert np.diff(track.t).min() == -326.0


def test_igc_one_clock_glitch_is_a_time_fault(tmp_path, rows):
    """One B record at 00:00:05 in the afternoon: dropped and named, no new day.

    It was read as the next day's (a step back of more than 12 h), and the rest of the log with
    it (the flight flown over 29 h).
    """
    base = read_track(write(tmp_path / "base.igc", igc(rows)))
    recs = igc(rows)
    k = 600
    assert base.t[k] % 86400 > 12 * 3600  # in the afternoon: 00:00:05 is 12 h back or more
    recs[k + 3] = "B000005" + recs[k + 3][7:]
    track = read_track(write(tmp_path / "glitch.igc", recs))
    same_but(track, base, [k])
    note = noted(track, "time fault", f"line {k + 4}:")
    assert "00:00:05" in note
    assert np.ptp(track.t) == np.ptp(base.t)


def test_igc_clock_glitch_within_the_day_is_left_to_the_conditioning(tmp_path, rows):
    """One B record at 23:59:59 in the afternoon: the day is not at stake, the reader keeps it.

    Every other record keeps its time (no day added); the conditioning drops the record, 8 h
    after the rest of the flight, as a recording apart and names its line.
    """
    base = read_track(write(tmp_path / "base.igc", igc(rows)))
    recs = igc(rows)
    k = 600
    recs[k + 3] = "B235959" + recs[k + 3][7:]
    path = write(tmp_path / "late.igc", recs)
    track = read_track(path)
    np.testing.assert_array_equal(np.delete(track.t, k), np.delete(base.t, k))
    assert track.t[k] % 86400 == 86399.0
    _, cf = load_flight(path)
    (apart,) = cf.report["order"]["apart"]
    assert apart["samples"] == 1 and apart["lines"] == [k + 4, k + 4]


@pytest.mark.parametrize(
    "shift",
    [
        timedelta(hours=11),  # midnight between two fixes 8 s apart
        timedelta(hours=11, minutes=20),  # midnight inside the 15-min gap at 12:32:32
    ],
)
def test_igc_midnight_rollover(tmp_path, rows, shift):
    """A log across midnight UTC: the next day, whether midnight falls between fixes or in a gap."""
    base = read_track(write(tmp_path / "base.igc", igc(rows)))
    track = read_track(write(tmp_path / "midnight.igc", igc(rows, shift)))
    np.testing.assert_array_equal(track.t, base.t + shift.total_seconds())
    assert len(track) == len(rows) and not any("dropped" in n for n in track.notes)


@pytest.mark.parametrize("stamp", ["250134", "126134", "122161"])
def test_igc_time_no_clock_shows(tmp_path, rows, stamp):
    """Hour 25, minute 61, second 61: the record's defect, dropped and named."""
    base = read_track(write(tmp_path / "base.igc", igc(rows)))
    recs = igc(rows)
    k = 700
    recs[k + 3] = "B" + stamp + recs[k + 3][7:]
    track = read_track(write(tmp_path / "clock.igc", recs))
    same_but(track, base, [k])
    noted(track, "no clock shows", f"line {k + 4}", stamp)


@pytest.mark.parametrize("at", [(9, "61"), (18, "60")])
def test_igc_position_no_chart_shows(tmp_path, rows, at):
    """A latitude or longitude of 61 or 60 minutes: the record's defect, dropped and named."""
    base = read_track(write(tmp_path / "base.igc", igc(rows)))
    recs = igc(rows)
    k = 700
    j, minutes = at
    recs[k + 3] = recs[k + 3][:j] + minutes + recs[k + 3][j + 2 :]
    track = read_track(write(tmp_path / "place.igc", recs))
    same_but(track, base, [k])
    noted(track, "no chart shows", f"line {k + 4}")


def test_nmea_position_no_chart_shows(tmp_path, rows):
    """A GGA latitude of 61 minutes: the sentence's defect, dropped and named."""
    base = read_track(write(tmp_path / "base.nmea", nmea_lines(rows)))
    sentences = nmea_lines(rows)
    k = 600  # GGA of row k: line 2k + 2
    fields = sentences[2 * k + 1][1:-3].split(",")
    fields[2] = fields[2][:2] + "61" + fields[2][4:]
    sentences[2 * k + 1] = nmea(",".join(fields))
    track = read_track(write(tmp_path / "place.nmea", sentences))
    same_but(track, base, [k])
    noted(track, "no chart shows", f"line {2 * k + 2}")


def test_nmea_clock_glitch_and_a_bad_date(tmp_path, rows):
    """One GGA at 00:00:05 (a time fault) and one RMC dated 000000: their lines named."""
    base = read_track(write(tmp_path / "base.nmea", nmea_lines(rows)))
    sentences = nmea_lines(rows)
    k = 600  # GGA of row k: line 2k + 2
    fields = sentences[2 * k + 1][1:-3].split(",")
    fields[1] = "000005.00"
    sentences[2 * k + 1] = nmea(",".join(fields))
    fields = sentences[2 * 400][1:-3].split(",")  # RMC of row 400: line 801
    fields[9] = "000000"
    sentences[2 * 400] = nmea(",".join(fields))
    track = read_track(write(tmp_path / "glitch.nmea", sentences))
    same_but(track, base, [k])
    noted(track, "time fault", f"line {2 * k + 2}:", "00:00:05")
    noted(track, "RMC date", "line 801", "'000000'")


# --------------------------------------------------------------------------- height references


def test_pressure_altitude_the_log_does_not_have(tmp_path, rows):
    """height_ref='pressure' on GPX and NMEA read their MSL (or ellipsoidal) altitude as one."""
    logs = {
        "log.nmea": (nmea_lines(rows[:300]), "GGA field 9 (altitude) (MSL)"),
        "log.gpx": (gpx([trkpt(r) for r in rows[:300]]), "ele (MSL)"),
    }
    for name, (lines, has) in logs.items():
        path = write(tmp_path / name, lines)
        with pytest.raises(InputError, match=r"height_ref='pressure' asks for a pressure") as e:
            read_track(path, height_ref="pressure")
        assert e.value.param == "height_ref" and has in one_line(e)
        assert str(path) in str(e.value)
    # the default, and the datum of a geometric altitude, as before
    track = read_track(tmp_path / "log.nmea")
    assert track.height_ref == "ellipsoid"
    alt = np.array([float(r["altitude"]) * FT for r in rows[:300]])
    np.testing.assert_allclose(track.h, np.round(alt, 1) + GNSS_ABOVE, atol=1e-9)
    assert read_track(tmp_path / "log.gpx", height_ref="ellipsoid").height_ref == "ellipsoid"


def test_pressure_altitude_refused_on_the_command_line(tmp_path, rows):
    """``fieldmap navsim --height-ref pressure`` on an NMEA log: one line, exit status 2."""
    path = write(tmp_path / "log.nmea", nmea_lines(rows[:300]))
    out = tmp_path / "out"
    argv = ["navsim", *FAST, "--trajectory", str(path), "--height-ref", "pressure"]
    run = subprocess.run(
        [sys.executable, "-m", "fieldmap", *argv, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    err = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(err) == 1, run.stderr
    assert "--height-ref pressure asks for a pressure altitude" in err[0]
    assert "Traceback" not in run.stderr and not out.exists()


def test_igc_altitude_zero_throughout(tmp_path, rows):
    """A recorder without a pressure sensor writes 0: no flight at sea level; GNSS used."""
    base = read_track(write(tmp_path / "base.igc", igc(rows)))
    recs = igc(rows)
    no_press = recs[:3] + [b[:25] + "00000" + b[30:] for b in recs[3:]]
    track = read_track(write(tmp_path / "press0.igc", no_press))
    same_but(track, base, [])
    noted(track, "no pressure altitude", "zero in every B record")
    with pytest.raises(InputError, match=r"height_ref='pressure' asks for a pressure") as e:
        read_track(tmp_path / "press0.igc", height_ref="pressure")
    assert e.value.param == "height_ref" and "GNSS altitude (B bytes 31-35)" in one_line(e)
    both = recs[:3] + [b[:25] + "0000000000" + b[35:] for b in recs[3:]]
    with pytest.raises(InputError, match=r"no altitude: the pressure altitude .* zero") as e:
        read_track(write(tmp_path / "both0.igc", both))
    one_line(e)


def test_csv_altitude_zero_throughout(tmp_path, text):
    """A traffic log whose only altitude column is 0 in every row: refused, one line."""
    lines = text.splitlines()
    head = lines[0].split(",")
    alt = head.index("altitude")
    zero = [lines[0]] + [
        ",".join(c if j != alt else "0" for j, c in enumerate(r.split(","))) for r in lines[1:]
    ]
    with pytest.raises(InputError, match=r"column altitude: zero in every row") as e:
        read_track(write(tmp_path / "alt0.csv", zero))
    one_line(e)


def test_adsb_altitude_of_zero_is_a_surface_report_without_one(tmp_path, text):
    """0 in an ADS-B altitude column is the export's placeholder, not a height.

    Surface position messages carry no altitude (DO-260B); the tables written from them put 0
    there, whatever the field's elevation (Sisteron's 1,800 ft read as sea level). The rows
    keep their time and position, marked as having no height (``no_height``; their ``h``
    interpolated between the others'), and the notes name them.
    """
    lines = text.splitlines()
    alt = lines[0].split(",").index("altitude")
    base = read_track(write(tmp_path / "base.csv", lines))
    ground = [1, 2, 3, 700]  # rows: the first three and one in flight
    zeroed = [lines[0]] + [
        ",".join(c if j != alt or k not in ground else "0" for j, c in enumerate(r.split(",")))
        for k, r in enumerate(lines[1:], start=1)
    ]
    track = read_track(write(tmp_path / "zero.csv", zeroed))
    rows = np.array(ground) - 1
    for name in ("t", "lat", "lon"):  # the same samples
        np.testing.assert_array_equal(getattr(track, name), getattr(base, name))
    assert base.no_height is None
    np.testing.assert_array_equal(np.flatnonzero(track.no_height), rows)
    np.testing.assert_array_equal(np.flatnonzero(track.surface_report), rows)
    assert base.surface_report is None
    others = np.setdiff1d(np.arange(base.t.size), rows)
    np.testing.assert_allclose(track.h[others], base.h[others], rtol=0, atol=1e-6)
    # between the heights of the others: the first rows take the first height of its own
    assert np.all(track.h[rows[:3]] == track.h[3])
    assert min(track.h[698], track.h[700]) <= track.h[699] <= max(track.h[698], track.h[700])
    note = noted(track, "4 rows of 0 read as no altitude", "surface reports")
    assert "lines 2, 3, 4, 701" in note
    # a real altitude of 0.5 ft is a height
    half = [lines[0]] + [
        ",".join(c if j != alt or k != 700 else "0.5" for j, c in enumerate(r.split(",")))
        for k, r in enumerate(lines[1:], start=1)
    ]
    assert read_track(write(tmp_path / "half.csv", half)).no_height is None


def test_adsb_rows_resampled_from_a_surface_report_have_no_height(tmp_path, text, rows):
    """A table resampled between a placeholder 0 and the next altitude: those rows are none.

    ``traffic`` resamples a flight onto a regular grid: between the last surface report (0)
    and the first airborne altitude it draws a straight line, whose rows are drawn from the
    placeholder, not measured. Rows off that line (a real climb) keep their heights.
    """
    lines = text.splitlines()
    head = lines[0].split(",")
    alt = head.index("altitude")
    t = np.array([when(r).timestamp() for r in rows])
    a = np.array([float(r["altitude"]) for r in rows])

    def table(values: dict[int, float]) -> list[str]:
        out = [lines[0]]
        for k, r in enumerate(lines[1:]):
            cells = r.split(",")
            if k in values:
                cells[alt] = repr(values[k])
            out.append(",".join(cells))
        return out

    # rows 0-2 surface reports; rows 3-4 on the line from (t2, 0) to (t5, a5)
    drawn = {k: float(a[5] * (t[k] - t[2]) / (t[5] - t[2])) for k in (3, 4)}
    track = read_track(write(tmp_path / "drawn.csv", table({0: 0.0, 1: 0.0, 2: 0.0, **drawn})))
    np.testing.assert_array_equal(np.flatnonzero(track.no_height), [0, 1, 2, 3, 4])
    # on the ground by the transponder's word: the surface reports, not the rows drawn
    np.testing.assert_array_equal(np.flatnonzero(track.surface_report), [0, 1, 2])
    assert "2 rows resampled between them" in noted(track, "surface reports")
    # the same rows 20 ft off the line: a climb of their own, heights kept
    off = {k: v + 20.0 for k, v in drawn.items()}
    track = read_track(write(tmp_path / "off.csv", table({0: 0.0, 1: 0.0, 2: 0.0, **off})))
    np.testing.assert_array_equal(np.flatnonzero(track.no_height), [0, 1, 2])


# --------------------------------------------------------------------------- several aircraft


def test_two_aircraft_in_one_csv(tmp_path, text):
    """Two gliders' rows interleaved by time were flown as one aircraft jumping between them."""
    with gzip.open(ADSB / "cevennes.csv.gz", "rt") as f:
        other = f.read().splitlines()
    assert other[0] == text.splitlines()[0]
    both = sorted(text.splitlines()[1:] + other[1:])  # ISO times first: in time order
    path = write(tmp_path / "two.csv", [other[0], *both])
    with pytest.raises(InputError, match=r"2 aircraft in one log") as e:
        read_track(path)
    msg = one_line(e)
    assert "dd0891: 1605 rows" in msg and "ddb18b: 1401 rows" in msg
    assert "one flight per file" in msg
    out = tmp_path / "out"
    run = subprocess.run(
        [sys.executable, "-m", "fieldmap", "navsim", *FAST, "--trajectory", str(path)]
        + ["--out", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    err = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(err) == 1 and "2 aircraft in one log" in err[0], run.stderr


# --------------------------------------------------------------------------- local defects


def test_igc_last_record_cut_short(tmp_path, rows):
    base = read_track(write(tmp_path / "base.igc", igc(rows)))
    recs = igc(rows)
    recs[-1] = recs[-1][:20]
    track = read_track(write(tmp_path / "cut.igc", recs))
    same_but(track, base, [len(rows) - 1])
    noted(track, "last B record", f"line {len(rows) + 3}", "20 of its 35 bytes")
    # nothing left: refused
    with pytest.raises(InputError, match=r"no B record .*the file ends inside it") as e:
        read_track(write(tmp_path / "only.igc", IGC_HEAD + [recs[-1]]))
    one_line(e)


def test_csv_lines_that_are_no_samples(tmp_path, text):
    """A last line cut short, rows of commas, a second export's header: dropped and named."""
    lines = text.splitlines()
    n = len(lines) - 1
    base = read_track(write(tmp_path / "base.csv", lines))
    cut = read_track(write(tmp_path / "cut.csv", lines[:-1] + [lines[-1][:25]]))
    same_but(cut, base, [n - 1], h_atol=0.05)
    noted(cut, f"last line ({n + 1})", "2 fields, the header (line 1) has 9")
    commas = read_track(write(tmp_path / "commas.csv", lines + [",,,,,,,,", ",,,,,,,,"]))
    same_but(commas, base, [])
    noted(commas, "2 rows of empty cells", f"lines {n + 2}, {n + 3}")
    twice = read_track(write(tmp_path / "twice.csv", lines[:801] + [lines[0]] + lines[801:]))
    same_but(twice, base, [])
    noted(twice, "1 repeat of the header (line 1)", "line 802")
    # a line of another length in the middle is still refused: the columns do not line up
    with pytest.raises(InputError, match=r"line 11: 2 fields, the header \(line 1\) has 9"):
        read_track(write(tmp_path / "short.csv", lines[:10] + [lines[10][:25]] + lines[11:]))


def test_csv_empty_time_and_infinite_value(tmp_path, text):
    lines = text.splitlines()
    base = read_track(write(tmp_path / "base.csv", lines))
    k = 300  # row k: line k + 2
    row = lines[k + 1].split(",")
    inf = lines.copy()
    inf[k + 1] = ",".join(row[:5] + ["inf"] + row[6:])
    track = read_track(write(tmp_path / "inf.csv", inf))
    # read as empty: the row keeps its time and position, without a height
    for name in ("t", "lat", "lon"):
        np.testing.assert_array_equal(getattr(track, name), getattr(base, name))
    np.testing.assert_array_equal(np.flatnonzero(track.no_height), [k])
    others = np.arange(len(base)) != k
    np.testing.assert_allclose(track.h[others], base.h[others], rtol=0, atol=0.05)
    noted(track, "altitude: 1 value not finite (inf) read as empty", f"line {k + 2}")
    noted(track, "altitude: 1 row without a value", f"line {k + 2}", "positions without a height")
    no_time = lines.copy()
    no_time[k + 1] = ",".join([""] + row[1:])
    track = read_track(write(tmp_path / "notime.csv", no_time))
    same_but(track, base, [k], h_atol=0.05)
    noted(track, "with an empty timestamp", f"line {k + 2}")


def test_gpx_points_without_a_readable_time(tmp_path, rows):
    base = read_track(write(tmp_path / "base.gpx", gpx([trkpt(r) for r in rows])))
    pts = [trkpt(r) for r in rows]
    pts[300] = trkpt(rows[300], time="BAD2019-05-23T11:51:01Z")
    pts[500] = pts[500].replace(pts[500][pts[500].index("<time>") : pts[500].index("<ext")], "")
    track = read_track(write(tmp_path / "time.gpx", gpx(pts)))
    same_but(track, base, [300, 500], h_atol=0.05)
    noted(track, "dropped 2 of 1605 <trkpt> without a readable <time>", "lines 304, 504")
    # no time at all: refused
    bare = [p.replace(p[p.index("<time>") : p.index("<ext")], "") for p in pts[:20]]
    with pytest.raises(InputError, match=r"line 4 column time: <trkpt> without <time>") as e:
        read_track(write(tmp_path / "bare.gpx", gpx(bare)))
    one_line(e)


def test_gpx_nan_speed_whitespace_and_bad_value_line(tmp_path, rows):
    """A GPX's 'NaN' speed, white space before <?xml, a point gpxpy cannot read.

    'NaN' in a speed extension is none (as in a CSV); white space before the declaration is
    read; a point that gpxpy cannot read is named by its line, not line 1.
    """
    base = read_track(write(tmp_path / "base.gpx", gpx([trkpt(r) for r in rows[:400]])))
    pts = [trkpt(r, speed="NaN" if k % 9 == 0 else None) for k, r in enumerate(rows[:400])]
    track = read_track(write(tmp_path / "nan.gpx", gpx(pts)))
    same_but(track, base, [])
    assert np.isnan(track.velocity.speed[::9]).all() and np.isfinite(track.velocity.speed[1])
    padded = tmp_path / "padded.gpx"
    padded.write_text("\n\n   " + (tmp_path / "base.gpx").read_text())
    track = read_track(padded)
    same_but(track, base, [])
    np.testing.assert_array_equal(track.lines, base.lines + 2)
    pts = [trkpt(r) for r in rows[:400]]
    pts[300] = pts[300].replace(f'lat="{rows[300]["latitude"]}"', 'lat=""')
    with pytest.raises(InputError, match=r"bad.gpx line 304: not a readable GPX file") as e:
        read_track(write(tmp_path / "bad.gpx", gpx(pts)))
    one_line(e)


def test_load_flight_drops_a_glitched_record_and_reports_it(tmp_path, rows):
    """The flight of a log with one clock glitch: the real span, the glitch in the report."""
    path = write(tmp_path / "glitch.igc", igc(rows[:500]))
    recs = path.read_text().splitlines()
    recs[203] = "B000005" + recs[203][7:]
    write(path, recs)
    flight, conditioned = load_flight(path)
    # 11 h before a morning's fixes: the same day, a recording apart (no day is at stake)
    (apart,) = conditioned.report["order"]["apart"]
    assert apart["samples"] == 1 and apart["lines"] == [204, 204]
    span = (when(rows[499]) - when(rows[0])).total_seconds()
    assert flight.duration <= span
