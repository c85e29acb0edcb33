"""GNSS receiver and flight-recorder logs: GPX 1.1, NMEA 0183 and IGC.

Each reader returns a :class:`~fieldmap.nav.logs.track.Parsed` for
:func:`fieldmap.nav.logs.read.read_track`, which recognises the format.

- **GPX 1.1** (Topografix, https://www.topografix.com/GPX/1/1/): ``<trkpt>`` of all tracks and
  segments in document order (``<rtept>`` when there is no track), read with ``gpxpy``. The
  schema calls ``<ele>`` the "elevation (in meters) of the point" and ``<geoidheight>`` the
  "height of geoid (mean sea level) above WGS84 earth ellipsoid, as defined in NMEA GGA": ``<ele>``
  is the height above mean sea level (MSL). With ``<geoidheight>`` on every point the file's own
  ellipsoidal height ``ele + geoidheight`` is used. The receiver's velocity, where the file has
  it: GPX 1.0's ``<speed>`` (m/s) and ``<course>`` (degrees from true north), or the same two in
  a GPX 1.1 ``<extensions>`` block (Garmin's ``TrackPointExtension`` v2 ``speed``/``course``, or
  any extension element so named).
- **NMEA 0183** (NMEA 0183 v4.11, GGA and RMC sentences; parsed with ``pynmea2``): GGA gives
  the UTC time of day, position, the altitude above MSL (field 9) and the geoid separation
  (field 11, geoid above the WGS84 ellipsoid): h = altitude + separation when every fix has it.
  RMC gives the date (field 9, ``ddmmyy``) and the receiver's velocity over the ground: speed
  (field 7, knots) and course (field 8, degrees from true north), attached to the GGA fix of the
  same time of day (the sentence next to it) when the RMC status (field 2) is ``A``. Sentences
  with a wrong checksum (XOR of the bytes between ``$`` and ``*``) are skipped and counted, as
  are fixes of quality 0 (no fix).
- **IGC** (FAI/IGC *Technical Specification for IGC-approved GNSS Flight Recorders*, appendix
  A): ``HFDTE`` date (``HFDTEDDMMYY`` or ``HFDTEDATE:DDMMYY,NN``), ``B`` fixes
  ``BHHMMSSDDMMmmmNDDDMMmmmEVPPPPPGGGGG``: pressure altitude (m, ICAO ISA, 1013.25 hPa datum)
  and GNSS altitude (m, "above the WGS84 ellipsoid" per the specification; the ``HFALG`` header
  ``GEO`` of recent recorders says MSL). ``LAD``/``LOD`` extensions (``I`` record) add
  decimals of minutes.

Times of day roll over at midnight (a step back by more than 12 h adds a day).

The velocities become a :class:`~fieldmap.nav.logs.track.Velocities` (no vertical speed: neither
format has one): the conditioning checks them against the positions and fits the path to them
(:func:`fieldmap.nav.logs.fit.observations`). Their resolution is the last digit the file prints
(the rounding's σ is that step/√12); a receiver's Doppler noise above it is estimated from the
values themselves. A speed without a course (or the reverse) gives no velocity vector and is
left out, and said.
"""

from __future__ import annotations

import re
from datetime import datetime, timezone
from typing import Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.nav.logs.track import Parsed, Velocities, utc_seconds

DAY = 86400.0
KT = 1852.0 / 3600.0


def _step(texts: list[str]) -> float:
    """Return the finest step of printed decimal numbers: 10^-(most decimals printed), 1 if none."""
    dec = [len(x.partition(".")[2]) for x in texts if x]
    return 10.0 ** -max(dec) if dec else 1.0


