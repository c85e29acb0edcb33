"""Flight logs as they come (fieldmap.nav.logs.read): CSV layouts, GPX, NMEA 0183, IGC, tables.

One synthetic flight (a great circle from 46.5° N 7° E on azimuth 60°, 230 m/s, climbing at
10 m/s to 11 km, 1 Hz for 30 minutes, across midnight UTC) is written by each test in one
format and read back: positions to the file's resolution, times as epoch seconds, heights after
the height-reference conversion (MSL: h - H is fieldmap's geoid height N).
"""

import gzip
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest

import fieldmap
from fieldmap.errors import InputError
from fieldmap.nav.logs.condition import condition
from fieldmap.nav.logs.read import R_ISA, RawTrack, parse_columns, read_track

T0 = datetime(2023, 6, 14, 23, 45, 0, tzinfo=timezone.utc)
FT = 0.3048
KT = 1852.0 / 3600.0
DATA = Path(__file__).parent / "data" / "flights"
ADSB = Path(__file__).parent / "data" / "adsb"


@pytest.fixture(scope="module")
def fl():
    """Return the synthetic flight: t (s from T0), lat, lon (deg), H (MSL, m), N and h = H + N."""
    t = np.arange(1800.0)
    la0, lo0, az = np.radians(46.5), np.radians(7.0), np.radians(60.0)
    d = 230.0 * t / 6_371_000.0
    la = np.arcsin(np.sin(la0) * np.cos(d) + np.cos(la0) * np.sin(d) * np.cos(az))
    lo = lo0 + np.arctan2(
        np.sin(az) * np.sin(d) * np.cos(la0), np.cos(d) - np.sin(la0) * np.sin(la)
    )
    lat, lon = np.degrees(la), np.degrees(lo)
    H = np.minimum(500.0 + 10.0 * t, 11_000.0)
    N = fieldmap.geoid_height(lat, lon)
    # the velocity over the ground, as a receiver gives it: central differences of the ECEF
    # positions (WGS84, written out here) in the local east/north axes; one-sided at the ends
    a, e2 = 6378137.0, 6.69437999014e-3
    p, q = np.radians(lat), np.radians(lon)
    nu = a / np.sqrt(1.0 - e2 * np.sin(p) ** 2)
    h = H + N
    x = np.stack(
        [
            (nu + h) * np.cos(p) * np.cos(q),
            (nu + h) * np.cos(p) * np.sin(q),
            (nu * (1.0 - e2) + h) * np.sin(p),
        ],
        -1,
    )
    v = np.gradient(x, t, axis=0)
    east = np.stack([-np.sin(q), np.cos(q), 0.0 * q], -1)
    north = np.stack([-np.sin(p) * np.cos(q), -np.sin(p) * np.sin(q), np.cos(p)], -1)
    ve, vn = np.sum(v * east, axis=1), np.sum(v * north, axis=1)
    return dict(
        t=t, lat=lat, lon=lon, H=H, N=N, h=h, epoch=T0.timestamp() + t,
        gs=np.hypot(ve, vn), course=np.degrees(np.arctan2(ve, vn)) % 360.0,
    )  # fmt: skip


def geoid(track):
    return fieldmap.geoid_height(track.lat, track.lon)


def write(path, lines):
    path.write_text("\n".join(lines) + "\n")
    return path


def iso(k, fmt="%Y-%m-%dT%H:%M:%SZ"):
    return (T0 + timedelta(seconds=float(k))).strftime(fmt)


def check_position(tr, fl, tol):
    assert isinstance(tr, RawTrack) and len(tr) == fl["t"].size
    np.testing.assert_allclose(tr.lat, fl["lat"], atol=tol, rtol=0)
    np.testing.assert_allclose(tr.lon, fl["lon"], atol=tol, rtol=0)
    assert tr.t.dtype == np.float64 and tr.lines.dtype == np.int64


# --------------------------------------------------------------------------- CSV layouts


def test_fieldmap_csv(tmp_path, fl):
    rows = ["# a comment", "time_s,lat_deg,lon_deg,height_m"]
    rows += [
        f"{t:g},{a:.9f},{b:.9f},{h:.4f}"
        for t, a, b, h in zip(fl["t"], fl["lat"], fl["lon"], fl["h"])
    ]
    tr = read_track(write(tmp_path / "f.csv", rows))
    check_position(tr, fl, 1e-9)
    np.testing.assert_allclose(tr.h, fl["h"], atol=1e-4)
    np.testing.assert_array_equal(tr.t, fl["t"])
    assert tr.height_ref == "ellipsoid" and tr.t0_utc is None
    assert tr.lines[0] == 3 and tr.lines[-1] == 1802 and tr.source.endswith("f.csv")
    # file order kept: a repeated and a backward time are the conditioning step's business
    rows[5:5] = [rows[4], rows[2]]
    tu = read_track(write(tmp_path / "u.csv", rows))
    assert list(tu.t[:6]) == [0, 1, 2, 2, 0, 3] and list(tu.lines[:6]) == [3, 4, 5, 6, 7, 8]


