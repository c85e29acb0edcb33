"""``fieldmap.config``: the FIELDMAP_* variables, read at one time, bad values are bad input."""

from __future__ import annotations

import os

import pytest

from fieldmap import _warp, cli, config
from fieldmap.errors import InputError


@pytest.fixture
def fresh(monkeypatch):
    """Forget the settings read so far (restored after the test) and clear the variables."""
    monkeypatch.setattr(config, "_current", None)
    names = ("FIELDMAP_THREADS", "FIELDMAP_KERNEL_CACHE", "FIELDMAP_VERBOSE", "FIELDMAP_DEBUG")
    for name in names:
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


def test_defaults():
    c = config.from_environ({"XDG_CACHE_HOME": "/x/cache"})
    assert c == config.Config(
        threads=None,
        kernel_cache="/x/cache/fieldmap/warp",
        model_cache="/x/cache/fieldmap/models",
        verbose=False,
        debug=False,
    )
    assert config.from_environ({"FIELDMAP_MODEL_CACHE": "/m"}).model_cache == "/m"
    home = os.path.expanduser("~/.cache/fieldmap/warp")
    assert config.from_environ({}).kernel_cache == home
    assert config.from_environ({"FIELDMAP_KERNEL_CACHE": "/k"}).kernel_cache == "/k"


@pytest.mark.parametrize("value, threads", [("1", 1), (" 16 ", 16), ("", None)])
def test_threads(value, threads):
    assert config.from_environ({"FIELDMAP_THREADS": value}).threads == threads


@pytest.mark.parametrize("value", ["abc", "0", "-2", "1.5", "2 cores"])
def test_bad_threads(value):
    with pytest.raises(
        InputError, match=f"FIELDMAP_THREADS must be a positive integer, got '{value}"
    ):
        config.from_environ({"FIELDMAP_THREADS": value})


@pytest.mark.parametrize(
    "value, on", [("1", True), ("TRUE", True), ("yes", True), ("0", False), ("off", False)]
)
def test_switches(value, on):
    c = config.from_environ({"FIELDMAP_VERBOSE": value, "FIELDMAP_DEBUG": value})
    assert c.verbose is on and c.debug is on


def test_bad_switch():
    with pytest.raises(InputError, match="FIELDMAP_DEBUG must be 1 or 0 .* got 'maybe'"):
        config.from_environ({"FIELDMAP_DEBUG": "maybe"})


def test_read_once_until_reload(fresh):
    fresh.setenv("FIELDMAP_THREADS", "3")
    assert config.get().threads == 3 and _warp.cpu_workers() == 3
    fresh.setenv("FIELDMAP_THREADS", "5")
    assert config.get().threads == 3  # not read again
    assert config.reload().threads == 5 and _warp.cpu_workers() == 5


def test_threads_context():
    outside = _warp.cpu_workers()
    with _warp.threads(1):
        assert _warp.cpu_workers() == 1
        with _warp.threads(7):
            assert _warp.cpu_workers() == 7
        assert _warp.cpu_workers() == 1
    assert _warp.cpu_workers() == outside
    for bad in (0, 1.5, True, "2"):
        with pytest.raises(InputError, match="thread count"):
            with _warp.threads(bad):
                pass


@pytest.mark.parametrize("value", ["abc", "0"])
def test_cli_bad_threads_is_bad_input(fresh, capsys, value):
    """FIELDMAP_THREADS=abc: exit 2 with one line (it was an internal error, exit 3)."""
    fresh.setenv("FIELDMAP_THREADS", value)
    assert cli.main(["point", "--input", os.devnull]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"fieldmap point: error: FIELDMAP_THREADS must be a positive integer, got '{value}'"
    ]


def test_cli_debug_shows_the_traceback(fresh, capsys):
    """An internal error is one line (exit 3); with FIELDMAP_DEBUG=1 it propagates."""
    from fieldmap.cli import point

    def boom(args):
        raise RuntimeError("boom")

    fresh.setattr(point, "run_point", boom)  # build_parser registers it again on each main()
    assert cli.main(["point", "--input", os.devnull]) == 3
    err = capsys.readouterr().err
    assert "internal error: RuntimeError: boom (set FIELDMAP_DEBUG=1" in err
    fresh.setattr(config, "_current", None)
    fresh.setenv("FIELDMAP_DEBUG", "1")
    with pytest.raises(RuntimeError, match="boom"):
        cli.main(["point", "--input", os.devnull])