def _velocities(
    speed: list[str], course: list[str], factor: float, names: tuple[str, str], notes: list[str]
) -> Velocities | None:
    """Velocities from the printed speeds (times ``factor`` to m/s) and courses; None if none."""
    both = [bool(a) and bool(b) for a, b in zip(speed, course)]
    one = sum(bool(a) != bool(b) for a, b in zip(speed, course))
    if not any(both):
        if one:
            notes.append(f"{one} fixes have a {names[0]} without a {names[1]} (or the reverse):"
                         " no velocity vector, not used")  # fmt: skip
        return None
    sp = np.array([float(a) if ok else np.nan for a, ok in zip(speed, both)]) * factor
    co = np.array([float(b) if ok else np.nan for b, ok in zip(course, both)])
    used_s = [a for a, ok in zip(speed, both) if ok]
    used_c = [b for b, ok in zip(course, both) if ok]
    res = (_step(used_s) * factor, _step(used_c), 0.0)
    notes.append(
        f"the receiver's velocities ({names[0]}, {names[1]}) at {sum(both)} fixes: observations "
        "of the flown path" + (f"; {one} with only one of the two left out" if one else "")
    )
    return Velocities(sp, co, None, res, names)


def _extension(point: object, name: str) -> str:
    """Text of a GPX 1.1 extension element ``name`` (any namespace, any depth), else ''."""
    for root in getattr(point, "extensions", None) or []:
        for el in root.iter():
            if str(el.tag).rpartition("}")[2].lower() == name and (el.text or "").strip():
                return str(el.text).strip()
    return ""


def _printed(v: float | None) -> str:
    """Return a number as the file printed it (the shortest repr of the float read), '' for None."""
    return "" if v is None else np.format_float_positional(float(v), trim="-")


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _days(tods: list[float]) -> np.ndarray:
    """Day index of each time of day in order: a step back by more than 12 h is midnight."""
    day, out, prev = 0, np.zeros(len(tods)), None
    for i, x in enumerate(tods):
        if prev is not None and x < prev - DAY / 2:
            day += 1
        out[i], prev = day, x
    return out


def read_gpx(text: str, source: str) -> Parsed:
    """Track (else route) points of a GPX 1.0/1.1 file, segments concatenated in order."""
    import gpxpy
    import gpxpy.gpx

    try:
        gpx = gpxpy.parse(text)
    except gpxpy.gpx.GPXException as exc:
        msg = str(exc).splitlines()[0]
        m = re.search(r"\.\.\. (.*?) \(", msg)
        pos = text.find(m.group(1)) if m else -1
        at = f" line {_line_of(text, pos)}" if pos >= 0 else ""
        raise InputError(f"{source}{at}: not a readable GPX file ({msg})") from None
    kind = "trkpt"
    pts: list = [p for trk in gpx.tracks for seg in trk.segments for p in seg.points]
    if not pts:
        kind, pts = "rtept", [p for r in gpx.routes for p in r.points]
    if not pts:
        raise InputError(f"{source}: no track or route points (<trkpt>, <rtept>) in the GPX file")
    tags = [m.start() for m in re.finditer(rf"<(?:\w+:)?{kind}\b", text)]
    if len(tags) == len(pts):
        lines, where = np.array([_line_of(text, p) for p in tags], dtype=np.int64), "line"
    else:
        lines, where = np.arange(1, len(pts) + 1, dtype=np.int64), kind
    t = np.empty(len(pts))
    for i, p in enumerate(pts):
        if p.time is None:
            raise InputError(f"{source} {where} {lines[i]} column time: <{kind}> without <time>")
        t[i] = utc_seconds(p.time)
    lat = np.array([p.latitude for p in pts], dtype=np.float64)
    lon = np.array([p.longitude for p in pts], dtype=np.float64)
    ele = np.array([np.nan if p.elevation is None else p.elevation for p in pts])
    alts = {"msl": ("ele", ele)}
    notes = [f"GPX: {len(pts)} <{kind}> points; <ele> read as height above mean sea level"]
    ref = "msl"
    if all(p.geoid_height is not None for p in pts):
        sep = np.array([p.geoid_height for p in pts], dtype=np.float64)
        alts["ellipsoid"] = ("ele+geoidheight", ele + sep)
        ref = "ellipsoid"
        notes[0] = f"GPX: {len(pts)} <{kind}> points; h = <ele> + <geoidheight> (the file's own)"
    speed = [_printed(getattr(p, "speed", None)) or _extension(p, "speed") for p in pts]
    course = [_printed(getattr(p, "course", None)) or _extension(p, "course") for p in pts]
    for k, (a, b) in enumerate(zip(speed, course)):
        for name, x in (("speed", a), ("course", b)):
            try:
                if x and not np.isfinite(float(x)):
                    raise ValueError
            except ValueError:
                raise InputError(
                    f"{source} {where} {lines[k]} column {name}: {x!r} is not a number"
                ) from None
    velocity = _velocities(speed, course, 1.0, ("<speed>", "<course>"), notes)
    out = Parsed(
        t, lat, lon, alts, ref, "m", lines, source, True, ("time", "lat", "lon"), where, notes
    )
    out.velocity = velocity
    return out


