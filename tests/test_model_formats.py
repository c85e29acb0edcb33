"""NGA plain coefficient files and GeographicLib .egm/.egm.cof: readers, detection, bad files."""

from __future__ import annotations

import math
import os
import struct
import subprocess
import sys

import numpy as np
import pytest

from fieldmap.errors import InputError, ModelFileError
from fieldmap.models.geographiclib import (
    gravity_tool,
    read_egm,
    run_gravity_tool,
    write_egm,
)
from fieldmap.models.nga import looks_like_nga, read_nga, write_nga
from fieldmap.models.registry import detect_format, kaula_model, load_model
from fieldmap.models.shmodel import SHModel

needs_tool = pytest.mark.skipif(
    gravity_tool() is None, reason="GeographicLib's Gravity (geographiclib-tools) missing"
)


def _use_model_cache(monkeypatch, folder) -> None:
    """Point the parsed-model cache at ``folder`` for this test (the settings are read once)."""
    import dataclasses

    from fieldmap import config

    monkeypatch.setattr(
        config, "_current", dataclasses.replace(config.get(), model_cache=str(folder))
    )


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    """Keep the on-disk model cache of these tests out of the user's cache folder."""
    _use_model_cache(monkeypatch, str(tmp_path / "model-cache"))
    from fieldmap.models.registry import clear_cache

    clear_cache()


# --------------------------------------------------------------------------------------------
# NGA


# The first lines of NGA's EGM96 file (egm96_to360.ascii), typed here by hand: an NGA file that
# fieldmap's writer did not produce, E exponents, six columns.
EGM96_HEAD = """\
    2    0   -0.484165371736E-03    0.000000000000E+00    0.356106544906E-10    0.000000000000E+00
    2    1   -0.186987635955E-09    0.119528012031E-08    0.100000000000E-29    0.100000000000E-29
    2    2    0.243914352398E-05   -0.140016683654E-05    0.537392435007E-10    0.543533451177E-10
    3    0    0.957254173792E-06    0.000000000000E+00    0.180850696272E-10    0.000000000000E+00
    3    1    0.202998882184E-05    0.248513158716E-06    0.139883953297E-09    0.136893179050E-09
    3    2    0.904627768605E-06   -0.619025944205E-06    0.109297252257E-09    0.111960647289E-09
    3    3    0.721072657057E-06    0.141435626958E-05    0.951133035316E-10    0.951241831296E-10
"""


def test_nga_hand_written_egm96_head(tmp_path):
    """A hand-typed EGM96 head: values as printed, EGM96's constants from the file name."""
    path = tmp_path / "egm96_to3.ascii"
    path.write_text(EGM96_HEAD)
    assert looks_like_nga(path.read_bytes()) and detect_format(path) == "nga"
    m = read_nga(path)
    assert (m.name, m.gm, m.radius, m.lmax) == ("EGM96", 3.986004418e14, 6378137.0, 3)
    assert m.C[0, 0] == 1.0 and not m.C[1].any() and not m.S[1].any()
    assert m.C[2, 0] == -0.484165371736e-03 and m.S[3, 3] == 0.141435626958e-05
    assert m.C[2, 1] == -0.186987635955e-09 and m.S[2, 2] == -0.140016683654e-05
    assert "EGM96's published values" in m.header["constants"]


@pytest.mark.parametrize("exponent", ["D", "E"])
def test_nga_round_trip(tmp_path, exponent):
    """write_nga -> read_nga is exact (17 digits), D or E exponents; EGM2008 constants."""
    model = kaula_model(40, seed=3)
    path = tmp_path / "EGM2008_to40_TideFree"
    write_nga(path, model, exponent=exponent)
    assert exponent in path.read_text().splitlines()[0]
    back = read_nga(path)
    np.testing.assert_array_equal(back.C, model.C)
    np.testing.assert_array_equal(back.S, model.S)
    assert (back.gm, back.radius, back.tide_system) == (3.986004415e14, 6378136.3, "tide_free")
    part = read_nga(path, lmax=10)
    np.testing.assert_array_equal(part.C, model.C[:11, :11])


