"""Bad input to every sub-command: one clear line, exit status != 0, no files written.

Each CLI case runs ``fieldmap.cli.main`` in this process (fast: Warp and the model are loaded
once) from an empty working folder that holds only the fixture files, and asserts: the exit
status, exactly one line on stderr naming the problem (never a traceback or a usage block), and
that no file or folder appeared (the default ``outputs/`` lies in that folder too). The real
console script is run once, for argparse's own errors. The public API is checked in
``test_bad_input_api.py``, interrupted writes and signals in ``test_interrupts.py``.
"""

from __future__ import annotations

import gzip
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fieldmap import cli

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
    "badnum.gfc": (
        (_HEAD + _BODY.replace("-4.84165E-04", "-4.8x165E-04")).encode(),
        "line 12: bad number",
    ),
    "gap.gfc": ((_HEAD + _BODY.replace("gfc 2 1 0.0 0.0\n", "")).encode(), "n=2 m=1"),
    "dup.gfc": ((_HEAD + _BODY + "gfc 2 2 0.0 0.0\n").encode(), "duplicate"),
    "n_lt_m.gfc": ((_HEAD + _BODY + "gfc 1 2 0.0 0.0\n").encode(), "order m > degree n"),
    "norm.gfc": (
        (_HEAD.replace("fully_normalized", "semi") + _BODY).encode(),
        "unknown normalisation",
    ),
    "truncated.gfc": ((_HEAD + _BODY[:40]).encode(), "line 11: 'gfc' line with 0 values"),
    "headeronly.gfc": (_HEAD.encode(), "no coefficient lines"),
    "nan.gfc": ((_HEAD + _BODY.replace("2.4e-06", "nan")).encode(), "bad number 'nan'"),
    "huge.gfc": (
        (_HEAD + _BODY.replace("2.4e-06", "1e300")).encode(),
        "line 14: coefficient n=2 m=2 is 1e+300",
    ),
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
POINT_OPTIONS = (
    [
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
        (["--quantity", "ewh"], "is one field; give the reference with --minus"),
        (["--quantity", "geoid", "--minus", "eigen-6s"], "--minus applies to --quantity ewh"),
        (["--quantity", "ewh", "--minus", "nonexist.gfc"], "unknown model"),
    ]
    + [(["--model", name], msg) for name, (_, msg) in BAD_MODELS.items()]
    + [(["--model", name], msg) for name, (_, _, msg) in ALIEN_MODELS.items()]
)


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
    "91 10 0": "latitude must be within [-90, 90] degrees, got 91",
    "10 1e300 0": "longitude must be within [-540, 540) degrees, got 1e+300",
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
    from fieldmap.cli import point as cli_point

    monkeypatch.setattr(
        cli_point,
        "evaluate_points",
        lambda lat, *a, **k: np.array([[1.0, 2.0, 3.0], [np.nan, 0.0, 0.0]]),
    )
    rc, out, err = _main(["point"], capsys, "1 2 3\n4 5 6\n", monkeypatch)
    assert out.splitlines() == [
        "1.000 2.000 3.000",
        "ERROR: result is not finite (point too close to the masses for this model)",
    ]
    assert rc == 1 and len(err.splitlines()) == 1


def test_point_input_size_is_capped(work, capsys, monkeypatch):
    """``--input /dev/zero`` ends with one error line instead of filling the memory."""
    from fieldmap.cli import point as cli_point

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
    ref = _main(["point", "--model", "good.gfc"], capsys, "10 20 0\n", monkeypatch)
    assert out == ref[1]  # the same model as from the file

    # an endless binary stream (``--model <(cat /dev/urandom)``): refused after its first bytes
    r, w = os.pipe()
    written = 0

    def feed():
        nonlocal written
        block = bytes(range(256)) * 256  # 64 KiB, a NUL byte first
        try:
            while written < 1 << 30:  # 1 GiB: a reader that never stops makes the test fail
                written += os.write(w, block)
        except OSError:  # EPIPE: the reader closed the pipe
            pass
        finally:
            os.close(w)

    import threading

    writer = threading.Thread(target=feed, daemon=True)
    writer.start()
    before = _tree(work)
    rc, out, err = _main(["point", "--model", f"/dev/fd/{r}"], capsys, "10 20 0\n", monkeypatch)
    os.close(r)  # the writer's next write fails: it stops
    writer.join(timeout=30)
    assert not writer.is_alive()
    _assert_one_line(rc, err, 2, "binary byte 0x00", before, work)
    assert out == ""
    # read at most the first 16 MiB chunk (checked for binary bytes before more is read) and
    # what the pipe held (64 KiB); 16.06 MiB measured
    assert written <= 17 << 20, written


def test_point_empty_input(work, capsys, monkeypatch):
    """Empty stdin is zero points (as GeographicLib's Gravity): no output, exit 0, silent."""
    rc, out, err = _main(["point"], capsys, "", monkeypatch)
    assert (rc, out, err) == (0, "", "")


