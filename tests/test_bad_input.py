"""Bad input to every sub-command and to the public API: one clear line, exit != 0, no files.

Each CLI case runs ``fieldmap.cli.main`` in this process (fast: Warp and the model are loaded
once) from an empty working folder that holds only the fixture files, and asserts: the exit
status, exactly one line on stderr naming the problem (never a traceback or a usage block), and
that no file or folder appeared (the default ``outputs/`` lies in that folder too). A few cases
run the real console script in a child process: signals, a broken pipe, argparse's own errors.
"""

from __future__ import annotations

import gzip
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fieldmap import cli
from fieldmap.errors import FieldmapError, InputError, ModelFileError

# A tiny valid ICGEM file (degree 2) and corruptions of it, each naming what must be reported.
_HEAD = """begin_of_head
modelname tiny
earth_gravity_constant 3.986004415E+14
radius 6378136.3
max_degree 2
norm fully_normalized
errors no
end_of_head
"""
_BODY = """gfc 0 0 1.0 0.0
gfc 1 0 0.0 0.0
gfc 1 1 0.0 0.0
gfc 2 0 -4.84165E-04 0.0
gfc 2 1 0.0 0.0
gfc 2 2 2.4e-06 -1.4e-06
"""
BAD_MODELS = {
    "empty.gfc": (b"", "empty file"),
    "garbage.gfc": (bytes(range(256)) * 8, "binary byte"),
    "text.gfc": (b"hello world\n", "end_of_head"),
    "corrupt.gfc.gz": (gzip.compress((_HEAD + _BODY).encode())[:40], "corrupt gzip"),
    "nohead_key.gfc": ((_HEAD.replace("radius 6378136.3\n", "") + _BODY).encode(), "'radius'"),
    "badnum.gfc": ((_HEAD + _BODY.replace("-4.84165E-04", "-4.8x165E-04")).encode(),
                   "line 12: bad number"),
    "gap.gfc": ((_HEAD + _BODY.replace("gfc 2 1 0.0 0.0\n", "")).encode(), "n=2 m=1"),
    "dup.gfc": ((_HEAD + _BODY + "gfc 2 2 0.0 0.0\n").encode(), "duplicate"),
    "n_lt_m.gfc": ((_HEAD + _BODY + "gfc 1 2 0.0 0.0\n").encode(), "order m > degree n"),
    "norm.gfc": ((_HEAD.replace("fully_normalized", "semi") + _BODY).encode(),
                 "unknown normalisation"),
    "truncated.gfc": ((_HEAD + _BODY[:40]).encode(), "line 11: 'gfc' line with 0 values"),
    "headeronly.gfc": (_HEAD.encode(), "no coefficient lines"),
    "nan.gfc": ((_HEAD + _BODY.replace("2.4e-06", "nan")).encode(), "bad number 'nan'"),
    "huge.gfc": ((_HEAD + _BODY.replace("2.4e-06", "1e300")).encode(),
                 "line 14: coefficient n=2 m=2 is 1e+300"),
}
# parse, but are no Earth model: evaluating them gave NaN or 1e300 mGal, printed as numbers
ALIEN_MODELS = {
    "moon.gfc": ("3.986004415E+14", "4.902800066E+12", "GM 4.9028e+12"),
    "radius.gfc": ("radius 6378136.3", "radius 1e300", "radius 1e+300 m"),
    "tinyradius.gfc": ("radius 6378136.3", "radius 1e-300", "radius 1e-300 m"),
}


@pytest.fixture
def work(tmp_path, monkeypatch):
    """Return an empty working folder (the cwd) holding the fixture files."""
    for name, (data, _) in BAD_MODELS.items():
        (tmp_path / name).write_bytes(data)
    (tmp_path / "good.gfc").write_text(_HEAD + _BODY)
    for name, (a, b, _) in ALIEN_MODELS.items():
        (tmp_path / name).write_text(_HEAD.replace(a, b) + _BODY)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def _main(argv, capsys, stdin: str | None = None, monkeypatch=None) -> tuple[int, str, str]:
    if stdin is not None:
        import io

        class _Stdin(io.StringIO):
            buffer = io.BytesIO(stdin.encode())

        monkeypatch.setattr(sys, "stdin", _Stdin(stdin))
    try:
        rc = cli.main(argv)
    except SystemExit as exc:  # argparse
        rc = exc.code
    out = capsys.readouterr()
    return rc, out.out, out.err


def _assert_one_line(rc, err, want_rc, msg, before, root):
    lines = err.strip().splitlines()
    assert rc == want_rc, (rc, err)
    assert len(lines) == 1, err
    assert "Traceback" not in err and "usage:" not in err
    assert msg.lower() in lines[0].lower(), lines[0]
    assert _tree(root) == before, sorted(_tree(root) - before)