def opensky_rows(fl, geo=True, scale=1.0):
    """OpenSky state vectors of ``fl``: 230 m/s, 60°, ``fl["vertrate"]`` (m/s; 10 if none)."""
    rows = ["time,icao24,lat,lon,velocity,heading,vertrate,baroaltitude,geoaltitude"]
    vr = np.broadcast_to(fl.get("vertrate", 10.0), fl["t"].shape)
    for k in range(fl["t"].size):
        g = f"{fl['H'][k] * scale:.2f}" if geo else ""
        rows.append(
            f"{int(fl['epoch'][k])},4b1815,{fl['lat'][k]:.7f},{fl['lon'][k]:.7f},230,60,"
            f"{vr[k]:g},{fl['H'][k] * scale:.2f},{g}"
        )
    return rows


def test_opensky_csv_geo_and_baro(tmp_path, fl):
    path = write(tmp_path / "states.csv", opensky_rows(fl))
    tr = read_track(path)
    check_position(tr, fl, 1e-7)
    np.testing.assert_array_equal(tr.t, fl["epoch"])
    assert tr.t0_utc == "2023-06-14T23:45:00Z"
    assert tr.height_ref == "msl" and any("read as MSL" in n for n in tr.notes)
    np.testing.assert_allclose(tr.h - fl["H"], geoid(tr), atol=0.02)
    # the barometric column on request: ISA geopotential -> geometric height, then + N
    tp = read_track(path, height_ref="pressure")
    z = R_ISA * fl["H"] / (R_ISA - fl["H"])
    np.testing.assert_allclose(tp.h - z, geoid(tp), atol=0.02)
    assert tp.height_ref == "pressure" and any("ISA" in n and "±" in n for n in tp.notes)
    # geoaltitude mostly empty: baroaltitude (pressure) is used
    tb = read_track(write(tmp_path / "baro.csv", opensky_rows(fl, geo=False)))
    assert tb.height_ref == "pressure" and len(tb) == fl["t"].size


def traffic_rows(fl, geo=False, fmt="%Y-%m-%d %H:%M:%S+00:00"):
    rows = ["timestamp,icao24,latitude,longitude,altitude,groundspeed,track,vertical_rate"]
    rows[0] += ",geoaltitude" if geo else ""
    for k in range(fl["t"].size):
        ft = fl["H"][k] / FT
        rows.append(
            f"{iso(k, fmt)},3c664e,{fl['lat'][k]:.6f},{fl['lon'][k]:.6f},{ft:.1f},447,60,1968"
            + (f",{ft:.1f}" if geo else "")
        )
    return rows


def test_traffic_csv_feet_and_iso_times(tmp_path, fl):
    tr = read_track(write(tmp_path / "traffic.csv", traffic_rows(fl)))
    check_position(tr, fl, 1e-6)
    np.testing.assert_allclose(tr.t, fl["epoch"], atol=1e-6)
    assert tr.height_ref == "pressure"
    assert any("in ft" in n for n in tr.notes) and any("ISA" in n for n in tr.notes)
    z = R_ISA * fl["H"] / (R_ISA - fl["H"])
    np.testing.assert_allclose(tr.h - z, geoid(tr), atol=0.05)
    # with a geoaltitude column (ft): MSL, naive ISO times are UTC
    tg = read_track(write(tmp_path / "g.csv", traffic_rows(fl, True, "%Y-%m-%dT%H:%M:%S")))
    assert tg.height_ref == "msl"
    np.testing.assert_allclose(tg.t, fl["epoch"], atol=1e-6)
    np.testing.assert_allclose(tg.h - fl["H"], geoid(tg), atol=0.05)


def test_iso_offsets_and_epoch_ms(tmp_path, fl):
    rows = ["2023-06-15T01:45:00.500+02:00,46.5,7.0,1000", "2023-06-14T23:45:01.5Z,46.5,7.0,1000"]
    tr = read_track(
        write(tmp_path / "iso.csv", ["timestamp,latitude,longitude,altitude"] + rows * 6)
    )
    np.testing.assert_allclose(tr.t[:2], T0.timestamp() + np.array([0.5, 1.5]))
    rows = ["timestamp,latitude,longitude,altitude"]
    rows += [
        f"{int(e * 1000)},{a},{b},{h / FT:.1f}"
        for e, a, b, h in zip(fl["epoch"], fl["lat"], fl["lon"], fl["H"])
    ]
    tm = read_track(write(tmp_path / "ms.csv", rows))
    np.testing.assert_allclose(tm.t, fl["epoch"])
    assert any("epoch milliseconds" in n for n in tm.notes)


