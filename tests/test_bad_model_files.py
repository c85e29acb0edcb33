"""Bad model files and model options: one line naming the file (and line), exit status 2.

Items of the CLI bad-input audit on the model readers, the model options and the model cache:
a corrupt gzip stream (zlib's own error, 1.1), a C̄00 that is no gravity model's (3.1), a
negative σ in a .gfc (3.2), a file edited in place with its modification time set back (3.4),
``.egm`` files that are not GeographicLib's (4.4), ``--model-dir`` with a file path (2.3),
``--epoch`` with a static model (2.4) and a model cache path that is a file (3.8). The CLI cases
run the real ``python -m fieldmap`` in an empty working folder and check the exit status, the one
line on stderr, nothing on stdout and no file left behind.
"""

from __future__ import annotations

import gzip
import os
import subprocess
import sys
import time
import zlib
from pathlib import Path

import pytest

from fieldmap.errors import InputError, ModelFileError
from fieldmap.models import icgem
from fieldmap.models.geographiclib import write_egm
from fieldmap.models.icgem import read_icgem
from fieldmap.models.nga import read_nga
from fieldmap.models.registry import clear_cache, detect_format, kaula_model, load_model

HEAD = """begin_of_head
modelname tiny
earth_gravity_constant 3.986004415E+14
radius 6378136.3
max_degree 2
norm fully_normalized
errors formal
end_of_head
"""  # 8 lines: data line k (from 0) is file line 9 + k
LINES = [
    "gfc 0 0 1.0 0.0 0.0 0.0\n",
    "gfc 1 0 0.0 0.0 0.0 0.0\n",
    "gfc 1 1 0.0 0.0 0.0 0.0\n",
    "gfc 2 0 -4.84165E-04 0.0 1.0e-12 0.0\n",
    "gfc 2 1 0.0 0.0 1.0e-12 1.0e-12\n",
    "gfc 2 2 2.4e-06 -1.4e-06 1.0e-12 1.0e-12\n",
]
GOOD = HEAD + "".join(LINES)
# NGA's header-less format; GM and radius from the name (EGM96)
NGA = (
    "    2    0 -0.484165D-03  0.0D+00 1.0D-12 0.0D+00\n"
    "    2    1  0.0D+00  0.0D+00 1.0D-12 1.0D-12\n"
    "    2    2  2.4D-06 -1.4D-06 1.0D-12 1.0D-12\n"
)
NGA_C00_ZERO = "    0    0  0.0D0 0.0D0 0.0D0 0.0D0\n" + NGA
# gzip magic, method and flags, then bytes that are no deflate stream: zlib.error, not EOFError
BAD_DEFLATE = b"\x1f\x8b\x08\x00garbagegarbage"


@pytest.fixture
def work(tmp_path):
    """Return an empty working folder (the model cache lies outside it)."""
    folder = tmp_path / "work"
    folder.mkdir()
    return folder


@pytest.fixture
def private_cache(tmp_path, monkeypatch):
    """Point the model cache at a new folder (the settings are read once); empty the memory one."""
    import dataclasses

    from fieldmap import config

    folder = tmp_path / "model-cache"
    monkeypatch.setattr(
        config, "_current", dataclasses.replace(config.get(), model_cache=str(folder))
    )
    clear_cache()
    yield folder
    clear_cache()


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