def test_nga_constants_given_or_refused(tmp_path):
    """An unknown name needs GM and radius; the header says which were used."""
    path = tmp_path / "mymodel.txt"
    write_nga(path, kaula_model(5))
    with pytest.raises(InputError, match="--gm, --radius"):
        read_nga(path)
    m = read_nga(path, gm=3.9e14, radius=6.4e6)
    assert (m.gm, m.radius) == (3.9e14, 6.4e6) and "(given)" in m.header["constants"]
    named = tmp_path / "EGM96"
    write_nga(named, kaula_model(5))
    mixed = read_nga(named, gm=3.9860044e14)
    assert mixed.radius == 6378137.0 and "the other from EGM96" in mixed.header["constants"]
    with pytest.raises(InputError, match="for NGA"):
        load_model("eigen-6s", gm=3.9e14)


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda ls: ls[:3] + ["    3    0   0.1E-05\n"] + ls[4:], r"line 4: expected 4 or 6"),
        (lambda ls: ls[:2] + [ls[2].replace("0.2439", "0.2x39")] + ls[3:], r"line 3: .*number"),
        (lambda ls: ls[:5] + ["    3    4  1.0E-07  1.0E-07  0  0\n"] + ls[6:], "line 6: order"),
        (lambda ls: ls + [ls[1]], r"line 8: second line for n=2 m=1"),
        (lambda ls: ls[:4] + ls[5:], r"no line for n=3 m=1"),
        (lambda ls: ls[:1] + ["    2  1.5   1.0E-07  1.0E-07  0.0  0.0\n"] + ls[2:], "line 2: deg"),
        (lambda ls: ["    2    0  -4.8E+02  0.0E+00  0.0E+00  0.0E+00\n"] + ls[1:], "line 1"),
    ],
)
def test_nga_malformed(tmp_path, edit, match):
    """Each defect: one ModelFileError line naming file and line."""
    lines = EGM96_HEAD.splitlines(keepends=True)
    path = tmp_path / "EGM96_bad"
    path.write_text("".join(edit(lines)))
    with pytest.raises(ModelFileError, match=match) as exc:
        read_nga(path)
    assert str(path) in str(exc.value) and "\n" not in str(exc.value)


def _mutate(base: bytes, alphabet: bytes, rng) -> bytes:
    b = bytearray(base)
    for _ in range(int(rng.integers(1, 4))):
        pos, ch = int(rng.integers(0, len(b))), alphabet[int(rng.integers(0, len(alphabet)))]
        op = int(rng.integers(0, 3))
        if op == 0:
            del b[pos]
        elif op == 1:
            b.insert(pos, ch)
        else:
            b[pos] = ch
    return bytes(b)


def test_nga_fuzz(tmp_path):
    """Random byte edits of a valid NGA file: a model or one clean error line, nothing else."""
    base = EGM96_HEAD.encode()
    rng = np.random.default_rng(1)
    path, outcomes = tmp_path / "EGM96_fuzz", {"ok": 0, "error": 0}
    for _ in range(300):
        path.write_bytes(_mutate(base, b" \n\t0123456789.-+eEdDx\xe9", rng))
        try:
            read_nga(path)
            outcomes["ok"] += 1
        except (ModelFileError, InputError) as exc:
            assert "\n" not in str(exc) and str(path) in str(exc)
            outcomes["error"] += 1
    assert outcomes["ok"] > 10 and outcomes["error"] > 100


# --------------------------------------------------------------------------------------------
# GeographicLib .egm / .egm.cof


def test_egm_round_trip_with_order_and_correction(tmp_path):
    """write_egm -> read_egm: coefficients, M < N (orders above M zero), correction, offset."""
    model = kaula_model(30, seed=4)
    corr = kaula_model(12, seed=5)
    name = write_egm(model, tmp_path, name="rt", order=20, correction=corr, height_offset=-0.41)
    back = read_egm(tmp_path / f"{name}.egm")
    expect_c = model.C.copy()
    expect_s = model.S.copy()
    expect_c[:, 21:] = 0.0
    expect_s[:, 21:] = 0.0
    np.testing.assert_array_equal(back.C, expect_c)
    np.testing.assert_array_equal(back.S, expect_s)
    assert (back.gm, back.radius, back.header["N"], back.header["M"]) == (
        model.gm,
        model.radius,
        30,
        20,
    )
    assert back.header["HeightOffset"] == -0.41
    np.testing.assert_array_equal(back.header["correction"].C, corr.C)
    np.testing.assert_array_equal(back.header["correction"].S, corr.S)
    # the .cof path and the name + folder reach the same model
    via_cof = load_model(str(tmp_path / "rt.egm.cof"))
    via_name = load_model("rt", model_dir=tmp_path)
    np.testing.assert_array_equal(via_cof.C, back.C)
    np.testing.assert_array_equal(via_name.S, back.S)


