"""Shared set-up: Warp configured once, the devices to test on, temporary files cleaned up.

Warp
    :func:`fieldmap._warp.init` runs once when the session starts, before any test module is
    imported, so kernels defined in test files get fieldmap's options (no backward pass).

``device``
    A test that takes a ``device`` argument runs once per Warp device present (``"cpu"``, then
    each ``"cuda:N"``), as Warp's own tests do; the list comes from
    :func:`fieldmap._warp.devices` (``wp.get_devices()``), asked once for the whole session.

Temporary files
    Child processes of the tests (the ``fieldmap`` console script, example scripts, CUDA builds)
    get a private ``TMPDIR`` that is removed when the session ends: Warp leaves a precompiled
    header folder (``wp_pch_*``, 4.5 MB per compiling thread) in the temporary folder of every
    process that compiles kernels and does not exit through Python's clean-up (signals,
    ``os._exit``); whatever else a child leaves there goes with it. ``tmp_path`` folders are kept
    for failed tests only (``tmp_path_retention_policy`` in pyproject.toml).

Skips (``FIELDMAP_STRICT_SKIPS=1``, set by ``.ci/run``)
    Every skipped test is listed at the end of the run with its reason, and the session fails
    (exit status 1) when a test skipped for a reason outside :data:`ALLOWED_SKIPS`: a missing
    GPU (CUDA device or compiler), or an optional peer named there. Anything else that CI
    installs (the ``test`` extra, GeographicLib's tools, a C compiler, the UDUNITS library) must
    be present, and a test of the project's own code never skips.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile

import pytest

from fieldmap import _warp

#: (private TMPDIR, previous TMPDIR) of this session
_tmp_key = pytest.StashKey[tuple]()

#: Reasons a test may skip in CI (``FIELDMAP_STRICT_SKIPS=1``), as (what, regular expression
#: searched in the skip reason, case-blind). A missing GPU: no CUDA device, or a Warp build
#: without NVRTC (CUDA code cannot be compiled). No optional peer is allowed today: everything
#: the tests compare with is installed by ``.ci/run`` (``make test`` installs the ``test`` extra:
#: pyshtools, navtk, python-ins, boule, cfchecker, dask, zarr, mpmath; apt installs
#: geographiclib-tools, g++ and UDUNITS-2), so a skip for one of them in CI is a broken install.
#: Add a peer here only if CI cannot install it, with the reason next to it.
ALLOWED_SKIPS: tuple[tuple[str, str], ...] = (("no GPU", r"\bcuda\b|\bgpu\b|nvrtc"),)


def pytest_configure(config: pytest.Config) -> None:
    """Configure Warp once; give the child processes a temporary folder of their own.

    The parsed-model cache of the tests (degree-2190 recursion tables among them, ~115 MB)
    goes into that folder too, not into the user's cache, unless ``FIELDMAP_MODEL_CACHE`` is set.
    """
    if not hasattr(config, "workerinput"):  # a pytest-xdist worker: the main process owns it
        root = tempfile.gettempdir()  # fixes this process's (and pytest's tmp_path) folder first
        private = tempfile.mkdtemp(prefix="fieldmap-tests-", dir=root)
        config.stash[_tmp_key] = (private, os.environ.get("TMPDIR"))
        os.environ["TMPDIR"] = private
        os.environ.setdefault("FIELDMAP_MODEL_CACHE", os.path.join(private, "model-cache"))
    # Warp's options (kernel cache, no backward pass) before any test module defines a kernel;
    # this reads the settings (fieldmap.config) once, after the folders above are set
    _warp.init()


def pytest_unconfigure(config: pytest.Config) -> None:
    """Remove the children's temporary folder and restore ``TMPDIR``."""
    saved = config.stash.get(_tmp_key, None)
    if saved is None:
        return
    private, previous = saved
    if previous is None:
        os.environ.pop("TMPDIR", None)
    else:
        os.environ["TMPDIR"] = previous
    shutil.rmtree(private, ignore_errors=True)


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Parametrize every ``device`` argument over the Warp devices present."""
    if "device" not in metafunc.fixturenames:
        return
    for mark in metafunc.definition.iter_markers("parametrize"):
        names = mark.args[0]
        names = [n.strip() for n in names.split(",")] if isinstance(names, str) else list(names)
        if "device" in names:  # the test chooses its devices itself
            return
    metafunc.parametrize("device", _warp.devices())


def _record_skip(report: pytest.TestReport | pytest.CollectReport) -> None:
    """Record a skip (an expected failure, ``xfail``, is no skip)."""
    if report.skipped and not hasattr(report, "wasxfail"):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        _SKIPS.append((report.nodeid, reason.removeprefix("Skipped: ")))


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Record every skipped test."""
    _record_skip(report)


def pytest_collectreport(report: pytest.CollectReport) -> None:
    """Record every skipped test file (a module-level ``importorskip``)."""
    _record_skip(report)


#: (test id, reason) of the skips of this process's session
_SKIPS: list[tuple[str, str]] = []


def _strict_skips() -> bool:
    return os.environ.get("FIELDMAP_STRICT_SKIPS", "") not in ("", "0")


def unexpected_skips(skips: list[tuple[str, str]]) -> list[tuple[str, str]]:
    """Return the skips whose reason matches none of :data:`ALLOWED_SKIPS`."""
    return [
        (nodeid, reason)
        for nodeid, reason in skips
        if not any(re.search(rx, reason, re.IGNORECASE) for _, rx in ALLOWED_SKIPS)
    ]


def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    """Fail the session on an unexpected skip when ``FIELDMAP_STRICT_SKIPS=1``."""
    if _strict_skips() and unexpected_skips(_SKIPS) and exitstatus == pytest.ExitCode.OK:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter, exitstatus: int, config: pytest.Config) -> None:
    """List the skipped tests; with ``FIELDMAP_STRICT_SKIPS=1``, say which are not allowed."""
    if not _SKIPS:
        return
    bad = set(unexpected_skips(_SKIPS)) if _strict_skips() else set()
    terminalreporter.section(f"{len(_SKIPS)} skipped tests")
    for nodeid, reason in _SKIPS:
        mark = "NOT ALLOWED " if (nodeid, reason) in bad else ""
        terminalreporter.write_line(f"{mark}{nodeid}: {reason}")
    if bad:
        terminalreporter.write_line(
            f"FIELDMAP_STRICT_SKIPS=1: {len(bad)} tests skipped for a reason outside "
            "ALLOWED_SKIPS (tests/conftest.py): the session fails",
            red=True,
        )