# ----------------------------------------------------------------------------- fieldmap point
POINT_OPTIONS = [
    (["--lmax", "-1"], "--lmax must be >= 0"),
    (["--lmax", "241"], "exceeds the degree 240"),
    (["--lmax", "1.5"], "invalid int value: '1.5'"),
    (["--lmax", "nan"], "invalid int value"),
    (["--lmax", "99999999999"], "exceeds the degree"),
    (["--epoch", "garbage"], "bad epoch"),
    (["--epoch", "nan"], "not a decimal year"),
    (["--epoch", "inf"], "not a decimal year"),
    (["--epoch", "2010-13-45"], "bad epoch"),
    (["--model", "nonexist.gfc"], "unknown model"),
    (["--model", "adir"], "is a directory"),
    (["--model", ""], "unknown model"),
    (["--device", "cuda:7"], "not present"),
    (["--device", "tpu"], "not present"),
    (["--quantity", "foo"], "invalid choice"),
    (["--normal", "j8"], "invalid choice"),
    (["--precision", "nan"], "invalid int value"),
    (["--precision", "100"], "--precision"),
    (["--input", "nonexist.txt"], "No such file"),
    (["--input", "adir"], "Is a directory"),
    (["--model", "/dev/zero"], "binary byte 0x00"),
] + [(["--model", name], msg) for name, (_, msg) in BAD_MODELS.items()] + [
    (["--model", name], msg) for name, (_, _, msg) in ALIEN_MODELS.items()]


@pytest.mark.parametrize("args, msg", POINT_OPTIONS, ids=lambda v: str(v))
def test_point_bad_options(work, capsys, monkeypatch, args, msg):
    """Bad options of ``fieldmap point``: exit 2, one line naming the problem."""
    before = _tree(work)
    rc, out, err = _main(["point", *args], capsys, "10 20 30\n", monkeypatch)
    _assert_one_line(rc, err, 2, msg, before, work)
    assert out == ""


BAD_LINES = {
    "nan 10 0": "latitude 'nan' is not finite",
    "10 inf 0": "longitude 'inf' is not finite",
    "10 10 -inf": "height '-inf' is not finite",
    "91 10 0": "latitude 91 outside",
    "10 1e300 0": "longitude 1e+300 outside [-540, 540)",
    "10 10 -1e6": "below the ellipsoid",
    "10 10 1e300": "height 1e+300 m is above",
    "a b c": "latitude 'a' is not a number",
    "1 2 3 4": "got 4 fields",
    "": "got 0 fields",
    "\x00\x01": "got 1 fields",
}


def test_point_bad_lines(work, capsys, monkeypatch):
    """Each bad line prints ERROR in its place; one summary line on stderr; exit 1."""
    lines = ["45 10 100", *BAD_LINES, "-30 200 0"]
    before = _tree(work)
    rc, out, err = _main(["point"], capsys, "\n".join(lines) + "\n", monkeypatch)
    got = out.splitlines()
    assert len(got) == len(lines)
    assert not got[0].startswith("ERROR") and not got[-1].startswith("ERROR")
    for text, (line, why) in zip(got[1:-1], BAD_LINES.items()):
        assert text.startswith("ERROR: ") and why in text, (line, text)
    assert np.isfinite([float(v) for v in got[0].split() + got[-1].split()]).all()
    _assert_one_line(rc, err, 1, f"{len(BAD_LINES)} of {len(lines)} input lines", before, work)


def test_point_never_prints_non_finite(work, capsys, monkeypatch):
    """A result that is NaN or inf is reported as a bad line, not printed as a number."""
    from fieldmap import cli_point

    monkeypatch.setattr(cli_point, "evaluate_points",
                        lambda lat, *a: np.array([[1.0, 2.0, 3.0], [np.nan, 0.0, 0.0]]))
    rc, out, err = _main(["point"], capsys, "1 2 3\n4 5 6\n", monkeypatch)
    assert out.splitlines() == ["1.000 2.000 3.000", "ERROR: result is not finite "
                                "(point too close to the masses for this model)"]
    assert rc == 1 and len(err.splitlines()) == 1


def test_point_input_size_is_capped(work, capsys, monkeypatch):
    """``--input /dev/zero`` ends with one error line instead of filling the memory."""
    from fieldmap import cli_point

    monkeypatch.setattr(cli_point, "MAX_INPUT_BYTES", 8 << 20)
    before = _tree(work)
    rc, out, err = _main(["point", "--input", "/dev/zero"], capsys)
    _assert_one_line(rc, err, 2, "/dev/zero: more than", before, work)
    assert out == ""


