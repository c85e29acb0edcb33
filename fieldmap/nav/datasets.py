"""Results of the navigation studies as ``xarray.Dataset`` objects (dims run, time; CF-1.8).

:func:`to_dataset` for the paper's studies (:class:`fieldmap.nav.studies.StudyResult`),
:func:`flight_dataset` for flight studies (:class:`fieldmap.nav.flightsim.FlightResult`); both
are written as NetCDF by :mod:`fieldmap.nav.report` and returned by the results' ``to_dataset``.
"""

from __future__ import annotations

import json

import numpy as np

__all__ = ["flight_dataset", "to_dataset"]


def to_dataset(res):
    """Error curves of a study as an ``xarray.Dataset`` (dims run, time; CF-1.8 attributes)."""
    import xarray as xr

    ds = xr.Dataset(
        {
            "position_error": (
                ("run", "time"),
                res.pos,
                {"units": "m", "long_name": "norm of the a-frame position error"},
            ),
            "velocity_error": (
                ("run", "time"),
                res.vel,
                {"units": "m s-1", "long_name": "norm of the inertial velocity error"},
            ),
        },
        coords={
            # an auxiliary coordinate: CF coordinate variables are numeric (CF 1.8 §5)
            "label": ("run", np.array(res.labels, dtype=str), {"long_name": "run label"}),
            "time": ("time", res.t, {"units": "s", "long_name": "time since launch"}),
        },
        attrs={
            "Conventions": "CF-1.8",
            "title": f"fieldmap navsim {res.study}",
            "source": f"truth {res.meta['truth_model']} degree {res.meta['truth_degree']}",
            "meta": json.dumps(res.meta, default=float),
        },
    )
    return ds


def flight_dataset(res):
    """Error curves, δg and the prediction of a flight study as an ``xarray.Dataset`` (CF-1.8)."""
    import xarray as xr

    models = list(res.dg)
    axis = np.array(["north", "east", "down"])
    sigma = {}
    if getattr(res, "dg_sigma", None) is not None:
        sigma["truth_gravity_sigma"] = (
            ("time", "axis"),
            res.dg_sigma,
            {
                "units": "m s-2",
                "long_name": "standard deviation of the truth model's gravitation (commission "
                "error from the coefficient sigma, diagonal propagation), NED",
            },
        )
    ds = xr.Dataset(
        {
            **sigma,
            "position_error": (
                ("run", "time", "axis"),
                res.dpos,
                {"units": "m", "long_name": "navigation minus true position, north east down"},
            ),
            "velocity_error": (
                ("run", "time", "axis"),
                res.dvel,
                {"units": "m s-1", "long_name": "navigation minus true velocity, NED"},
            ),
            "attitude_error": (
                ("run", "time", "axis"),
                res.datt,
                {"units": "rad", "long_name": "small-angle attitude error about N, E, D"},
            ),
            "gravity_error": (
                ("model", "time", "axis"),
                np.stack([res.dg[m] for m in models]) if models else np.zeros((0, res.t.size, 3)),
                {"units": "m s-2", "long_name": "navigation model minus truth gravitation, NED"},
            ),
            "predicted_position_error": (
                ("model", "time", "horizontal_axis"),
                np.stack([res.predicted[m] for m in models])
                if models
                else np.zeros((0, res.t.size, 2)),
                {
                    "units": "m",
                    "long_name": "double time integral of the horizontal gravity error",
                },
            ),
            "latitude": ("time", res.track[:, 0], {"units": "degrees_north"}),
            "longitude": ("time", res.track[:, 1], {"units": "degrees_east"}),
            "height": ("time", res.track[:, 2], {"units": "m", "long_name": "ellipsoidal height"}),
        },
        coords={
            "run": ("run", np.array(res.labels, dtype=str)),
            "run_model": ("run", np.array(res.models, dtype=str)),
            "draw": ("run", res.draw),
            "model": ("model", np.array(models, dtype=str)),
            "time": ("time", res.t, {"units": "s", "long_name": "time since the first sample"}),
            "axis": ("axis", axis),
            "horizontal_axis": ("horizontal_axis", axis[:2]),
        },
        attrs={
            "Conventions": "CF-1.8",
            "title": "fieldmap navsim flight study",
            "source": f"truth {res.summary['meta']['truth_model']} degree "
            f"{res.summary['meta']['truth_degree']}",
            "meta": json.dumps(res.summary["meta"], default=float),
        },
    )
    return ds
