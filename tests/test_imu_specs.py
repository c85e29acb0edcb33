"""IMU presets, TOML custom units and the Allan deviation of the simulated sensors."""

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.nav import sensors
from fieldmap.nav.sensors import (
    GM_ADEV_PEAK,
    PRESETS,
    RANGES,
    TOML_KEYS,
    ImuErrorSpec,
    allan_deviation,
    allan_table,
    gm_allan_deviation,
    load_imu,
    spec_from_mapping,
)


def test_presets_are_ordered_by_grade():
    """Every error source shrinks from consumer to strategic; ideal has none."""
    order = ["consumer", "industrial", "navigation", "strategic"]
    for key in (
        "accel_vrw_ug_per_sqrt_hz",
        "gyro_bias_deg_per_h",
        "gyro_arw_deg_per_sqrt_h",
        "gyro_bias_instability_deg_per_h",
    ):
        vals = [getattr(PRESETS[g], key) for g in order]
        assert vals == sorted(vals, reverse=True), key
    assert PRESETS["ideal"].is_ideal and not PRESETS["tactical"].is_ideal
    assert load_imu("Table4")[1] == sensors.TABLE4
    assert load_imu("table2-group1")[1] == sensors.TABLE2_GROUPS[1]


def test_toml_unit_keys(tmp_path):
    """Unit-carrying keys land in the right fields; shared keys fill both triads."""
    p = tmp_path / "my.toml"
    p.write_text(
        'name = "my unit"\naccel_bias_ug = 50\naccel_vrw_ug_per_sqrt_hz = 20.0\n'
        "gyro_bias_deg_per_h = 0.5\ngyro_arw_deg_per_sqrt_h = 0.05\n"
        "gyro_bias_instability_deg_per_h = 0.1\nbias_instability_tau_s = 600\n"
        "scale_factor_ppm = 100\ngyro_scale_factor_ppm = 50\nmisalignment_arcsec = 20\n"
    )
    name, spec = load_imu(p)
    assert name == "my unit"
    assert spec == ImuErrorSpec(
        accel_bias_ug=50, accel_vrw_ug_per_sqrt_hz=20, gyro_bias_deg_per_h=0.5,
        gyro_arw_deg_per_sqrt_h=0.05, gyro_bias_instability_deg_per_h=0.1,
        accel_bias_instability_tau_s=600, gyro_bias_instability_tau_s=600,
        accel_scale_factor_ppm=100, gyro_scale_factor_ppm=50, accel_misalignment_arcsec=20,
        gyro_misalignment_arcsec=20,
    )  # fmt: skip


@pytest.mark.parametrize(
    "text, msg",
    [
        ("accel_bias = 3\n", "unknown key(s) accel_bias"),
        ('gyro_bias_deg_per_h = "x"\n', "is not a number"),
        ("gyro_bias_deg_per_h = -1\n", "gyro_bias_deg_per_h = -1 is outside the allowed range 0"),
        ("bias_instability_tau_s = 0\n", "= 0 is outside the allowed range 0.01 … 1000000 s"),
        ("gyro_bias_deg_per_h = \n", "not valid TOML"),
        ("accel_bias_ug = 1e300\n", "accel_bias_ug = 1e+300 is outside the allowed range 0 … "),
        ("accel_bias_ug = nan\n", "accel_bias_ug = nan is not a finite number"),
        ("gyro_arw_deg_per_sqrt_h = inf\n", "gyro_arw_deg_per_sqrt_h = inf is not a finite"),
        ("misalignment_arcsec = -inf\n", "misalignment_arcsec = -inf is not a finite"),
        ("accel_bias_ug = 99999999999999999999999\n", "99999999999999999999999 is outside"),
        ("", "sets no error terms"),
        ('name = "x"\ndescription = "y"\n', "sets no error terms"),
        ("bias_instability_tau_s = 100\n", "sets no error terms"),
    ],
)
def test_toml_bad_input(tmp_path, text, msg):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(InputError) as exc:
        load_imu(p)
    line = str(exc.value)
    assert msg in line and "\n" not in line, line
    assert line.startswith(f"{p}:") or line.startswith(f"{p} sets"), line  # names the file


def test_empty_file_names_the_ideal_preset(tmp_path):
    """An empty file is no ideal IMU; the message says how to ask for one."""
    p = tmp_path / "empty.toml"
    p.write_text("# nothing yet\n")
    with pytest.raises(InputError, match="use the preset 'ideal' \\(--imu ideal\\)"):
        load_imu(p)
    assert load_imu("ideal")[1].is_ideal
    with pytest.raises(InputError, match="IMU spec sets no error terms"):
        spec_from_mapping({})
    # explicit zeros are a choice, not an omission
    assert spec_from_mapping({"accel_bias_ug": 0, "gyro_bias_deg_per_h": 0.0}).is_ideal


def test_ranges_cover_every_key():
    assert set(RANGES) == set(TOML_KEYS)
    for key, (lo, hi, unit) in RANGES.items():
        assert 0 <= lo < hi and unit, key
        assert (lo > 0) == key.endswith("_tau_s"), key  # only correlation times must be > 0
        assert key in sensors.__doc__ or key.partition("_")[2] in sensors.__doc__, key


