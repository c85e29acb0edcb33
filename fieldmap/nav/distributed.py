"""Navigation Monte Carlo on a Dask cluster: runs (draws × models) split into tasks.

:func:`propagate_on` is :func:`fieldmap.nav.studies.propagate` with the runs split into groups,
each propagated by one task on a ``dask.distributed`` worker. The scenario (trajectory, truth
model, exact IMU increments) is shipped once per worker (``client.scatter(broadcast=True)``).
:func:`flight_block_on` does the same for each time block of the flight study
(:func:`fieldmap.nav.flightsim.run_flight`): the client synthesises the block's exact IMU
increments once, ships them to every worker, and the workers propagate groups of runs from the
states the client keeps between blocks. Each run is one Warp thread that depends on no other
run, so the results are those of a local run bit for bit, whatever the grouping.
"""

from __future__ import annotations

import contextlib
import functools
import math
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

__all__ = ["flight_block_on", "on_cluster", "propagate_on"]


@contextlib.contextmanager
def on_cluster(client) -> Iterator[None]:
    """Run the navigation launches of the enclosed studies on a Dask cluster.

    Within the block, :func:`fieldmap.nav.studies.propagate` (the paper's studies) and each time
    block of :func:`fieldmap.nav.flightsim.run_flight` (a flight study) split their runs
    (draws × models) into tasks on ``client`` (:func:`propagate_on`, :func:`flight_block_on`;
    bit for bit the local result); ``client=None`` keeps them here.
    """
    from fieldmap.nav import flightblocks, studies

    fn = None if client is None else functools.partial(propagate_on, client)
    blk = None if client is None else functools.partial(flight_block_on, client)
    with studies.propagated_by(fn), flightblocks.blocks_propagated_by(blk):
        yield


def _task(sc, gravity, sets, imu_set, errors):
    from fieldmap.nav import studies
    from fieldmap.products.cluster import worker_setup

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


def _flight_task(traj, model, sets, args: dict):
    from fieldmap.nav.flightblocks import propagate_block
    from fieldmap.products.cluster import worker_setup

    worker_setup()
    return propagate_block(traj=traj, model=model, sets=sets, **args)


def _rows(value, a: int, b: int, n: int):
    """Rows ``a:b`` of a per-run value (array, list or dict of them); anything else as is."""
    if isinstance(value, dict):
        return {k: _rows(v, a, b, n) for k, v in value.items()}
    if isinstance(value, (list, tuple)) and len(value) == n:
        return list(value[a:b])
    if isinstance(value, np.ndarray) and value.ndim >= 1 and value.shape[0] == n:
        return value[a:b]
    return value


def _stack(parts: list):
    """Inverse of :func:`_rows` over consecutive groups."""
    first = parts[0]
    if isinstance(first, dict):
        return {k: _stack([p[k] for p in parts]) for k in first}
    if isinstance(first, np.ndarray) and first.ndim >= 1:
        return np.concatenate(parts)
    return first


def flight_block_on(client, traj, frame, sets, tb, nb, dt, every, state, grav, model, imu_set,
                    kerr, aiding, baro, baro_bias, baro_state, rate_hz, device, sample0=0,
                    runs_per_task: int | None = None):  # fmt: skip
    """:func:`fieldmap.nav.flightblocks.propagate_block` with the runs split over ``client``.

    The trajectory and the truth model travel once per worker for the whole flight, the block's
    IMU increments once per worker and block; every per-run argument
    (:data:`fieldmap.nav.flightblocks.PER_RUN_ARGS`) is cut into groups of ``runs_per_task`` runs
    (default: four tasks per worker), and the results are put back together in run order.
    """
    from fieldmap.nav.flightblocks import PER_RUN_ARGS
    from fieldmap.products.cluster import scattered

    n = len(grav)
    nworkers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
    per = runs_per_task or max(1, math.ceil(n / (4 * nworkers)))
    traj_f, model_f = scattered(client, traj), scattered(client, model)
    # one future for the whole list (scatter splits a list into one future per item)
    (sets_f,) = client.scatter([sets], broadcast=True, hash=False)
    per_run = {
        "state": state, "grav": grav, "imu_set": imu_set, "kerr": kerr,
        "baro_bias": baro_bias, "baro_state": baro_state,
    }  # fmt: skip
    if set(per_run) != set(PER_RUN_ARGS):  # propagate_block's per-run arguments changed
        raise RuntimeError(f"per-run arguments {sorted(per_run)} != {sorted(PER_RUN_ARGS)}")
    common = {
        "frame": frame, "tb": tb, "nb": nb, "dt": dt, "every": every, "aiding": aiding,
        "baro": baro, "rate_hz": rate_hz, "device": device, "sample0": sample0,
    }  # fmt: skip
    futures = [
        client.submit(
            _flight_task,
            traj_f,
            model_f,
            sets_f,
            {**common, **{k: _rows(v, a, a + per, n) for k, v in per_run.items()}},
            pure=False,
        )
        for a in range(0, n, per)
    ]
    try:
        parts = client.gather(futures)
    finally:
        sets_f.release()
    res = _stack([p[0] for p in parts])
    nxt = _stack([p[1] for p in parts])
    return res, nxt