def _dm(s: str, hemi: str, neg: str, where: str, name: str) -> float:
    """Degrees from NMEA ``(d)ddmm.mmmm`` and a hemisphere letter."""
    try:
        v = float(s)
        if not s[:1].isdigit() or v < 0 or hemi not in ("NS" if neg == "S" else "EW"):
            raise ValueError
    except ValueError:
        raise InputError(
            f"{where} column {name}: {s + ',' + hemi!r} is not ddmm.mmmm,N|S|E|W"
        ) from None
    d = np.floor(v / 100.0)
    return float((d + (v - 100.0 * d) / 60.0) * (-1.0 if hemi == neg else 1.0))


def _tod(s: str, where: str) -> float:
    """Seconds of the day from ``hhmmss[.ss]``."""
    m = re.fullmatch(r"(\d{2})(\d{2})(\d{2}(?:\.\d*)?)", s)
    if not m or int(m[1]) > 23 or int(m[2]) > 59 or float(m[3]) >= 61:
        raise InputError(f"{where} column field 1 (UTC time): {s!r} is no hhmmss.ss")
    return int(m[1]) * 3600.0 + int(m[2]) * 60.0 + float(m[3])


def read_nmea(text: str, source: str) -> Parsed:
    """GGA fixes of an NMEA 0183 log, dated by RMC sentences (see the module docstring)."""
    import pynmea2

    stamps: list[tuple[str, int, float, Any]] = []  # (GGA|RMC, line, time of day, payload)
    skipped = {"with a bad checksum": 0, "incomplete": 0, "without a fix": 0}
    for lineno, raw in enumerate(text.splitlines(), start=1):
        i = raw.find("$")
        s = raw[i:].strip() if i >= 0 else ""
        if s[3:6] not in ("GGA", "RMC"):
            continue
        has_sum = bool(re.search(r"\*[0-9A-Fa-f]{2}$", s))
        try:
            msg = pynmea2.parse(s, check=has_sum)
            f = list(msg.data) + [""] * 14
        except pynmea2.ChecksumError:
            skipped["with a bad checksum"] += 1
            continue
        except pynmea2.ParseError:
            skipped["incomplete"] += 1
            continue
        where = f"{source} line {lineno}"
        if s[3:6] == "RMC":
            if not f[0]:
                continue
            day0 = None
            if re.fullmatch(r"\d{6}", f[8]):
                d = (int(f[8][4:]) + 2000, int(f[8][2:4]), int(f[8][:2]))
                try:
                    day0 = datetime(*d, tzinfo=timezone.utc).timestamp()
                except ValueError:
                    raise InputError(f"{where} column RMC field 9 (date): {f[8]!r} is no ddmmyy")
            vel = ("", "")
            if f[1] == "A":
                for j, name in ((6, "field 7 (speed, knots)"), (7, "field 8 (course)")):
                    try:
                        if f[j] and not np.isfinite(float(f[j])):
                            raise ValueError
                    except ValueError:
                        raise InputError(f"{where} column RMC {name}: {f[j]!r} is not a number")
                vel = (f[6], f[7])
            stamps.append(("RMC", lineno, _tod(f[0], where), (day0, vel)))
            continue
        if not has_sum and (len(msg.data) < 11 or not f[8]):
            skipped["incomplete"] += 1
            continue
        if f[5] in ("", "0") or not f[1] or not f[3]:
            skipped["without a fix"] += 1
            continue
        try:
            alt = float(f[8]) if f[8] else np.nan
            sep = float(f[10]) if f[10] else np.nan
        except ValueError:
            raise InputError(f"{where} column GGA field 9/11 (altitude, separation): not a number")
        pos = (
            _dm(f[1], f[2], "S", where, "GGA field 2 (latitude)"),
            _dm(f[3], f[4], "W", where, "GGA field 4 (longitude)"),
        )
        stamps.append(("GGA", lineno, _tod(f[0], where), (*pos, alt, sep)))
    fixes = [k for k, s in enumerate(stamps) if s[0] == "GGA"]
    why = ", ".join(f"{n} sentences {k}" for k, n in skipped.items() if n)
    if not fixes:
        raise InputError(
            f"{source}: no usable GGA fix in the NMEA log ({why or 'no GGA sentence'})"
        )
    days = _days([s[2] for s in stamps])
    anchors = [
        (k, s[3][0] - days[k] * DAY)
        for k, s in enumerate(stamps)
        if s[0] == "RMC" and s[3][0] is not None
    ]
    t, lines, cols = np.empty(len(fixes)), np.empty(len(fixes), np.int64), []
    base, a = (anchors[0][1] if anchors else 0.0), 0
    for j, k in enumerate(fixes):
        while a < len(anchors) and anchors[a][0] <= k:  # the latest RMC date before the fix
            base, a = anchors[a][1], a + 1
        t[j], lines[j] = base + days[k] * DAY + stamps[k][2], stamps[k][1]
        cols.append(stamps[k][3])
    lat, lon, alt, sep = np.array(cols, dtype=np.float64).T
    notes = [f"NMEA 0183: {len(fixes)} GGA fixes" + (f"; skipped {why}" if why else "")]
    speed: list[str] = []
    course: list[str] = []
    for k in fixes:  # the RMC of the same epoch: the sentence before or after the GGA
        same = [
            j
            for j in (k - 1, k + 1)
            if 0 <= j < len(stamps)
            and stamps[j][0] == "RMC"
            and stamps[j][2] == stamps[k][2]
            and days[j] == days[k]
        ]
        sp_k, co_k = stamps[same[0]][3][1] if same else ("", "")
        speed.append(sp_k)
        course.append(co_k)
    if not anchors:
        notes.append("no RMC date: times are seconds from 00:00 UTC of the log's first day")
    alts = {"msl": ("GGA field 9 (altitude)", alt)}
    ref = "msl"
    if np.all(np.isfinite(sep[np.isfinite(alt)])):
        alts["ellipsoid"] = ("GGA fields 9+11", alt + sep)
        ref = "ellipsoid"
        notes.append("h = GGA altitude (MSL) + the receiver's geoid separation (field 11)")
    names = ("GGA field 1 (UTC time)", "GGA field 2 (latitude)", "GGA field 4 (longitude)")
    velocity = _velocities(
        speed, course, KT, ("RMC field 7 (speed)", "RMC field 8 (course)"), notes
    )
    out = Parsed(t, lat, lon, alts, ref, "m", lines, source, bool(anchors), names, "line", notes)
    out.velocity = velocity
    return out