def test_model_from_a_pipe(work, capsys, monkeypatch):
    """A model read from a pipe (``--model <(zcat f.gz)``) works; binary streams stop at once."""
    r, w = os.pipe()
    with open(w, "wb") as fh:
        fh.write((_HEAD + _BODY).encode())
    rc, out, err = _main(["point", "--model", f"/dev/fd/{r}"], capsys, "10 20 0\n", monkeypatch)
    os.close(r)
    assert rc == 0 and len(out.split()) == 3, err


def test_point_empty_input(work, capsys, monkeypatch):
    """Empty stdin is zero points (as GeographicLib's Gravity): no output, exit 0, silent."""
    rc, out, err = _main(["point"], capsys, "", monkeypatch)
    assert (rc, out, err) == (0, "", "")


# ----------------------------------------------------------------------------- fieldmap verify
@pytest.mark.parametrize("args, msg", [
    (["--lmax", "-1"], "within 0..240"),
    (["--lmax", "241"], "within 0..240"),
    (["--lmax", "x"], "invalid int value"),
    (["--points", "0"], "within 5..1000000"),
    (["--points", "100000000"], "within 5..1000000"),
    (["--points", "x"], "invalid int value"),
    (["--device", "cuda:7"], "not present"),
    (["--device", "bogus"], "not present"),
])
def test_verify_bad_options(work, capsys, args, msg):
    """Bad options of ``fieldmap verify``."""
    before = _tree(work)
    rc, _, err = _main(["verify", *args], capsys)
    _assert_one_line(rc, err, 2, msg, before, work)


# ----------------------------------------------------------------- fieldmap map/sweep/truncation
GRID_CASES = [
    (["--step-deg", "0"], "step must be a positive number"),
    (["--step-deg", "-1"], "step must be a positive number"),
    (["--step-deg", "nan"], "step must be a positive number"),
    (["--step-deg", "inf"], "step must be a positive number"),
    (["--step-deg", "x"], "invalid float value"),
    (["--step-deg", "200"], "larger than 90"),
    (["--step-deg", "0.03"], "GiB"),  # the result would not fit in (8 GiB of) memory
    (["--lat-max", "91"], "latitude limit"),
    (["--lat-max", "-1"], "latitude limit"),
    (["--lat-max", "nan"], "latitude limit"),
    (["--lat-max", "0"], "no area"),
    (["--region", "10", "10", "0", "10"], "empty region"),
    (["--region", "0", "10", "10", "10"], "empty region"),
    (["--region", "0", "10", "20", "10"], "empty region"),
    (["--region", "nan", "10", "0", "10"], "finite"),
    (["--region", "0", "10", "0", "inf"], "finite"),
    (["--region", "0", "10", "-95", "10"], "within -90..90"),
    (["--region", "0", "400", "0", "10"], "within -360..360"),
    (["--region", "0", "1", "0", "1"], "larger than the region"),
    (["--region", "0", "10", "0"], "expected 4 arguments"),
    (["--device", "cuda:7"], "not present"),
    (["--device", "bogus"], "not present"),
    (["--ellipsoid", "foo"], "unknown ellipsoid"),
    (["--out", "afile"], "not a folder"),
    (["--out", "afile/sub"], "not a folder"),
    (["--out", "/proc/fieldmap_out"], "cannot create output folder"),
    (["--out", "/dev/null"], "not a folder"),
    (["--out", "/proc/self"], "is not writable"),
    (["--out", "/sys"], "is not writable"),
    (["--out", ""], "output folder name is empty"),
    (["--height-km", "nan"], "finite"),
    (["--height-km", "inf"], "finite"),
    (["--height-km=-inf"], "finite"),
    (["--height-km", "x"], "'x'"),
    (["--height-km", "-100"], "below -1000 m"),
    (["--height-km", "-6400"], "below -1000 m"),
    (["--height-km", "1e300"], "is above 100000 km"),
]
MODEL_CASES = [
    (["--lmax", "-1"], "outside the model"),
    (["--lmax", "241"], "exceeds the degree 240"),
    (["--lmax", "1.5"], "invalid int value"),
    (["--epoch", "garbage"], "bad epoch"),
    (["--epoch", "1e300"], "not a decimal year"),
    (["--model", "nonexist.gfc"], "unknown model"),
    (["--model", "adir"], "is a directory"),
    (["--model", "garbage.gfc"], "binary byte"),
    (["--model", "corrupt.gfc.gz"], "corrupt gzip"),
    (["--model", "good.gfc", "--lmax", "3"], "outside 0..2"),
    (["--thresholds-mg", "x"], "'x' is not a number"),
    (["--thresholds-mg", "nan"], "positive finite"),
    (["--thresholds-mg", "-1"], "positive finite"),
    (["--thresholds-mg", "0"], "positive finite"),
    (["--thresholds-mg", "0.05,x"], "'x' is not a number"),
    (["--thresholds-mg", ","], "no value"),
    (["--thresholds-mg", "0.05,0.05"], "repeated threshold"),
]


