"""Navigation-error studies of Chen et al. (2022) §5: Tables 1, 3, 4 and Figs. 11-13.

A :class:`Scenario` holds the reference trajectory (Fig. 9 like boost-glide), its exact IMU
increments under the truth gravitation (default: bundled EIGEN-6S at full degree) and the exact
states at the output times. Each study puts all its navigation runs (gravity models × IMU error
draws × IMU grades) into **one** call of :func:`fieldmap.nav.strapdown.propagate_lci` (one Warp
launch, one thread per run) and reduces the errors against the exact trajectory.

Errors are the norms of the a-frame position and inertial-velocity differences (navigation −
truth); the paper's tables give "absolute values" of the final errors.

"Without gravity-model error" runs (Table 4) use a second increment set synthesized with the
navigation model itself as the truth (same trajectory, same sensor errors), which isolates the IMU
errors at the cost of a cheap second synthesis instead of a degree-240 navigation run per draw.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel
from fieldmap.nav import imu_errors
from fieldmap.nav.imu import Gravitation, ImuIncrements, load_truth_model, synthesize
from fieldmap.nav.propagator import (  # noqa: F401 - EARTH_RADIUS: public here in 0.2
    EARTH_RADIUS,
    Propagator,
    divergence,
    final_stats,
)
from fieldmap.nav.trajectory import BoostGlide, Kinematics, Trajectory

#: Navigation gravity models of Table 1 (keys of the JSON output).
TABLE1_MODELS = ("j2", "j4", "j6", "exact", "sh18", "sh200")
#: Paper values (Chen et al. 2022 Table 1): |δv| m/s, |δp| m, CPU s per gravity evaluation,
#: keyed by our navigation model names (the paper has no exact-normal row).
PAPER_TABLE1 = {
    "j2": (0.742, 387.18, 0.000003),
    "j4": (0.686, 351.28, 0.000003),
    "j6": (0.686, 351.19, 0.000004),
    "sh18": (0.181, 117.52, 0.000214),
    "sh200": (0.060, 35.88, 0.004449),
}
#: Paper values (Chen et al. 2022 Table 3): |δv| m/s, |δp| m per accelerometer group.
PAPER_TABLE3 = {1: (2.033, 1019.98), 2: (0.507, 296.69), 3: (0.667, 344.29), 4: (0.686, 351.19)}
#: normal navigation models -> the ``normal=`` name of :mod:`fieldmap.field.normal` (the same
#: names: the exact level-ellipsoid field is ``"exact"`` on both sides)
NORMAL_KINDS = {"j2": "j2", "j4": "j4", "j6": "j6", "exact": "exact"}


def check_model_names(names, sh_model) -> list[str]:
    """Validate navigation gravity names (``j2 j4 j6 exact sh shN``); raise :class:`InputError`.

    Returns the names in lower case, ``sh`` as ``sh<lmax>``; the deprecated ``"normal"`` becomes
    ``"exact"`` with one ``DeprecationWarning``.
    """
    from fieldmap.nav.strapdown import gravity_names, parse_gravity

    out = []
    for name in gravity_names(list(names)):
        key = str(name).strip().lower()
        parse_gravity(key, sh_model)
        out.append(key if key != "sh" else f"sh{sh_model.lmax}")
    if not out:
        raise InputError("no navigation gravity model given")
    return out


@dataclass
class Scenario:
    """Trajectory, truth model, exact IMU increments and exact states at the output times."""

    traj: Trajectory
    truth_model: SHModel
    imu: ImuIncrements
    output_every: int
    t_out: np.ndarray
    truth: Kinematics
    device: str | None = None
    extra_sets: dict = field(default_factory=dict)

    @property
    def truth_key(self) -> str:
        """Navigation name of the truth model (``shN`` at its full degree)."""
        return f"sh{self.truth_model.lmax}"

    def imu_set(self, nav_truth: str | None = None) -> ImuIncrements:
        """Increments under the truth model, or (cached) under a normal model ``nav_truth``."""
        if nav_truth is None:
            return self.imu
        if nav_truth not in self.extra_sets:
            g = Gravitation(
                NORMAL_KINDS[nav_truth], device=self.device, ellipsoid=self.traj.frame.ellipsoid
            )
            self.extra_sets[nav_truth] = synthesize(
                self.traj,
                self.imu.rate_hz,
                g,
                n_gauss=self.imu.meta["n_gauss"],
                duration=self.imu.duration,
            )
        return self.extra_sets[nav_truth]


def build_scenario(
    duration: float = 800.0,
    rate_hz: float = 200.0,
    truth: str = "eigen-6s",
    truth_lmax: int | None = None,
    n_gauss: int = 3,
    output_dt: float = 1.0,
    trajectory: Trajectory | None = None,
    device: str | None = None,
    progress: bool = False,
) -> Scenario:
    """Synthesize the IMU of the boost-glide path (or ``trajectory``) under the truth model.

    Parameters
    ----------
    duration : float
        Flight time simulated. Units: s.
    rate_hz : float
        IMU sample rate (navigation step 2/rate). Units: Hz.
    truth : str
        Truth gravity model name or ICGEM path (``fieldmap.models.registry.load_model``).
    truth_lmax : int, optional
        Truth degree (default: full).
    n_gauss : int
        Gauss–Legendre nodes per IMU sample.
    output_dt : float
        Interval of the stored error curves; a whole number of navigation steps (2/rate) that
        divides the run (else :class:`InputError`), or at least ``duration`` (the end state
        only). Units: s.
    trajectory : Trajectory, optional
        Default :class:`fieldmap.nav.trajectory.BoostGlide` of length ``duration``.
    device : str, optional
        Warp device.
    progress : bool
        tqdm progress bars.
    """
    for what, v in (("duration", duration), ("output interval", output_dt), ("rate", rate_hz)):
        if isinstance(v, (str, bytes, bool)) or not np.isfinite(v) or v <= 0:
            raise InputError(f"{what} must be a positive number, got {v!r}")
    traj = trajectory or BoostGlide(duration=max(float(duration), 1.0))
    model = load_truth_model(truth, truth_lmax)
    g = Gravitation("sh", model=model, device=device, ellipsoid=traj.frame.ellipsoid)
    imu = synthesize(traj, rate_hz, g, n_gauss=n_gauss, duration=duration, progress=progress)
    assert isinstance(imu, ImuIncrements)  # one gravitation in, one increment set out
    steps = imu.n_samples // 2
    every = output_steps(output_dt, steps, 2.0 / float(rate_hz))
    t_out = imu.t0 + 2.0 * imu.dt * every * np.arange(steps // every + 1)
    return Scenario(traj, model, imu, every, t_out, traj.kinematics(t_out), device)


def output_steps(output_dt: float, steps: int, step_s: float) -> int:
    """Navigation steps per stored state for an output interval ``output_dt`` (s).

    ``output_dt`` must be a whole number of steps of ``step_s`` seconds that divides the
    ``steps`` of the run, or at least the run's length (then only the end state is stored);
    otherwise :class:`InputError` names the nearest valid intervals.
    """
    if output_dt >= steps * step_s * (1.0 - 1e-12):
        return steps
    k = output_dt / step_s
    every = int(round(k))
    if every >= 1 and abs(k - every) <= 1e-9 * max(1.0, k) and steps % every == 0:
        return every
    divisors = [d for d in range(1, steps + 1) if steps % d == 0]
    lo = max([d for d in divisors if d * step_s <= output_dt] or [1])
    hi = min([d for d in divisors if d * step_s >= output_dt] or [steps])
    raise InputError(
        f"output interval {output_dt:g} s is not a whole number of navigation steps "
        f"({step_s:g} s) dividing the run ({steps * step_s:g} s): use e.g. "
        f"{lo * step_s:g} s or {hi * step_s:g} s"
    )


def propagate(
    sc: Scenario,
    gravity: list[str],
    sets: list[ImuIncrements] | None = None,
    imu_set=None,
    errors: imu_errors.ErrorDraws | None = None,
    progress: bool = False,
    *,
    client=None,
    runs_per_task: int | None = None,
):
    """Propagate every run over the whole record (one block, LCI); errors vs. the truth.

    The runs go to one :class:`fieldmap.nav.propagator.Propagator` (here: one Warp launch; with
    ``client``, groups of runs as tasks on that Dask cluster); with ``progress`` the runs go into
    up to 8 propagators in turn (a tqdm bar over them). Every run depends on no other run: the
    same bits in every case.

    Returns
    -------
    dict
        ``pos`` and ``vel`` (n_runs, n_out) error norms (m, m/s), ``dP``, ``dV`` (n_runs, n_out, 3)
        a-frame error vectors, ``hor``, ``ver``, ``ned`` (north, east, down), ``t`` (n_out,),
        ``seconds`` wall time of the propagation, ``diverged``.
    """
    from fieldmap.nav.strapdown import dcm_to_quat

    sets = sets or [sc.imu]
    dth = np.stack([s.dtheta for s in sets])
    dv = np.stack([s.dv for s in sets])
    gravity = list(gravity)
    n = len(gravity)
    imu_set = (
        np.zeros(n, dtype=np.int64) if imu_set is None else np.asarray(imu_set, dtype=np.int64)
    )
    k0 = sc.traj.kinematics([sc.imu.t0])
    t0 = time.perf_counter()

    def launch(idx):
        """Propagate the runs ``idx`` (balanced over the CPU chunks)."""
        perm = idx[balanced_order([gravity[i] for i in idx])]
        m = perm.size
        start = {
            "P": np.tile(k0.P_a[0], (m, 1)),
            "V": np.tile(k0.V_a[0], (m, 1)),
            "q": np.tile(dcm_to_quat(k0.C_b_to_a[0]), (m, 1)),
        }
        prop = Propagator(
            "lci", start, [gravity[i] for i in perm], sc.imu.dt, launch=sc.traj.frame,
            sh_model=sc.truth_model, imu_set=imu_set[perm],
            errors=None if errors is None else errors.take(perm).kernel_errors(),
            t_start=sc.imu.t0, output_every=2 * sc.output_every, device=sc.device,
            client=client, runs_per_task=runs_per_task,
        )  # fmt: skip
        return perm, prop.propagate(dth, dv, 0)

    if progress and n > 1:
        # several propagators, each a cost-balanced share of the runs: every run is
        # independent (own thread, own noise stream), so the numbers are those of one launch
        from tqdm import tqdm

        from fieldmap.nav.strapdown import gravity_cost

        order = np.argsort([-gravity_cost(g, sc.truth_model) for g in gravity], kind="stable")
        parts = [order[j :: min(n, 8)] for j in range(min(n, 8))]
        done = [launch(p) for p in tqdm(parts, desc="navigation runs", unit="launch")]
        perm = np.concatenate([p for p, _ in done])
        res = {k: np.concatenate([r[k] for _, r in done]) for k in ("P", "V")}
        res["t"] = done[0][1]["t"]
    else:
        perm, res = launch(np.arange(n))
    secs = time.perf_counter() - t0
    inv = np.argsort(perm)
    dP = res["P"][inv] - sc.truth.P_a[None]
    dV = res["V"][inv] - sc.truth.V_a[None]
    with np.errstate(invalid="ignore", over="ignore"):
        d_ned = _a_to_ned(sc, dP)
        out = {
            "t": res["t"],
            "dP": dP,
            "dV": dV,
            "pos": np.linalg.norm(dP, axis=-1),
            "vel": np.linalg.norm(dV, axis=-1),
            "hor": np.hypot(d_ned[..., 0], d_ned[..., 1]),
            "ver": np.abs(d_ned[..., 2]),
            "ned": d_ned,
            "seconds": secs,
        }
    out["diverged"] = divergence(out["pos"], res["t"], gravity)
    return out


def _a_to_ned(sc: Scenario, dP: np.ndarray) -> np.ndarray:
    """A-frame error vectors (n, n_out, 3) -> north, east, down at the true position."""
    from fieldmap.field.frames import ecef_to_geodetic
    from fieldmap.nav.flight import _C_n_to_e

    r = sc.truth.r_e
    lat, lon, _ = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], sc.traj.frame.ellipsoid)
    C_a_e = np.swapaxes(sc.traj.frame.C_e_to_a(sc.t_out), -1, -2)
    M = np.swapaxes(_C_n_to_e(lat, lon), -1, -2) @ C_a_e  # C_a^n (n_out, 3, 3)
    return np.einsum("tij,rtj->rti", M, dP)


def balanced_order(gravity: list[str], parts: int | None = None) -> np.ndarray:
    """Order of the runs that gives every CPU chunk of the launch a similar cost.

    ``fieldmap._warp.launch_chunked`` splits the threads into contiguous pieces, one per core;
    runs are sorted by estimated cost ((N+1)² per step for SH degree N, 1 for the normal models)
    and dealt round-robin into the pieces.
    """
    from fieldmap._warp import chunks, cpu_workers
    from fieldmap.nav.strapdown import gravity_cost

    n = len(gravity)
    cost = np.array([gravity_cost(g) for g in gravity], dtype=np.float64)
    order = np.argsort(-cost, kind="stable")
    pieces = chunks(n, parts or cpu_workers())
    buckets: list[list[int]] = [[] for _ in pieces]
    room = [cnt for _, cnt in pieces]
    load = np.zeros(len(pieces))
    for i in order:
        open_ = [b for b in range(len(pieces)) if len(buckets[b]) < room[b]]
        b = min(open_, key=lambda j: load[j])
        buckets[b].append(int(i))
        load[b] += cost[i]
    return np.array([i for b in buckets for i in b], dtype=np.int64)


def gravity_eval_seconds(
    name: str, sh_model, n_points: int | None = None, device: str = "cpu", repeats: int = 3
) -> float:
    """Measured cost of one gravity evaluation of navigation model ``name`` (one CPU thread).

    Points along the boost-glide path are evaluated in one batch through the same Warp device
    functions the propagator uses; the median wall time over ``repeats`` divided by the number of
    points is returned. Units: s.
    """
    from fieldmap import _warp
    from fieldmap.nav.strapdown import gravity_names

    key = gravity_names([name.strip().lower()])[0]
    if key in NORMAL_KINDS:
        g = Gravitation(NORMAL_KINDS[key], device=device)
        n_points = n_points or 20000
    else:
        from fieldmap.nav.strapdown import parse_gravity

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

    def to_dataset(self):
        """Return the error curves as an ``xarray.Dataset`` over (run, time) (CF-1.8)."""
        from fieldmap.nav.datasets import to_dataset

        return to_dataset(self)


def table1(
    sc: Scenario,
    models=TABLE1_MODELS,
    timing: bool = True,
    progress: bool = False,
    *,
    client=None,
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


def _mc_rows(labels, out, n, extra):
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
    groups=(1, 2, 3, 4),
    draws: int = 50,
    seed: int = 0,
    nav: str = "j4",
    mode: str = "gauss",
    progress: bool = False,
    *,
    client=None,
) -> StudyResult:
    """Table 3 / Fig. 12: ``nav`` gravity with the accelerometer error groups of Table 2.

    ``draws`` Monte Carlo runs per group (group 4, error-free, is deterministic: one run) in one
    launch; statistics of the final errors over the draws.
    """
    nav = check_model_names([nav], sc.truth_model)[0]
    parts, labels, extra, counts = [], [], [], []
    for gi, grp in enumerate(groups):
        if grp not in imu_errors.TABLE2_GROUPS:
            raise InputError(f"unknown Table 2 group {grp!r} (1..4)")
        spec = imu_errors.TABLE2_GROUPS[grp]
        n = 1 if spec == imu_errors.ImuErrorSpec() else int(draws)
        parts.append(imu_errors.draw(spec, n, seed=seed + 1000 * gi, mode=mode))
        counts.append(n)
        labels.append(f"group{grp}")
        extra.append(
            {
                "group": grp,
                "acc_bias_ug": spec.acc_bias_ug,
                "acc_noise_ug_rthz": spec.acc_noise_ug_rthz,
                "draws": n,
            }
        )
    err = imu_errors.ErrorDraws.concat(parts)
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


def table4(
    sc: Scenario,
    models=("j4", "sh18", "sh200"),
    draws: int = 20,
    seed: int = 0,
    spec: imu_errors.ImuErrorSpec = imu_errors.TABLE4,
    mode: str = "gauss",
    reference: str = "j4",
    progress: bool = False,
    *,
    client=None,
) -> StudyResult:
    """Table 4 / Fig. 13: full IMU error model with and without the gravity-model error.

    Rows: ``imu_only`` (navigation with ``reference`` on increments synthesized with
    ``reference`` as truth: no gravity-model error) and one row per navigation model in ``models``
    on the truth increments (IMU + gravity-model error). The same ``draws`` error draws are used
    in every row; all runs go into one launch.
    """
    names = check_model_names(models, sc.truth_model)
    ref = check_model_names([reference], sc.truth_model)[0]
    if ref not in NORMAL_KINDS:
        raise InputError(
            f"the IMU-only reference must be a normal model (j2 j4 j6 exact), got {ref!r}"
        )
    err1 = imu_errors.draw(spec, draws, seed=seed, mode=mode)
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
        "trajectory": sc.traj.name,
        "duration_s": float(sc.imu.duration),
        "imu_rate_hz": float(sc.imu.rate_hz),
        "n_gauss": int(sc.imu.meta["n_gauss"]),
        "device": sc.device or "auto",
    }
