"""The ICGEM reader parses its data in chunks of lines (issue 17): the chunk size changes nothing.

Every file is read with chunks of a few lines and in one chunk; models must agree bit for bit
(C, S, σ, header, epoch) and errors word for word (same line numbers), including errors on the
first and last line of a chunk and errors whose rank beats an earlier chunk's error.
"""

from __future__ import annotations

import gzip
import math

import numpy as np
import pytest

import fieldmap.models.icgem as icgem
from fieldmap.errors import InputError, ModelFileError
from fieldmap.models.icgem import read_icgem, write_icgem
from fieldmap.models.registry import kaula_model

HEAD = """free text
begin_of_head
modelname      tiny
earth_gravity_constant  3.986004415E+14
radius         6378136.3
max_degree     {nmax}
norm           {norm}
{extra}end_of_head
"""
NHEAD = 8  # lines up to end_of_head with extra=""; data line k is file line NHEAD + 1 + k


def _lines(nmax, skip=(), nsig=2):
    out = []
    for n in range(nmax + 1):
        for m in range(n + 1):
            if (n, m) not in skip:
                sig = "".join(f" {1e-12 * (n + m + 1):.6e}" for _ in range(nsig))
                c = 1.0 if n == 0 else 1e-6 * (n + 1) + 1e-8 * m  # C00 = 1: a gravity model's
                out.append(f"gfc {n} {m} {c:.16e} {2e-7 * m:.6e}{sig}\n")
    return out


def _write(tmp_path, name, lines, nmax=6, norm="fully_normalized", extra="", gz=False):
    path = tmp_path / name
    data = (HEAD.format(nmax=nmax, norm=norm, extra=extra) + "".join(lines)).encode("latin-1")
    path.write_bytes(gzip.compress(data) if gz else data)
    return path


V1 = [
    "gfct 2 1 1.0e-6 2.0e-6 1e-12 2e-12 20000101\n",
    "trnd 2 1 1.0e-9 -1.0e-9 0 0\n",
    "acos 2 1 3.0e-9 0 0 0 1.0\n",
    "asin 2 1 0 5.0e-9 0 0 2.0\n",
    "gfct 3 0 1.0e-6 0 20050101.1200\n",
    "dot 3 0 1.0e-9 0\n",
    "acos 3 0 3.0e-9 0 0.5\n",
]
V2 = [
    "gfct 2 0 -4.0e-4 0 0 0 20000101.0000 20100101.0000\n",
    "trnd 2 0 1.0e-10 0 0 0 20000101.0000 20100101.0000\n",
    "gfct 2 0 -5.0e-4 0 0 0 20100101.0000 20200101.0000\n",
    "acos 2 0 2.0e-10 0 0 0 20100101.0000 20200101.0000 1.0\n",
    "gfct 4 1 1e-7 2e-7 20000101 20300101\n",
    "asin 4 1 1e-10 2e-10 20000101 20300101 0.25\n",
]


def _files(tmp_path):
    """(path, read options) of valid files of every kind the reader handles."""
    out = []
    for nsig in (0, 2, 4):
        extra = "" if nsig else "errors no\n"
        p = _write(tmp_path, f"s{nsig}.gfc", _lines(6, nsig=nsig), extra=extra)
        out += [(p, {}), (p, {"lmax": 3}), (p, {"lmax": 0})]
    out.append((_write(tmp_path, "s.gfc.gz", _lines(6), gz=True), {}))
    out.append((_write(tmp_path, "u.gfc", _lines(6), norm="unnormalized"), {}))
    out.append((_write(tmp_path, "o.gfc", _lines(6, skip={(0, 0), (1, 0), (1, 1)})), {}))
    blank = ["\r\n \t\r\n" if k % 5 == 0 else "" for k in range(28)]  # blank lines too
    crlf = "".join(t.replace("\n", "\r\n") + e for t, e in zip(_lines(6), blank))
    out.append((_write(tmp_path, "crlf.gfc", [crlf]), {}))
    out.append((_write(tmp_path, "nonl.gfc", ["".join(_lines(6)).rstrip("\n")]), {}))
    v1 = _lines(6, skip={(2, 1), (3, 0)}) + V1
    v1_mixed = v1[::-1]  # time-variable lines first, static lines in reverse order
    for name, lines in (("v1.gfc", v1), ("v1r.gfc", v1_mixed)):
        p = _write(tmp_path, name, lines)
        out += [(p, {}), (p, {"epoch": 2005.3}), (p, {"lmax": 2, "epoch": "2010-01-01"})]
    p = _write(tmp_path, "v2.gfc", _lines(6, skip={(2, 0), (4, 1)}) + V2, extra="format icgem2.0\n")
    out += [(p, {"epoch": 2005.0}), (p, {"epoch": 2012.0}), (p, {"epoch": 2012.0, "lmax": 3})]
    return out