def _grid_argv(cmd, args):
    step = [] if any(a.startswith("--step-deg") for a in args) else ["--step-deg", "5"]
    return [cmd, *args, *step]


@pytest.mark.parametrize("cmd", ["map", "sweep", "truncation"])
@pytest.mark.parametrize("args, msg", GRID_CASES, ids=lambda v: str(v))
def test_grid_bad_input(work, capsys, monkeypatch, cmd, args, msg):
    """Bad grid specifications, heights, devices and output folders: exit 2, nothing written."""
    from fieldmap import cli_maps

    # the memory check must not depend on this machine: pretend it has 8 GiB
    monkeypatch.setattr(cli_maps, "_memory_bytes", lambda: 8 * 2**30)
    before = _tree(work)
    rc, _, err = _main(_grid_argv(cmd, args), capsys)
    _assert_one_line(rc, err, 2, msg, before, work)


@pytest.mark.parametrize("cmd", ["map", "sweep"])
@pytest.mark.parametrize("args, msg", MODEL_CASES, ids=lambda v: str(v))
def test_model_bad_input(work, capsys, cmd, args, msg):
    """Bad model, degree, epoch and thresholds of the map products."""
    before = _tree(work)
    rc, _, err = _main(_grid_argv(cmd, args), capsys)
    _assert_one_line(rc, err, 2, msg, before, work)


@pytest.mark.parametrize("args, msg", [
    (["--height-km", "20,nan,30"], "finite"),
    (["--height-km", "20", "x"], "'x' is not a number"),
    (["--height-km", ","], "no value"),
    (["--height-km", "20,20"], "repeated height"),
    (["--height-km", "20", "2e5"], "is above 100000 km"),
])
def test_sweep_bad_heights(work, capsys, args, msg):
    """Lists of heights with one bad entry."""
    before = _tree(work)
    rc, _, err = _main(_grid_argv("sweep", args), capsys)
    _assert_one_line(rc, err, 2, msg, before, work)


@pytest.mark.parametrize("orders, msg", [
    ("x", "'x' is not a number"),
    ("3", "among 2, 4, 6"),
    ("8", "among 2, 4, 6"),
    ("2,2", "distinct"),
    ("2.5", "'2.5' is not a number"),
    ("", "no value"),
])
def test_truncation_bad_orders(work, capsys, orders, msg):
    """``--orders`` of ``fieldmap truncation``."""
    before = _tree(work)
    rc, _, err = _main(["truncation", "--orders", orders, "--step-deg", "5"], capsys)
    _assert_one_line(rc, err, 2, msg, before, work)


def test_missing_out_folder_is_created_only_on_success(work, capsys):
    """A missing --out folder is created (with parents) by a good run, and not by a bad one."""
    rc, _, err = _main(["truncation", "--step-deg", "5", "--height-km", "nan",
                        "--out", "new/deeper"], capsys)
    assert rc == 2 and not (work / "new").exists(), err
    rc, _, err = _main(["truncation", "--step-deg", "30", "--orders", "2", "--no-plots",
                        "--out", "new/deeper"], capsys)
    assert rc == 0, err
    names = sorted(p.name for p in (work / "new" / "deeper").iterdir())
    assert [n.rsplit(".", 1)[1] for n in names] == ["json", "nc"], names


