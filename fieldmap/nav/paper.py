"""Navigation-error studies of Chen et al. (2022) §5: Tables 1, 3, 4 as study configurations.

Navigation-error studies of Chen et al. (2022) §5: Tables 1, 3, 4 and Figs. 11-13.

A :class:`~fieldmap.nav.study.Scenario` holds the reference trajectory (Fig. 9 like
boost-glide), its exact IMU increments under the truth gravitation (default: bundled EIGEN-6S at
full degree) and the exact states at the output times. Each study puts all its navigation runs
(gravity models × IMU error draws × IMU grades) into **one** call of
:func:`fieldmap.nav.mechanize.propagate_lci` (one Warp launch, one thread per run) and reduces
the errors against the exact trajectory.

Errors are the norms of the a-frame position and inertial-velocity differences (navigation −
truth); the paper's tables give "absolute values" of the final errors.

"Without gravity-model error" runs (Table 4) use a second increment set synthesized with the
navigation model itself as the truth (same trajectory, same sensor errors), which isolates the IMU
errors at the cost of a cheap second synthesis instead of a degree-240 navigation run per draw.

The scenario and the propagation of the runs live in :mod:`fieldmap.nav.study` (their names
are re-exported here); this module builds the tables on them.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.nav import sensors
from fieldmap.nav.imu import Gravitation
from fieldmap.nav.propagator import final_stats
from fieldmap.nav.study import NORMAL_KINDS, Scenario, check_model_names, propagate
from fieldmap.nav.trajectory import BoostGlide

if TYPE_CHECKING:
    import xarray as xr

    from fieldmap.models.shmodel import SHModel

#: Navigation gravity models of Table 1 (keys of the JSON output).
TABLE1_MODELS = ("j2", "j4", "j6", "exact", "sh18", "sh200")


def gravity_eval_seconds(
    name: str,
    sh_model: SHModel,
    n_points: int | None = None,
    device: str = "cpu",
    repeats: int = 3,
) -> float:
    """Measured cost of one gravity evaluation of navigation model ``name`` (one CPU thread).

    Points along the boost-glide path are evaluated in one batch through the same Warp device
    functions the propagator uses; the median wall time over ``repeats`` divided by the number of
    points is returned. Units: s.
    """
    from fieldmap import _warp

    key = name.strip().lower()
    if key in NORMAL_KINDS:
        g = Gravitation(NORMAL_KINDS[key], device=device)
        n_points = n_points or 20000
    else:
        from fieldmap.nav.gravity import parse_gravity

        lmax = parse_gravity(key, sh_model)[1]
        g = Gravitation("sh", model=sh_model, lmax=lmax, device=device)
        n_points = n_points or max(200, min(20000, int(4e7 / (lmax + 1) ** 2)))
    r = BoostGlide().kinematics(np.linspace(0.0, 800.0, n_points)).r_e
    g(r[:8])  # compile / build tables outside the timing
    times = []
    with _warp.threads(1):  # CPU launches on one thread
        for _ in range(repeats):
            t0 = time.perf_counter()
            g(r)
            times.append(time.perf_counter() - t0)
    return float(np.median(times) / n_points)


@dataclass
class StudyResult:
    """Rows of a table plus the error curves behind it (see :mod:`fieldmap.cli.nav` for output)."""

    study: str
    rows: list[dict]
    t: np.ndarray
    labels: list[str]
    pos: np.ndarray
    vel: np.ndarray
    meta: dict

    def to_dataset(self) -> xr.Dataset:
        """Return the error curves as an ``xarray.Dataset`` over (run, time) (CF-1.8)."""
        from fieldmap.nav.study import to_dataset

        return to_dataset(self)


def table1(
    sc: Scenario,
    models: Sequence[str] = TABLE1_MODELS,
    timing: bool = True,
    progress: bool = False,
    *,
    client: Any = None,
) -> StudyResult:
    """Table 1 / Fig. 11: navigation errors with only the gravity-model error.

    One launch propagates every model in ``models`` plus the truth model itself (the numerical
    floor: truth = navigation model, no sensor errors).
    """
    names = check_model_names(models, sc.truth_model)
    runs = names + [sc.truth_key]
    out = propagate(sc, runs, progress=progress, client=client)
    rows: list[dict[str, Any]] = []
    for i, name in enumerate(names):
        row = {
            "model": name,
            "final_velocity_error_m_s": float(out["vel"][i, -1]),
            "final_position_error_m": float(out["pos"][i, -1]),
            "final_horizontal_error_m": float(out["hor"][i, -1]),
            "final_vertical_error_m": float(out["ver"][i, -1]),
            "final_north_error_m": float(out["ned"][i, -1, 0]),
            "final_east_error_m": float(out["ned"][i, -1, 1]),
            "final_down_error_m": float(out["ned"][i, -1, 2]),
        }
        if timing:
            row["gravity_eval_seconds"] = gravity_eval_seconds(name, sc.truth_model)
        rows.append(row)
    floor: dict[str, Any] = {
        "nav_gravity": sc.truth_key,
        "final_position_error_m": float(out["pos"][-1, -1]),
        "final_velocity_error_m_s": float(out["vel"][-1, -1]),
        "max_position_error_m": float(out["pos"][-1].max()),
    }
    # how far below the smallest gravity-model effect of this run the floor lies (want >= 10)
    floor["margin_position"] = min(r["final_position_error_m"] for r in rows) / max(
        floor["final_position_error_m"], 1e-300
    )
    floor["margin_velocity"] = min(r["final_velocity_error_m_s"] for r in rows) / max(
        floor["final_velocity_error_m_s"], 1e-300
    )
    meta = _meta(sc) | {
        "floor": floor,
        "propagation_seconds": out["seconds"],
        "n_runs": len(runs),
        "diverged": out["diverged"],
    }
    labels = names + [f"floor:{sc.truth_key}"]
    return StudyResult("table1", rows, out["t"], labels, out["pos"], out["vel"], meta)


def _mc_rows(
    labels: list[str], out: dict[str, Any], n: int, extra: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for j, lab in enumerate(labels):
        sl = slice(j * n, (j + 1) * n)
        row = dict(extra[j])
        for key, unit in (
            ("vel", "velocity_error_m_s"),
            ("pos", "position_error_m"),
            ("hor", "horizontal_error_m"),
            ("ver", "vertical_error_m"),
        ):
            for stat, v in final_stats(out[key][sl, -1]).items():
                row[f"final_{unit}_{stat}"] = v
        rows.append(row)
    return rows


def table3(
    sc: Scenario,
    groups: Sequence[int] = (1, 2, 3, 4),
    draws: int = 50,
    seed: int = 0,
    nav: str = "j4",
    mode: str = "gauss",
    progress: bool = False,
    *,
    client: Any = None,
) -> StudyResult:
    """Table 3 / Fig. 12: ``nav`` gravity with the accelerometer error groups of Table 2.

    ``draws`` Monte Carlo runs per group (group 4, error-free, is deterministic: one run) in one
    launch; statistics of the final errors over the draws.
    """
    nav = check_model_names([nav], sc.truth_model)[0]
    parts, labels, extra, counts = [], [], [], []
    for gi, grp in enumerate(groups):
        if grp not in sensors.TABLE2_GROUPS:
            raise InputError(f"unknown Table 2 group {grp!r} (1..4)")
        spec = sensors.TABLE2_GROUPS[grp]
        n = 1 if spec == sensors.ImuErrorSpec() else int(draws)
        parts.append(sensors.draw(spec, n, seed=seed + 1000 * gi, mode=mode))
        counts.append(n)
        labels.append(f"group{grp}")
        extra.append(
            {
                "group": grp,
                "accel_bias_ug": spec.accel_bias_ug,
                "accel_vrw_ug_per_sqrt_hz": spec.accel_vrw_ug_per_sqrt_hz,
                "draws": n,
            }
        )
    err = sensors.ErrorDraws.concat(parts)
    out = propagate(sc, [nav] * err.n, errors=err, progress=progress, client=client)
    rows, start = [], 0
    for j, n in enumerate(counts):
        sub = {
            k: (v[start : start + n] if k in ("pos", "vel", "hor", "ver") else v)
            for k, v in out.items()
        }
        rows += _mc_rows([labels[j]], sub, n, [extra[j]])
        start += n
    meta = _meta(sc) | {
        "nav_gravity": nav,
        "draws": int(draws),
        "seed": int(seed),
        "bias_mode": mode,
        "propagation_seconds": out["seconds"],
        "n_runs": err.n,
        "diverged": out["diverged"],
    }
    run_labels = [f"{labels[j]}/{i}" for j, n in enumerate(counts) for i in range(n)]
    return StudyResult("table3", rows, out["t"], run_labels, out["pos"], out["vel"], meta)


@dataclass(frozen=True)
class MonteCarlo:
    """The Monte Carlo draws of the sensor errors of a study, validated on construction.

    Parameters
    ----------
    draws : int
        Runs per row (the same draws in every row).
    seed : int
        Seed of the draws (:func:`fieldmap.nav.sensors.draw`).
    mode : {"gauss", "sign", "fixed"}
        How bias, scale factor and misalignment are drawn (:mod:`fieldmap.nav.sensors`).
    spec : ImuErrorSpec
        The 1σ sensor errors (default: the paper's Table 4).
    """

    draws: int = 20
    seed: int = 0
    mode: str = "gauss"
    spec: sensors.ImuErrorSpec = sensors.TABLE4

    def __post_init__(self) -> None:
        for name, what, low in (("draws", "number of Monte Carlo draws", 1), ("seed", "seed", 0)):
            v = getattr(self, name)
            try:
                whole = not isinstance(v, (bool, np.bool_)) and float(v) == int(v)
            except (TypeError, ValueError, OverflowError):
                whole = False
            if not whole:
                raise InputError(f"{what} must be an integer, got {v!r}", param=name)
            if v < low:
                raise InputError(f"{what} must be >= {low}, got {v}", param=name)
        if self.mode not in sensors.MODES:
            raise InputError(f"unknown bias mode {self.mode!r} (known: {', '.join(sensors.MODES)})")


def table4(
    sc: Scenario,
    models: Sequence[str] = ("j4", "sh18", "sh200"),
    monte_carlo: MonteCarlo | None = None,
    reference: str = "j4",
    progress: bool = False,
    *,
    client: Any = None,
) -> StudyResult:
    """Table 4 / Fig. 13: full IMU error model with and without the gravity-model error.

    Rows: ``imu_only`` (navigation with ``reference`` on increments synthesized with
    ``reference`` as truth: no gravity-model error) and one row per navigation model in ``models``
    on the truth increments (IMU + gravity-model error). The same draws of ``monte_carlo``
    (default ``MonteCarlo()``: 20 draws of the Table 4 errors, seed 0) are used in every row;
    all runs go into one launch.
    """
    mc = MonteCarlo() if monte_carlo is None else monte_carlo
    draws, seed, mode, spec = mc.draws, mc.seed, mc.mode, mc.spec
    names = check_model_names(models, sc.truth_model)
    ref = check_model_names([reference], sc.truth_model)[0]
    if ref not in NORMAL_KINDS:
        raise InputError(
            f"the IMU-only reference must be a normal model (j2 j4 j6 exact), got {ref!r}"
        )
    err1 = sensors.draw(spec, draws, seed=seed, mode=mode)
    rows_models = [ref] + names
    err = err1.repeat(len(rows_models))
    grav = [m for m in rows_models for _ in range(err1.n)]
    imu_set = [1 if j == 0 else 0 for j in range(len(rows_models)) for _ in range(err1.n)]
    out = propagate(
        sc,
        grav,
        sets=[sc.imu, sc.imu_set(ref)],
        imu_set=imu_set,
        errors=err,
        progress=progress,
        client=client,
    )
    labels = ["imu_only"] + [f"imu+{m}" for m in names]
    extra = [
        {"case": lab, "nav_gravity": m, "gravity_model_error": j > 0, "draws": err1.n}
        for j, (lab, m) in enumerate(zip(labels, rows_models))
    ]
    rows = _mc_rows(labels, out, err1.n, extra)
    meta = _meta(sc) | {
        "draws": int(draws),
        "seed": int(seed),
        "bias_mode": mode,
        "imu_errors": spec.__dict__,
        "propagation_seconds": out["seconds"],
        "n_runs": err.n,
        "diverged": out["diverged"],
    }
    run_labels = [f"{lab}/{i}" for lab in labels for i in range(err1.n)]
    return StudyResult("table4", rows, out["t"], run_labels, out["pos"], out["vel"], meta)


def _meta(sc: Scenario) -> dict:
    return {
        "truth_model": sc.truth_model.name,
        "truth_degree": int(sc.truth_model.lmax),
        "truth_tide_system": sc.truth_model.tide_system,
        "trajectory": sc.traj.name,
        "duration_s": float(sc.imu.duration),
        "imu_rate_hz": float(sc.imu.rate_hz),
        "n_gauss": int(sc.imu.meta["n_gauss"]),
        "device": sc.device or "auto",
    }
