"""Navigation studies (small sizes): Table 1 ordering and floor, Tables 3/4, CLI, examples.

Table 3/4 statistics and determinism; the ``fieldmap navsim`` CLI (outputs, one-line errors,
nothing written); the examples with their small-size switch.
"""

import json
import os
import runpy
import sys

import numpy as np
import pytest

from fieldmap import navsim
from fieldmap.cli import main as cli_main


@pytest.fixture(scope="module")
def scenario():
    # 60 s of the boost at 100 Hz, truth EIGEN-6S degree 240 (the full bundled model)
    return navsim.build_scenario(duration=60.0, rate_hz=100.0, n_gauss=2, device="cpu")


@pytest.fixture(scope="module")
def t1(scenario):
    return navsim.table1(scenario, navsim.TABLE1_MODELS, timing=False)


def test_table1_ordering_as_in_the_paper(t1):
    p = {r["model"]: r["final_position_error_m"] for r in t1.rows}
    v = {r["model"]: r["final_velocity_error_m_s"] for r in t1.rows}
    # Chen et al. (2022) Table 1: J2 worst, J4 ≈ J6, SH18 better, SH200 best
    for e in (p, v):
        assert e["j2"] > e["j4"] > e["sh18"] > e["sh200"]
        assert abs(e["j4"] - e["j6"]) < 0.01 * e["j4"]
        assert abs(e["j6"] - e["normal"]) < 0.01 * e["j6"]
        assert e["j2"] - e["j4"] > 10 * abs(e["j4"] - e["j6"])


def test_table1_floor_is_ten_times_below_the_smallest_effect(t1):
    floor = t1.meta["floor"]
    assert floor["nav_gravity"] == "sh240"
    smallest_p = min(r["final_position_error_m"] for r in t1.rows)
    smallest_v = min(r["final_velocity_error_m_s"] for r in t1.rows)
    assert floor["final_position_error_m"] * 10 < smallest_p
    assert floor["final_velocity_error_m_s"] * 10 < smallest_v
    assert floor["margin_position"] == pytest.approx(smallest_p / floor["final_position_error_m"])
    assert t1.labels[-1] == "floor:sh240"
    assert t1.pos.shape == (7, t1.t.size) and t1.t[-1] == pytest.approx(60.0)
    assert np.all(t1.pos[:, 0] < 1e-9)  # the runs start on the truth


def test_gravity_eval_seconds_increase_with_cost(scenario):
    sec = {
        m: navsim.gravity_eval_seconds(m, scenario.truth_model, repeats=1)
        for m in ("j4", "sh18", "sh200")
    }
    assert 0 < sec["j4"] < sec["sh18"] < sec["sh200"]


def test_balanced_order_spreads_expensive_runs():
    order = navsim.balanced_order(["j2", "sh200", "sh200", "j4"], parts=2)
    assert sorted(order.tolist()) == [0, 1, 2, 3]
    assert {int(order[0]), int(order[2])} == {1, 2}  # one SH200 run per chunk


def test_table3_statistics_and_determinism(scenario, t1):
    a = navsim.table3(scenario, draws=4, seed=7)
    b = navsim.table3(scenario, draws=4, seed=7)
    c = navsim.table3(scenario, draws=4, seed=8)
    assert a.rows == b.rows
    assert a.rows[0] != c.rows[0]
    by = {r["group"]: r for r in a.rows}
    # group 4 (no accelerometer error) is the J4 run of Table 1 exactly
    j4 = next(r for r in t1.rows if r["model"] == "j4")
    assert by[4]["final_position_error_m_mean"] == pytest.approx(
        j4["final_position_error_m"], rel=1e-12
    )
    assert by[4]["draws"] == 1 and by[1]["draws"] == 4
    # 100 µg bias for 60 s: ~½·b·t² ≈ 1.8 m per axis, far above the 1.1 m gravity error
    assert by[1]["final_position_error_m_rms"] > 1.5 * by[4]["final_position_error_m_mean"]
    r = by[1]
    assert (
        r["final_position_error_m_p05"]
        <= r["final_position_error_m_p50"]
        <= r["final_position_error_m_p95"]
    )
    assert r["final_position_error_m_rms"] >= r["final_position_error_m_mean"]


def test_table4_rows(scenario):
    res = navsim.table4(scenario, ["j4", "sh200"], draws=3, seed=1)
    assert [r["case"] for r in res.rows] == ["imu_only", "imu+j4", "imu+sh200"]
    assert res.pos.shape[0] == 9
    assert not res.rows[0]["gravity_model_error"] and res.rows[1]["gravity_model_error"]


def _run_cli(argv, capsys):
    code = cli_main(["navsim", *argv])
    return code, capsys.readouterr()


def test_cli_writes_tables_json_netcdf_png(tmp_path, capsys):
    out = tmp_path / "o"
    code, cap = _run_cli(
        [
            "--study",
            "table1",
            "--duration",
            "20",
            "--rate",
            "100",
            "--truth-degree",
            "60",
            "--models",
            "j2,j4,j6,normal,sh18,sh40",
            "--no-timing",
            "--out",
            str(out),
        ],
        capsys,
    )
    assert code == 0, cap.err
    assert "floor (sh60 = truth)" in cap.out
    files = sorted(os.listdir(out))
    assert files == [f"navsim_table1.{e}" for e in ("csv", "json", "nc", "png")]
    doc = json.loads((out / "navsim_table1.json").read_text())
    for key in ("j2", "j4", "j6", "normal", "sh18", "sh40"):
        assert set(doc[key]) >= {"final_position_error_m", "final_velocity_error_m_s"}
    assert doc["truth_model"] == "EIGEN-6S" and doc["truth_degree"] == 60
    assert doc["floor"]["final_position_error_m"] < doc["sh40"]["final_position_error_m"]
    import xarray as xr

    with xr.open_dataset(out / "navsim_table1.nc") as ds:
        assert ds.position_error.shape == (7, 21) and ds.position_error.attrs["units"] == "m"


@pytest.mark.parametrize(
    "argv, msg",
    [
        (["--models", "j2,j3"], "unknown navigation gravity"),
        (["--models", "sh300"], "outside"),
        (["--truth-degree", "999"], "lmax"),
        (["--duration", "0"], "positive"),
        (["--duration", "nan"], "positive"),
        (["--rate", "-5"], "positive"),
        (["--draws", "0"], "draws"),
        (["--truth", "no-such-model"], "unknown model"),
        (["--device", "cuda:7"], "not present"),
    ],
)
def test_cli_bad_input_one_line_nothing_written(tmp_path, capsys, argv, msg):
    out = tmp_path / "never"
    code, cap = _run_cli([*argv, "--out", str(out)], capsys)
    assert code == 2
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and msg in lines[0] and lines[0].startswith("fieldmap navsim: error:")
    assert not out.exists()


@pytest.mark.parametrize("script", ["table1_gravity_models.py", "table3_accel_errors.py"])
def test_examples_small(tmp_path, script, monkeypatch, capsys):
    path = os.path.join(os.path.dirname(__file__), "..", "examples", script)
    monkeypatch.setattr(sys, "argv", [script, "--small", "--out", str(tmp_path)])
    with pytest.raises(SystemExit) as exc:
        runpy.run_path(path, run_name="__main__")
    assert exc.value.code == 0
    assert "paper" in capsys.readouterr().out
    assert len(os.listdir(tmp_path)) == 4