def _hand_cof(ident: bytes, N: int, M: int, cvals, svals, corr=(-1, -1)) -> bytes:
    out = ident + struct.pack("<ii", N, M)
    out += struct.pack(f"<{len(cvals)}d", *cvals) + struct.pack(f"<{len(svals)}d", *svals)
    return out + struct.pack("<ii", *corr)


def _hand_egm(folder, name="hand", ident="HANDMADE", extra=(), norm="full"):
    lines = [
        "EGMF-1",
        "# written by hand in a test",
        f"Name {name}",
        "ModelRadius 6378136.3",
        "ModelMass 3986004.415e8",
        "AngularVelocity 7292115e-11",
        "ReferenceRadius 6378137",
        "ReferenceMass 3986004.418e8",
        "Flattening 1/298.257223563",
        f"Normalization {norm}",
        f"ID {ident}",
        *extra,
    ]
    (folder / f"{name}.egm").write_text("\n".join(lines) + "\n")
    return folder / f"{name}.egm"


def test_egm_hand_built_file(tmp_path):
    """A .cof packed here with struct (N = 3, M = 2, Schmidt), independent of write_egm."""
    # C columns m = 0 (n = 0..3), m = 1 (n = 1..3), m = 2 (n = 2..3); S for m = 1, 2
    c = [0.0, 0.0, -1.0e-3, 2.0e-6, 0.0, 3.0e-9, 4.0e-7, 5.0e-6, 6.0e-7]
    s = [0.0, 7.0e-9, 8.0e-7, 9.0e-6, 1.0e-7]
    path = _hand_egm(tmp_path, norm="schmidt")
    (tmp_path / "hand.egm.cof").write_bytes(_hand_cof(b"HANDMADE", 3, 2, c, s))
    m = read_egm(path)
    r5, r7 = math.sqrt(5.0), math.sqrt(7.0)  # Schmidt -> full: divide by sqrt(2n + 1)
    assert (m.gm, m.radius, m.lmax, m.header["M"]) == (3.986004415e14, 6378136.3, 3, 2)
    assert m.header["Flattening"] == pytest.approx(1 / 298.257223563, rel=1e-15)
    assert m.C[0, 0] == 1.0 and m.C[2, 0] == pytest.approx(-1.0e-3 / r5, rel=1e-15)
    assert m.C[3, 0] == pytest.approx(2.0e-6 / r7, rel=1e-15)
    assert m.C[3, 1] == pytest.approx(4.0e-7 / r7, rel=1e-15)
    assert m.C[2, 2] == pytest.approx(5.0e-6 / r5, rel=1e-15)
    assert m.S[3, 2] == pytest.approx(1.0e-7 / r7, rel=1e-15) and m.C[3, 3] == 0.0
    assert "correction" not in m.header


@needs_tool
def test_egm_reader_agrees_with_gravity_tool(tmp_path):
    """Gravity and fieldmap read the same files: gravity (M < N) and geoid (correction, offset).

    The tool is the independent reader here: its -G on a model with M < N equals fieldmap's
    gravity of the model it read; its -H (HeightOffset, a correction series) equals
    fieldmap's geoid height. Measured 2e-14 m/s² and 3e-12 m.
    """
    from fieldmap.field import geodesy as gd
    from fieldmap.field import gravity as fg

    model = kaula_model(60, seed=6, gm=3.986004415e14, radius=6378136.3)
    corr = kaula_model(20, seed=7)
    corr = SHModel("corr", 1.0, 1.0, corr.C * 1e4, corr.S * 1e4, 20)  # decimetres
    name = write_egm(model, tmp_path, name="mn", order=45, correction=corr, height_offset=-0.41)
    back = load_model("mn", model_dir=tmp_path)
    rng = np.random.default_rng(2)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, 200)))
    lon = rng.uniform(-180, 180, 200)
    h = rng.uniform(0, 50e3, 200)
    tool = run_gravity_tool(np.c_[lat, lon, h], tmp_path, name, "gravity", precision=15)
    np.testing.assert_allclose(fg.gravity(lat, lon, h, model=back), tool, rtol=0, atol=1e-13)
    tool_n = run_gravity_tool(np.c_[lat, lon, 0 * h], tmp_path, name, "geoid", precision=12)
    n = gd.geoid_height(lat, lon, model=back)
    corr_part = gd.correction_height(back, lat, lon) + 0.41
    assert np.abs(corr_part).max() > 0.01  # the correction series matters here
    np.testing.assert_allclose(n, tool_n[:, 0], rtol=0, atol=1e-6)