#: fields of an IGC B record: name, first byte, last byte (1-based, inclusive)
_B_FIELDS = (
    ("time", 2, 7, r"\d{6}"),
    ("latitude", 8, 15, r"\d{7}[NS]"),
    ("longitude", 16, 24, r"\d{8}[EW]"),
    ("fix validity", 25, 25, r"[AV]"),
    ("pressure altitude", 26, 30, r"-\d{4}|\d{5}"),
    ("GNSS altitude", 31, 35, r"-\d{4}|\d{5}"),
)


def _igc_dm(digits: str, extra: str, deg: int) -> float:
    minutes = float(digits[deg : deg + 2] + "." + digits[deg + 2 :] + extra)
    return int(digits[:deg]) + minutes / 60.0


def read_igc(text: str, source: str) -> Parsed:
    """B fixes of an IGC flight recorder file (see the module docstring)."""
    day0, alg, ext, rows, tods = None, None, {}, [], []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        s = raw.rstrip()
        if s.startswith("HFDTE") or s.startswith("HODTE"):
            m = re.match(r"H[FO]DTE(?:[A-Z ]*:)?\s*(\d{2})(\d{2})(\d{2})", s)
            try:
                dd, mm, yy = (int(m[k]) for k in (1, 2, 3)) if m else (0, 0, 0)
                day0 = datetime(yy + (2000 if yy < 80 else 1900), mm, dd, tzinfo=timezone.utc)
            except ValueError:
                raise InputError(f"{source} line {lineno} column HFDTE: {s!r} has no DDMMYY date")
        elif s.startswith("HFALG"):
            alg = s.split(":")[-1].strip().upper()[:3]
        elif s.startswith("I") and re.fullmatch(r"I\d{2}(\d{4}[A-Z0-9]{3})*", s):
            ext = {
                s[k + 4 : k + 7]: (int(s[k : k + 2]), int(s[k + 2 : k + 4]))
                for k in range(3, len(s), 7)
            }
        elif s.startswith("B"):
            for name, a, b, pat in _B_FIELDS:
                if not re.fullmatch(pat, s[a - 1 : b]):
                    raise InputError(
                        f"{source} line {lineno} column {name} (B record bytes {a}-{b}): "
                        f"{s[a - 1 : b]!r} does not match the IGC B record"
                    )
            lad, lod = (s[ext[k][0] - 1 : ext[k][1]] if k in ext else "" for k in ("LAD", "LOD"))
            y = _igc_dm(s[7:14], lad if lad.isdigit() else "", 2) * (-1 if s[14] == "S" else 1)
            x = _igc_dm(s[15:23], lod if lod.isdigit() else "", 3) * (-1 if s[23] == "W" else 1)
            rows.append(
                (lineno, y, x, float(s[25:30]), float(s[30:35]) if s[24] == "A" else np.nan)
            )
            tods.append(int(s[1:3]) * 3600.0 + int(s[3:5]) * 60.0 + int(s[5:7]))
    if not rows:
        raise InputError(f"{source}: no B record (fix) in the IGC file")
    lines, lat, lon, press, gnss = (np.array(c) for c in zip(*rows))
    t = np.asarray(tods) + _days(tods) * DAY + (day0.timestamp() if day0 else 0.0)
    gref = "msl" if alg == "GEO" else "ellipsoid"
    alts = {"pressure": ("pressure altitude (B bytes 26-30)", press)}
    alts[gref] = ("GNSS altitude (B bytes 31-35)", gnss)
    notes, ref_note = [f"IGC: {len(rows)} B fixes"], None
    if not np.any(np.nan_to_num(gnss) != 0.0):
        ref = "pressure"
        notes.append("no GNSS altitude (all zero or 2D fixes): pressure altitude used")
    else:
        ref = gref
        if alg is None:
            ref_note = (
                "GNSS altitude read as height above the WGS84 ellipsoid (IGC specification; no "
                "HFALG header): pass height_ref='msl' if your recorder writes MSL"
            )
    if day0 is None:
        notes.append("no HFDTE date: times are seconds from 00:00 UTC of the flight's first day")
    return Parsed(
        t,
        lat,
        lon,
        alts,
        ref,
        "m",
        lines.astype(np.int64),
        source,
        day0 is not None,
        ("time (B bytes 2-7)", "latitude", "longitude"),
        "line",
        notes,
        ref_note,
    )
