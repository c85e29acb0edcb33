"""The Dask cluster that map blocks and navigation runs may go to: clients, workers, models.

:func:`parse_scheduler` reads ``--scheduler`` (``threads``, ``local:N``, an address);
:func:`open_client` connects, or starts a LocalCluster for the run, failing in one line when
nothing listens; :func:`worker_setup` prepares a worker process before its first task (its share
of the cores, glibc's allocator thresholds); :func:`scattered` ships a model once per worker and
client. Used by the block engine (:mod:`fieldmap.products.engine`) and by the navigation studies
(:mod:`fieldmap.nav.propagator`). Dask itself is imported only when a cluster is used.
"""

from __future__ import annotations

import contextlib
import os
import weakref
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from fieldmap.errors import InputError

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

_WORKER_READY = False


def worker_setup() -> None:
    """Prepare a Dask worker process for the kernels (once per process; a no-op elsewhere).

    - Warp launches use the worker's share of the cores (``FIELDMAP_THREADS`` = its threads,
      unless set).
    - glibc's allocator gets back the dynamic thresholds of a plain process: Dask's nanny
      starts workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which freezes the mmap threshold at
      128 KiB, so that every array of a block is a fresh ``mmap`` whose pages fault in on first
      touch. Measured here: a block's CPU time doubled (0.56 s -> 1.17 s for the blocks of a
      0.1 deg map). Large blocks are then served from the heap, as in the client process, and
      at most ``2 * 32 MiB`` of freed memory is kept before it is returned to the system.
    """
    global _WORKER_READY
    if _WORKER_READY:
        return
    try:
        from distributed import get_worker

        w = get_worker()
    except (ImportError, ValueError):
        return
    if "FIELDMAP_THREADS" not in os.environ:
        os.environ["FIELDMAP_THREADS"] = str(max(1, int(w.state.nthreads)))
    _glibc_thresholds(mmap_bytes=32 * 2**20)
    _WORKER_READY = True


def _glibc_thresholds(mmap_bytes: int) -> bool:
    """Set glibc's mmap and trim thresholds (``mallopt``); False where there is no glibc."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    if not name or not hasattr(os, "confstr"):
        return False
    try:
        if "glibc" not in (os.confstr("CS_GNU_LIBC_VERSION") or "").lower():
            return False
        libc = ctypes.CDLL(name)
    except (OSError, ValueError):
        return False
    m_trim_threshold, m_mmap_threshold = -1, -3  # <malloc.h>
    ok = libc.mallopt(m_mmap_threshold, ctypes.c_int(mmap_bytes))
    ok &= libc.mallopt(m_trim_threshold, ctypes.c_int(2 * mmap_bytes))
    return bool(ok)


def parse_scheduler(text: str | None) -> tuple[str, int] | str | None:
    """``None``/"threads" (local thread pool), ``("local", N)`` or a scheduler address."""
    if text is None or text in ("threads", "none", ""):
        return None
    if text.startswith("local:"):
        try:
            n = int(text.split(":", 1)[1])
        except ValueError:
            n = 0
        if n < 1:
            raise InputError(f"--scheduler local:N needs a worker count N >= 1, got {text!r}")
        return ("local", n)
    if text == "local":
        return ("local", max(1, os.cpu_count() or 1))
    return text


@contextlib.contextmanager
def open_client(
    scheduler: tuple[str, int] | str | None, connect_timeout: float = 5.0
) -> Iterator[Any]:
    """Yield a ``dask.distributed.Client`` for a parsed scheduler; close what was opened.

    ``None`` (no scheduler: run here) yields None. ``("local", N)`` starts a LocalCluster of N
    single-threaded worker processes on 127.0.0.1 (no dashboard) and shuts it down afterwards;
    an address connects to a running scheduler.
    An unreachable scheduler is an :class:`InputError` (one line, CLI exit 2).
    """
    if scheduler is None:
        yield None
        return
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise InputError(
            "Dask is not installed: pip install 'fieldmap[distributed]' (dask[distributed], zarr)"
        ) from None
    import logging

    if isinstance(scheduler, tuple):
        n = scheduler[1]
        cores = max(1, os.cpu_count() or 1)
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            dashboard_address="127.0.0.1:0",
            silence_logs=logging.ERROR,
            env={"FIELDMAP_THREADS": str(max(1, cores // n))},
        )
        try:
            with Client(cluster) as client:
                yield client
        finally:
            cluster.close()
        return
    _probe(scheduler, connect_timeout)
    try:
        client = Client(scheduler, timeout=connect_timeout)
    except (OSError, TimeoutError, ValueError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"cannot reach the Dask scheduler at {scheduler!r}: {msg}") from None
    try:
        yield client
    finally:
        client.close()


def _probe(address: str, timeout: float) -> None:
    """Fail in milliseconds, not after Dask's connect retries, when nothing listens (tcp)."""
    import socket
    from urllib.parse import urlsplit

    if not isinstance(address, str) or not address.startswith("tcp://"):
        return
    try:
        u = urlsplit(address)
        host, port = u.hostname, u.port
    except ValueError:
        raise InputError(f"bad Dask scheduler address {address!r}") from None
    if host is None or port is None:
        raise InputError(f"Dask scheduler address {address!r} needs tcp://HOST:PORT")
    try:
        socket.create_connection((host, port), timeout=timeout).close()
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise InputError(f"cannot reach the Dask scheduler at {address!r}: {why}") from None


#: client -> {id(model): (weak reference to the model, its future on the cluster)}
_SCATTERED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def scattered(client: Any, model: SHModel) -> Any:
    """Return the future of ``model`` broadcast to every worker of ``client``, once per client.

    Products made one after the other on the same client (a notebook, a study over several
    maps) reuse the copy the workers already hold: a degree-2190 model is 77 MB per worker.
    The copy lives as long as the model object and the client; a model that is garbage
    collected, or a client that is closed, releases it. The object is taken as immutable (an
    :class:`~fieldmap.models.shmodel.SHModel` is frozen): one changed in place is not shipped
    again.
    """
    try:
        per_client = _SCATTERED.setdefault(client, {})
    except TypeError:  # a client that cannot be weakly referenced: no reuse
        return client.scatter(model, broadcast=True, hash=False)
    entry = per_client.get(id(model))
    if entry is not None and entry[0]() is model and entry[1].status == "finished":
        return entry[1]
    fut = client.scatter(model, broadcast=True, hash=False)
    key = id(model)

    def forget(
        _ref: weakref.ref[SHModel], key: int = key, per_client: dict[int, Any] = per_client
    ) -> None:
        # drop the cache's reference only: a graph or a task still holding the future keeps
        # the data on the cluster, the last reference gone releases it (Future.__del__)
        per_client.pop(key, None)

    try:
        per_client[key] = (weakref.ref(model, forget), fut)
    except TypeError:  # a model that cannot be weakly referenced: not kept
        pass
    return fut