def fieldmap(work: Path, *args, stdin="30 0 20000\n", cache=None):
    """Run ``python -m fieldmap ARGS`` in ``work``; return (process, files it added)."""
    env = {**os.environ, "FIELDMAP_MODEL_CACHE": str(cache or work.parent / "cache")}
    env.pop("FIELDMAP_DEBUG", None)
    before = _tree(work)
    run = subprocess.run(
        [sys.executable, "-m", "fieldmap", *args],
        cwd=work,
        input=stdin,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    return run, _tree(work) - before


def refused(result, *words) -> str:
    """Assert exit 2, one line on stderr holding ``words``, no stdout, no new file."""
    run, added = result
    err = run.stderr.strip().splitlines()
    assert run.returncode == 2, (run.returncode, run.stderr)
    assert len(err) == 1 and "Traceback" not in run.stderr, run.stderr
    for word in words:
        assert word in err[0], (word, err[0])
    assert run.stdout == "" and not added, (run.stdout, added)
    return err[0]


def _flipped_gzip(text: bytes) -> bytes:
    """``text`` gzipped, with one byte of the deflate stream changed so that zlib fails."""
    data = gzip.compress(text, mtime=0)
    for pos in range(len(data) // 2, len(data) - 8):
        bad = bytearray(data)
        bad[pos] ^= 0xFF
        try:
            gzip.decompress(bytes(bad))
        except zlib.error:
            return bytes(bad)
        except (OSError, EOFError):
            continue
    raise AssertionError("no byte flip gives a zlib error")  # pragma: no cover


# ------------------------------------------------------------------ 1.1 corrupt gzip streams
@pytest.mark.parametrize(
    "name, data",
    [
        ("bad.gfc.gz", BAD_DEFLATE),
        ("EGM96_bad.gz", BAD_DEFLATE),
        ("EGM96_flip.gz", _flipped_gzip(NGA.encode() * 40)),
        ("flip.gfc.gz", _flipped_gzip(GOOD.encode() + b"\n" * 4000)),
    ],
    ids=["gfc-garbage", "nga-garbage", "nga-flipped", "gfc-flipped"],
)
def test_corrupt_gzip_is_bad_input(work, name, data):
    """A zlib error (not the EOFError of a truncated file) is one line naming the file."""
    (work / name).write_bytes(data)
    refused(fieldmap(work, "point", "--no-cache", "--model", name), name, "corrupt gzip")


@pytest.mark.parametrize("in_memory", [True, False])
def test_corrupt_gzip_readers(tmp_path, monkeypatch, in_memory):
    """Both gzip paths of the ICGEM reader (in memory, streamed to a file) and the NGA reader."""
    if not in_memory:
        monkeypatch.setattr(icgem, "GZ_IN_MEMORY", 0)
    for name, data in (("a.gfc.gz", BAD_DEFLATE), ("b.gfc.gz", _flipped_gzip(GOOD.encode()))):
        (tmp_path / name).write_bytes(data)
        assert detect_format(tmp_path / name) == "icgem"  # its reader names the damage
        with pytest.raises(ModelFileError, match=f"{name}: truncated or corrupt gzip data"):
            read_icgem(tmp_path / name)
    (tmp_path / "EGM96_x.gz").write_bytes(_flipped_gzip(NGA.encode() * 40))
    with pytest.raises(ModelFileError, match="EGM96_x.gz: truncated or corrupt gzip data"):
        read_nga(tmp_path / "EGM96_x.gz")


# ------------------------------------------------------------------------- 3.1 C00 must be 1
def test_c00_far_from_one_is_refused(work):
    """C̄00 = 0 gave a 975,321 mGal "disturbance"; now the file and line are named."""
    (work / "c00.gfc").write_text(GOOD.replace("gfc 0 0 1.0", "gfc 0 0 0.0"))
    refused(fieldmap(work, "point", "--model", "c00.gfc"), "c00.gfc, line 9:", "C00 is 0")
    (work / "EGM96_c00").write_text(NGA_C00_ZERO)
    refused(fieldmap(work, "point", "--model", "EGM96_c00"), "EGM96_c00, line 1:", "C00 is 0")


@pytest.mark.parametrize(
    "c00, ok", [("1.0", True), ("1.000000001", True), ("0.99", True), ("1.5", False), ("-1", False)]
)
def test_c00_band(tmp_path, c00, ok):
    """C̄00 within 1 ± 0.02 is read (a value just above 1 too), beyond it refused by every reader."""
    path = tmp_path / "c.gfc"
    path.write_text(GOOD.replace("gfc 0 0 1.0", f"gfc 0 0 {c00}"))
    nga = tmp_path / "EGM96_c"
    nga.write_text(f"    0    0  {c00}D0 0.0D0 0.0D0 0.0D0\n" + NGA)
    if ok:
        assert read_icgem(path).C[0, 0] == read_nga(nga).C[0, 0] == float(c00)
        return
    with pytest.raises(ModelFileError, match=r"c\.gfc, line 9: C00 is .* not 1"):
        read_icgem(path)
    with pytest.raises(ModelFileError, match="EGM96_c, line 1: C00 is .* not 1"):
        read_nga(nga)


@pytest.mark.parametrize(
    "line, ok",
    [
        ("gfc 1 0 2e-10", True),
        ("gfc 1 1 -1e-3", True),
        ("gfc 1 0 0.5", False),
        ("gfc 1 1 2e-3", False),
    ],
)
def test_degree1_band(tmp_path, line, ok):
    """|C̄1m|, |S̄11| up to 1e-3 (a centre of mass ~11 km off): read; beyond: the file's line."""
    n, m = line.split()[1:3]
    path = tmp_path / "d.gfc"
    path.write_text(GOOD.replace(f"gfc {n} {m} 0.0", line))
    nga = tmp_path / "EGM96_d"
    value = f"{float(line.split()[3]):.6E}".replace("E", "D")
    nga.write_text(f"    1    {m}  {value} 0.0D0 0.0D0 0.0D0\n" + NGA)
    if ok:
        assert read_icgem(path).C[1, int(m)] == read_nga(nga).C[1, int(m)] == float(line.split()[3])
        return
    k = 10 if m == "0" else 11
    with pytest.raises(ModelFileError, match=rf"d\.gfc, line {k}: degree-1 coefficient n=1 m={m}"):
        read_icgem(path)
    with pytest.raises(ModelFileError, match=f"EGM96_d, line 1: degree-1 coefficient n=1 m={m}"):
        read_nga(nga)


def test_models_with_c00_one_still_load(tmp_path):
    """The bundled EIGEN-6S, a Kaula model written as .gfc and .egm: C̄00 = 1, read as before."""
    assert load_model("eigen-6s", lmax=2).C[0, 0] == 1.0
    name = write_egm(kaula_model(4, seed=1), tmp_path)
    assert load_model(name, model_dir=tmp_path, cache=False).C[0, 0] == 1.0


# ---------------------------------------------------------------- 3.2 negative sigma in a .gfc
def test_negative_sigma_in_gfc(work, monkeypatch):
    """Refused as the NGA reader refuses it, file and line named, whatever the chunk size."""
    text = GOOD.replace("gfc 2 1 0.0 0.0 1.0e-12 1.0e-12", "gfc 2 1 0.0 0.0 1.0e-12 -1.0e-12")
    (work / "neg.gfc").write_text(text)
    refused(fieldmap(work, "point", "--model", "neg.gfc"), "neg.gfc, line 13:", "negative")
    one = pytest.raises(ModelFileError, read_icgem, work / "neg.gfc")
    monkeypatch.setattr(icgem, "CHUNK_LINES", 2)
    two = pytest.raises(ModelFileError, read_icgem, work / "neg.gfc")
    assert str(one.value) == str(two.value)


# ------------------------------------------------------ 3.4 edits that set the mtime back
def test_edit_in_place_with_mtime_restored_is_read_again(tmp_path, private_cache):
    """Same size, inode and mtime (``touch -r``), new content: the change time tells."""
    path = tmp_path / "g.gfc"
    path.write_text(GOOD)
    before = os.stat(path)
    assert load_model(str(path)).C[2, 0] == -4.84165e-4
    time.sleep(0.05)  # the change time moves on by a clock tick at least
    with open(path, "r+b") as f:  # in place: same inode, same size
        f.write(GOOD.replace("-4.84165E-04", "-4.94165E-04").encode())
    os.utime(path, ns=(before.st_atime_ns, before.st_mtime_ns))
    after = os.stat(path)
    assert (after.st_ino, after.st_size, after.st_mtime_ns) == (
        before.st_ino,
        before.st_size,
        before.st_mtime_ns,
    )
    assert after.st_ctime_ns != before.st_ctime_ns
    assert load_model(str(path)).C[2, 0] == -4.94165e-4  # the in-memory cache
    clear_cache()
    assert load_model(str(path)).C[2, 0] == -4.94165e-4  # the on-disk cache (a new process)


# ------------------------------------------------------------ 4.4 .egm files not GeographicLib's
@pytest.mark.parametrize(
    "data",
    [b"Name good\nModelRadius 6378137\nModelMass 3.986004418e14\nID ABCDEFGH\n", bytes(range(256))],
    ids=["no EGMF-1 line", "binary"],
)
def test_bad_egm_files_speak_of_egm(work, data):
    """Messages about a .egm file speak of GeographicLib's format, not of ICGEM's.

    With its .egm.cof and without: the metadata's problem comes first.
    """
    (work / "m.egm").write_bytes(data)
    for cof in (False, True):
        if cof:
            write_egm(kaula_model(4, seed=1), work.parent, name="m")
            os.replace(work.parent / "m.egm.cof", work / "m.egm.cof")
        args = ("point", "--model", "m.egm")
        line = refused(fieldmap(work, *args), "m.egm, line 1:", "GeographicLib")
        assert "ICGEM" not in line and "end_of_head" not in line


# --------------------------------------------------------- 2.3 --model-dir with a file path
def test_model_dir_with_a_file_path(work):
    """--model-dir does nothing for a file path outside it: refused, as with the bundled model."""
    (work / "good.gfc").write_text(GOOD)
    (work / "dir").mkdir()
    for model in ("good.gfc", str(work / "good.gfc")):
        refused(fieldmap(work, "point", "--model", model, "--model-dir", "dir"), "--model-dir")
    with pytest.raises(InputError, match="model_dir"):
        load_model(str(work / "good.gfc"), model_dir=work / "dir", cache=False)
    # a path to a file inside DIR, absolute or relative, is read (it is in DIR)
    (work / "dir" / "inside.gfc").write_text(GOOD)
    for model in (str(work / "dir" / "inside.gfc"), os.path.join("dir", "inside.gfc")):
        run, _ = fieldmap(work, "point", "--model", model, "--model-dir", "dir")
        assert run.returncode == 0 and len(run.stdout.split()) == 3, run.stderr
    inside = load_model(str(work / "dir" / "inside.gfc"), model_dir=work / "dir", cache=False)
    assert inside.source == str(work / "dir" / "inside.gfc")


def test_model_dir_still_finds_its_models(work):
    """A GeographicLib name in --model-dir, and a path relative to it, are read from there."""
    name = write_egm(kaula_model(4, seed=1), work / "dir")
    (work / "dir" / "good.gfc").write_text(GOOD)
    for model in (name, "good.gfc"):
        run, added = fieldmap(work, "point", "--model", model, "--model-dir", "dir")
        assert run.returncode == 0 and len(run.stdout.split()) == 3 and not added, run.stderr


# ----------------------------------------------------------- 2.4 --epoch with a static model
def test_epoch_with_a_static_model(work):
    """--epoch has nothing to act on in a static model (.gfc, NGA, .egm): refused, not ignored."""
    (work / "good.gfc").write_text(GOOD)
    (work / "EGM96_tiny").write_text(NGA)
    name = write_egm(kaula_model(4, seed=1), work / "dir")
    cases = [
        (["point", "--model", "good.gfc"], "good.gfc is a static model"),
        (["point", "--model", "EGM96_tiny"], "EGM96_tiny is an NGA coefficient file, static"),
        (["point", "--model", name, "--model-dir", "dir"], ".egm model, static"),
        (
            ["map", "--model", "good.gfc", "--step-deg", "30", "--no-plots", "--out", "out"],
            "good.gfc is a static model",
        ),
    ]
    for args, msg in cases:
        refused(fieldmap(work, *args, "--epoch", "2020"), msg, "--epoch 2020")


def test_epoch_with_time_variable_models(tmp_path):
    """Accepted where the file has time-variable lines, even above the degree read."""
    tv = GOOD.replace("gfc 2 0 -4.84165E-04 0.0 1.0e-12 0.0", "gfct 2 0 -4.8e-4 0 0 0 20000101")
    tv += "trnd 2 0 1.0e-11 0.0 0.0 0.0\n"
    (tmp_path / "tv.gfc").write_text(tv)
    assert read_icgem(tmp_path / "tv.gfc", epoch=2010.0).C[2, 0] == pytest.approx(-4.8e-4 + 1e-10)
    assert read_icgem(tmp_path / "tv.gfc", lmax=1, epoch=2010.0).epoch == 2010.0
    assert load_model("eigen-6s", lmax=1, epoch=2020).epoch == 2020.0
    static_v2 = GOOD.replace("errors formal", "errors formal\nformat icgem2.0")
    (tmp_path / "v2.gfc").write_text(static_v2)  # no intervals: read without an epoch
    assert read_icgem(tmp_path / "v2.gfc").epoch is None
    with pytest.raises(InputError, match="static model"):
        read_icgem(tmp_path / "v2.gfc", epoch=2010.0)


# ----------------------------------------------------------- 3.8 a model cache that is a file
def test_model_cache_path_is_a_file(work):
    """``cache info``, ``cache clear`` and a run that uses the cache say so; --no-cache runs."""
    (work / "good.gfc").write_text(GOOD)
    afile = work.parent / "afile"
    afile.write_text("")
    for cache, msg in ((afile, "is not a folder"), (afile / "sub", f"({afile} is not a folder)")):
        for action in ("info", "clear"):
            line = refused(fieldmap(work, "cache", action, cache=cache), str(cache), msg)
            assert "FIELDMAP_MODEL_CACHE" in line
    refused(fieldmap(work, "point", "--model", "good.gfc", cache=afile), "FIELDMAP_MODEL_CACHE")
    run, _ = fieldmap(work, "point", "--model", "good.gfc", "--no-cache", cache=afile)
    assert run.returncode == 0 and len(run.stdout.split()) == 3, run.stderr
    assert afile.read_text() == ""


# ------------------------------------- the cache and copies of a file under another name
def test_cache_keeps_what_a_file_name_means(tmp_path, private_cache):
    """A copy of a file under another name is read as what that name makes it.

    An NGA file takes GM, radius and name from its file name: a copy named otherwise is another
    model (or none), never the cached one. A model's source is the path read.
    """
    for name in ("EGM96_a", "EGM2008_a", "mine"):
        (tmp_path / name).write_text(NGA)
    egm96 = load_model(str(tmp_path / "EGM96_a"))
    egm08 = load_model(str(tmp_path / "EGM2008_a"))
    assert (egm96.name, egm96.gm, egm96.radius) == ("EGM96", 3.986004418e14, 6378137.0)
    assert (egm08.name, egm08.gm, egm08.radius) == ("EGM2008", 3.986004415e14, 6378136.3)
    assert egm08.source == str(tmp_path / "EGM2008_a")
    with pytest.raises(InputError, match="mine: an NGA coefficient file carries no GM"):
        load_model(str(tmp_path / "mine"))
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "EGM96_a").write_text(NGA)
    assert load_model(str(tmp_path / "d" / "EGM96_a")).source == str(tmp_path / "d" / "EGM96_a")
    # two links to one file, named EGM96 and EGM2008: two models, in memory too
    (tmp_path / "sym").mkdir()
    (tmp_path / "sym" / "real_coeffs").write_text(NGA)
    for name in ("EGM96.txt", "EGM2008.txt"):
        (tmp_path / "sym" / name).symlink_to("real_coeffs")
    for cache in (False, True):
        clear_cache()
        a = load_model(str(tmp_path / "sym" / "EGM96.txt"), cache=cache)
        b = load_model(str(tmp_path / "sym" / "EGM2008.txt"), cache=cache)
        assert (a.name, a.gm, a.radius) == ("EGM96", 3.986004418e14, 6378137.0)
        assert (b.name, b.gm, b.radius) == ("EGM2008", 3.986004415e14, 6378136.3)