def test_mapping_odd_names_feet(tmp_path, fl):
    rows = ["Zeit;Breite;Länge;Höhe [ft];Bemerkung"]
    rows += [
        f"{iso(k, '%d.%m.%Y %H:%M:%S')};{fl['lat'][k]:.8f};{fl['lon'][k]:.8f};"
        f"{fl['H'][k] / FT:.3f};x"
        for k in range(fl["t"].size)
    ]
    path = write(tmp_path / "odd.txt", rows)
    cols = "time=Zeit,lat=Breite,lon=Länge,alt=Höhe [ft]"
    tr = read_track(path, columns=cols, alt_units="ft", time_format="%d.%m.%Y %H:%M:%S")
    check_position(tr, fl, 1e-8)
    np.testing.assert_allclose(tr.t, fl["epoch"])
    assert tr.height_ref == "msl" and any("column mapping" in n for n in tr.notes)
    np.testing.assert_allclose(tr.h - fl["H"], geoid(tr), atol=0.02)
    te = read_track(
        path,
        columns=parse_columns(cols),
        alt_units="ft",
        height_ref="ellipsoid",
        time_format="%d.%m.%Y %H:%M:%S",
    )
    np.testing.assert_allclose(te.h, fl["H"], atol=1e-3)
    assert not any("column mapping" in n for n in te.notes)


def test_empty_cells_dropped_and_gzip(tmp_path, fl):
    """Rows without a position are dropped; a row with a position and no altitude is kept.

    ADS-B exports hold rows between altitude messages and a taxi's surface reports with an
    empty altitude: their positions are measurements, kept as positions without a height.
    """
    rows = opensky_rows(fl)
    for k in (5, 6, 700):  # ADS-B exports: rows without a position or altitude
        c = rows[k].split(",")
        c[2 if k != 700 else 8] = "" if k != 6 else "NaN"
        rows[k] = ",".join(c)
    path = tmp_path / "states.csv.gz"
    path.write_bytes(gzip.compress(("\n".join(rows) + "\n").encode()))
    tr = read_track(path)
    assert len(tr) == fl["t"].size - 2
    assert any("dropped 2 of 1800" in n and "line 6" in n for n in tr.notes)
    assert 6 not in tr.lines and tr.lines[4] == 8
    assert any("1 row without a value (line 701)" in n for n in tr.notes), tr.notes
    np.testing.assert_array_equal(tr.lines[tr.no_height], [701])
    np.testing.assert_allclose(tr.lat[tr.lines == 701], fl["lat"][699], atol=1e-6)


def test_parse_columns():
    assert parse_columns(" time=ts, lat=Lat ,lon=Lon,alt=h ") == {
        "time": "ts",
        "lat": "Lat",
        "lon": "Lon",
        "alt": "h",
    }
    for bad, what in (
        ("time=a,lat=b,lon=c", "missing alt"),
        ("time=a,x=b", "not one of"),
        ("time=a,time=b,lat=c,lon=d,alt=e", "twice"),
        ("time", "not one of"),
    ):
        with pytest.raises(InputError, match=what):
            parse_columns(bad)


# --------------------------------------------------------------------------- GPX, NMEA, IGC


def test_gpx_segments_msl(tmp_path, fl):
    gpxpy = pytest.importorskip("gpxpy")
    import gpxpy.gpx as g

    gpx = g.GPX()
    trk = g.GPXTrack()
    gpx.tracks.append(trk)
    for part in (slice(0, 900), slice(900, None)):
        seg = g.GPXTrackSegment()
        trk.segments.append(seg)
        for k in range(fl["t"].size)[part]:
            seg.points.append(
                g.GPXTrackPoint(
                    fl["lat"][k],
                    fl["lon"][k],
                    elevation=round(fl["H"][k], 2),
                    time=T0 + timedelta(seconds=k),
                )
            )
    tr = read_track(write(tmp_path / "flight.gpx", [gpx.to_xml()]))
    assert gpxpy is not None
    check_position(tr, fl, 1e-9)
    np.testing.assert_allclose(tr.t, fl["epoch"])
    assert tr.height_ref == "msl" and tr.t0_utc == "2023-06-14T23:45:00Z"
    np.testing.assert_allclose(tr.h - fl["H"], geoid(tr), atol=0.02)
    assert np.all(np.diff(tr.lines) > 0)  # the line of each <trkpt>


def nmea(body: str) -> str:
    """Return an NMEA 0183 sentence with its checksum: XOR of the characters between $ and *."""
    cs = 0
    for ch in body:
        cs ^= ord(ch)
    return f"${body}*{cs:02X}"


def ddmm(v: float, hemi: str, width: int) -> tuple[str, str]:
    a = abs(v)
    d, m = int(a), round((abs(v) - int(a)) * 60.0, 4)
    d, m = (d + 1, 0.0) if m >= 60.0 else (d, m)
    return f"{d:0{width}d}{m:07.4f}", hemi[int(v < 0)]


def nmea_lines(fl, sep=True, bad=(), knots=1.0 / KT):
    """Return the flight as GGA + RMC sentences; RMC speeds are the ground speed times ``knots``."""
    out = []
    for k in range(fl["t"].size):
        tt = T0 + timedelta(seconds=k)
        hms, dmy = tt.strftime("%H%M%S.00"), tt.strftime("%d%m%y")
        la, ns = ddmm(fl["lat"][k], "NS", 2)
        lo, ew = ddmm(fl["lon"][k], "EW", 3)
        s = f"{fl['N'][k]:.1f}" if sep else ""
        v = f"{fl['gs'][k] * knots:.1f},{fl['course'][k]:.1f}"
        out.append(nmea(f"GPRMC,{hms},A,{la},{ns},{lo},{ew},{v},{dmy},,,A"))
        gga = nmea(f"GPGGA,{hms},{la},{ns},{lo},{ew},1,09,0.8,{fl['H'][k]:.1f},M,{s},M,,")
        out.append(gga[:-2] + "00" if k in bad else gga)
    return out