# ----------------------------------------------------------------------------- fieldmap navsim
NAVSIM_CASES = [
    (["--rate", "0"], "--rate must be a positive number"),
    (["--rate", "nan"], "--rate must be a positive number"),
    (["--rate", "inf"], "--rate must be a positive number"),
    (["--rate", "x"], "invalid float value"),
    (["--rate", "1e7"], "IMU samples, more than"),
    (["--duration", "0"], "--duration must be a positive number"),
    (["--duration", "nan"], "--duration must be a positive number"),
    (["--duration", "1e9"], "longer than the boost-glide path"),
    (["--duration", "0.001"], "fewer than 2 IMU samples"),
    (["--output-dt", "0"], "--output-dt must be a positive number"),
    (["--output-dt", "inf"], "--output-dt must be a positive number"),
    (["--output-dt", "1e9"], "longer than --duration"),
    (["--draws", "0"], "--draws must be within"),
    (["--draws", "1000000"], "--draws must be within"),
    (["--draws", "x"], "invalid int value"),
    (["--gauss", "0"], "--gauss"),
    (["--seed", "-1"], "--seed must be >= 0"),
    (["--truth", "nonexist.gfc"], "unknown model"),
    (["--truth", "foo"], "unknown model"),
    (["--truth", "empty.gfc"], "empty file"),
    (["--truth", "garbage.gfc"], "binary byte"),
    (["--truth", "corrupt.gfc.gz"], "corrupt gzip"),
    (["--truth-degree", "-1"], "outside the model"),
    (["--truth-degree", "241"], "exceeds the degree 240"),
    (["--models", "foo"], "unknown navigation gravity model 'foo'"),
    (["--models", ","], "no navigation gravity model"),
    (["--models", "j2,sh300"], "outside 2..240"),
    (["--models", "sh-1"], "unknown navigation gravity model"),
    (["--models", "j8"], "unknown navigation gravity model"),
    (["--nav", "foo"], "unknown navigation gravity model"),
    (["--study", "table9"], "invalid choice"),
    (["--bias-mode", "x"], "invalid choice"),
    (["--device", "cuda:7"], "not present"),
    (["--out", "afile"], "not a folder"),
    (["--out", "afile/sub"], "not a folder"),
    (["--out", "/proc/fieldmap_out"], "cannot create output folder"),
    (["--out", ""], "output folder name is empty"),
]


@pytest.mark.parametrize("args, msg", NAVSIM_CASES, ids=lambda v: str(v))
def test_navsim_bad_input(work, capsys, args, msg):
    """Bad ``fieldmap navsim`` options are all found before any work starts."""
    before = _tree(work)
    argv = ["navsim", *args] + ([] if args[0] == "--duration" else ["--duration", "5"])
    rc, out, err = _main(argv, capsys)
    _assert_one_line(rc, err, 2, msg, before, work)
    assert out == ""


# ----------------------------------------------------------------------------- public API
def test_api_models_and_reader(work):
    """``load_model`` and ``read_icgem`` raise FieldmapError subclasses for bad arguments."""
    from fieldmap.icgem import read_icgem
    from fieldmap.models import load_model

    for lmax in (1.5, float("nan"), float("inf"), "x", True, [3]):
        with pytest.raises(InputError, match="integer degree"):
            load_model(lmax=lmax)
        with pytest.raises(InputError, match="integer degree"):
            read_icgem("good.gfc", lmax=lmax)
    assert load_model("good.gfc", lmax=2.0).lmax == 2  # an integral float is a degree
    assert load_model(None, lmax=4).lmax == 4  # None: the default model
    with pytest.raises(InputError, match="outside 0..2"):
        read_icgem("good.gfc", lmax=-1)
    for bad in (123, 4.5, object()):
        with pytest.raises(InputError, match="model must be"):
            load_model(bad)
    with pytest.raises(InputError, match="must be a path"):
        read_icgem(None)
    for epoch in ([2010], {"y": 1}, True, "2010-02-30", float("nan")):
        with pytest.raises(InputError, match="epoch"):
            load_model(epoch=epoch)
    for name, (_, msg) in BAD_MODELS.items():
        with pytest.raises(ModelFileError, match=msg.replace("+", r"\+")) as info:
            read_icgem(name)
        assert name in str(info.value) and "\n" not in str(info.value)
    for name, (_, _, msg) in ALIEN_MODELS.items():
        assert read_icgem(name).lmax == 2  # a valid file ...
        with pytest.raises(InputError, match="not an Earth model"):
            load_model(name)  # ... but not a model fieldmap evaluates


