"""Navigation Monte Carlo on a Dask cluster: runs (draws × models) split into tasks.

:func:`propagate_on` is :func:`fieldmap.nav.studies.propagate` with the runs split into groups,
each propagated by one task on a ``dask.distributed`` worker. The scenario (trajectory, truth
model, exact IMU increments) is shipped once per worker (``client.scatter(broadcast=True)``).
Each run is one Warp thread that depends on no other run, so the result is that of
:func:`~fieldmap.nav.studies.propagate` bit for bit, whatever the grouping.
"""

from __future__ import annotations

import contextlib
import functools
import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

__all__ = ["on_cluster", "propagate_on"]


@contextlib.contextmanager
def on_cluster(client) -> Iterator[None]:
    """Run the navigation launches of the enclosed studies on a Dask cluster.

    Within the block, :func:`fieldmap.nav.studies.propagate` splits its runs (draws × models)
    into tasks on ``client`` (:func:`propagate_on`, bit for bit the local result); ``client=None``
    keeps them here.
    """
    from fieldmap.nav import studies

    fn = None if client is None else functools.partial(propagate_on, client)
    with studies.propagated_by(fn):
        yield


def _task(sc, gravity, sets, imu_set, errors):
    from fieldmap.nav import studies
    from fieldmap.products.blocks import worker_setup

    worker_setup()
    return studies.propagate(sc, gravity, sets=sets, imu_set=imu_set, errors=errors)


def propagate_on(
    client,
    sc,
    gravity: list[str],
    sets=None,
    imu_set=None,
    errors=None,
    runs_per_task: int | None = None,
) -> dict:
    """Propagate every run of a study on ``client``; same result as ``studies.propagate``.

    Parameters
    ----------
    client : dask.distributed.Client
    sc : fieldmap.nav.studies.Scenario
    gravity, sets, imu_set, errors
        As :func:`fieldmap.nav.studies.propagate`.
    runs_per_task : int, optional
        Runs per task (default: four tasks per worker).

    Returns
    -------
    dict
        ``t``, ``dP``, ``dV``, ``pos``, ``vel`` as :func:`~fieldmap.nav.studies.propagate`;
        ``seconds`` is the wall time of the whole distributed propagation.
    """
    gravity = list(gravity)
    n = len(gravity)
    imu_set = np.zeros(n, dtype=np.int64) if imu_set is None else np.asarray(imu_set, np.int64)
    nworkers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
    per = runs_per_task or max(1, math.ceil(n / (4 * nworkers)))
    t0 = time.perf_counter()
    sc_f = client.scatter(sc, broadcast=True, hash=False)
    sets_f = client.scatter(sets, broadcast=True, hash=False) if sets is not None else None
    futures = [
        client.submit(
            _task,
            sc_f,
            gravity[a : a + per],
            sets_f,
            imu_set[a : a + per],
            None if errors is None else errors.take(np.arange(a, min(n, a + per))),
            pure=False,
        )
        for a in range(0, n, per)
    ]
    parts = client.gather(futures)
    from fieldmap.nav.studies import divergence

    runs = ("dP", "dV", "pos", "vel", "hor", "ver", "ned")  # one row per run
    out: dict[str, Any] = {k: np.concatenate([p[k] for p in parts]) for k in runs}
    out["t"] = parts[0]["t"]
    out["seconds"] = time.perf_counter() - t0
    out["diverged"] = divergence(out["pos"], out["t"], gravity)
    return out