def _read(path, chunk, monkeypatch, **kw):
    """Model (as comparable tuples) or error (type, message) of a read with ``chunk`` lines."""
    monkeypatch.setattr(icgem, "CHUNK_LINES", chunk)
    try:
        m = read_icgem(path, **kw)
    except (ModelFileError, InputError) as exc:
        return type(exc).__name__, str(exc)
    arrays = [None if a is None else (a.shape, a.tobytes()) for a in (m.C, m.S)]
    arrays += [None if a is None else (a.shape, a.tobytes()) for a in (m.sigma_c, m.sigma_s)]
    meta = (
        m.name,
        m.gm,
        m.radius,
        m.max_degree,
        m.nominal_degree,
        m.tide_system,
        repr(m.epoch),
        m.header,
    )
    return meta, arrays


@pytest.mark.parametrize("chunk", [1, 2, 3, 7])
def test_valid_files_same_bits(tmp_path, monkeypatch, chunk):
    """Every kind of valid file: the same bits with chunks of 1 to 7 lines as in one chunk.

    Static, σ (2 and 4 columns), errors no, gzip, unnormalised, degrees 0-1 left out, CRLF and
    blank lines, no final newline, icgem1.0 and icgem2.0 time-variable, lmax cuts, epochs.
    """
    for path, kw in _files(tmp_path):
        one = _read(path, 1 << 20, monkeypatch, **kw)
        assert one[0] not in ("ModelFileError", "InputError"), (path, kw, one)
        assert _read(path, chunk, monkeypatch, **kw) == one, (path, kw)


def _err(path, chunk, monkeypatch, **kw):
    got = _read(path, chunk, monkeypatch, **kw)
    assert got[0] in ("ModelFileError", "InputError"), (path, got)
    return got[1]


GOOD = _lines(6)  # 28 data lines: with 7-line chunks lines 0-6, 7-13, 14-20, 21-27


@pytest.mark.parametrize("at", [0, 6, 7, 13, 14, 27])
@pytest.mark.parametrize(
    "bad, msg",
    [
        ("gfq 3 3 0 0\n", "unknown keyword 'gfq'"),
        ("gfc 3\n", "line too short"),
        ("gfc 3 x 0 0\n", "bad degree/order '3' 'x'"),
        ("gfc 3 3 0 0 0 0 0 0 0\n", "'gfc' line with 7 values"),
        ("gfc 2 3 0 0\n", "order m > degree n (n=2, m=3)"),
        ("gfc 7 0 0 0\n", "degree above max_degree 6"),
        ("gfc 3 3 1.0x 0\n", "bad number '1.0x'"),
        ("acos 2 1 0 0 -1\n", "period must be positive"),
    ],
)
def test_error_on_chunk_edges(tmp_path, monkeypatch, at, bad, msg):
    """An error on the first or last line of a chunk names that line, whatever the chunk size."""
    lines = GOOD[:at] + [bad] + GOOD[at:]
    path = _write(tmp_path, "e.gfc", lines)
    for chunk in (1 << 20, 7, 3, 1):
        got = _err(path, chunk, monkeypatch)
        assert got.startswith(f"{path}, line {NHEAD + 1 + at}: ") and msg in got, (chunk, got)


@pytest.mark.parametrize(
    "edits, msg, line",
    [  # (data line, inserted text), ...: the whole-file check order wins over the line order
        ([(2, "gfc 2 3 0 0\n"), (20, "gfq 1 1 0 0\n")], "unknown keyword", 21),
        ([(2, "gfc 3 3 1.0x 0\n"), (20, "gfc 9 0 0 0\n")], "degree above max_degree", 21),
        ([(2, "acos 2 1 0 0 -1\n"), (20, "gfc 3 3 1.0x 0\n")], "bad number", 21),
        ([(2, "gfc 2 2 0 0 0 0 0 0 0 0\n"), (20, "gfct 2 1\n")], "'gfc' line with 8", 3),
        ([(20, "gfc 2 2 0 0 0 0 0 0 0 0\n"), (2, "gfct 2 1\n")], "'gfc' line with 8", 22),
        ([(5, GOOD[3]), (12, GOOD[3]), (25, GOOD[10])], "first given on line 12", 6),
        ([(27, "gfc 2 1 1 0\n")], "first given on line 13", 28),
    ],
)
def test_error_rank_across_chunks(tmp_path, monkeypatch, edits, msg, line):
    """Several problems in several chunks: the same one wins as in a one-chunk read.

    ``line``: data line + 1 of the error (file line NHEAD + line).
    """
    lines = GOOD[:]
    for at, text in edits:
        lines.insert(at, text)
    path = _write(tmp_path, "r.gfc", lines)
    one = _err(path, 1 << 20, monkeypatch)
    assert msg in one and f"line {NHEAD + line}:" in one, one
    for chunk in (7, 3, 2, 1):
        assert _err(path, chunk, monkeypatch) == one