def test_api_maps_reject_bad_grids():
    """The map API refuses the same grids as the CLI (the checks live in fieldmap.grid)."""
    import fieldmap

    cases = [
        (fieldmap.disturbance_map, {"step_deg": 0}),
        (fieldmap.disturbance_map, {"step_deg": "x"}),
        (fieldmap.disturbance_map, {"step_deg": 10, "lat_max": 91}),
        (fieldmap.disturbance_map, {"step_deg": 10, "height_km": float("nan")}),
        (fieldmap.disturbance_map, {"step_deg": 10, "height_km": -100}),
        (fieldmap.disturbance_map, {"step_deg": 10, "lmax": 241}),
        (fieldmap.disturbance_map, {"step_deg": 10, "lmax": 1.5}),
        (fieldmap.disturbance_map, {"step_deg": 10, "region": (0, 10, 20, 10)}),
        (fieldmap.disturbance_map, {"step_deg": 10, "thresholds_mg": [-1]}),
        (fieldmap.disturbance_map, {"step_deg": 10, "model": "nonexist.gfc"}),
        (fieldmap.disturbance_map, {"step_deg": 10, "epoch": "garbage"}),
        (fieldmap.altitude_sweep, {"step_deg": 10, "height_km": []}),
        (fieldmap.altitude_sweep, {"step_deg": 10, "height_km": [20, float("inf")]}),
        (fieldmap.truncation_map, {"step_deg": 10, "orders": [3]}),
        (fieldmap.truncation_map, {"step_deg": 10, "orders": [2, 2]}),
    ]
    for func, kw in cases:
        with pytest.raises(FieldmapError):
            func(**kw)


def test_api_gravity_rejects_bad_points():
    """``fieldmap.gravity`` refuses non-numeric, non-finite and impossible coordinates."""
    from fieldmap import gravity as fg

    for lat, lon, h in (([np.nan], [0], [0]), (["a"], [0], [0]), ([91], [0], [0]),
                        ([0], [np.inf], [0]), ([0], [0], [np.inf]), ([0], [0], [-1e6])):
        for func in (fg.gravitation, fg.gravity, fg.disturbance):
            with pytest.raises(InputError):
                func(lat, lon, h)
    with pytest.raises(InputError):
        fg.disturbance([0], [0], [0], lmax=500)
    with pytest.raises(InputError):
        fg.disturbance([0], [0], [0], frame="xyz")


def test_api_navsim_inputs():
    """Navigation inputs: IMU arrays, dt, names, degrees, trajectories below the surface."""
    from fieldmap import imu, navsim
    from fieldmap.launch_frames import LaunchFrame
    from fieldmap.models import load_model
    from fieldmap.trajectory import Stationary

    good = np.zeros((10, 3))
    for dth, dv, dt, msg in (
        (good, good, 0.0, "positive"),
        (good, good, -0.005, "positive"),
        (good, good, float("nan"), "positive"),
        (good, good, "x", "must be a number"),
        (good, np.zeros((12, 3)), 0.005, "differ in length"),
        (good, np.zeros((10, 2)), 0.005, r"shape \(n, 3\)"),
        (good[:9], good[:9], 0.005, "even number"),
        ([["a", "b", "c"]] * 10, good, 0.005, "numeric arrays"),
        (np.full((10, 3), np.nan), good, 0.005, "NaN or inf"),
        (good, np.full((10, 3), np.inf), 0.005, "NaN or inf"),
    ):
        with pytest.raises(InputError, match=msg):
            imu.validate_increments(dth, dv, dt)
    model = load_model(lmax=40)
    for names, msg in ((["j8"], "unknown"), (["sh41"], "outside 2..40"), ([], "no navigation")):
        with pytest.raises(InputError, match=msg):
            navsim.check_model_names(names, model)
    with pytest.raises(InputError, match="unknown gravity model kind"):
        imu.Gravitation("j8")
    with pytest.raises(InputError, match="output interval"):
        navsim.build_scenario(duration=2.0, output_dt=float("nan"))
    with pytest.raises(InputError, match="more than"):
        imu.sample_count(800.0, 1e6)
    for n in (0, -1, 2.5, 1000):
        with pytest.raises(InputError, match="Gauss"):
            imu.gauss_legendre01(n)
    frame = LaunchFrame(lon0=105.0, B0=25.0, A0=90.0)
    for kw in ({"lat": 91.0}, {"h": float("nan")}, {"lon": "x"}):
        with pytest.raises(InputError):
            Stationary(frame, 10.0, **kw)
    for duration in ("x", None, float("nan"), 0.0):
        with pytest.raises(InputError, match="duration"):
            Stationary(frame, duration)
    with pytest.raises(InputError, match="not present"):
        imu.Gravitation("j2", device="cuda:7")
    with pytest.raises(InputError, match="integer degree"):
        imu.Gravitation("sh", model=model, lmax=2.5)
    for kw in ({"duration": "x"}, {"rate_hz": float("inf")}, {"output_dt": -1.0}):
        with pytest.raises(InputError, match="must be a positive number"):
            navsim.build_scenario(**kw)
    deep = Stationary(frame, 10.0, h=-5000.0)
    with pytest.raises(InputError, match="below the surface"):
        imu.synthesize(deep, 20.0, imu.Gravitation("j2"))


