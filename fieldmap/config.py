"""Settings from the environment: every ``FIELDMAP_*`` variable, read at one time, in one place.

The variables are read together on the first call of :func:`get` (the first Warp launch, or the
start of a CLI command) and kept for the life of the process; :func:`reload` reads them again.
A bad value is bad input (:class:`fieldmap.errors.InputError`: one line, CLI exit status 2).

========================= ==================================================================
Variable                  Meaning
========================= ==================================================================
``FIELDMAP_THREADS``      Threads for Warp launches on the CPU: a positive integer. Default:
                          the cores this process may run on (its CPU affinity mask).
``FIELDMAP_KERNEL_CACHE`` Folder of Warp's compiled-kernel cache. Default:
                          ``$XDG_CACHE_HOME/fieldmap/warp`` (``~/.cache/fieldmap/warp``).
``FIELDMAP_MODEL_CACHE``  Folder of the parsed-model cache (:mod:`fieldmap.models.cache`).
                          Default: ``$XDG_CACHE_HOME/fieldmap/models``.
``FIELDMAP_VERBOSE``      ``1``: show Warp's own start-up messages (such as its notice that no
                          CUDA driver is present), hidden by default.
``FIELDMAP_DEBUG``        ``1``: the CLI shows the traceback of an internal error instead of
                          one line (exit status 3).
========================= ==================================================================

Switches accept ``1``/``true``/``yes``/``on`` and ``0``/``false``/``no``/``off`` (any case); unset
or empty means off. To change the thread count for one block of code (a timing on one core, say),
use :func:`fieldmap._warp.threads` rather than the environment, which is not read again.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass

from fieldmap.errors import InputError

__all__ = ["Config", "from_environ", "get", "reload"]

_TRUE = ("1", "true", "yes", "on")
_FALSE = ("", "0", "false", "no", "off")


@dataclass(frozen=True)
class Config:
    """fieldmap's settings, as read from the environment.

    Attributes
    ----------
    threads : int or None
        ``FIELDMAP_THREADS``: threads for CPU launches; ``None`` means one per available core.
    kernel_cache : str
        ``FIELDMAP_KERNEL_CACHE``: Warp's kernel cache folder (resolved to its default if unset).
    model_cache : str
        ``FIELDMAP_MODEL_CACHE``: the parsed-model cache folder (resolved to its default).
    verbose : bool
        ``FIELDMAP_VERBOSE``: show Warp's start-up messages.
    debug : bool
        ``FIELDMAP_DEBUG``: the CLI re-raises internal errors (traceback) instead of one line.
    """

    threads: int | None
    kernel_cache: str
    model_cache: str
    verbose: bool
    debug: bool


def _switch(env: Mapping[str, str], name: str) -> bool:
    value = env.get(name, "").strip().lower()
    if value in _TRUE:
        return True
    if value in _FALSE:
        return False
    raise InputError(f"{name} must be 1 or 0 (true/false, yes/no, on/off), got {value!r}")


def _threads(env: Mapping[str, str]) -> int | None:
    value = env.get("FIELDMAP_THREADS", "").strip()
    if not value:
        return None
    try:
        n = int(value)
    except ValueError:
        n = 0
    if n < 1:
        raise InputError(f"FIELDMAP_THREADS must be a positive integer, got {value!r}")
    return n


def from_environ(env: Mapping[str, str] | None = None) -> Config:
    """Read the settings from ``env`` (default: ``os.environ``), checking every value.

    Raises
    ------
    fieldmap.errors.InputError
        A variable has a value it cannot take (``FIELDMAP_THREADS=abc``, ``FIELDMAP_DEBUG=maybe``).
    """
    env = os.environ if env is None else env
    base = os.path.join(env.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "fieldmap")
    cache = env.get("FIELDMAP_KERNEL_CACHE", "").strip() or os.path.join(base, "warp")
    models = env.get("FIELDMAP_MODEL_CACHE", "").strip() or os.path.join(base, "models")
    return Config(
        threads=_threads(env),
        kernel_cache=cache,
        model_cache=models,
        verbose=_switch(env, "FIELDMAP_VERBOSE"),
        debug=_switch(env, "FIELDMAP_DEBUG"),
    )


_current: Config | None = None


def get() -> Config:
    """Return the settings, reading the environment on the first call only."""
    global _current
    if _current is None:
        _current = from_environ()
    return _current


def reload() -> Config:
    """Read the environment again (for a program or a test that changed it) and return it."""
    global _current
    _current = None
    return get()