def test_static_and_time_variable_errors_across_chunks(tmp_path, monkeypatch):
    """Duplicates of gfc and gfct lines, gaps, orphans, time stamps, validity intervals."""
    v1 = _lines(6, skip={(2, 1), (3, 0)}) + V1
    cases = [
        ([*v1, "gfc 2 1 0 0\n"], {}),  # gfc after a gfct of the same coefficient
        (["gfct 5 5 1e-7 0 20000101\n", *v1], {}),  # gfct before a gfc of it
        ([*v1, "gfct 3 0 1.0e-6 0 20050101\n"], {}),  # two gfct lines
        ([*v1, "acos 3 0 1e-9 0 0.5\n"], {}),  # duplicate acos term
        ([*v1, "trnd 4 4 1e-9 0\n"], {}),  # trend without gfct
        ([*v1[:5], *v1[6:]], {}),  # degree gap
        (v1[:-9] + V1, {}),  # file truncated
        ([*v1, "gfct 5 5 1e-7 0 20001301\n"], {}),  # bad time stamp
        (_lines(6, skip={(5, 5), (6, 6)}) + ["gfc 6 6 2.0 0\n"], {}),  # gap, before outsize
        (_lines(6, skip={(6, 6)}) + ["gfc 6 6 2.0 0\n"], {}),  # beyond 1 in size
        ([*v1, "acos 3 0 1e3 0 1\n"], {}),  # beyond 1 in size, named on the gfct line
    ]
    for k, (lines, kw) in enumerate(cases):
        path = _write(tmp_path, f"t{k}.gfc", lines)
        one = _err(path, 1 << 20, monkeypatch, **kw)
        for chunk in (7, 3, 1):
            assert _err(path, chunk, monkeypatch, **kw) == one, (k, one)
    v2 = _lines(6, skip={(2, 0), (4, 1)}) + V2
    p2 = _write(tmp_path, "v2.gfc", v2, extra="format icgem2.0\n")
    p2d = _write(tmp_path, "v2d.gfc", [*v2, V2[0]], extra="format icgem2.0\n")
    for path, kw in ((p2, {"epoch": 2021.0}), (p2, {}), (p2d, {"epoch": 2005.0})):
        one = _err(path, 1 << 20, monkeypatch, **kw)
        for chunk in (7, 3, 1):
            assert _err(path, chunk, monkeypatch, **kw) == one


def test_fuzzed_files_same_outcome(tmp_path, monkeypatch):
    """Random byte edits: the same model or the same error with 3-line chunks as in one chunk."""
    base = _write(tmp_path, "b.gfc", _lines(6, skip={(2, 1), (3, 0)}) + V1).read_bytes()
    alphabet = b" \n\t0123456789.-+eEdDgfcmtrnd_xyz\xe9"
    rng = np.random.default_rng(5)
    path, kinds = tmp_path / "fuzz.gfc", set()
    for _ in range(150):
        b = bytearray(base)
        for _ in range(int(rng.integers(1, 4))):
            pos = int(rng.integers(len(base) - 1200, len(b)))
            ch = alphabet[int(rng.integers(0, len(alphabet)))]
            op = int(rng.integers(0, 3))
            if op == 0:
                del b[pos]
            elif op == 1:
                b.insert(pos, ch)
            else:
                b[pos] = ch
        path.write_bytes(bytes(b))
        one = _read(path, 1 << 20, monkeypatch)
        kinds.add(one[0] if isinstance(one[0], str) else "model")
        assert _read(path, 3, monkeypatch) == one
    assert {"model", "ModelFileError"} <= kinds


def test_chunks_are_bounded(tmp_path, monkeypatch):
    """The tokeniser never sees more than CHUNK_LINES lines at once."""
    path = tmp_path / "k.gfc"
    write_icgem(path, kaula_model(30, seed=2))
    seen = []
    real = icgem.tokenise

    def spy(raw, offset=0, count=-1, newlines=None):
        out = real(raw, offset, count, newlines)
        seen.append(out[4].size)
        return out

    monkeypatch.setattr(icgem, "tokenise", spy)
    monkeypatch.setattr(icgem, "CHUNK_LINES", 50)
    back = read_icgem(path)
    assert seen and max(seen) <= 50 and sum(seen) == 31 * 32 // 2
    np.testing.assert_array_equal(back.C, kaula_model(30, seed=2).C)