@pytest.mark.parametrize(
    "case, match",
    [
        ("magic", r"line 1: not a GeographicLib"),
        ("id", r"byte 0: ID"),
        ("short", r"ends inside the model coefficients"),
        ("extra", r"bytes of extra data"),
        ("c00", r"byte 16: C00 must be 0"),
        ("order", r"byte 8: bad model degree and order"),
        ("nan", r"byte 40: coefficient is not finite"),
        ("mass", r"line 5: ModelMass 'heavy' is not a number"),
        ("noid", r"no ID line"),
    ],
)
def test_egm_malformed(tmp_path, case, match):
    """Each defect: one ModelFileError naming the file and the line or byte offset."""
    c = [0.0, 0.0, -1.0e-3, 2.0e-6, 0.0, 3.0e-9, 4.0e-7, 5.0e-6, 6.0e-7]
    s = [0.0, 7.0e-9, 8.0e-7, 9.0e-6, 1.0e-7]
    path = _hand_egm(tmp_path)
    cof = _hand_cof(b"HANDMADE", 3, 2, c, s)
    if case == "magic":
        path.write_text("EGMF-2\n" + path.read_text().split("\n", 1)[1])
    elif case == "id":
        cof = b"OTHERIDX" + cof[8:]
    elif case == "short":
        cof = cof[:60]
    elif case == "extra":
        cof = cof + b"\0\0\0"
    elif case == "c00":
        cof = _hand_cof(b"HANDMADE", 3, 2, [1.0] + c[1:], s)
    elif case == "order":
        cof = _hand_cof(b"HANDMADE", 2, 3, c, s)
    elif case == "nan":
        cof = _hand_cof(b"HANDMADE", 3, 2, c[:3] + [math.nan] + c[4:], s)
    elif case == "mass":
        path.write_text(path.read_text().replace("ModelMass 3986004.415e8", "ModelMass heavy"))
    elif case == "noid":
        path.write_text(path.read_text().replace("ID HANDMADE", ""))
    (tmp_path / "hand.egm.cof").write_bytes(cof)
    with pytest.raises(ModelFileError, match=match) as exc:
        read_egm(path)
    assert "hand.egm" in str(exc.value) and "\n" not in str(exc.value)


def test_egm_fuzz(tmp_path):
    """Random edits of the .egm text and the .cof bytes: a model or one clean error line."""
    model = kaula_model(6, seed=8)
    name = write_egm(model, tmp_path, name="fz", correction=kaula_model(2, seed=1))
    egm, cof = tmp_path / f"{name}.egm", tmp_path / f"{name}.egm.cof"
    base_egm, base_cof = egm.read_bytes(), cof.read_bytes()
    rng = np.random.default_rng(4)
    outcomes = {"ok": 0, "error": 0}
    for k in range(300):
        if k % 2:
            egm.write_bytes(_mutate(base_egm, b" \n\t0123456789.-/eE#xID", rng))
            cof.write_bytes(base_cof)
        else:
            egm.write_bytes(base_egm)
            cof.write_bytes(_mutate(base_cof, bytes(range(256)), rng))
        try:
            read_egm(egm)
            outcomes["ok"] += 1
        except ModelFileError as exc:
            assert "\n" not in str(exc) and "fz.egm" in str(exc)
            outcomes["error"] += 1
    assert outcomes["ok"] > 10 and outcomes["error"] > 100


def test_cli_nga_and_egm_models(tmp_path):
    """``fieldmap point`` reads an NGA file (constants told on stderr) and an .egm by name."""
    model = kaula_model(20, seed=9, gm=3.986004415e14, radius=6378136.3)
    write_nga(tmp_path / "EGM2008_small", model)
    write_egm(model, tmp_path, name="small")
    env = {**os.environ, "FIELDMAP_MODEL_CACHE": str(tmp_path / "c")}

    def run(args):
        return subprocess.run(
            [sys.executable, "-m", "fieldmap", "point", "--precision", "9", *args],
            input="10 20 1000\n",
            capture_output=True,
            text=True,
            timeout=300,
            env=env,
        )

    a = run(["--model", str(tmp_path / "EGM2008_small")])
    b = run(["--model", "small", "--model-dir", str(tmp_path)])
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    assert "EGM2008's published values" in a.stderr and "6378136.3" in a.stderr
    assert a.stdout == b.stdout and len(a.stdout.split()) == 3
    bad = run(["--model", "nosuch", "--model-dir", str(tmp_path)])
    assert bad.returncode == 2 and "nosuch.egm" in bad.stderr
