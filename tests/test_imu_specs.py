"""IMU presets, TOML custom units and the Allan deviation of the simulated sensors."""

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.nav import imu_errors
from fieldmap.nav.allan import allan_deviation, allan_table
from fieldmap.nav.imu_errors import GM_ADEV_PEAK, ImuErrorSpec, gm_allan_deviation
from fieldmap.nav.imu_specs import PRESETS, load_imu


def test_presets_are_ordered_by_grade():
    """Every error source shrinks from consumer to strategic; ideal has none."""
    order = ["consumer", "industrial", "navigation", "strategic"]
    for key in ("acc_noise_ug_rthz", "gyro_bias_deg_h", "gyro_arw_deg_rth", "gyro_bi_deg_h"):
        vals = [getattr(PRESETS[g], key) for g in order]
        assert vals == sorted(vals, reverse=True), key
    assert PRESETS["ideal"].is_ideal and not PRESETS["tactical"].is_ideal
    assert load_imu("Table4")[1] == imu_errors.TABLE4
    assert load_imu("table2-group1")[1] == imu_errors.TABLE2_GROUPS[1]


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
        acc_bias_ug=50, acc_noise_ug_rthz=20, gyro_bias_deg_h=0.5, gyro_arw_deg_rth=0.05,
        gyro_bi_deg_h=0.1, acc_bi_tau_s=600, gyro_bi_tau_s=600, acc_scale_ppm=100,
        gyro_scale_ppm=50, acc_misalign_arcsec=20, gyro_misalign_arcsec=20,
    )  # fmt: skip


@pytest.mark.parametrize(
    "text, msg",
    [
        ("accel_bias = 3\n", "unknown key(s) accel_bias"),
        ('gyro_bias_deg_per_h = "x"\n', "is not a number"),
        ("gyro_bias_deg_per_h = -1\n", "must be finite and >= 0"),
        ("bias_instability_tau_s = 0\n", "must be > 0 s"),
        ("gyro_bias_deg_per_h = \n", "not valid TOML"),
    ],
)
def test_toml_bad_input(tmp_path, text, msg):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(InputError, match=msg.replace("(", r"\(").replace(")", r"\)")):
        load_imu(p)


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
    spec = ImuErrorSpec(acc_noise_ug_rthz=20.0, gyro_arw_deg_rth=0.1)
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
    spec = ImuErrorSpec(gyro_bi_deg_h=2.0, gyro_bi_tau_s=1.0, acc_bi_ug=30.0, acc_bi_tau_s=1.0)
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
