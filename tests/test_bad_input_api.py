"""Bad input to the public Python API, interrupted and failing writes, real CLI processes.

Companion of ``test_bad_input.py`` (the sub-commands, run in-process), sharing its fixtures:
the API raises :class:`fieldmap.errors.FieldmapError` subclasses for bad arguments; output is
all-or-nothing under Ctrl-C, SIGTERM, a full disk or a failing figure; the real console script
prints one line for signals, a broken pipe and argparse's errors.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_bad_input import (  # noqa: F401 - ``work`` is a fixture
    _BODY,
    _HEAD,
    ALIEN_MODELS,
    BAD_MODELS,
    _assert_one_line,
    _main,
    _tree,
    work,
)

from fieldmap import cli
from fieldmap.errors import FieldmapError, InputError, ModelFileError


# ----------------------------------------------------------------------------- public API
def test_api_models_and_reader(work):  # noqa: F811 (fixture)
    """``load_model`` and ``read_icgem`` raise FieldmapError subclasses for bad arguments."""
    from fieldmap.models.icgem import read_icgem
    from fieldmap.models.registry import load_model

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
    """The map API refuses the same grids as the CLI (checks: fieldmap.grids)."""
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
    """``fieldmap.field.gravity`` refuses non-numeric, non-finite and impossible coordinates."""
    from fieldmap.field import gravity as fg

    for lat, lon, h in (
        ([np.nan], [0], [0]),
        (["a"], [0], [0]),
        ([91], [0], [0]),
        ([0], [np.inf], [0]),
        ([0], [0], [np.inf]),
        ([0], [0], [-1e6]),
    ):
        for func in (fg.gravitation, fg.gravity, fg.disturbance):
            with pytest.raises(InputError):
                func(lat, lon, h)
    with pytest.raises(InputError):
        fg.disturbance([0], [0], [0], lmax=500)
    with pytest.raises(InputError):
        fg.disturbance([0], [0], [0], frame="xyz")


def test_api_navsim_inputs():
    """Navigation inputs: IMU arrays, dt, names, degrees, trajectories below the surface."""
    from fieldmap.models.registry import load_model
    from fieldmap.nav import imu
    from fieldmap.nav import studies as navsim
    from fieldmap.nav.launch_frames import LaunchFrame
    from fieldmap.nav.trajectory import Stationary

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
    """``fieldmap.cli.verify.run_checks`` checks its arguments before running anything."""
    from fieldmap.cli.verify import run_checks

    for kw, msg in (
        ({"devices": ["cuda:7"]}, "not present"),
        ({"devices": "tpu"}, "not present"),
        ({"lmax": 241}, "0..240"),
        ({"lmax": 2.5}, "integer degree"),
        ({"points": 1}, "5..1000000"),
        ({"points": "x"}, "must be an integer"),
        ({"points": None}, "must be an integer"),
        ({"points": 1e300}, "5..1000000"),
    ):
        with pytest.raises(InputError, match=msg):
            run_checks(**kw)


def test_api_imu_errors():
    """IMU error specs, draws and their application refuse bad values with InputError."""
    from fieldmap.nav import imu_errors as ie

    for value in (-1.0, float("nan"), "x", None, True):
        with pytest.raises(InputError, match="acc_bias_ug"):
            ie.ImuErrorSpec(acc_bias_ug=value)
    for kw, msg in (
        ({"n": 0}, ">= 1"),
        ({"n": 2.5}, "integer"),
        ({"n": 2, "seed": -1}, ">= 0"),
        ({"n": 2, "seed": "x"}, "integer"),
        ({"n": 2, "mode": "x"}, "bias mode"),
    ):
        with pytest.raises(InputError, match=msg):
            ie.draw(ie.TABLE4, **kw)
    d = ie.draw(ie.TABLE4, 2)
    z = np.zeros((4, 3))
    for args, kw, msg in (
        ((z, z, 0.0, d), {}, "positive"),
        ((z, z, 0.005, d), {"run": 5}, "run 5"),
        ((z, np.zeros((6, 3)), 0.005, d), {}, "differ in length"),
        ((z, z * np.nan, 0.005, d), {}, "NaN or inf"),
    ):
        with pytest.raises(InputError, match=msg):
            ie.apply(*args, **kw)


def test_build_scenario_long_output_interval_is_fast():
    """An output interval longer than the flight stores the last state (no endless search)."""
    from fieldmap.nav import studies as navsim

    t0 = time.perf_counter()
    sc = navsim.build_scenario(duration=2.0, rate_hz=50.0, truth_lmax=8, output_dt=1e9)
    assert time.perf_counter() - t0 < 60.0
    assert sc.t_out[-1] == pytest.approx(sc.imu.t0 + sc.imu.duration)


# ----------------------------------------------------------------------------- atomic writing
def test_output_batch_leaves_nothing_on_interrupt(tmp_path):
    """Ctrl-C while the third file of a batch is written: no file, no temporary, no new folder."""
    from fieldmap.products.io import output_batch

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
def test_map_interrupted_while_writing(work, capsys, monkeypatch, how):  # noqa: F811 (fixture)
    """A map run stopped while writing its figures leaves none of its files (NetCDF, JSON)."""
    from fieldmap.products import plots

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
    want = {
        "interrupt": (130, "interrupted"),
        "sigterm": (143, "terminated"),
        "error": (3, "internal error: RuntimeError: figure failed"),
    }[how]
    _assert_one_line(rc, err, want[0], want[1], before, work)
    assert signal.getsignal(signal.SIGTERM) is not cli._on_sigterm  # handler restored


@pytest.mark.parametrize(
    "sig, exc", [(signal.SIGINT, KeyboardInterrupt), (signal.SIGTERM, cli._Terminated)]
)
def test_signals_wait_for_the_file_being_written(sig, exc):
    """A signal during one file's write is delivered after it (HDF5 locks stay consistent).

    Without the deferral, Ctrl-C in the middle of writing a 185 MB NetCDF file hung the
    process for good (a lock of the writer left held, then waited on by its cleanup).
    """
    from fieldmap.products import io as fio

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


def test_disk_full_while_writing(work, capsys, monkeypatch):  # noqa: F811 (fixture)
    """ENOSPC while the NetCDF is written: one line naming it, no file left (not even .tmp)."""
    import errno

    from fieldmap.products import io as fio

    def full(ds, tmp, *args):
        Path(tmp).write_bytes(b"CDF\x01partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp))

    monkeypatch.setattr(fio, "_netcdf_to", full)
    before = _tree(work)
    rc, _, err = _main(["truncation", "--step-deg", "30", "--out", "res"], capsys)
    _assert_one_line(rc, err, 2, "No space left on device", before, work)


def test_writers_use_temp_and_replace_in_same_folder(tmp_path, monkeypatch):
    """Writers rename a temporary file of the destination folder over the final name."""
    from fieldmap.products import io as fio

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
    return subprocess.Popen(
        [sys.executable, "-m", "fieldmap", *args],
        env=env,
        text=True,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        **kw,
    )


@pytest.mark.parametrize(
    "sig, rc, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
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
