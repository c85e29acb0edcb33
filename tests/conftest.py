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
"""

from __future__ import annotations

import os
import shutil
import tempfile

import pytest

from fieldmap import _warp

#: (private TMPDIR, previous TMPDIR) of this session
_tmp_key = pytest.StashKey[tuple]()


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