def test_nmea_gga_rmc_midnight(tmp_path, fl):
    tr = read_track(write(tmp_path / "log.nmea", nmea_lines(fl, bad=(3, 4, 5))))
    assert len(tr) == fl["t"].size - 3 and any(
        "3 sentences with a bad checksum" in n for n in tr.notes
    )
    keep = np.setdiff1d(np.arange(fl["t"].size), [3, 4, 5])
    np.testing.assert_allclose(tr.t, fl["epoch"][keep])  # across midnight: the RMC dates
    np.testing.assert_allclose(tr.lat, fl["lat"][keep], atol=1e-6)
    np.testing.assert_allclose(tr.lon, fl["lon"][keep], atol=1e-6)
    assert tr.height_ref == "ellipsoid" and tr.lines[0] == 2
    np.testing.assert_allclose(tr.h, fl["h"][keep], atol=0.1)  # altitude + separation
    # no separation field: MSL + fieldmap's N; GGA without RMC: seconds of the day
    tm = read_track(write(tmp_path / "nosep.txt", nmea_lines(fl, sep=False)))
    assert tm.height_ref == "msl"
    np.testing.assert_allclose(tm.h - np.round(fl["H"], 1), geoid(tm), atol=0.02)
    gga_only = [s for s in nmea_lines(fl) if "GGA" in s]
    tg = read_track(write(tmp_path / "gga.nmea", gga_only))
    assert tg.t0_utc is None and tg.t[0] == 23 * 3600 + 45 * 60 and tg.t[-1] == 86400 + 899


def _velocity_report(track):
    return condition(track).report["velocity"]


def test_nmea_rmc_velocities_observed(tmp_path, fl):
    """RMC speed and course enter the fit; the report gives the flown residuals against them."""
    tr = read_track(write(tmp_path / "log.nmea", nmea_lines(fl)))
    v = tr.velocity
    assert v is not None and v.climb is None
    np.testing.assert_allclose(v.speed, fl["gs"], atol=0.051 * KT)  # printed to 0.1 kt
    np.testing.assert_allclose(v.track, fl["course"], atol=0.05)
    assert v.resolution == pytest.approx((0.1 * KT, 0.1, 0.0))
    assert any("receiver's velocities" in n for n in tr.notes)
    rep = _velocity_report(tr)
    assert rep["columns"] == ["RMC field 7 (speed)", "RMC field 8 (course)"]
    assert rep["groundspeed_rms_m_s"] < 0.2 and rep["track_rms_deg"] < 0.1


def test_nmea_rmc_velocities_in_the_wrong_unit_left_out(tmp_path, fl):
    """Speeds in km/h written where knots belong: a factor 1.85, the velocities left out.

    The positions alone fly the path; the note names the columns and the factor.
    """
    tr = read_track(write(tmp_path / "kmh.nmea", nmea_lines(fl, knots=3.6)))
    cf = condition(tr)
    (note,) = [n for n in cf.report["notes"] if "× its positions' throughout" in n]
    assert "RMC field 7" in note and "1.85 ×" in note
    assert "velocity" not in cf.report["channels"]


def test_nmea_rmc_void_or_without_course(tmp_path, fl):
    """Status V (void) RMC and RMC without a course give no velocity vector; said."""
    void = [s.replace(",A,", ",V,", 1) if "RMC" in s else s for s in nmea_lines(fl)]
    void = [nmea(s[1:-3]) for s in void]
    assert read_track(write(tmp_path / "void.nmea", void)).velocity is None
    nocourse = []
    for s in nmea_lines(fl):
        if "RMC" in s:
            f = s[1:-3].split(",")
            f[8] = ""
            s = nmea(",".join(f))
        nocourse.append(s)
    tr = read_track(write(tmp_path / "nocourse.nmea", nocourse))
    assert tr.velocity is None
    assert any("without a RMC field 8 (course)" in n for n in tr.notes)


def _gpx_velocity(fl, version: str) -> str:
    pts = []
    for k in range(fl["t"].size):
        sp, co = f"{fl['gs'][k]:.2f}", f"{fl['course'][k]:.2f}"
        if version == "1.0":
            vel = f"<course>{co}</course><speed>{sp}</speed>"
        else:
            vel = (
                "<extensions><gpxtpx:TrackPointExtension>"
                f"<gpxtpx:speed>{sp}</gpxtpx:speed><gpxtpx:course>{co}</gpxtpx:course>"
                "</gpxtpx:TrackPointExtension></extensions>"
            )
        pts.append(
            f'<trkpt lat="{fl["lat"][k]:.9f}" lon="{fl["lon"][k]:.9f}">'
            f"<ele>{fl['H'][k]:.2f}</ele><time>{iso(k)}</time>{vel}</trkpt>"
        )
    ns = f"http://www.topografix.com/GPX/{version.replace('.', '/')}"
    tpx = "http://www.garmin.com/xmlschemas/TrackPointExtension/v2"
    return (
        f'<?xml version="1.0"?><gpx version="{version}" creator="test" xmlns="{ns}" '
        f'xmlns:gpxtpx="{tpx}"><trk><trkseg>{"".join(pts)}</trkseg></trk></gpx>'
    )