# ----------------------------------------------------------------------------- fieldmap verify
@pytest.mark.parametrize(
    "args, msg",
    [
        (["--lmax", "-1"], "within 0..240"),
        (["--lmax", "241"], "within 0..240"),
        (["--lmax", "x"], "invalid int value"),
        (["--points", "0"], "within 5..1000000"),
        (["--points", "100000000"], "within 5..1000000"),
        (["--points", "x"], "invalid int value"),
        (["--device", "cuda:7"], "not present"),
        (["--device", "bogus"], "not present"),
    ],
)
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
    (["--height-km", "-100"], "--height-km: height -100 km is below -10 km"),
    (["--height-km", "-6400"], "below -10 km"),
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
    (["--thresholds-mg", "x"], "--thresholds-mg: thresholds must be numbers in mg, got ['x']"),
    (["--thresholds-mg", "nan"], "positive finite"),
    (["--thresholds-mg", "-1"], "positive finite"),
    (["--thresholds-mg", "0"], "positive finite"),
    (["--thresholds-mg", "0.05,x"], "must be numbers in mg, got ['0.05', 'x']"),
    (["--thresholds-mg", ","], "no value"),
    (["--thresholds-mg", "0.05,0.05"], "repeated threshold"),
    (["--quantity", "ewh"], "is one field; give the reference with --minus"),
    (["--quantity", "ewh", "--model", "good.gfc"], "is one field"),  # a static model
    (["--quantity", "trr", "--minus", "eigen-6s"], "--minus applies to --quantity ewh"),
    (["--quantity", "ewh", "--minus", "nonexist.gfc"], "unknown model"),
]


def _grid_argv(cmd, args):
    step = [] if any(a.startswith("--step-deg") for a in args) else ["--step-deg", "5"]
    return [cmd, *args, *step]


@pytest.mark.parametrize("cmd", ["map", "sweep", "truncation"])
@pytest.mark.parametrize("args, msg", GRID_CASES, ids=lambda v: str(v))
def test_grid_bad_input(work, capsys, monkeypatch, cmd, args, msg):
    """Bad grid specifications, heights, devices and output folders: exit 2, nothing written."""
    from fieldmap.grids import spec as gridspec

    # the memory check must not depend on this machine: pretend it has 8 GiB
    monkeypatch.setattr(gridspec, "_memory_bytes", lambda: 8 * 2**30)
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


@pytest.mark.parametrize(
    "args, msg",
    [
        (["--height-km", "20,nan,30"], "finite"),
        (["--height-km", "20", "x"], "'x' is not a number"),
        (["--height-km", ","], "no value"),
        (["--height-km", "20,20"], "heights must be distinct: 20 km is repeated"),
        (["--height-km", "20", "2e5"], "is above 100000 km"),
    ],
)
def test_sweep_bad_heights(work, capsys, args, msg):
    """Lists of heights with one bad entry."""
    before = _tree(work)
    rc, _, err = _main(_grid_argv("sweep", args), capsys)
    _assert_one_line(rc, err, 2, msg, before, work)


@pytest.mark.parametrize(
    "orders, msg",
    [
        ("x", "--orders: orders must be among 2, 4, 6 (or j2, j4, j6), got 'x'"),
        ("j2,j5", "among 2, 4, 6, got [2, 5]"),
        ("3", "among 2, 4, 6"),
        ("8", "among 2, 4, 6"),
        ("2,2", "distinct"),
        ("2.5", "--orders: orders must be distinct values among 2, 4, 6, got [2.5]"),
        ("", "no value"),
    ],
)
def test_truncation_bad_orders(work, capsys, orders, msg):
    """``--orders`` of ``fieldmap truncation``."""
    before = _tree(work)
    rc, _, err = _main(["truncation", "--orders", orders, "--step-deg", "5"], capsys)
    _assert_one_line(rc, err, 2, msg, before, work)


def test_missing_out_folder_is_created_only_on_success(work, capsys):
    """A missing --out folder is created (with parents) by a good run, and not by a bad one."""
    rc, _, err = _main(
        ["truncation", "--step-deg", "5", "--height-km", "nan", "--out", "new/deeper"], capsys
    )
    assert rc == 2 and not (work / "new").exists(), err
    rc, _, err = _main(
        ["truncation", "--step-deg", "30", "--orders", "2", "--no-plots", "--out", "new/deeper"],
        capsys,
    )
    assert rc == 0, err
    names = sorted(p.name for p in (work / "new" / "deeper").iterdir())
    assert [n.rsplit(".", 1)[1] for n in names] == ["json", "nc"], names


# ----------------------------------------------------------------------------- optional parts
@pytest.mark.parametrize("module", ["zarr", "dask"])
def test_missing_optional_dependency(work, capsys, monkeypatch, module):
    """``--format zarr`` without zarr (or dask): one line naming the module and extra, exit 2."""
    monkeypatch.setitem(sys.modules, module, None)  # ``import zarr`` now fails as if not installed
    for name in [m for m in sys.modules if m.startswith(module + ".")]:
        monkeypatch.delitem(sys.modules, name)  # no submodule imported earlier is reused
    before = _tree(work)
    rc, _, err = _main(["map", "--format", "zarr", "--step-deg", "30", "--out", "res"], capsys)
    want = f"fieldmap map: error: {module} is not installed: pip install 'fieldmap[distributed]'"
    _assert_one_line(rc, err, 2, want, before, work)
    assert err.strip() == want


