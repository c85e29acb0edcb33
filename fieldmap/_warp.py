"""Warp runtime: configuration before first use, device selection, multi-core CPU launches.

Warp's CPU backend runs one launch on one core. Launches release the GIL, so
:func:`launch_chunked` splits a 1-D launch into contiguous chunks (one per core) and
launches them from a thread pool; on CUDA it issues a single launch.

Kernels that go through :func:`launch_chunked` take an ``offset: wp.int32`` as their *last*
input and index their work as ``i = wp.tid() + offset``. Settings (``FIELDMAP_THREADS``,
``FIELDMAP_KERNEL_CACHE``, ``FIELDMAP_VERBOSE``) come from :mod:`fieldmap.config`.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import threading
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import warp as wp

from fieldmap import config
from fieldmap.errors import InputError

_lock = threading.Lock()
_ready = False
_pool: ThreadPoolExecutor | None = None
_threads: contextvars.ContextVar[int | None] = contextvars.ContextVar("threads", default=None)


def cpu_workers() -> int:
    """Return the number of threads for CPU launches.

    In order: :func:`threads` in effect, ``FIELDMAP_THREADS`` (:mod:`fieldmap.config`), the
    cores this process may run on.
    """
    n = _threads.get()
    return n if n is not None else _default_workers()


@contextlib.contextmanager
def threads(n: int) -> Iterator[None]:
    """Run the CPU launches of the enclosed block (in this thread) on ``n`` threads.

    Examples
    --------
    >>> from fieldmap import _warp
    >>> with _warp.threads(1):
    ...     _warp.cpu_workers()
    1
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise InputError(f"thread count must be a positive integer, got {n!r}")
    token = _threads.set(n)
    try:
        yield
    finally:
        _threads.reset(token)


def _default_workers() -> int:
    n = config.get().threads
    if n is not None:
        return n
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - non-Linux
        return max(1, os.cpu_count() or 1)


def init() -> None:
    """Configure and initialise Warp once (cache directory, quiet logs, no autodiff)."""
    global _ready
    if _ready:
        return
    with _lock:
        if _ready:
            return
        wp.config.kernel_cache_dir = config.get().kernel_cache
        wp.config.log_level = wp.LOG_WARNING  # no "Module ... load" chatter on stdout
        wp.config.enable_backward = False
        wp.config.verbose_warnings = False
        _quiet_init()
        _ready = True


def _quiet_init() -> None:
    """Run ``wp.init()`` with its native "no CUDA driver" notice kept off the user's terminal.

    On a CPU-only machine Warp prints a warning from C code on file descriptor 2; fieldmap runs
    on the CPU there by design. Anything else written during init is passed through.
    """
    import tempfile

    if config.get().verbose:
        wp.init()
        return
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            text = tmp.read().decode("utf-8", "replace")
    keep = [ln for ln in text.splitlines() if ln.strip() and "CUDA driver" not in ln]
    if keep:
        print("\n".join(keep), file=sys.stderr)


def devices() -> list[str]:
    """Names of all Warp devices present (``"cpu"`` first, then ``"cuda:N"``)."""
    init()
    return [str(d) for d in wp.get_devices()]


class DeviceError(InputError):
    """Raised when a requested device does not exist on this machine."""


def resolve_device(device: str | None = None) -> str:
    """Return a valid Warp device name.

    ``None`` or ``"auto"`` picks the first CUDA device when present, else ``"cpu"``.
    """
    names = devices()
    if device in (None, "auto"):
        cuda = [d for d in names if d.startswith("cuda")]
        return cuda[0] if cuda else "cpu"
    if device == "cuda":
        device = "cuda:0"
    if device not in names:
        raise DeviceError(f"device {device!r} not present (available: {', '.join(names)})")
    return device


def _pool_get() -> ThreadPoolExecutor:
    global _pool
    if _pool is None:
        with _lock:
            if _pool is None:
                _pool = ThreadPoolExecutor(
                    max_workers=_default_workers(), thread_name_prefix="fieldmap"
                )
    return _pool


def chunks(n: int, parts: int) -> list[tuple[int, int]]:
    """Split ``range(n)`` into at most ``parts`` contiguous ``(start, count)`` pieces."""
    parts = max(1, min(parts, n))
    base, extra = divmod(n, parts)
    out, start = [], 0
    for k in range(parts):
        cnt = base + (1 if k < extra else 0)
        if cnt:
            out.append((start, cnt))
        start += cnt
    return out


def launch_chunked(
    kernel: wp.Kernel, dim: int, inputs: list, device: str, parts: int | None = None
) -> None:
    """Launch a 1-D ``kernel`` over ``dim`` threads, using every CPU core on the CPU backend.

    Parameters
    ----------
    kernel : warp.Kernel
        A kernel whose last input is ``offset: wp.int32``.
    dim : int
        Total number of threads.
    inputs : list
        Kernel inputs *without* the trailing offset.
    device : str
        Warp device name.
    parts : int, optional
        Number of CPU chunks; default: one per worker thread (CPU) and 1 (CUDA).
    """
    init()
    if dim <= 0:
        return
    if not str(device).startswith("cpu"):
        wp.launch(kernel, dim=dim, inputs=[*inputs, 0], device=device)
        return
    pieces = chunks(dim, parts or cpu_workers())
    # load (compile) the module once, before several threads would race to do it
    wp.load_module(kernel.module, device=device)
    if len(pieces) == 1:
        wp.launch(kernel, dim=dim, inputs=[*inputs, 0], device=device)
        return
    pool = _pool_get()
    # the calling thread launches the first piece itself: one thread hand-off fewer
    futs = [
        pool.submit(wp.launch, kernel, dim=cnt, inputs=[*inputs, start], device=device)
        for start, cnt in pieces[1:]
    ]
    try:
        start, cnt = pieces[0]
        wp.launch(kernel, dim=cnt, inputs=[*inputs, start], device=device)
    finally:
        for f in futs:
            f.result()
    wp.synchronize_device(device)