@pytest.mark.parametrize("version", ["1.0", "1.1"])
def test_gpx_speed_and_course_observed(tmp_path, fl, version):
    """GPX 1.0 <speed>/<course>, GPX 1.1 Garmin TrackPointExtension speed/course."""
    pytest.importorskip("gpxpy")
    tr = read_track(write(tmp_path / f"v{version}.gpx", [_gpx_velocity(fl, version)]))
    v = tr.velocity
    assert v is not None
    np.testing.assert_allclose(v.speed, np.round(fl["gs"], 2))
    np.testing.assert_allclose(v.track, np.round(fl["course"], 2))
    assert v.resolution == pytest.approx((0.01, 0.01, 0.0))
    rep = _velocity_report(tr)
    assert rep["columns"] == ["<speed>", "<course>"]
    assert rep["groundspeed_rms_m_s"] < 0.2 and rep["track_rms_deg"] < 0.1


def b_record(k, fl, gnss, press=None):
    tt = T0 + timedelta(seconds=k)
    out = []
    for v, w, hemi in ((fl["lat"][k], 2, "NS"), (fl["lon"][k], 3, "EW")):
        a = abs(v)
        d, m = int(a), round((a - int(a)) * 60000)
        d, m = (d + 1, 0) if m >= 60000 else (d, m)
        out.append(f"{d:0{w}d}{m:05d}{hemi[int(v < 0)]}")
    p = round(fl["H"][k]) if press is None else press
    return f"B{tt:%H%M%S}{out[0]}{out[1]}A{p:05d}{gnss:05d}"


def test_igc_gnss_pressure_midnight(tmp_path, fl):
    head = ["AXXX001 fieldmap test", "HFDTEDATE:140623,01", "HFGIDGLIDERID:D-1234", "I013638FXA"]
    recs = [b_record(k, fl, round(fl["h"][k])) + "035" for k in range(fl["t"].size)]
    tr = read_track(write(tmp_path / "flight.igc", head + recs + ["GABCDEF"]))
    check_position(tr, fl, 1e-5)  # 0.001 minute
    np.testing.assert_allclose(tr.t, fl["epoch"])  # midnight rollover
    assert tr.height_ref == "ellipsoid" and any("HFALG" in n for n in tr.notes)
    np.testing.assert_allclose(tr.h, np.round(fl["h"]))
    assert tr.lines[0] == 5
    # HFALG says GEO: GNSS altitude is MSL; the old HFDTEDDMMYY header
    head2 = ["AXXX001", "HFDTE140623", "HFALGALTGPS:GEO"]
    recs = [b_record(k, fl, round(fl["H"][k])) for k in range(fl["t"].size)]
    tg = read_track(write(tmp_path / "geo.igc", head2 + recs))
    assert tg.height_ref == "msl"
    np.testing.assert_allclose(tg.h - np.round(fl["H"]), geoid(tg), atol=0.02)
    # no GNSS altitude: pressure altitude (ISA)
    recs = [b_record(k, fl, 0) for k in range(fl["t"].size)]
    tp = read_track(write(tmp_path / "baro.igc", head2 + recs))
    assert tp.height_ref == "pressure" and any("ISA" in n for n in tp.notes)
    Hp = np.round(fl["H"])
    np.testing.assert_allclose(tp.h - R_ISA * Hp / (R_ISA - Hp), geoid(tp), atol=0.02)


# --------------------------------------------------------------------------- tables


def test_dataframe_dataset_dict(fl):
    pd = pytest.importorskip("pandas")
    xr = pytest.importorskip("xarray")
    ts = pd.to_datetime(fl["epoch"], unit="s", utc=True)
    df = pd.DataFrame(
        dict(timestamp=ts, latitude=fl["lat"], longitude=fl["lon"], altitude=fl["H"] / FT)
    )
    tr = read_track(df)
    np.testing.assert_allclose(tr.t, fl["epoch"])
    assert tr.source == "DataFrame" and tr.height_ref == "pressure" and tr.lines[0] == 1
    ds = xr.Dataset(
        {
            k: ("time_s", fl[v])
            for k, v in (("lat_deg", "lat"), ("lon_deg", "lon"), ("height_m", "h"))
        },
        coords={"time_s": fl["t"]},
    )
    tx = read_track(ds)
    assert tx.source == "Dataset" and tx.height_ref == "ellipsoid"
    np.testing.assert_allclose(tx.h, fl["h"])
    arrays = {"T": fl["epoch"], "y": fl["lat"], "x": fl["lon"], "z": fl["H"]}
    ta = read_track(arrays, columns={"time": "T", "lat": "y", "lon": "x", "alt": "z"})
    assert ta.source == "arrays" and ta.t0_utc == "2023-06-14T23:45:00Z"
    with pytest.raises(InputError, match="arrays record 3 column y: 'north' is not a number"):
        bad = dict(arrays, y=np.array([str(v) for v in fl["lat"]], dtype=object))
        bad["y"][2] = "north"
        read_track(bad, columns="time=T,lat=y,lon=x,alt=z")