@pytest.mark.parametrize("key", sorted(RANGES))
def test_each_key_range(key):
    """The bounds are accepted; just past them, NaN and ±inf are refused naming key and range."""
    lo, hi, unit = RANGES[key]
    for ok in (lo, hi, (lo + hi) / 2):
        spec_from_mapping({"gyro_bias_deg_per_h": 1.0, key: ok}, "my.toml")
    for bad in (hi * 1.001, lo - 1e-9, -1.0, 1e300):
        with pytest.raises(InputError) as exc:
            spec_from_mapping({key: bad}, "my.toml")
        msg = str(exc.value)
        assert msg.startswith(f"my.toml: {key} = {bad!r} is outside the allowed range"), msg
        assert f"{hi:.15g} {unit}" in msg, msg
    for bad in (float("nan"), float("inf"), -float("inf")):
        with pytest.raises(InputError, match=f"my.toml: {key} = {bad!r} is not a finite number"):
            spec_from_mapping({key: bad}, "my.toml")


def _preset_as_toml(spec: ImuErrorSpec) -> dict:
    """Write the preset with the per-triad TOML keys."""
    return {k: getattr(spec, fields[0]) for k, fields in TOML_KEYS.items() if len(fields) == 1}


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_presets_lie_within_the_ranges(tmp_path, name):
    """Every bundled preset passes the file checks and reads back identical from a TOML file."""
    spec = PRESETS[name]
    data = _preset_as_toml(spec)
    for key, value in data.items():
        lo, hi, _ = RANGES[key]
        assert lo <= value <= hi, (name, key, value)
    p = tmp_path / f"{name}.toml"
    p.write_text("".join(f"{k} = {v!r}\n" for k, v in data.items()))
    assert load_imu(p)[1] == spec  # explicit zeros: even ``ideal`` written out is accepted


@pytest.mark.parametrize("shared_first", [True, False])
def test_specific_key_wins_over_shared_one(shared_first):
    """``accel_bias_instability_tau_s`` beats ``bias_instability_tau_s`` in either order."""
    items = [("bias_instability_tau_s", 600.0), ("accel_bias_instability_tau_s", 100.0)]
    items += [("scale_factor_ppm", 10.0), ("gyro_scale_factor_ppm", 20.0)]
    items += [("accel_bias_ug", 1.0)]
    data = dict(items if shared_first else items[::-1])
    spec = spec_from_mapping(data)
    assert (spec.accel_bias_instability_tau_s, spec.gyro_bias_instability_tau_s) == (100.0, 600.0)
    assert (spec.accel_scale_factor_ppm, spec.gyro_scale_factor_ppm) == (10.0, 20.0)


def test_numpy_scalars_from_python():
    """A mapping built in Python may hold NumPy numbers; they are checked the same way."""
    spec = spec_from_mapping({"accel_bias_ug": np.float32(5.0), "gyro_bias_deg_per_h": np.int64(2)})
    assert (spec.accel_bias_ug, spec.gyro_bias_deg_per_h) == (5.0, 2.0)
    with pytest.raises(InputError, match=r"accel_bias_ug = 1e\+300 is outside"):
        spec_from_mapping({"accel_bias_ug": np.float64(1e300)})


def test_unknown_preset():
    with pytest.raises(InputError, match="unknown IMU 'gold'"):
        load_imu("gold")


def test_gm_peak_constant():
    """The Gauss–Markov Allan maximum, checked by a dense grid (independent of the optimiser)."""
    x = np.linspace(0.5, 5.0, 200001)
    assert GM_ADEV_PEAK == pytest.approx(gm_allan_deviation(x).max(), rel=1e-9)
    assert x[np.argmax(gm_allan_deviation(x))] == pytest.approx(1.89, abs=0.01)


def test_allan_white_noise_slope_and_value():
    """VRW/ARW only: slope −1/2 and σ(1 s) = the density (1 µg/√Hz -> 1 µg at 1 s)."""
    spec = ImuErrorSpec(accel_vrw_ug_per_sqrt_hz=20.0, gyro_arw_deg_per_sqrt_h=0.1)
    tab = allan_table(spec, 2000.0, 100.0, seed=3)
    t = tab["tau_s"]
    sel = (t >= 0.05) & (t <= 20.0)
    for key, expect in (("accel_adev_ug", 20.0), ("gyro_adev_deg_h", 6.0)):
        y = tab[key]
        slope = np.polyfit(np.log(t[sel]), np.log(y[sel]), 1)[0]
        assert slope == pytest.approx(-0.5, abs=0.03), key
        # estimate at 1 s from 2e5 samples: ~1/sqrt(N/m) ~ 0.7 % relative scatter
        at1 = np.exp(np.interp(0.0, np.log(t), np.log(y)))
        assert at1 == pytest.approx(expect, rel=0.03), key


