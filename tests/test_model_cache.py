"""On-disk cache of parsed models: reuse, staleness, corruption, opt-out, clearing."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from fieldmap.errors import InputError
from fieldmap.models import cache
from fieldmap.models.icgem import read_icgem, write_icgem
from fieldmap.models.registry import clear_cache, kaula_model, load_model


def _use_model_cache(monkeypatch, folder) -> None:
    """Point the parsed-model cache at ``folder`` for this test (the settings are read once)."""
    import dataclasses

    from fieldmap import config

    monkeypatch.setattr(
        config, "_current", dataclasses.replace(config.get(), model_cache=str(folder))
    )


@pytest.fixture
def root(tmp_path, monkeypatch):
    """Return a private cache folder (and empty the in-memory cache)."""
    folder = tmp_path / "cache"
    _use_model_cache(monkeypatch, str(folder))
    clear_cache()
    return folder


@pytest.fixture
def gfc(tmp_path):
    """Return a small ICGEM file and its model."""
    model = kaula_model(30, seed=11)
    path = tmp_path / "k30.gfc"
    write_icgem(path, model)
    return path, model


class Counting:
    """A reader that counts its calls."""

    def __init__(self, path):
        self.path, self.calls = path, 0

    def __call__(self, lmax):  # noqa: D102 - the reader protocol
        self.calls += 1
        return read_icgem(self.path, lmax=lmax)


def _entries(root):
    folder = root / "entries"
    return (
        sorted(p for p in folder.iterdir() if not p.name.startswith(".")) if folder.exists() else []
    )


def test_second_read_comes_from_the_cache(root, gfc):
    """One parse, then memory-mapped arrays equal to the parsed ones; truncations slice it."""
    path, model = gfc
    reader = Counting(path)
    a = cache.cached_read([str(path)], "icgem-test", None, reader)
    b = cache.cached_read([str(path)], "icgem-test", None, reader)
    assert reader.calls == 1 and isinstance(b.C, np.memmap)
    np.testing.assert_array_equal(b.C, model.C)
    np.testing.assert_array_equal(b.S, a.S)
    assert (b.gm, b.radius, b.name, b.max_degree, b.nominal_degree) == (
        a.gm,
        a.radius,
        a.name,
        a.max_degree,
        a.nominal_degree,
    )
    part = cache.cached_read([str(path)], "icgem-test", 10, reader)
    assert reader.calls == 1 and part.lmax == part.max_degree == 10
    assert part.nominal_degree == a.nominal_degree
    np.testing.assert_array_equal(part.C, model.C[:11, :11])
    assert len(_entries(root)) == 1


def test_stat_index_avoids_rehashing(root, gfc, monkeypatch):
    """While size, mtime, ctime and inode are unchanged the file is not hashed again."""
    path, _ = gfc
    reader = Counting(path)
    cache.cached_read([str(path)], "v", None, reader)
    calls = []
    real = cache._sha256_file
    monkeypatch.setattr(cache, "_sha256_file", lambda p: calls.append(p) or real(p))
    cache.cached_read([str(path)], "v", None, reader)
    assert calls == [] and reader.calls == 1
    os.utime(path, ns=(1, 1))  # touched: rehashed, same content, same entry
    cache.cached_read([str(path)], "v", None, reader)
    assert len(calls) == 1 and reader.calls == 1


def test_changed_file_or_reader_version_is_a_new_entry(root, gfc):
    """New content -> parsed again; another variant (reader version, epoch) -> parsed again."""
    path, model = gfc
    reader = Counting(path)
    cache.cached_read([str(path)], "icgem-v1", None, reader)
    other = kaula_model(30, seed=12)
    write_icgem(path, other)
    st = os.stat(path)
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns + 1000))
    m = cache.cached_read([str(path)], "icgem-v1", None, reader)
    assert reader.calls == 2
    np.testing.assert_array_equal(m.C, other.C)
    cache.cached_read([str(path)], "icgem-v2", None, reader)
    assert reader.calls == 3 and len(_entries(root)) == 3


@pytest.mark.parametrize("damage", ["flip", "truncate", "meta", "shape", "missing"])
def test_corrupt_entry_is_rebuilt(root, gfc, damage):
    """A damaged entry is never used: it is deleted, the file parsed and the entry rewritten."""
    path, model = gfc
    reader = Counting(path)
    cache.cached_read([str(path)], "v", None, reader)
    (entry,) = _entries(root)
    c_npy = entry / "C.npy"
    if damage == "flip":
        raw = bytearray(c_npy.read_bytes())
        raw[-100] ^= 0x01  # one bit of one coefficient
        c_npy.write_bytes(bytes(raw))
    elif damage == "truncate":
        c_npy.write_bytes(c_npy.read_bytes()[:500])
    elif damage == "meta":
        (entry / "meta.json").write_text("{not json")
    elif damage == "shape":
        meta = json.loads((entry / "meta.json").read_text())
        meta["arrays"]["C"]["shape"] = [3, 3]
        (entry / "meta.json").write_text(json.dumps(meta))
    else:
        (entry / "S.npy").unlink()
    m = cache.cached_read([str(path)], "v", None, reader)
    assert reader.calls == 2
    np.testing.assert_array_equal(m.C, model.C)
    np.testing.assert_array_equal(m.S, model.S)
    again = cache.cached_read([str(path)], "v", None, reader)  # the rebuilt entry is good
    assert reader.calls == 2 and isinstance(again.C, np.memmap)


def test_no_cache_and_unwritable_cache(root, gfc, tmp_path, monkeypatch):
    """cache=False writes nothing; a cache folder that cannot be created still loads.

    A cache "folder" under a file is a misconfiguration, not an unwritable folder: refused.
    """
    path, model = gfc
    m = load_model(str(path), cache=False)
    np.testing.assert_array_equal(m.C, model.C)
    assert not root.exists()
    blocker = tmp_path / "file-not-folder"
    blocker.write_text("x")
    _use_model_cache(monkeypatch, str(blocker / "cache"))
    clear_cache()
    with pytest.raises(InputError, match="file-not-folder is not a folder"):
        load_model(str(path))
    np.testing.assert_array_equal(load_model(str(path), cache=False).S, model.S)
    if not os.path.isdir("/proc"):
        return
    _use_model_cache(monkeypatch, "/proc/fieldmap-cache")  # no process can create it, not root
    clear_cache()
    m = load_model(str(path))
    np.testing.assert_array_equal(m.S, model.S)


def test_load_model_uses_cache_across_in_memory_clears(root, gfc):
    """Through load_model: the second load (memory cache cleared, as a new process) is mapped."""
    path, model = gfc
    load_model(str(path))
    clear_cache()
    m = load_model(str(path))
    assert isinstance(m.C, np.memmap)
    np.testing.assert_array_equal(m.C, model.C)
    m10 = load_model(str(path), lmax=10)
    np.testing.assert_array_equal(m10.C, model.C[:11, :11])


def test_cli_cache_info_and_clear(root, gfc):
    """``fieldmap cache info`` lists the entry, ``fieldmap cache clear`` removes it."""
    path, _ = gfc
    env = {**os.environ, "FIELDMAP_MODEL_CACHE": str(root)}

    def run(*args, stdin=""):
        return subprocess.run(
            [sys.executable, "-m", "fieldmap", *args],
            input=stdin,
            capture_output=True,
            text=True,
            timeout=300,
            env=env,
        )

    first = run("point", "--model", str(path), stdin="10 20 0\n")
    second = run("point", "--model", str(path), stdin="10 20 0\n")
    assert first.returncode == 0 and first.stdout == second.stdout
    info = run("cache", "info")
    assert "1 cached models" in info.stdout and str(path.name) in info.stdout
    assert "removed 1 cached models" in run("cache", "clear").stdout
    assert _entries(root) == []
    nocache = run("point", "--model", str(path), "--no-cache", stdin="10 20 0\n")
    assert nocache.stdout == first.stdout and _entries(root) == []


def test_recursion_tables_cache(root):
    """Degree >= 1000 tables: computed once, then verified memory maps; damage recomputes."""
    from fieldmap.field.sh import recursion_tables

    calls = []

    def compute(lmax):
        calls.append(lmax)
        return recursion_tables(lmax)

    L = cache.TABLES_MIN_DEGREE
    first = cache.cached_tables(L, compute)
    second = cache.cached_tables(L, compute)
    assert calls == [L] and isinstance(second["anm"], np.memmap)
    for k in ("anm", "bnm", "fnm", "sect"):
        np.testing.assert_array_equal(second[k], first[k])
    (folder,) = (root / "tables").iterdir()
    raw = bytearray((folder / "bnm.npy").read_bytes())
    raw[-8] ^= 0x10
    (folder / "bnm.npy").write_bytes(bytes(raw))
    third = cache.cached_tables(L, compute)
    assert calls == [L, L]
    np.testing.assert_array_equal(third["bnm"], first["bnm"])
    assert cache.cached_tables(10, compute) and calls == [L, L, 10]  # small: never cached


def test_a_copy_named_otherwise_hits_the_entry(root, gfc, tmp_path):
    """An ICGEM file's entry holds no file name: copies named otherwise hit one entry.

    So the bundled model read from a zip import (a new temporary name each run) hits its one
    entry. NGA files keep their name (see
    tests/test_bad_model_files.py::test_cache_keeps_what_a_file_name_means).
    """
    path, model = gfc
    load_model(str(path))
    for i in range(2):
        copy = tmp_path / f"tmp{i}xyzk30.gfc"
        copy.write_bytes(path.read_bytes())
        clear_cache()
        np.testing.assert_array_equal(load_model(str(copy)).C, model.C)
    assert len(_entries(root)) == 1


def test_recursion_tables_with_a_cache_path_that_is_a_file(tmp_path, monkeypatch, gfc):
    """The tables are computed when the cache path is a file (load_model(cache=False) runs).

    A model load with the cache on still reports the path.
    """
    afile = tmp_path / "afile"
    afile.write_text("")
    _use_model_cache(monkeypatch, str(afile))
    clear_cache()
    L = cache.TABLES_MIN_DEGREE
    assert cache.cached_tables(L, lambda lmax: {"x": np.arange(3.0)})["x"].tolist() == [0, 1, 2]
    cache.prefetch_tables(L)
    assert afile.read_text() == ""
    with pytest.raises(InputError, match="afile is not a folder"):
        load_model(str(gfc[0]))