# --------------------------------------------------------------------------- bad input


def test_unknown_columns(tmp_path):
    path = write(tmp_path / "x.csv", ["when,north,east,up", "0,1,2,3"])
    with pytest.raises(InputError) as e:
        read_track(path)
    msg = str(e.value)
    assert "unrecognised columns (when, north, east, up)" in msg and "--columns time=" in msg
    assert "\n" not in msg
    with pytest.raises(InputError, match="no column 'lat'.*columns: when, north, east, up"):
        read_track(path, columns="time=when,lat=lat,lon=east,alt=up")


def test_bad_time_latitude_number(tmp_path, fl):
    rows = traffic_rows(fl)
    rows[5] = rows[5].replace(rows[5].split(",")[0], "2023-06-14 25:99:00")
    with pytest.raises(
        InputError, match=r"line 6 column timestamp: '2023-06-14 25:99:00' is not a time"
    ):
        read_track(write(tmp_path / "t.csv", rows))
    rows = ["time_s,lat_deg,lon_deg,height_m"] + [f"{k},46.5,7.0,1000" for k in range(20)]
    rows[10] = "9,95.5,7.0,1000"
    with pytest.raises(InputError, match=r"line 11 column lat_deg: 95.5 is beyond ±90°"):
        read_track(write(tmp_path / "lat.csv", rows))
    rows[10] = "9,46.5,7.0,1e3m"
    with pytest.raises(InputError, match=r"line 11 column height_m: '1e3m' is not a number"):
        read_track(write(tmp_path / "num.csv", rows))
    rows[10] = "9,46.5,400,1000"
    with pytest.raises(InputError, match=r"line 11 column lon_deg: 400 is beyond ±360°"):
        read_track(write(tmp_path / "lon.csv", rows))
    rows[10] = "9,46.5,7.0"
    with pytest.raises(InputError, match=r"line 11: 3 fields, the header \(line 1\) has 4"):
        read_track(write(tmp_path / "short.csv", rows))


def test_feet_read_as_metres(tmp_path, fl):
    path = write(tmp_path / "feet.csv", opensky_rows(fl, scale=1 / FT))
    with pytest.raises(InputError, match=r"altitudes up to 36,\d{3} m .*feet read as metres\?"):
        read_track(path)
    tr = read_track(path, alt_units="ft")  # declared: no guess, converted
    np.testing.assert_allclose(tr.h - fl["H"], geoid(tr), atol=0.05)
    jumpy = dict(fl, H=1000.0 + 600.0 * (np.arange(fl["t"].size) % 2))
    with pytest.raises(InputError, match=r"line \d+ column geoaltitude: vertical rate 600 m/s sus"):
        read_track(write(tmp_path / "rate.csv", opensky_rows(jumpy)))
    # units in the column name (fieldmap's height_m): no guess
    rows = ["time_s,lat_deg,lon_deg,height_m"]
    rows += [f"{k},{a},{b},{h / FT}" for k, a, b, h in zip(fl["t"], fl["lat"], fl["lon"], fl["H"])]
    assert read_track(write(tmp_path / "balloon.csv", rows)).h.max() > 36_000


def test_radians(tmp_path, fl):
    rows = ["time_s,lat_deg,lon_deg,height_m"]
    rows += [
        f"{t:g},{np.radians(a):.9f},{np.radians(b):.9f},1000"
        for t, a, b in zip(fl["t"], fl["lat"], fl["lon"])
    ]
    with pytest.raises(InputError, match="line 2 column lat_deg: .*look like radians"):
        read_track(write(tmp_path / "rad.csv", rows))


def test_not_a_flight(tmp_path):
    for name, data, what in (
        ("empty.csv", b"", "empty flight log"),
        ("blank.csv", b"\n  \n", "empty flight log"),
        ("comments.csv", b"# nothing\n", "empty flight log"),
        (
            "image.csv",
            b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(64),
            r"not a flight log \(a PNG image\)",
        ),
        ("blob.bin", b"\x01\x02\x00\x03" * 50, "binary data"),
        ("numbers.csv", b"1,2,3\n4,5,6\n", "line 1: numbers where the header row"),
        ("header.csv", b"time_s,lat_deg,lon_deg,height_m\n", r"a header \(line 1\) but no samples"),
        ("x.gpx", b"<gpx><wpt lat='1' lon='2'/></gpx>", "no track or route points"),
        ("x.igc", b"AXXX\nHFDTE010120\n", "no B record"),
    ):
        with pytest.raises(InputError, match=what):
            read_track(_bytes(tmp_path / name, data))
    with pytest.raises(InputError, match="flight log not found"):
        read_track(tmp_path / "missing.csv")