def test_allan_bias_instability_floor():
    """Gauss–Markov only: the maximum sits at the spec's floor B near 1.89 τ_c."""
    spec = ImuErrorSpec(
        gyro_bias_instability_deg_per_h=2.0,
        gyro_bias_instability_tau_s=1.0,
        accel_bias_instability_ug=30.0,
        accel_bias_instability_tau_s=1.0,
    )
    tab = allan_table(spec, 20000.0, 20.0, seed=5)
    t = tab["tau_s"]
    for key, B in (("gyro_adev_deg_h", 2.0), ("accel_adev_ug", 30.0)):
        y = tab[key]
        assert y.max() == pytest.approx(B, rel=0.05), key
        assert 1.0 <= t[np.argmax(y)] <= 4.0, key
        # and the whole curve follows the closed form over 0.2..20 s
        sel = (t >= 0.2) & (t <= 20.0)
        expect = gm_allan_deviation(t[sel], B / GM_ADEV_PEAK, 1.0)
        np.testing.assert_allclose(y[sel], expect, rtol=0.08)


def test_allan_deviation_of_a_known_sequence():
    """A ramp (rate = constant + drift) has σ(τ) = K τ/√2 exactly (IEEE 952 Table C.1)."""
    dt, K = 0.1, 3.0
    rate = 5.0 + K * dt * np.arange(1000)
    taus, adev = allan_deviation(rate, dt, taus=[0.1, 1.0, 5.0])
    np.testing.assert_allclose(adev, K * taus / np.sqrt(2.0), rtol=1e-9)


def test_cli_imu_allan(tmp_path, capsys):
    """``fieldmap imu allan`` writes CSV/JSON/PNG; a bad key is one line, exit 2, no files."""
    import json

    from fieldmap.cli import main

    assert (
        main(["imu", "allan", "--imu", "tactical", "--duration", "100", "--out", str(tmp_path)])
        == 0
    )
    doc = json.loads((tmp_path / "imu_allan_tactical.json").read_text())
    assert doc["gyro_arw_at_1s_deg_h"] == pytest.approx(0.125 * 60)
    assert (tmp_path / "imu_allan_tactical.png").stat().st_size > 10_000
    bad = tmp_path / "bad.toml"
    bad.write_text("gyro_noise = 1\n")
    out = tmp_path / "o2"
    assert main(["imu", "allan", "--imu", str(bad), "--out", str(out)]) == 2
    assert "unknown key(s) gyro_noise" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    "text, msg",
    [
        ("accel_bias_ug = 1e300\n", "accel_bias_ug = 1e+300 is outside the allowed range 0 … "),
        ("", "sets no error terms"),
    ],
)
def test_cli_imu_out_of_range(tmp_path, capsys, text, msg):
    """Through the CLI, a value out of range or an empty file: one line, exit 2, no files."""
    from fieldmap.cli import main

    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    out = tmp_path / "o"
    assert main(["imu", "allan", "--imu", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("fieldmap imu: error: ") and msg in err[0], err
    assert str(bad) in err[0]
    assert not out.exists()


def _toml(spec: dict) -> str:
    return "".join(f"{key} = {value!r}\n" for key, value in spec.items())


def test_one_vocabulary_toml_json_python(tmp_path, capsys):
    """A run's ``imu_spec`` (JSON) copied into a TOML file flies as the same IMU.

    The keys of a TOML file, of :class:`ImuErrorSpec` and of the study JSON are one set: a
    spec goes TOML -> run -> JSON -> TOML -> run and comes back equal, field by field.
    """
    import dataclasses
    import json

    from fieldmap.cli import main

    assert {f.name for f in dataclasses.fields(ImuErrorSpec)} <= set(TOML_KEYS)
    first = tmp_path / "mine.toml"
    first.write_text(
        "name = 'mine'\naccel_bias_ug = 300.0\naccel_vrw_ug_per_sqrt_hz = 40.0\n"
        "gyro_arw_deg_per_sqrt_h = 0.05\ngyro_bias_deg_per_h = 0.7\n"
        "gyro_bias_instability_deg_per_h = 0.2\nbias_instability_tau_s = 900.0\n"
    )
    route = ["--route", "47,8,500;47.02,8,500", "--speed-mps", "100", "--rate", "10"]
    fast = [*route, "--lmax", "10", "--models", "j4", "--draws", "2", "--no-timing", "--no-plots"]

    def fly(toml, out):
        assert main(["navsim", *fast, "--imu", str(toml), "--out", str(out)]) == 0
        return json.loads((out / "navsim_flight.json").read_text())["meta"]["imu_spec"]

    spec = fly(first, tmp_path / "a")
    assert spec["accel_bias_ug"] == 300.0 and spec["gyro_arw_deg_per_sqrt_h"] == 0.05
    assert spec["accel_bias_instability_tau_s"] == spec["gyro_bias_instability_tau_s"] == 900.0
    assert ImuErrorSpec(**spec) == load_imu(first)[1]  # Python takes the JSON keys as they are
    copied = tmp_path / "copied.toml"
    copied.write_text(_toml(spec))
    assert load_imu(copied)[1] == load_imu(first)[1]
    assert fly(copied, tmp_path / "b") == spec
    capsys.readouterr()
