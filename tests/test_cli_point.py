"""``fieldmap point`` and ``fieldmap verify`` run as subprocesses (the way users run them)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from fieldmap.models.geographiclib import gravity_tool, run_gravity_tool, write_egm
from fieldmap.models.registry import load_model


def _run(args, stdin="", env=None):
    return subprocess.run(
        [sys.executable, "-m", "fieldmap", *args],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=300,
        env={**os.environ, **(env or {})},
    )


def _numbers(stdout):
    return np.array([[float(v) for v in line.split()] for line in stdout.splitlines()])


POINTS = np.array(
    [
        [45.0, 10.0, 1000.0],
        [90.0, 0.0, 0.0],
        [-89.99, 170.0, 100e3],
        [0.0, -75.5, 20e3],
        [-33.9, 151.2, -50.0],
    ]
)


def _stdin(points):
    return "".join(f"{a!r} {b!r} {c!r}\n" for a, b, c in np.asarray(points).tolist())


def test_disturbance_matches_api_and_geographiclib(tmp_path):
    """Default output: δg east north up in mGal, same as the API and as GeographicLib's Gravity."""
    from fieldmap.field import gravity as fg

    out = _run(["point", "--precision", "10"], _stdin(POINTS))
    assert out.returncode == 0, out.stderr
    got = _numbers(out.stdout)
    want = fg.disturbance(POINTS[:, 0], POINTS[:, 1], POINTS[:, 2], model="eigen-6s")
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)  # printed with 10 decimals
    if gravity_tool():
        name = write_egm(load_model(), tmp_path)
        tool = run_gravity_tool(POINTS, tmp_path, name, "disturbance", precision=10)
        np.testing.assert_allclose(got, tool, rtol=0, atol=1e-8)
    default = _numbers(_run(["point"], _stdin(POINTS[:1])).stdout)  # 3 decimals, as Gravity
    np.testing.assert_allclose(default[0], want[0], rtol=0, atol=5e-4 + 1e-12)


def test_gravity_and_normal_quantities():
    """--quantity gravity (m/s², incl. centrifugal) and normal --normal (the names of normal=)."""
    from fieldmap.field import gravity as fg
    from fieldmap.field.normal import normal_gravity

    lat, lon, h = POINTS.T
    out = _run(
        ["point", "--quantity", "gravity", "--precision", "14", "--lmax", "60"], _stdin(POINTS)
    )
    assert out.returncode == 0, out.stderr
    want = fg.gravity(lat, lon, h, model=load_model("eigen-6s", lmax=60))
    np.testing.assert_allclose(_numbers(out.stdout), want, rtol=0, atol=1e-13)
    for kind in ("exact", "j2", "j4", "j6", "GROVES_J2"):  # any case, _ or -, as normal=
        out = _run(
            ["point", "--quantity", "normal", "--normal", kind, "--precision", "14"], _stdin(POINTS)
        )
        assert out.returncode == 0, out.stderr
        want = normal_gravity(lat, lon, h, normal=kind, centrifugal=True, frame="enu")
        np.testing.assert_allclose(_numbers(out.stdout), want, rtol=0, atol=1e-13)
    exact = _numbers(_run(["point", "--quantity", "normal", "--precision", "9"], "0 0 0\n").stdout)[
        0
    ]
    assert exact[2] == pytest.approx(-9.7803253359, abs=1e-9)  # WGS84 γ_e (NIMA TR8350.2)


