"""Navigation Monte Carlo on a Dask cluster: the deprecated entry points.

Pass ``client=`` to the studies instead (:func:`fieldmap.nav.paper.table1`, ``table3``,
``table4``, :func:`~fieldmap.nav.study.propagate`, :func:`fieldmap.nav.study.run_flight`):
their :class:`fieldmap.nav.propagator.Propagator` splits the runs (draws × models) into tasks on
the cluster, the same bits as here. :func:`on_cluster` and :func:`propagate_on` keep fieldmap
0.2's calls working until 0.3.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy.typing as npt

if TYPE_CHECKING:
    from distributed import Client

    from fieldmap.nav.imu import ImuIncrements
    from fieldmap.nav.sensors import ErrorDraws
    from fieldmap.nav.study import Scenario

__all__ = ["on_cluster", "propagate_on"]


@contextlib.contextmanager
def on_cluster(client: Client | None) -> Iterator[None]:
    """Run the navigation of the enclosed studies on a Dask cluster (prefer ``client=``).

    Within the block, every :class:`fieldmap.nav.propagator.Propagator` built without a client
    (the paper's studies, each time block of a flight study) uses ``client``; ``client=None``
    keeps them here.
    """
    from fieldmap import _compat
    from fieldmap.nav.propagator import default_client

    _compat.warn("fieldmap.nav.distributed.on_cluster(client): pass client= to the study")
    with default_client(client):
        yield


def propagate_on(
    client: Client | None,
    sc: Scenario,
    gravity: list[str],
    sets: list[ImuIncrements] | None = None,
    imu_set: npt.ArrayLike | None = None,
    errors: ErrorDraws | None = None,
    runs_per_task: int | None = None,
) -> dict[str, Any]:
    """:func:`fieldmap.nav.study.propagate` on ``client`` (prefer its ``client=``)."""
    from fieldmap import _compat
    from fieldmap.nav.study import propagate

    _compat.warn("fieldmap.nav.distributed.propagate_on(client, ...): pass client= to propagate")
    return propagate(sc, gravity, sets, imu_set, errors, client=client, runs_per_task=runs_per_task)