def test_api_verify():
    """``fieldmap.verify.run_checks`` checks its arguments before running anything."""
    from fieldmap.verify import run_checks

    for kw, msg in (({"devices": ["cuda:7"]}, "not present"), ({"devices": "tpu"}, "not present"),
                    ({"lmax": 241}, "0..240"), ({"lmax": 2.5}, "integer degree"),
                    ({"points": 1}, "5..1000000"), ({"points": "x"}, "must be an integer"),
                    ({"points": None}, "must be an integer"), ({"points": 1e300}, "5..1000000")):
        with pytest.raises(InputError, match=msg):
            run_checks(**kw)


def test_api_imu_errors():
    """IMU error specs, draws and their application refuse bad values with InputError."""
    from fieldmap import imu_errors as ie

    for value in (-1.0, float("nan"), "x", None, True):
        with pytest.raises(InputError, match="acc_bias_ug"):
            ie.ImuErrorSpec(acc_bias_ug=value)
    for kw, msg in (({"n": 0}, ">= 1"), ({"n": 2.5}, "integer"), ({"n": 2, "seed": -1}, ">= 0"),
                    ({"n": 2, "seed": "x"}, "integer"), ({"n": 2, "mode": "x"}, "bias mode")):
        with pytest.raises(InputError, match=msg):
            ie.draw(ie.TABLE4, **kw)
    d = ie.draw(ie.TABLE4, 2)
    z = np.zeros((4, 3))
    for args, kw, msg in (((z, z, 0.0, d), {}, "positive"), ((z, z, 0.005, d), {"run": 5}, "run 5"),
                          ((z, np.zeros((6, 3)), 0.005, d), {}, "differ in length"),
                          ((z, z * np.nan, 0.005, d), {}, "NaN or inf")):
        with pytest.raises(InputError, match=msg):
            ie.apply(*args, **kw)


def test_build_scenario_long_output_interval_is_fast():
    """An output interval longer than the flight stores the last state (no endless search)."""
    from fieldmap import navsim

    t0 = time.perf_counter()
    sc = navsim.build_scenario(duration=2.0, rate_hz=50.0, truth_lmax=8, output_dt=1e9)
    assert time.perf_counter() - t0 < 60.0
    assert sc.t_out[-1] == pytest.approx(sc.imu.t0 + sc.imu.duration)


# ----------------------------------------------------------------------------- atomic writing
def test_output_batch_leaves_nothing_on_interrupt(tmp_path):
    """Ctrl-C while the third file of a batch is written: no file, no temporary, no new folder."""
    from fieldmap.io import output_batch

    out = tmp_path / "a" / "b"
    with pytest.raises(KeyboardInterrupt):
        with output_batch(out) as batch:
            batch.json({"x": 1}, "one.json")
            batch.text("a,b\n", "two.csv")
            with open(batch.path("three.nc"), "w") as fh:
                fh.write("partial")
                raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []
    with output_batch(out) as batch:
        batch.json({"x": 1}, "one.json")
    assert sorted(p.name for p in out.iterdir()) == ["one.json"]
    assert (out / "one.json").read_text() == '{\n  "x": 1\n}\n'


@pytest.mark.parametrize("how", ["interrupt", "sigterm", "error"])
def test_map_interrupted_while_writing(work, capsys, monkeypatch, how):
    """A map run stopped while writing its figures leaves none of its files (NetCDF, JSON)."""
    from fieldmap import plots

    def boom(*a, **k):
        if how == "interrupt":
            raise KeyboardInterrupt
        if how == "sigterm":
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # the handler raises before this ends
        raise RuntimeError("figure failed")

    monkeypatch.setattr(plots, "plot_isolines", boom)
    before = _tree(work)
    rc, _, err = _main(["map", "--step-deg", "10", "--out", "res"], capsys)
    want = {"interrupt": (130, "interrupted"), "sigterm": (143, "terminated"),
            "error": (3, "internal error: RuntimeError: figure failed")}[how]
    _assert_one_line(rc, err, want[0], want[1], before, work)
    assert signal.getsignal(signal.SIGTERM) is not cli._on_sigterm  # handler restored


@pytest.mark.parametrize("sig, exc", [(signal.SIGINT, KeyboardInterrupt),
                                      (signal.SIGTERM, cli._Terminated)])
