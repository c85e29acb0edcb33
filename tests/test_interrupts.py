"""Interrupted and failing writes, signals and a broken pipe: output is all-or-nothing.

Under Ctrl-C, SIGTERM, a full disk or a failing figure a run leaves none of its files (not even a
temporary one) and says so in one line; the real console script does the same for signals and a
reader that goes away. Bad arguments are in ``test_bad_input_cli.py`` and ``test_bad_input_api.py``.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path

import pytest
from test_bad_input_cli import (  # noqa: F401 - ``work`` is a fixture
    _assert_one_line,
    _main,
    _spawn,
    _tree,
    work,
)

from fieldmap import cli


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

    # the handlers the CLI runs under, set here: pytest started from a shell that ignores SIGINT
    # (``make test &``, ``nohup``, some CI runners) inherits SIG_IGN, and then no Ctrl-C arrives
    previous = {
        signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
        signal.SIGTERM: signal.signal(signal.SIGTERM, cli._on_sigterm),
    }
    steps = []
    try:
        with pytest.raises(exc):
            with fio.signals_deferred():
                os.kill(os.getpid(), sig)
                time.sleep(0.05)
                steps.append("write finished")
            steps.append("not reached")
        # the handlers in place before the block are back
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        assert signal.getsignal(signal.SIGTERM) is cli._on_sigterm
    finally:
        for s, handler in previous.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
    assert steps == ["write finished"]


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


def test_sigint_ignored_when_started_so(tmp_path):
    """Started with SIGINT ignored (a background job of a script, ``nohup``), the CLI keeps it so.

    Ctrl-C meant for the foreground job does not stop it; SIGTERM still ends it in one line.
    """
    p = _spawn(["point"], sigint=signal.SIG_IGN, stdin=subprocess.PIPE, cwd=tmp_path)
    time.sleep(3.0)  # past start-up: blocked reading stdin inside main()
    p.send_signal(signal.SIGINT)
    time.sleep(0.5)
    assert p.poll() is None  # still waiting for input
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert err.strip().splitlines() == ["fieldmap point: terminated"]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("lines_read", [0, 1])
def test_broken_pipe_is_quiet(tmp_path, lines_read):
    """``fieldmap point < many | head -1``: no traceback when the reader goes away.

    The reader takes ``lines_read`` lines (``head -1`` reads one, a reader that fails at once
    none), then closes the pipe while the command still has thousands of lines to print.
    """
    pts = "".join(f"{i % 80} {i % 360} 0\n" for i in range(20000))
    p = _spawn(["point", "--quantity", "normal"], stdin=subprocess.PIPE, cwd=tmp_path)
    p.stdin.write(pts)
    p.stdin.close()
    got = [p.stdout.readline() for _ in range(lines_read)]
    p.stdout.close()  # the reader is gone; 20000 - lines_read lines are still to come
    err = p.stderr.read()
    p.stderr.close()
    p.wait(timeout=120)
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert err == ""
    assert p.returncode == 1
    for line in got:  # what the reader did get is whole output lines: g east north up
        assert len(line.split()) == 3 and line.endswith("\n"), line