def test_missing_module_that_is_no_optional_dependency():
    """Only the modules of an extra are a missing optional part; others stay internal errors."""
    assert cli.missing_optional(ModuleNotFoundError("x", name="distributed.client")) == (
        "distributed is not installed: pip install 'fieldmap[distributed]'"
    )
    assert cli.missing_optional(ModuleNotFoundError("x", name="numcodecs")) is None
    assert cli.missing_optional(ModuleNotFoundError("x")) is None
    assert cli.missing_optional(ImportError("x", name="zarr")) is None
    assert cli.missing_optional(ValueError("zarr")) is None


def test_optional_dependencies_match_pyproject():
    """The CLI's table of extras is pyproject.toml's (the extras fieldmap imports from)."""
    import re

    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib

    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    extras = tomllib.loads(pyproject.read_text())["project"]["optional-dependencies"]
    # test, dev, docs and the benchmarks' peers (bench) are not imported by fieldmap itself
    runtime = {k: v for k, v in extras.items() if k not in ("test", "dev", "docs", "bench")}

    def name(requirement):  # "dask[distributed]>=2024.1" -> "dask[distributed]"
        return re.match(r"[A-Za-z0-9_.\-]+(\[[^\]]*\])?", requirement.replace(" ", "")).group(0)

    assert {k: {name(r) for r in v} for k, v in runtime.items()} == {
        k: set(v) for k, v in cli.OPTIONAL_DEPENDENCIES.items()
    }


# ----------------------------------------------------------------------------- fieldmap navsim
_ROUTE = ["--route", "47,8,500;47.1,8.2,500", "--speed-mps", "100"]
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
    # the gravity budget's terms (issue 26)
    ([*_ROUTE, "--omission-model", "foo"], "unknown degree-variance model 'foo'"),
    ([*_ROUTE, "--commission", "maybe"], "invalid choice"),
    (
        [*_ROUTE, "--commission", "on", "--truth-model", "good.gfc", "--models", "j4"],
        "no coefficient standard deviations",
    ),
    (["--omission-model", "kaula"], "--omission-model applies to"),
    (
        [*_ROUTE, "--method", "covariance", "--draws", "5"],
        "--draws applies to --method monte-carlo",
    ),
    ([*_ROUTE, "--method", "kalman"], "invalid choice"),
]


@pytest.mark.parametrize("args, msg", NAVSIM_CASES, ids=lambda v: str(v))
def test_navsim_bad_input(work, capsys, args, msg):
    """Bad ``fieldmap navsim`` options are all found before any work starts."""
    before = _tree(work)
    argv = ["navsim", *args] + ([] if args[0] == "--duration" else ["--duration", "5"])
    rc, out, err = _main(argv, capsys)
    _assert_one_line(rc, err, 2, msg, before, work)
    assert out == ""


# ----------------------------------------------------------------------------- --help
@pytest.mark.parametrize(
    "cmd, words",
    [
        ("point", ["degrees", "metres", "mGal", "m/s²", "[-540, 540)", "exit 2"]),
        ("verify", ["1e-12", "5..1000000"]),
        ("map", ["km", "degrees", "mg", "9.80665e-3 m/s²", "created", "nothing written"]),
        ("sweep", ["km", "degrees", "mGal", "distinct", "created", "nothing written"]),
        ("truncation", ["km", "degrees", "mGal", "2,4,6", "created", "nothing written"]),
        ("navsim", ["Hz", "in s", "1..16", "created", "nothing written"]),
    ],
)
def test_help_documents_units(capsys, cmd, words):
    """Every sub-command's --help exits 0 and states units and accepted ranges."""
    with pytest.raises(SystemExit) as info:
        cli.main([cmd, "--help"])
    assert info.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    for w in words:
        assert w in text, (cmd, w)


# ----------------------------------------------------------------------------- real console script
def _spawn(args, *, sigint=signal.SIG_DFL, **kw):
    """Start the console script (``python -m fieldmap``) with SIGINT set to ``sigint``.

    The child's SIGINT disposition is set here, not inherited from however pytest was started:
    a shell that runs the suite with SIGINT ignored (``make test &``, ``nohup``, some CI
    runners) passes SIG_IGN on, and Python then never turns Ctrl-C into KeyboardInterrupt.
    A Python handler in the parent becomes SIG_DFL in the child at exec; SIG_IGN stays ignored.
    """
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    parent = signal.signal(
        signal.SIGINT, signal.default_int_handler if sigint == signal.SIG_DFL else sigint
    )
    try:
        return subprocess.Popen(
            [sys.executable, "-m", "fieldmap", *args],
            env=env,
            text=True,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            **kw,
        )
    finally:
        signal.signal(signal.SIGINT, signal.SIG_DFL if parent is None else parent)


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
