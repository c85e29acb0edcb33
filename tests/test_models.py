"""Model loading by name or path, the in-memory cache, and the synthetic Kaula model."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.models.icgem import write_icgem
from fieldmap.models.registry import clear_cache, kaula_model, load_model


def test_bundled_default_cached_case_insensitive():
    """``load_model()`` is EIGEN-6S; names are case-insensitive; the parse is cached."""
    a = load_model()
    b = load_model("EIGEN-6S")
    assert a is b  # served from the cache
    assert (a.name, a.lmax, a.gm, a.radius) == ("EIGEN-6S", 240, 3.986004415e14, 6378136.46)
    assert "bundled" in a.source
    t = load_model("eigen-6s", lmax=12)
    assert t.lmax == 12
    np.testing.assert_array_equal(t.C, a.C[:13, :13])
    with pytest.raises(InputError, match="exceeds the degree 240"):
        load_model("eigen-6s", lmax=241)
    e = load_model("eigen-6s", epoch="2010-01-01")
    assert e.epoch == 2010.0 and e.C[2, 0] != a.C[2, 0]
    clear_cache()
    assert load_model() is not a


def test_bundled_model_found_from_any_directory(tmp_path):
    """importlib.resources, not a path relative to the working directory."""
    code = "from fieldmap.models.registry import load_model; print(load_model().lmax)"
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "240"


def test_user_file_and_unknown_name(tmp_path):
    """A path loads a user file (with truncation); an unknown name is one clear error."""
    model = kaula_model(30, seed=5)
    path = tmp_path / "user.gfc.gz"
    write_icgem(path, model)
    part = load_model(os.fspath(path), lmax=10)
    np.testing.assert_array_equal(part.C, model.C[:11, :11])
    assert load_model(path, lmax=10) is part  # truncated reads are cached too
    full = load_model(path)
    assert load_model(path) is full
    np.testing.assert_array_equal(full.S, model.S)
    with pytest.raises(InputError, match="unknown model 'egm2099'"):
        load_model("egm2099")
    assert load_model(model, lmax=5).lmax == 5


def test_kaula_model_rule_and_determinism():
    """Degree variances follow σn = 1e-5/n²; C00 = 1, degree 1 zero, Earth-like C20; seeded."""
    a, b, c = kaula_model(400, seed=1), kaula_model(400, seed=1), kaula_model(400, seed=2)
    np.testing.assert_array_equal(a.C, b.C)
    assert not np.array_equal(a.C, c.C)
    assert a.C[0, 0] == 1.0 and not a.C[1].any() and not a.S[1].any() and not a.S[:, 0].any()
    assert a.C[2, 0] == -4.84165e-4
    assert not np.triu(a.C, 1).any() and not np.triu(a.S, 1).any()
    n = np.arange(100, 401)
    # RMS over the 2n+1 coefficients of each degree (C_n0 and all C_nm, S_nm with m >= 1)
    rms = np.sqrt((a.C[n] ** 2 + a.S[n] ** 2).sum(axis=1) / (2 * n + 1))
    ratio = rms * n**2 / 1e-5
    assert abs(ratio.mean() - 1.0) < 0.02 and ratio.min() > 0.8 and ratio.max() < 1.2
    with pytest.raises(InputError):
        kaula_model(-1)


def test_truncated_model_says_its_degree():
    """``truncated(36)`` holds degree 36 and says so; the file's degree stays nominal_degree."""
    full = load_model("eigen-6s")
    t = full.truncated(36)
    assert (t.lmax, t.max_degree, t.nominal_degree) == (36, 36, 240)
    assert (full.lmax, full.max_degree, full.nominal_degree) == (240, 240, 240)
    assert t.truncated(10).max_degree == 10
    # read with lmax: the same as a truncation
    part = load_model("eigen-6s", lmax=12)
    assert (part.max_degree, part.nominal_degree) == (12, 240)


def test_model_repr_is_one_short_line():
    """Name, degree, GM, a, tide system and epoch; no coefficient arrays."""
    m = load_model("eigen-6s").truncated(36)
    text = repr(m)
    assert "\n" not in text and len(text) < 160, text
    assert text == (
        "SHModel('EIGEN-6S', degree=36 (of 240), GM=3.986004415e+14 m3/s2, a=6378136.46 m, "
        "tide_system=tide_free, epoch=2005.0000)"
    )
    k = kaula_model(8, seed=1)
    assert repr(k).startswith(f"SHModel({k.name!r}, degree=8, ") and "epoch=static" in repr(k)
    assert "tide_system" not in repr(k)  # unknown: not shown