@pytest.mark.parametrize("text", [b"", b"a", b"a\n", b"a\nb", b"\n\n\n", b"ab\ncd\n\nef\ng"])
@pytest.mark.parametrize("lines", [1, 2, 3])
def test_line_chunks_cover_the_data(text, lines):
    """Pieces end after every lines-th newline and cover the data exactly."""
    raw = b"head\n" + text
    pieces = list(icgem.line_chunks(raw, 5, lines))
    assert b"".join(raw[lo:hi] for lo, hi, _ in pieces) == text
    for k, (lo, hi, nl) in enumerate(pieces):
        assert list(nl) == [i for i, c in enumerate(raw[lo:hi]) if c == 10]
        assert len(nl) == lines or k == len(pieces) - 1


def test_read_bytes_mapped(tmp_path):
    """Plain files come back mapped (same bytes), gzip ones as bytes; blank files are empty."""
    path = _write(tmp_path, "m.gfc", GOOD)
    mapped = icgem.read_bytes(path, mapped=True)
    assert not isinstance(mapped, bytes) and mapped[:] == path.read_bytes()
    icgem.release(mapped, 0, len(mapped))  # drops the pages, keeps the bytes
    assert mapped[:] == path.read_bytes()
    gz = _write(tmp_path, "m.gfc.gz", GOOD, gz=True)
    assert icgem.read_bytes(gz, mapped=True) == path.read_bytes()
    blank = tmp_path / "blank.gfc"
    blank.write_bytes(b" \t\r\n\x0b\x0c")
    with pytest.raises(ModelFileError, match="empty file"):
        icgem.read_bytes(blank, mapped=True)


def test_block_scans_match_whole_array_ones(tmp_path, monkeypatch):
    """Binary check, unnormalised conversion and the size check, in blocks: same results."""
    monkeypatch.setattr(icgem, "BLOCK", 64)
    text = HEAD.format(nmax=6, norm="x", extra="") + "".join(GOOD)
    raw = (text + "gfc 6 6 \x07 0\n").encode()
    with pytest.raises(ModelFileError, match=rf"line {text.count(chr(10)) + 1}: binary byte 0x07"):
        icgem.check_text("p", raw)
    assert icgem.count_newlines(raw, 3, len(raw) - 5) == raw[3:-5].count(b"\n")
    rng = np.random.default_rng(1)
    C, S = np.tril(rng.standard_normal((40, 40))), np.tril(rng.standard_normal((40, 40)))
    n = np.arange(40.0)[:, None]
    m = np.arange(40)[None, :]
    fact = np.vectorize(lambda k: float(math.factorial(int(k))))
    with np.errstate(invalid="ignore", divide="ignore"):
        norm = np.sqrt(
            np.where(m == 0, 1, 2) * (2 * n + 1) * fact(np.maximum(n - m, 0)) / fact(n + m)
        )
    C2, S2 = icgem.unnormalized_to_full(C.copy(), S.copy(), "p")
    np.testing.assert_allclose(C2[m <= n], (C / norm)[m <= n], rtol=1e-13)
    assert not np.triu(C2, 1).any() and not np.triu(S2, 1).any()
    small = C * 1e-3
    assert icgem.first_outsize(small, small) is None
    small[23, 4] = -2.0
    small[30, 1] = 3.0
    assert icgem.first_outsize(small, small * 0) == (23, 4, -2.0)


def test_large_gzip_files_stream_to_a_mapping(tmp_path, monkeypatch):
    """Above GZ_IN_MEMORY a gzip file is decompressed chunk by chunk into a mapped temporary file.

    The model has the same bits as one decompressed in memory, and bad gzip files give the same
    one-line errors.
    """
    path = _write(tmp_path, "big.gfc.gz", _lines(6), gz=True)
    in_memory = _read(path, 7, monkeypatch)
    monkeypatch.setattr(icgem, "GZ_IN_MEMORY", 0)
    monkeypatch.setattr(icgem, "_CHUNK", 100)  # many chunks
    raw = icgem.read_bytes(path, mapped=True)
    assert not isinstance(raw, bytes) and raw[:] == gzip.decompress(path.read_bytes())
    assert _read(path, 7, monkeypatch) == in_memory
    cut = tmp_path / "cut.gfc.gz"
    cut.write_bytes(path.read_bytes()[:-20])
    with pytest.raises(ModelFileError, match="truncated or corrupt gzip data"):
        icgem.read_bytes(cut, mapped=True)
    empty = tmp_path / "empty.gfc.gz"
    empty.write_bytes(gzip.compress(b""))
    with pytest.raises(ModelFileError, match="empty file"):
        icgem.read_bytes(empty, mapped=True)
    binary = tmp_path / "bin.gfc.gz"
    binary.write_bytes(gzip.compress(b"\x00" * 1000))
    with pytest.raises(ModelFileError, match="binary byte 0x00"):
        icgem.read_bytes(binary, mapped=True)
