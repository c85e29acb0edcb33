"""Start-up of ``fieldmap point``: the model loads while Warp is imported; same bits, same errors.

:mod:`fieldmap.cli.startup` imports Warp and builds the kernel's struct in a thread while the
main thread verifies the model and its recursion tables
(:func:`fieldmap.models.cache.prefetch_tables`). These tests check that the numbers are those
of the plain API, that a prefetched table entry is used once and only when it is the right
one, that errors come in the former order, and that an in-process run leaves the garbage
collector as it was. (Its speed is measured by ``benchmarks/bench_points.py``, not here.)
"""

from __future__ import annotations

import dataclasses
import gc
import io
import shutil
import sys

import numpy as np
import pytest

from fieldmap.models import cache
from fieldmap.models.registry import clear_cache, kaula_model, load_model


@pytest.fixture
def root(tmp_path, monkeypatch):
    """Return a private model cache folder (and empty the in-memory caches)."""
    from fieldmap import config

    folder = tmp_path / "cache"
    monkeypatch.setattr(
        config, "_current", dataclasses.replace(config.get(), model_cache=str(folder))
    )
    clear_cache()
    monkeypatch.setattr(cache, "_prefetched", {})
    return folder


def _forget_structs():
    """Empty the struct, table and coefficient caches of the point kernels."""
    from fieldmap.field import sh

    for store in (sh._cache, sh._tables, sh._coefs):
        store.clear()


def test_prefetched_tables_are_taken_once(root):
    """The next cached_tables call takes the prefetched entry; later calls load it again."""
    from fieldmap.field.sh import recursion_tables

    L = cache.TABLES_MIN_DEGREE
    first = cache.cached_tables(L, recursion_tables)  # computed and stored
    cache.prefetch_tables(L)
    (ahead,) = cache._prefetched.values()
    second = cache.cached_tables(L, recursion_tables)
    assert second is ahead and cache._prefetched == {}
    third = cache.cached_tables(L, recursion_tables)
    assert third is not second and isinstance(third["anm"], np.memmap)
    for k in ("anm", "bnm", "fnm", "sect"):
        np.testing.assert_array_equal(second[k], first[k])
        np.testing.assert_array_equal(third[k], first[k])
    cache.prefetch_tables(L + 1)  # no entry of that degree: nothing
    assert cache._prefetched == {}


def test_prefetch_skips_damaged_and_ambiguous_entries(root):
    """A damaged entry is not prefetched (it is rebuilt as usual); nor is one of several."""
    from fieldmap.field.sh import recursion_tables

    calls = []

    def compute(lmax):
        calls.append(lmax)
        return recursion_tables(lmax)

    L = cache.TABLES_MIN_DEGREE
    cache.cached_tables(L, compute)
    (folder,) = (root / "tables").iterdir()
    raw = bytearray((folder / "fnm.npy").read_bytes())
    raw[-8] ^= 0x10
    (folder / "fnm.npy").write_bytes(bytes(raw))
    cache.prefetch_tables(L)
    assert cache._prefetched == {}
    fresh = cache.cached_tables(L, compute)
    assert calls == [L, L]
    np.testing.assert_array_equal(fresh["fnm"], recursion_tables(L)["fnm"])
    shutil.copytree(folder, folder.with_name(f"L{L}-olderformulas"))
    cache.prefetch_tables(L)  # two entries of that degree: which one is unknown until imported
    assert cache._prefetched == {}


@pytest.mark.parametrize("quantity", ["disturbance", "gravity", "gradient", "anomaly"])
def test_point_values_are_those_of_the_api(root, tmp_path, quantity):
    """evaluate_points (model loaded during Warp's import, tables prefetched) = the plain API."""
    from fieldmap.cli.point import evaluate_points
    from fieldmap.field import geodesy
    from fieldmap.field import gravity as fg
    from fieldmap.field.gradient import gradient_tensor
    from fieldmap.models.geographiclib import write_egm

    L = cache.TABLES_MIN_DEGREE  # tables of this degree live in the on-disk cache
    write_egm(kaula_model(L, seed=3), str(tmp_path), name="k")
    path = str(tmp_path / "k.egm")
    lat = np.array([30.0, -45.5, 89.9, 0.0])
    lon = np.array([105.0, 12.25, -170.0, 0.0])
    h = np.array([20e3, 0.0, 1e5, -50.0])
    m = load_model(path)
    if quantity == "disturbance":
        want = fg.disturbance(lat, lon, h, model=m, units="mGal", frame="enu", device="cpu")
    elif quantity == "gravity":
        want = fg.gravity(lat, lon, h, model=m, frame="enu", device="cpu")
    elif quantity == "gradient":
        want = gradient_tensor(lat, lon, h, model=m, quantity="gravity", device="cpu")
        want = want.reshape(-1, 9)
    else:
        want = np.stack(geodesy.gravity_anomaly(lat, lon, h, model=m, device="cpu"), axis=-1)
    clear_cache()
    _forget_structs()
    got = evaluate_points(lat, lon, h, quantity=quantity, model=path, device="cpu")
    assert cache._prefetched == {}  # the prefetched tables were taken
    np.testing.assert_array_equal(got, want)


def _run(argv, monkeypatch, stdin="30 105 20000\n"):
    from fieldmap.cli import main

    monkeypatch.setattr(sys, "stdin", io.StringIO(stdin))
    return main(argv)


def test_errors_keep_their_order(root, capsys, monkeypatch):
    """A bad device is reported before a bad model (the model now loads first); one line."""
    rc = _run(["point", "--model", "/nonexistent/m.gfc", "--device", "cuda:97"], monkeypatch)
    err = capsys.readouterr().err
    assert rc == 2 and len(err.splitlines()) == 1 and "cuda:97" in err
    rc = _run(["point", "--model", "/nonexistent/m.gfc"], monkeypatch)
    err = capsys.readouterr().err
    assert rc == 2 and len(err.splitlines()) == 1 and "/nonexistent/m.gfc" in err


def test_in_process_run_leaves_the_collector_alone(root, capsys, monkeypatch):
    """Only the ``fieldmap`` program itself turns collection off and freezes at its end."""
    frozen = gc.get_freeze_count()
    assert _run(["point"], monkeypatch) == 0
    assert gc.isenabled() and gc.get_freeze_count() == frozen
    assert len(capsys.readouterr().out.split()) == 3