def test_signals_wait_for_the_file_being_written(sig, exc):
    """A signal during one file's write is delivered after it (HDF5 locks stay consistent).

    Without the deferral, Ctrl-C in the middle of writing a 185 MB NetCDF file hung the
    process for good (a lock of the writer left held, then waited on by its cleanup).
    """
    from fieldmap import io as fio

    previous = signal.signal(signal.SIGTERM, cli._on_sigterm)
    steps = []
    try:
        with pytest.raises(exc):
            with fio.signals_deferred():
                os.kill(os.getpid(), sig)
                time.sleep(0.05)
                steps.append("write finished")
            steps.append("not reached")
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert steps == ["write finished"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_disk_full_while_writing(work, capsys, monkeypatch):
    """ENOSPC while the NetCDF is written: one line naming it, no file left (not even .tmp)."""
    import errno

    from fieldmap import io as fio

    def full(ds, tmp):
        Path(tmp).write_bytes(b"CDF\x01partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp))

    monkeypatch.setattr(fio, "_netcdf_to", full)
    before = _tree(work)
    rc, _, err = _main(["truncation", "--step-deg", "30", "--out", "res"], capsys)
    _assert_one_line(rc, err, 2, "No space left on device", before, work)


def test_writers_use_temp_and_replace_in_same_folder(tmp_path, monkeypatch):
    """Writers rename a temporary file of the destination folder over the final name."""
    from fieldmap import io as fio

    seen = []
    real = os.replace

    def spy(src, dst):
        seen.append((Path(src), Path(dst)))
        return real(src, dst)

    monkeypatch.setattr(fio.os, "replace", spy)
    fio.write_json({"a": 1}, tmp_path / "x.json")
    with fio.output_batch(tmp_path) as b:
        b.text("t", "y.csv")
    assert [d.name for _, d in seen] == ["x.json", "y.csv"]
    assert all(s.parent == d.parent == tmp_path and s.name.startswith(".") for s, d in seen)
    with pytest.raises(TypeError):
        fio.write_json({"a": object()}, tmp_path / "z.json")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.json", "y.csv"]


# ----------------------------------------------------------------------------- real processes
def _spawn(args, **kw):
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen([sys.executable, "-m", "fieldmap", *args], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


@pytest.mark.parametrize("sig, rc, word", [(signal.SIGINT, 130, "interrupted"),
                                           (signal.SIGTERM, 143, "terminated")])
def test_signal_one_line(tmp_path, sig, rc, word):
    """Ctrl-C or SIGTERM while ``fieldmap point`` waits for input: one line, no traceback."""
    p = _spawn(["point"], stdin=subprocess.PIPE, cwd=tmp_path)
    time.sleep(3.0)  # past start-up: blocked reading stdin inside main()
    p.send_signal(sig)
    out, err = p.communicate(timeout=60)
    assert p.returncode == rc, err
    assert err.strip().splitlines() == [f"fieldmap point: {word}"]
    assert list(tmp_path.iterdir()) == []


def test_broken_pipe_is_quiet(tmp_path):
    """``fieldmap point < many | head -1``: no traceback when the reader goes away."""
    pts = "".join(f"{i % 80} {i % 360} 0\n" for i in range(20000))
    p = _spawn(["point", "--quantity", "normal"], stdin=subprocess.PIPE, cwd=tmp_path)
    p.stdin.write(pts)
    p.stdin.close()
    p.stdout.close()  # the reader is gone before anything is printed
    err = p.stderr.read()
    p.stderr.close()
    p.wait(timeout=120)
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert p.returncode == 1


def test_console_script_parse_errors_one_line(tmp_path):
    """Errors found by argparse in the real console script: one line, exit 2, no usage block."""
    p = _spawn(["map", "--lmax", "x"], cwd=tmp_path)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 2 and out == ""
    assert err.strip().splitlines() == [
        "fieldmap map: error: argument --lmax: invalid int value: 'x' (see 'fieldmap map --help')"
    ]
    p = _spawn(["bogus"], cwd=tmp_path)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 2 and len(err.strip().splitlines()) == 1 and "invalid choice" in err


# ----------------------------------------------------------------------------- --help
@pytest.mark.parametrize("cmd, words", [
    ("point", ["degrees", "metres", "mGal", "m/s²", "[-540, 540)", "exit 2"]),
    ("verify", ["1e-12", "5..1000000"]),
    ("map", ["km", "degrees", "mg", "9.80665e-3 m/s²", "created", "nothing written"]),
    ("sweep", ["km", "degrees", "mGal", "distinct", "created", "nothing written"]),
    ("truncation", ["km", "degrees", "mGal", "2,4,6", "created", "nothing written"]),
    ("navsim", ["Hz", "in s", "1..16", "created", "nothing written"]),
])
def test_help_documents_units(capsys, cmd, words):
    """Every sub-command's --help exits 0 and states units and accepted ranges."""
    with pytest.raises(SystemExit) as info:
        cli.main([cmd, "--help"])
    assert info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for w in words:
        assert w in text, (cmd, w)