def _bytes(path, data):
    path.write_bytes(data)
    return path


def test_nmea_bad_checksums_only(tmp_path, fl):
    bad = [s[:-2] + ("00" if s[-2:] != "00" else "11") for s in nmea_lines(fl)[:40]]
    with pytest.raises(InputError, match=r"no usable GGA fix .*40 sentences with a bad checksum"):
        read_track(write(tmp_path / "bad.nmea", bad))
    nofix = [nmea("GPGGA,120000.00,,,,,0,00,,,M,,M,,")] * 3
    with pytest.raises(InputError, match="3 sentences without a fix"):
        read_track(write(tmp_path / "nofix.nmea", nofix))


def test_igc_bad_record(tmp_path, fl):
    recs = ["AXXX", "HFDTE140623"] + [b_record(k, fl, 1000) for k in range(5)]
    recs[4] = recs[4][:8] + "47x0000N" + recs[4][16:]
    with pytest.raises(InputError, match=r"line 5 column latitude \(B record bytes 8-15\)"):
        read_track(write(tmp_path / "bad.igc", recs))


def test_options_refused(tmp_path, fl):
    path = write(tmp_path / "s.csv", opensky_rows(fl)[:20])
    for kw, what in (
        ({"alt_units": "km"}, "alt_units"),
        ({"height_ref": "agl"}, "height_ref"),
        ({"time_format": "julian"}, "time_format"),
    ):
        with pytest.raises(InputError, match=what):
            read_track(path, **kw)
    igc = write(tmp_path / "a.igc", ["AXXX", "HFDTE140623", b_record(0, fl, 1000)])
    with pytest.raises(InputError, match="columns applies to CSV"):
        read_track(igc, columns="time=a,lat=b,lon=c,alt=d")


# --------------------------------------------------------------------------- real ADS-B data


def test_real_samples_in_repository():
    files = sorted(DATA.glob("*.csv.gz"))
    assert len(files) >= 2 and sum(f.stat().st_size for f in files) < 300_000
    for f in files:
        tr = read_track(f)
        assert len(tr) > 800 and tr.t0_utc is not None
        assert np.all(np.abs(tr.lat) <= 90) and np.all(np.isfinite(tr.h))
        assert any("layout traffic" in n for n in tr.notes)
    tr = read_track(DATA / "adsb_4b1815_porto_20220713.csv.gz")
    assert len(tr) == 4500 and tr.height_ref == "pressure" and tr.t[-1] - tr.t[0] > 3600


@pytest.mark.parametrize(
    "name", ["elal747", "noisy_landing", "cevennes", "qantas747", "munich", "sisteron"]
)
def test_traffic_package_samples(name):
    """Real logs of the traffic package (tests/data/adsb): 747s, a landing, gliders, a survey."""
    path = ADSB / f"{name}.csv.gz"
    with gzip.open(path, "rt") as f:
        rows = sum(1 for _ in f) - 1
    tr = read_track(path)
    assert len(tr) >= 0.95 * rows and tr.t0_utc is not None
    assert np.nanmax(tr.h) < 15_000


@pytest.mark.parametrize(
    "name, rows, spikes",
    [
        # line 7443 on: 15850 ft, 1150, 15800, 1700, 15750 (1 Hz)
        ("noisy_time_issue", 8294, [7445, 7447]),
        # 130 rows without an altitude (positions without a height); 35975 ft held during the
        # take-off roll at Zurich (line 86 on; 1525 ft between), trimmed with the roll by the
        # conditioning
        ("noisy_takeoff", 730, []),
    ],
)
def test_altitude_spikes_are_not_a_unit_error(name, rows, spikes):
    """Isolated barometric spikes in a log in feet: read (kept), then removed by conditioning."""
    tr = read_track(ADSB / f"{name}.csv.gz")
    assert len(tr) == rows
    cf = condition(tr)
    found = {
        line
        for f in cf.report["faults"]["list"]
        if f["channel"] == "height"
        for line in range(f["lines"][0], f["lines"][1] + 1)
    }
    assert set(spikes) <= found
    k = cf.report["kinematics"]
    assert k["peak_climb_rate_m_s"] < 30 and k["peak_descent_rate_m_s"] < 30  # an airliner
    for line in spikes:  # the conditioned height there: the trend of the neighbours
        j = int(np.searchsorted(tr.lines, line))
        h = np.interp(tr.t[j], cf.samples.t + cf.report["t_start_s"], cf.samples.h)
        assert abs(h - (tr.h[j - 1] + tr.h[j + 1]) / 2) < 20