def test_bad_lines_keep_line_count():
    """Each bad line prints ERROR in its place; good lines are computed; exit status 1."""
    lines = [
        "45 10 1000",
        "foo 1 2",
        "91 0 0",
        "",
        "1 2 3 4",
        "0 0 nan",
        "0 0 -20000",
        "0 0 1e12",
        "12 34",
        "inf 0 0",
        "-89.99 170 100000",
    ]
    out = _run(["point"], "\n".join(lines) + "\n")
    assert out.returncode == 1
    assert "Traceback" not in out.stderr + out.stdout
    res = out.stdout.splitlines()
    assert len(res) == len(lines)
    bad = {
        1: "not a number",
        2: "latitude must be within [-90, 90]",
        3: "0 fields",
        4: "4 fields",
        5: "not finite",
        6: "below the ellipsoid",
        7: "is above",
        9: "not finite",
    }
    for i, text in enumerate(res):
        if i in bad:
            assert text.startswith("ERROR: ") and bad[i] in text, (i, text)
        else:
            assert len(text.split()) == 3 and not text.startswith("ERROR"), (i, text)
    good = _numbers("\n".join(res[i] for i in (0, 10)))
    alone = _numbers(_run(["point"], "45 10 1000\n-89.99 170 100000\n").stdout)
    np.testing.assert_array_equal(good, alone)
    h0 = _run(["point"], "12 34\n12 34 0\n").stdout.splitlines()
    assert h0[0] == h0[1]  # h defaults to 0, as in GeographicLib's Gravity


@pytest.mark.parametrize(
    "args, msg",
    [
        (["--model", "no-such-model"], "unknown model"),
        (["--lmax", "500"], "exceeds the degree"),
        (["--device", "cuda:7"], "not present"),
        (["--epoch", "someday"], "bad epoch"),
        (["--precision", "-1"], "--precision"),
    ],
)
def test_bad_options_one_line(args, msg):
    """Bad options: one line on stderr, exit 2, no traceback."""
    out = _run(["point", *args], "45 10 0\n")
    assert out.returncode == 2
    assert msg in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_empty_input():
    """No input lines: no output, success."""
    out = _run(["point"], "")
    assert (out.returncode, out.stdout) == (0, "")


def test_verify_command():
    """``fieldmap verify`` prints the table and passes on this machine."""
    out = _run(["verify", "--device", "cpu", "--lmax", "40", "--points", "30"])
    assert out.returncode == 0, out.stdout + out.stderr
    text = out.stdout
    for what in (
        "SH gravitation",
        "normal gravitation exact",
        "normal gravitation j6",
        "max rel diff",
        "kernel [ms]",
    ):
        assert what in text
    assert "FAIL" not in text


def test_verify_reports_failures(monkeypatch):
    """A comparison beyond 1e-12 relative is flagged (so the command can fail)."""
    from fieldmap.cli import verify

    def broken(device, opts):
        yield verify._compare(
            "deliberately wrong", device, lambda: np.ones(3) * (1 + 1e-9), lambda: np.ones(3), ""
        )

    monkeypatch.setattr(verify, "CHECKS", (("numpy", broken),))
    rows = verify.run_checks(["cpu"])
    assert len(rows) == 1 and not rows[0].ok
    assert rows[0].max_rel == pytest.approx(1e-9, rel=1e-6, abs=0)
    assert "FAIL" in verify.format_table(rows)


def test_comma_separated_points_read_as_whitespace_separated():
    """``printf "30,105,20000" | fieldmap point``: the CSV export a user has at hand.

    Comma-separated lines (spaces around the commas allowed, h optional) give the numbers of the
    same points separated by whitespace; an empty field is a bad line, not a number skipped.
    """
    points = "30 105 20000\n-33.9 151.2\n45.5 -10 1000\n"
    commas = "30,105,20000\n-33.9, 151.2\n 45.5 , -10 , 1000 \n"
    want = _run(["point", "--precision", "10"], points)
    got = _run(["point", "--precision", "10"], commas)
    assert want.returncode == got.returncode == 0, got.stderr
    assert got.stdout == want.stdout and len(got.stdout.splitlines()) == 3
    bad = _run(["point"], "30,,105\n30,105,20000,5\n")
    assert bad.returncode == 1
    first, second = bad.stdout.splitlines()
    assert first == "ERROR: empty field 2 in '30,,105'"
    assert second == "ERROR: expected 'lat lon [h]', got 4 fields"