def test_real_log_in_wrong_units_refused(tmp_path):
    """A real log mis-declared is still refused, spikes or not; declared right it is read."""
    path = ADSB / "noisy_time_issue.csv.gz"  # ft, with the spikes above: ft read as metres
    with pytest.raises(InputError, match=r"altitudes up to 38,\d{3} m .*feet read as metres\?"):
        read_track(path, columns="time=timestamp,lat=latitude,lon=longitude,alt=altitude")
    # a real climb (noisy_takeoff 17:39:58-17:41:02, 1875 -> 5125 ft, 16 m/s) made a fighter's
    # by 7 x its height gain (~110 m/s, < 25,000 ft), then written as feet and as metres
    with gzip.open(ADSB / "noisy_takeoff.csv.gz", "rt") as f:
        real = [r.split(",") for r in f.read().splitlines()[263:328] if r.split(",")[5]]
    a0 = float(real[0][5])
    rows = [f"{r[0]},{r[3]},{r[4]},{a0 + 7 * (float(r[5]) - a0):.1f}" for r in real]
    ft = write(tmp_path / "ft.csv", ["timestamp,latitude,longitude,altitude"] + rows)
    tr = read_track(ft)  # traffic layout: ft
    assert len(tr) == len(real) and 80 < np.ptp(tr.h) / np.ptp(tr.t) < 140
    m = write(tmp_path / "m.csv", ["time,lat,lon,baroaltitude"] + rows)  # OpenSky: metres
    with pytest.raises(
        InputError,
        match=r"m.csv line \d+ column baroaltitude: vertical rate \d{3} m/s sustained over 5 "
        r"samples \(an aircraft: < 300 m/s\): altitudes in m\? pass alt_units='ft'",
    ):
        read_track(m)


def test_glitches_alternating_with_the_altitudes_are_no_unit_error(tmp_path):
    """A relay aircraft's log that interleaves another's altitudes is read, with or without rates.

    The ``tour_de_france`` relay's climb (4,650 to 12,500 ft, 10:36-10:41) has altitudes of
    675-1,775 ft every sample or few: steps of 300-400 m/s both ways, 3 in 5 in places, that
    the running median keeps, but no height gained net. Without its velocity columns (positions
    and altitudes only, as many logs come) it was refused as feet read as metres; the
    conditioning rejects the glitches as faults and flies the climb.
    """
    src = Path(__file__).parent / "data" / "corpus" / "tv_relay" / "tour_de_france_3924a4_08.csv.gz"
    with gzip.open(src, "rt") as f:
        rows = [r.split(",") for r in f.read().splitlines()[:240]]
    keep = [j for j, c in enumerate(rows[0]) if c not in ("groundspeed", "track", "vertical_rate")]
    path = write(tmp_path / "relay.csv", [",".join(r[j] for j in keep) for r in rows])
    tr = read_track(path)
    assert len(tr) == len(rows) - 1
    # above 4,500 ft from line 26 on: the altitudes below 2,000 ft there are the other's
    low = [line for line, r in enumerate(rows[1:], start=2) if line > 25 and float(r[5]) < 2000]
    assert len(low) == 19
    cf = condition(tr)
    found = {
        line
        for f in cf.report["faults"]["list"]
        if f["channel"] == "height"
        for line in range(f["lines"][0], f["lines"][1] + 1)
    }
    assert set(low) <= found
    # the path climbs with the log's true altitudes, not down to the glitches
    k = cf.report["kinematics"]
    assert k["peak_climb_rate_m_s"] < 25 and k["peak_descent_rate_m_s"] < 25


def test_isolated_spikes_are_no_unit_error(tmp_path, fl):
    """Spikes (1 or 2 samples, two within 5) and a wrong level held are no sustained rate."""
    H = fl["H"].copy()
    H[[300, 302]] = [1150 * FT, 1700 * FT]  # two spikes down within 5 samples
    H[[600, 601]] = 36_000 * FT  # two samples up
    H[900:906] = 36_000 * FT  # a wrong level held 6 s (a take-off roll's)
    H[[1200, 1202, 1204]] = H[1200] + np.array([4000.0, -4000.0, 4000.0])  # 3 in 5, alternating
    spiky = dict(fl, H=H)
    tr = read_track(write(tmp_path / "spiky.csv", traffic_rows(spiky)))
    z = R_ISA * H / (R_ISA - H)
    np.testing.assert_allclose(tr.h - z, geoid(tr), atol=0.05)  # read as they are: not cleaned
    # the same spikes on a fighter's climb (100 m/s to 8 km) in feet read as metres: refused
    steep = dict(
        spiky,
        H=np.minimum(500.0 + 100.0 * fl["t"], 8000.0),
        vertrate=np.where(fl["t"] < 75.0, 100.0, 0.0),
    )
    steep["H"][[30, 32]] = [1150 * FT, 1700 * FT]
    steep["H"][[50, 51]] = 36_000 * FT
    assert read_track(write(tmp_path / "m.csv", opensky_rows(steep))).h.max() > 8000
    # the log has its own vertical rates: the conditioning holds the heights against them (the
    # reader's sustained-rate test is for logs without), and refuses the factor between them
    wrong = read_track(write(tmp_path / "ft.csv", opensky_rows(steep, scale=1 / FT)))
    with pytest.raises(InputError, match=r"vertical rates are [0-9.]+ × the rate of its heights"):
        condition(wrong)
