r"""The Monte Carlo navigation study: scenario, runs, NED errors, summary and Dataset.

The scenario of a navigation study and the propagation of its runs against the truth.

A :class:`Scenario` holds the reference trajectory, its exact IMU increments under the truth
gravitation and the exact states at the output times (:func:`build_scenario`);
:func:`propagate` runs many navigation runs (gravity models × IMU error draws × increment sets)
through one :class:`fieldmap.nav.propagator.Propagator` and returns their errors against the
truth. The tables of :mod:`fieldmap.nav.paper` are built on these.

Flight studies' start state and stored states in geodetic terms.

:func:`fieldmap.nav.study.run_flight` starts a :class:`fieldmap.nav.propagator.Propagator`
from :func:`initial_state` (the truth at t = 0) and turns each block's stored states into
latitude, longitude, height, NED velocity and attitude with :func:`geodetic_outputs`.

Errors of a flight study: NED error vectors, the first-order prediction, the recommendation.

The reductions behind :func:`fieldmap.nav.study.run_flight`: :func:`ned_errors` turns the
navigated states into north, east, down position, NED velocity and small-angle attitude errors
against the truth; :func:`gravity_error_along` gives each navigation model's gravity error along
the track and its double time integral (the first-order prediction of the horizontal error);
:func:`summarize` writes the JSON document with the final-error statistics and the recommended
model (the simplest, in :func:`simplicity_order`, whose added error stays small).

Navigation study on a user's flight: what each gravity model costs next to the IMU's errors.

For a :class:`~fieldmap.nav.trajectory.Trajectory` (usually a
:class:`~fieldmap.nav.trajectory.FlightTrajectory`), an IMU spec and a list of navigation gravity
models, :func:`run_flight` propagates, in one batched launch per time block:

* ``imu_only`` runs: J4 navigation on increments synthesized with J4 as the truth — the IMU's
  own errors without any gravity-model error (with an ideal IMU: the replay floor);
* one run per navigation model and draw on increments synthesized under the truth field
  (default EIGEN-6S at full degree) — IMU errors plus the gravity-model error.

The same Monte Carlo draws (biases, noise seeds, Gauss–Markov states) are used in every row, so
``run(model) − run(imu_only)`` isolates the gravity-model error draw by draw.

Time blocks. Synthesis and propagation run in blocks of ``block_s`` seconds: the IMU record of
one block (two increment sets) is synthesized, propagated for every run, and the final states
(position, velocity, attitude, Gauss–Markov biases, baro loop) start the next block. The noise
(sensor white noise, Gauss–Markov bias-instability and baro noise and drift draws) is a
counter-based stream keyed on (run seed, global IMU sample index), so the errors do not depend
on ``block_s``. Memory is bounded by one block's increments plus the decimated error curves,
whatever the flight length.

Errors are reported in the local level frame of the truth: north, east, down position error (m,
from the latitude/longitude/height differences through the radii of curvature), NED velocity
error (m/s) and the small-angle attitude error ψ with C_b^n(nav) = (I − [ψ×]) C_b^n(true) (rad).

First-order prediction. The navigation model's gravity error along the path,
δg = g_model − g_truth (NED), integrated twice in time, predicts the horizontal position error
of a short flight; it neglects the Schuler feedback (−g/R δp: 8 % of the gravity term after
5 min, the whole of it after a quarter Schuler period, 21 min) and the Coriolis coupling.

The error reductions, the prediction and the recommendation live in
:mod:`fieldmap.nav.study` (re-exported here); this module runs the study.

Results of the navigation studies as ``xarray.Dataset`` objects (dims run, time; CF-1.8).

:func:`to_dataset` for the paper's studies (:class:`fieldmap.nav.paper.StudyResult`),
:func:`flight_dataset` for flight studies (:class:`fieldmap.nav.study.FlightResult`); both
are written as NetCDF by :mod:`fieldmap.nav.report` and returned by the results' ``to_dataset``.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fieldmap.durations import seconds
from fieldmap.errors import Advice, InputError, Keyword, Label, Setting
from fieldmap.models.shmodel import SHModel
from fieldmap.nav import sensors
from fieldmap.nav.budget import (
    GRAVITY_DRAWS,
    GravityBudget,
    GravityTerms,
    gravity_budget,
    gravity_error_along,
    recommend,
    simplicity_order,
)
from fieldmap.nav.gravity import table_file
from fieldmap.nav.imu import (
    MAX_SAMPLES,
    Gravitation,
    ImuIncrements,
    ImuSampling,
    load_truth_model,
    sample_count,
    synthesize,
)
from fieldmap.nav.mechanize import NavConfig, dcm_to_quat, quat_to_dcm
from fieldmap.nav.propagator import Propagator, check_mechanization, divergence, final_stats
from fieldmap.nav.trajectory import BoostGlide, Kinematics, Trajectory, geodetic_state

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

    from fieldmap.field.ellipsoid import Ellipsoid
    from fieldmap.nav.covariance import CovarianceResult, CovarianceStudyResult

#: normal navigation models -> the ``normal=`` name of :mod:`fieldmap.field.normal` (the same
#: names: the exact level-ellipsoid field is ``"exact"`` on both sides)
NORMAL_KINDS = {"j2": "j2", "j4": "j4", "j6": "j6", "exact": "exact"}


def check_model_names(names: Any, sh_model: SHModel) -> list[str]:
    """Validate navigation gravity names (``j2 j4 j6 exact sh shN table:FILE auto``).

    Returns the names in lower case (a table's file name as given), ``sh`` as ``sh<lmax>``,
    ``auto`` as :func:`fieldmap.nav.gravity.auto_models` (a model ``auto`` adds appears
    once, also when named besides). Raises
    :class:`InputError` for an unknown name, an unreadable table, or a model named twice
    (``j4,j4``, ``sh,sh200`` with a degree-200 model, one table file under two names).
    """
    from fieldmap.nav.gravity import auto_models, parse_gravity

    given: list = []
    auto: set = set()  # the names "auto" stands for: once each, with the user's own
    for name in names:  # "auto": every normal model and a ladder of SH degrees
        if isinstance(name, str) and name.strip().lower() == "auto":
            given.extend(auto_models(sh_model))
            auto.update(auto_models(sh_model))
        else:
            given.append(name)
    out: list[str] = []
    seen: dict[str, str] = {}  # what makes two names one model (a table's real path) -> name
    for name in given:
        path = table_file(name)
        if path is not None:  # a file name keeps its case
            parse_gravity(name, sh_model)
            key, same = f"table:{path}", os.path.realpath(path)
        else:
            key = str(name).strip().lower()
            parse_gravity(key, sh_model)
            key = same = key if key != "sh" else f"sh{sh_model.lmax}"
        typed = str(name).strip()
        if same in seen:
            if key in auto:
                continue
            what = (
                f"{typed!r} given twice"
                if typed.lower() == seen[same].lower()
                else f"{seen[same]!r} and {typed!r} are the same model"
            )
            raise InputError(f"navigation gravity model {what}: name each model once")
        seen[same] = typed
        out.append(key)
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
            sampling = ImuSampling(self.imu.rate_hz, self.imu.meta["n_gauss"])
            self.extra_sets[nav_truth] = synthesize(
                self.traj, sampling, g, duration=self.imu.duration
            )
        return self.extra_sets[nav_truth]


def build_scenario(
    duration: float = 800.0,
    sampling: ImuSampling | None = None,
    truth: str | SHModel = "eigen-6s",
    truth_lmax: int | None = None,
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
    sampling : ImuSampling, optional
        IMU rate (navigation step 2/rate) and Gauss–Legendre nodes per sample (default
        ``ImuSampling()``: 200 Hz, 3 nodes).
    truth : str or SHModel
        Truth gravity model name or ICGEM path (``fieldmap.models.registry.load_model``), or
        the model itself (e.g. converted to a tide system).
    truth_lmax : int, optional
        Truth degree (default: full).
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
    sampling = ImuSampling() if sampling is None else sampling
    rate_hz = sampling.rate_hz
    for what, v in (("duration", duration), ("output interval", output_dt)):
        if isinstance(v, (str, bytes, bool)) or not np.isfinite(v) or v <= 0:
            raise InputError(f"{what} must be a positive number, got {v!r}")
    steps = sample_count(duration, rate_hz) // 2  # the synthesis's: checked before it runs
    every = output_steps(output_dt, steps, 2.0 / float(rate_hz))
    traj = trajectory or BoostGlide(duration=max(float(duration), 1.0))
    model = load_truth_model(truth, truth_lmax)
    g = Gravitation("sh", model=model, device=device, ellipsoid=traj.frame.ellipsoid)
    imu = synthesize(traj, sampling, g, duration=duration, progress=progress)
    assert isinstance(imu, ImuIncrements)  # one gravitation in, one increment set out
    assert imu.n_samples // 2 == steps
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
        Keyword("output_dt"),
        f": output interval {output_dt:g} s is not a whole number of navigation steps "
        f"({step_s:g} s) dividing the run ({steps * step_s:g} s): use e.g. "
        f"{lo * step_s:g} s or {hi * step_s:g} s",
        param="output_dt",
    )


def propagate(
    sc: Scenario,
    gravity: list[str],
    sets: list[ImuIncrements] | None = None,
    imu_set: Any = None,
    errors: sensors.ErrorDraws | None = None,
    progress: bool = False,
    *,
    client: Any = None,
    runs_per_task: int | None = None,
) -> dict[str, Any]:
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
    from fieldmap.nav.mechanize import dcm_to_quat

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

    def launch(idx: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
        """Propagate the runs ``idx`` (balanced over the CPU chunks)."""
        perm = idx[balanced_order([gravity[i] for i in idx])]
        m = perm.size
        start = {
            "P": np.tile(k0.P_a[0], (m, 1)),
            "V": np.tile(k0.V_a[0], (m, 1)),
            "q": np.tile(dcm_to_quat(k0.C_b_to_a[0]), (m, 1)),
        }
        nav = NavConfig(
            [gravity[i] for i in perm], sh_model=sc.truth_model, imu_set=imu_set[perm],
            errors=None if errors is None else errors.take(perm).kernel_errors(),
            t0=sc.imu.t0, output_every=2 * sc.output_every,
        )  # fmt: skip
        prop = Propagator(
            "lci", start, sc.imu.dt, nav, launch=sc.traj.frame, device=sc.device, client=client
        )
        prop.runs_per_task = runs_per_task
        return perm, prop.propagate(dth, dv, 0)

    if progress and n > 1:
        # several propagators, each a cost-balanced share of the runs: every run is
        # independent (own thread, own noise stream), so the numbers are those of one launch
        from tqdm import tqdm

        from fieldmap.nav.gravity import gravity_cost

        order = np.argsort([-gravity_cost(g, sc.truth_model) for g in gravity], kind="stable")
        parts = [order[j :: min(n, 8)] for j in range(min(n, 8))]
        done = [launch(p) for p in tqdm(parts, desc="navigation runs", unit="launch")]
        perm = np.concatenate([p for p, _ in done])
        res: dict[str, Any] = {k: np.concatenate([r[k] for _, r in done]) for k in ("P", "V")}
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
    from fieldmap.nav.frames import C_n_to_e

    r = sc.truth.r_e
    lat, lon, _ = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], sc.traj.frame.ellipsoid)
    C_a_e = np.swapaxes(sc.traj.frame.C_e_to_a(sc.t_out), -1, -2)
    M = np.swapaxes(C_n_to_e(lat, lon), -1, -2) @ C_a_e  # C_a^n (n_out, 3, 3)
    return np.einsum("tij,rtj->rti", M, dP)


def balanced_order(gravity: list[str], parts: int | None = None) -> np.ndarray:
    """Order of the runs that gives every CPU chunk of the launch a similar cost.

    ``fieldmap._warp.launch_chunked`` splits the threads into contiguous pieces, one per core;
    runs are sorted by estimated cost ((N+1)² per step for SH degree N, 1 for the normal models)
    and dealt round-robin into the pieces.
    """
    from fieldmap._warp import chunks, cpu_workers
    from fieldmap.nav.gravity import gravity_cost

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


def initial_state(
    traj: Trajectory,
    frame: str,
    lat0: np.ndarray,
    lon0: np.ndarray,
    h0: np.ndarray,
    v0: np.ndarray,
    C0: np.ndarray,
    n: int,
) -> dict[str, np.ndarray]:
    """Start state of ``n`` runs at the truth's first epoch (NED: llh (rad), v, q; LCI: P, V, q)."""
    st: dict[str, np.ndarray] = {}
    if frame == "ned":
        st.update(
            llh=np.tile([np.radians(lat0[0]), np.radians(lon0[0]), h0[0]], (n, 1)),  # rad, m
            v=np.tile(v0[0], (n, 1)),
            q=np.tile(dcm_to_quat(C0[0]), (n, 1)),
        )
    else:
        k = traj.kinematics([0.0])
        st.update(
            P=np.tile(k.P_a[0], (n, 1)),
            V=np.tile(k.V_a[0], (n, 1)),
            q=np.tile(dcm_to_quat(k.C_b_to_a[0]), (n, 1)),
        )
    return st


def geodetic_outputs(launch: Any, out: dict[str, Any]) -> dict[str, Any]:
    """Turn the stored states of :meth:`~fieldmap.nav.propagator.Propagator.propagate` into NED.

    Returns ``lat``, ``lon`` (degrees), ``h`` (m), ``v`` (NED, m/s) and ``C`` (C_b^n), one row
    per run; LCI states are carried from the a-frame (``launch``) to the Earth.
    """
    if "llh" not in out and "lat" in out:
        return {
            "lat": out["lat"], "lon": out["lon"], "h": out["h"], "v": out["v"],
            "C": quat_to_dcm(out["q"]),
        }  # fmt: skip
    from fieldmap.field.frames import ecef_to_geodetic
    from fieldmap.nav.frames import C_n_to_e

    fr = launch
    t = out["t"]
    n = out["P"].shape[0]
    # a_state_to_ecef gives the Earth-relative velocity (the inertial one less ω × r) already
    r_e, v_e = fr.a_state_to_ecef(out["P"].reshape(-1, 3), out["V"].reshape(-1, 3), np.tile(t, n))
    lat, lon, h = ecef_to_geodetic(r_e[:, 0], r_e[:, 1], r_e[:, 2], fr.ellipsoid)
    C_n_e = C_n_to_e(lat, lon)
    v_ned = np.einsum("nji,nj->ni", C_n_e, v_e)
    C_b_a = quat_to_dcm(out["q"]).reshape(-1, 3, 3)
    C_a_e = np.swapaxes(fr.C_e_to_a(np.tile(t, n)), -1, -2)
    C_b_n = np.swapaxes(C_n_e, -1, -2) @ C_a_e @ C_b_a
    shp = (n, t.size)
    return {
        "lat": lat.reshape(shp),
        "lon": lon.reshape(shp),
        "h": h.reshape(shp),
        "v": v_ned.reshape(shp + (3,)),
        "C": C_b_n.reshape(shp + (3, 3)),
    }


def ned_errors(
    lat: np.ndarray,
    lon: np.ndarray,
    h: np.ndarray,
    v: np.ndarray,
    C: np.ndarray,
    truth: tuple[np.ndarray, ...],
    ell: Ellipsoid,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """NED position, velocity and small-angle attitude errors against the truth tuple."""
    tl, tn, th, tv, tC = truth
    la = np.radians(tl)
    s = np.sin(la)
    w = 1.0 - ell.e2 * s * s
    R_E = ell.a / np.sqrt(w)
    R_N = ell.a * (1.0 - ell.e2) / w**1.5
    dlon = (lon - tn + 180.0) % 360.0 - 180.0
    dpos = np.stack(
        [
            np.radians(lat - tl) * (R_N + th),
            np.radians(dlon) * (R_E + th) * np.cos(la),
            -(h - th),
        ],
        -1,
    )
    dvel = v - tv
    E = C @ np.swapaxes(tC, -1, -2)  # ≈ I − [ψ×]
    datt = 0.5 * np.stack(
        [E[..., 2, 1] - E[..., 1, 2], E[..., 0, 2] - E[..., 2, 0], E[..., 1, 0] - E[..., 0, 1]], -1
    )
    return dpos, dvel, -datt


#: most track points at which the truth's commission σ is evaluated (linear in time between)
SIGMA_POINTS = 2000


def truth_sigma_along(
    track: Any, t: np.ndarray, model: SHModel, ell: Ellipsoid
) -> np.ndarray | None:
    """Commission σ of the truth's gravity along the track, NED (n, 3) in m/s², or None.

    From the truth model's coefficient σ (:func:`fieldmap.field.commission.commission_sigma`,
    diagonal propagation); None for a model without σ. At most :data:`SIGMA_POINTS` points
    are evaluated, evenly spaced in the output index, and interpolated linearly in time
    between them (σ varies on the scale of the model's shortest wavelength, tens of km).
    """
    if model.sigma_c is None or model.sigma_s is None:
        return None
    from fieldmap.field.commission import MGAL, commission_sigma

    n = len(t)
    idx = np.unique(np.linspace(0, n - 1, min(n, SIGMA_POINTS)).round().astype(int))
    s = commission_sigma(
        track[idx, 0], track[idx, 1], track[idx, 2], model=model, quantity="disturbance",
        ellipsoid=ell,
    )  # fmt: skip
    ned = s[:, [1, 0, 2]] / MGAL  # east, north, up -> north, east, down (σ has no sign)
    if idx.size == n:
        return ned
    return np.stack([np.interp(t, t[idx], ned[:, k]) for k in range(3)], axis=-1)


def summarize(
    dpos: np.ndarray,
    dvel: np.ndarray,
    run_models: Any,
    rows: list[str],
    fraction: Any,
    diverged: list[dict[str, Any]],
    meta: dict[str, Any],
    budget: GravityBudget | None = None,
) -> dict[str, Any]:
    """Build the JSON document: final errors per row, the gravity budget, a recommendation.

    With a ``budget`` (:func:`fieldmap.nav.budget.gravity_budget`) each model's ``gravity``
    entry gives its contribution to the final horizontal and vertical error, term by term
    (model difference, omission, commission; RMS over the budget's draws), and the
    recommendation is the simplest model whose whole gravity contribution stays below
    ``fraction`` × the IMU-only horizontal error, naming the term that dominates. Without one,
    the Monte Carlo ``added_horizontal_error_m`` decides (the difference of two nonlinear runs
    per draw, reported in both cases).
    """
    run_models = np.array(run_models)
    fin = dpos[:, -1]
    doc: dict[str, Any] = {"meta": meta, "models": {}, "fraction": fraction}
    ref = fin[run_models == "imu_only"]
    imu_h = float(np.sqrt(np.mean(np.sum(ref[:, :2] ** 2, -1))))
    bad_models = {d["model"] for d in diverged}
    for r in rows:
        sel = run_models == r
        f = fin[sel]
        entry = {
            "final_position_error_m": final_stats(np.linalg.norm(f, axis=-1)),
            "final_horizontal_error_m": final_stats(np.hypot(f[:, 0], f[:, 1])),
            "final_vertical_error_m": final_stats(np.abs(f[:, 2])),
            "final_north_error_m": final_stats(f[:, 0]),
            "final_east_error_m": final_stats(f[:, 1]),
            "final_down_error_m": final_stats(f[:, 2]),
            "final_velocity_error_m_s": final_stats(np.linalg.norm(dvel[sel, -1], axis=-1)),
            "diverged": r in bad_models,
        }
        if r != "imu_only":
            d = f - ref  # same draws, same order
            entry["added_horizontal_error_m"] = float(np.sqrt(np.mean(np.sum(d[:, :2] ** 2, -1))))
            entry["added_vertical_error_m"] = float(np.sqrt(np.mean(d[:, 2] ** 2)))
            if budget is not None:
                entry["gravity"] = budget.summary(r)
        doc["models"][r] = entry
    doc["imu_only_horizontal_error_m"] = imu_h
    order = simplicity_order([r for r in rows if r != "imu_only"])
    recommend(doc, order, imu_h, fraction, budget is not None, meta.get("truth_degree", "L"))
    doc["diverged"] = list(diverged)
    return doc


#: default altitude aiding switches to baro for flights longer than this (s)
BARO_AFTER_S = 900.0


@dataclass(frozen=True)
class BaroSpec:
    """Baro altimeter error model and loop time constant of the altitude aiding.

    ``bias_m`` 1σ constant error per run (pressure-altitude offset), ``noise_m`` white noise per
    baro sample at ``rate_hz``, ``drift_m``/``drift_tau_s`` a Gauss–Markov drift (weather), the
    third-order loop with a triple pole at −1/``loop_tau_s``. Defaults: 5 m, 0.5 m at 10 Hz,
    3 m over 1 h, τ = 100 s (a MEMS barometer: e.g. Bosch BMP388 absolute accuracy ±0.5 hPa
    ≈ ±4 m, relative noise ~0.03 hPa ≈ 0.25 m).
    """

    bias_m: float = 5.0
    noise_m: float = 0.5
    rate_hz: float = 10.0
    drift_m: float = 3.0
    drift_tau_s: float = 3600.0
    loop_tau_s: float = 100.0


@dataclass
class FlightResult:
    """Error curves and summary of :func:`run_flight`.

    ``t`` (n_out,) s; ``labels`` run labels (``imu_only/3``, ``j2/3`` …), ``models`` the
    navigation-model row of each run (``imu_only`` for the reference), ``draw`` its draw;
    ``dpos``, ``dvel``, ``datt`` (n_runs, n_out, 3) NED position (m), velocity (m/s) and
    attitude (rad) errors; ``track`` lat, lon, h (n_out, 3) of the truth; ``dg`` per model
    (n_out, 3) NED gravity error (m/s²) and ``predicted`` (n_out, 2) its double integral
    (m, north/east); ``summary`` the JSON document; ``diverged`` one ``{"run", "model",
    "time_s"}`` per diverged run (:func:`fieldmap.nav.propagator.divergence`).
    """

    t: np.ndarray
    labels: list
    models: list
    draw: np.ndarray
    dpos: np.ndarray
    dvel: np.ndarray
    datt: np.ndarray
    track: np.ndarray
    dg: dict
    predicted: dict
    summary: dict
    diverged: list = field(default_factory=list)
    #: commission σ of the truth gravity along the track, NED (n_out, 3) m/s²; None without σ
    dg_sigma: Any = None
    #: each gravity term's position error through the linear error model (nav.budget)
    budget: GravityBudget | None = None
    #: GNSS-aided: the filter's horizontal σ of the IMU-only error (n_out,) m; else None
    sigma_h: Any = None
    #: GNSS-aided: the filter's linear covariance, σ(t) per error source; else None
    covariance: CovarianceResult | None = None

    def to_dataset(self) -> xr.Dataset:
        """Return the results as an ``xarray.Dataset`` over (run, time) with units (CF-1.8)."""
        return flight_dataset(self)

    def plot(self, kind: str = "errors") -> Figure:
        """Draw the study as a :class:`matplotlib.figure.Figure` (``fig.savefig("f.png")``).

        Parameters
        ----------
        kind : {"errors", "budget", "track"}
            ``"errors"`` (default): the position errors over time per navigation model, the
            gravity error along the track and the error each model adds, the recommendation
            as the caption (``navsim_flight.png``); ``"budget"``: the error budget, one bar per
            error source, sorted, the gravity terms (a) model difference, (b) omission,
            (c) commission beside the IMU's, at the flight's end or at the end of the worst
            GNSS outage (``navsim_flight_budget.png``); ``"track"``: the ground track
            (``navsim_flight_track.png`` draws it over the truth's disturbance).
            See :mod:`fieldmap.nav.plots`.
        """
        from fieldmap.nav.plots import flight_figure

        return flight_figure(self, kind)


def _steps_per_output(output_dt: float, rate_hz: float) -> int:
    k = output_dt * rate_hz
    every = int(round(k))
    if every < 1 or abs(k - every) > 1e-9 * max(k, 1.0):
        raise InputError(
            f"output interval {output_dt:g} s is not a whole number of IMU samples at "
            f"{rate_hz:g} Hz",
            param="output_dt",
        )
    return every


def default_output_dt(duration: float) -> float:
    """About 3600 stored states per run, at least one per second. Units: s."""
    return float(max(1.0, np.ceil(duration / 3600.0)))


#: a compensation table must hold the flight's path this far above and below it (m): room for
#: the navigator's own height error
TABLE_HEIGHT_MARGIN = 50.0


def check_tables_cover(names: Any, traj: Any, duration: float) -> None:
    """Refuse (one line) a compensation table that does not cover the flight's path.

    The path is checked every second (and at its end), with 50 m of height margin each way for
    the navigator's own height error.
    """
    files = [f for f in (table_file(m) for m in names) if f is not None]
    if not files:
        return
    from fieldmap.products.tables.model import load_table, outside_message

    if len(set(files)) > 1:  # as the propagator would, but before any work
        raise InputError(
            f"one compensation table per launch, got {len(set(files))}: {', '.join(files)}"
        )
    t = np.unique(np.r_[np.arange(0.0, duration, 1.0), duration])
    lat, lon, h = (np.asarray(v, dtype=np.float64) for v in traj.geodetic(t))
    for f in files:
        tab = load_table(f)
        for dh in (-TABLE_HEIGHT_MARGIN, TABLE_HEIGHT_MARGIN):
            inside = tab.contains(lat, lon, h + dh)
            if not np.all(inside):
                k = int(np.flatnonzero(~inside)[0])
                raise InputError(
                    f"table:{f} does not cover the flight at t = {t[k]:g} s: "
                    + outside_message(tab, lat[k], lon[k], h[k] + dh)
                )


@dataclass(frozen=True)
class FlightStudy:
    """A flight study, validated once: the flight, the IMU, the navigation models and the run.

    Python users and ``fieldmap navsim --trajectory/--route`` build it alike; :func:`run_flight`
    and the layers below trust it. Construction refuses bad input in one line
    (:class:`~fieldmap.errors.InputError`) and resolves what the options leave open (the
    trajectory, the IMU spec, the truth model, the checked model names, the duration, the
    altitude aiding, the output interval, the time blocks), before any work.

    Parameters
    ----------
    flight : Trajectory, FlightSamples, path, str or sequence of (lat, lon, h)
        The flight: a trajectory (e.g. :class:`~fieldmap.nav.trajectory.FlightTrajectory`), the
        samples of :func:`~fieldmap.nav.trajectory.read_flight` or
        :func:`~fieldmap.nav.trajectory.route_flight`, a flight log file (a path: CSV, ADS-B
        export, GPX, NMEA, IGC or NetCDF, read and conditioned by
        :func:`fieldmap.nav.logs.load_flight` with its defaults, the truth model's geoid for
        MSL heights, as ``fieldmap navsim --trajectory FILE``), or a route (``"lat,lon,h;..."``
        or waypoints; degrees, degrees, m) flown at ``speed_mps``. A string of numbers,
        commas and semicolons is a route; any other string is a file.
    imu : str or ImuErrorSpec
        A preset name (``ideal consumer industrial tactical navigation strategic
        table2-groupN table4``), an IMU TOML file, or a spec (:mod:`fieldmap.nav.sensors`).
    models : str or sequence of str
        Navigation gravity models (``"j2,sh18"`` or ``["j2", "sh18"]``: j2 j4 j6 exact sh shN
        table:FILE auto; ``normal``, the deprecated name of ``exact``, is read as ``exact``
        with a ``DeprecationWarning``).
    draws : int
        Monte Carlo draws, 1..:data:`fieldmap.limits.MAX_DRAWS` (an ideal IMU flies one).
    seed : int
        Seed of the draws (>= 0).
    rate_hz : float
        IMU rate. Units: Hz.
    frame : {"ned", "lci"}
        Mechanization: Earth-relative NED or the launch-centred inertial frame (first sample).
    altitude_aiding : {"auto", "none", "baro"}
        Baro loop on the vertical channel (NED only); ``auto``: baro for flights over 15 min.
    baro : BaroSpec
        Baro error model and loop time constant.
    truth : str or SHModel
        Truth gravity model (bundled name, ICGEM file or a loaded model).
    truth_lmax : int, optional
        Truth degree (default: the model's).
    truth_evaluation : {"interpolated", "full"}
        ``interpolated`` (default): the truth disturbance on a time grid along the path plus
        the exact normal field at every quadrature node
        (:class:`fieldmap.nav.gravity.TrackGravitation`, its measured interpolation error in
        the summary); ``full``: the SH model at every node.
    gravity_rate_hz : float or "full", optional
        SH navigation models: rate of the disturbance update (the exact normal field every
        step; :func:`fieldmap.nav.gravity.gravity_update_every`). None (default): the slowest
        rate whose extrapolation error stays below 0.1 % of the disturbance; "full": the
        whole model every step.
    n_gauss : int
        Gauss–Legendre nodes per IMU sample in the synthesis, 1..16.
    duration : float or str, optional
        Part of the flight to simulate (default all). Units: s, or a string with its unit
        (``"5min"``, ``"1.5h"``: :func:`fieldmap.durations.seconds`).
    output_dt : float or str, optional
        Interval of the stored errors (default :func:`default_output_dt`). Units: s, or a
        string with its unit.
    block_s : float
        Length of a synthesis/propagation block (memory bound). Units: s.
    fraction : float
        ``recommended_model``: the simplest model whose added horizontal error (RMS over draws)
        stays below ``fraction`` × the IMU-only horizontal error.
    speed_mps : float, optional
        Ground speed of a ``flight`` given as a route (flown into the trajectory: None once
        the study is built). Units: m/s.
    imu_name : str, optional
        Label of the IMU in the outputs (default: the preset name, the TOML file's ``name``,
        or ``"custom"`` for a spec).
    omission_model : {"tscherning-rapp", "kaula", "fitted"} or None
        Degree-variance model of the field above the truth's degree (the omission term of the
        gravity budget, :mod:`fieldmap.nav.budget`); None or ``"none"``: left out (said in
        the summary).
    commission : bool, optional
        Realise the truth model's coefficient errors (the commission term). None (default): when
        the truth carries coefficient σ; True with a truth without σ is refused.
    method : {"monte-carlo", "covariance"}
        ``monte-carlo``: strapdown runs of every model and IMU draw; ``covariance``: linear
        covariance analysis, σ(t) per error source in one pass
        (:func:`fieldmap.nav.covariance.covariance_study`; ``draws`` then unused).
    gnss : GnssSpec, optional
        GNSS aiding through outages (:class:`fieldmap.nav.aiding.GnssSpec`: fix rate and noise,
        outages; NED only): a loosely coupled Kalman filter with feedback. None: free inertial
        (with the altitude aiding).

    Examples
    --------
    >>> study = FlightStudy(
    ...     "49,2.55,10000;48.5,4,10000", speed_mps=230, imu="tactical",
    ...     models="j2,sh12", draws=2, duration=300,
    ... )
    >>> study.models, study.n_draws, study.aiding, study.duration_s
    (('j2', 'sh12'), 2, 'none', 300.0)
    """

    flight: Any
    imu: Any = "ideal"
    models: Any = ("j2", "j4", "j6", "exact", "sh18", "sh200")
    draws: int = 20
    seed: int = 0
    rate_hz: float = 200.0
    frame: str = "ned"
    altitude_aiding: str = "auto"
    baro: BaroSpec = BaroSpec()
    truth: Any = "eigen-6s"
    truth_lmax: int | None = None
    truth_evaluation: str = "interpolated"
    gravity_rate_hz: float | str | None = None
    n_gauss: int = 3
    duration: float | str | None = None
    output_dt: float | str | None = None
    block_s: float = 600.0
    fraction: float = 0.1
    speed_mps: float | None = None
    imu_name: str | None = None
    omission_model: str | None = "tscherning-rapp"
    commission: bool | None = None
    method: str = "monte-carlo"
    gnss: Any = None
    # resolved at construction (read-only): the altitude aiding ("baro"/"none"), the flown
    # duration and the stored-state interval (s), the samples per output, flown and per block,
    # and the draws flown
    aiding: str = field(init=False)
    duration_s: float = field(init=False)
    output_dt_s: float = field(init=False)
    every: int = field(init=False)
    n_samples: int = field(init=False)
    per_block: int = field(init=False)
    n_draws: int = field(init=False)
    gravity_every: int = field(init=False)
    gravity_terms: GravityTerms = field(init=False)
    #: a flight given as a log file: what its conditioning did
    #: (:class:`~fieldmap.nav.logs.report.ConditionedFlight`, its ``report`` lands in the
    #: summary's ``conditioning``); None for any other flight
    conditioning: Any = field(init=False)

    def __post_init__(self) -> None:
        from fieldmap.limits import MAX_DRAWS
        from fieldmap.nav.trajectory import FlightSamples, FlightTrajectory, route_flight

        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        flight, truth_model = self.flight, None
        put("conditioning", None)
        if isinstance(flight, os.PathLike) or (isinstance(flight, str) and not _is_route(flight)):
            if self.speed_mps is not None:
                raise InputError(
                    Keyword("speed_mps"),
                    f" applies to a route flight, not to the flight file {flight}",
                    param="speed_mps",
                )
            from fieldmap.nav.logs import load_flight

            # the truth's geoid makes a log's MSL heights ellipsoidal
            truth_model = load_truth_model(self.truth, self.truth_lmax)
            flight, conditioning = load_flight(flight, model=truth_model)
            put("conditioning", conditioning)
        elif isinstance(flight, (str, list, tuple, np.ndarray)):
            if self.speed_mps is None:
                raise InputError(
                    "a route flight needs its ground speed", Label("speed_mps"), param="speed_mps"
                )
            flight = route_flight(flight, self.speed_mps)
            put("speed_mps", None)  # flown into the trajectory: dataclasses.replace works
        elif self.speed_mps is not None:
            raise InputError(Keyword("speed_mps"), " applies to a route flight", param="speed_mps")
        if isinstance(flight, FlightSamples):
            flight = FlightTrajectory(flight)
        if not isinstance(flight, Trajectory):
            raise InputError(
                Keyword("flight"),
                " must be a Trajectory, FlightSamples, a log file or a route, got "
                f"{type(flight).__name__}",
                param="flight",
            )
        put("flight", flight)
        spec: sensors.ImuErrorSpec
        if isinstance(self.imu, sensors.ImuErrorSpec):
            label, spec = "custom", self.imu
        elif isinstance(self.imu, (str, os.PathLike)):
            if not str(self.imu).strip():
                raise InputError(
                    Keyword("imu"),
                    f" is empty: give a preset ({', '.join(sensors.PRESETS)}) or an IMU .toml file",
                    param="imu",
                )
            label, spec = sensors.load_imu(self.imu)
        else:
            raise InputError(
                Keyword("imu"),
                f" must be a preset name, a .toml file or an ImuErrorSpec, got "
                f"{type(self.imu).__name__}",
                param="imu",
            )
        put("imu", spec)
        put("imu_name", label if self.imu_name is None else str(self.imu_name))
        if self.truth_evaluation not in ("interpolated", "full"):
            raise InputError(
                Keyword("truth_evaluation"),
                f" must be 'interpolated' or 'full', got {self.truth_evaluation!r}",
                param="truth_evaluation",
            )
        frame = check_mechanization(self.frame)
        put("frame", frame)
        aiding = str(self.altitude_aiding).lower()
        if aiding not in ("auto", "none", "baro"):
            raise InputError(
                Keyword("altitude_aiding"),
                f" must be 'auto', 'none' or 'baro', got {self.altitude_aiding!r}",
                param="altitude_aiding",
            )
        if self.method not in ("monte-carlo", "covariance"):
            raise InputError(
                Keyword("method"),
                f" must be 'monte-carlo' or 'covariance', got {self.method!r}",
                param="method",
            )
        if not 0 < self.fraction < 1:
            raise InputError(
                Keyword("fraction"), f" must be in (0, 1), got {self.fraction}", param="fraction"
            )
        for name in ("rate_hz", "block_s"):
            v = getattr(self, name)
            if isinstance(v, (str, bool)) or not np.isfinite(v) or v <= 0:
                raise InputError(
                    Keyword(name), f" must be a positive number, got {v!r}", param=name
                )
        n_draws = 1 if spec.is_ideal else self.draws
        if isinstance(self.draws, bool) or not 1 <= int(self.draws) <= MAX_DRAWS:
            raise InputError(
                Keyword("draws"), f" must be within 1..{MAX_DRAWS}, got {self.draws}", param="draws"
            )
        if isinstance(self.seed, bool) or int(self.seed) < 0:
            raise InputError(Keyword("seed"), f" must be >= 0, got {self.seed}", param="seed")
        if not 1 <= int(self.n_gauss) <= 16:
            raise InputError(
                Keyword("n_gauss"), f" must be in 1..16, got {self.n_gauss}", param="n_gauss"
            )
        put("n_draws", int(n_draws))
        model = (
            load_truth_model(self.truth, self.truth_lmax) if truth_model is None else truth_model
        )
        put("truth", model)
        names = self.models
        if isinstance(names, str):  # "j2,sh18" or "j2 sh18", as the CLI takes them
            names = names.replace(",", " ").split()
        put("models", tuple(check_model_names(names, model)))
        traj = self.flight
        duration = (
            traj.duration if self.duration is None else seconds(self.duration, param="duration")
        )
        if not 0 < duration <= traj.duration * (1 + 1e-12):
            raise InputError(
                Keyword("duration"),
                f" {duration:g} s does not fit the flight ({traj.duration:g} s)",
                param="duration",
            )
        put("duration_s", duration)
        try:
            check_tables_cover(self.models, traj, duration)
        except InputError as exc:
            raise InputError(Keyword("models"), f": {exc}", param="models") from None
        if aiding == "auto":
            aiding = "baro" if duration > BARO_AFTER_S and frame == "ned" else "none"
        check_mechanization(frame, baro=aiding == "baro")
        put("aiding", aiding)
        rate_hz = self.rate_hz
        output_dt = (
            default_output_dt(duration)
            if self.output_dt is None
            else seconds(self.output_dt, param="output_dt")
        )
        per_fix = _check_gnss(self, duration, frame)
        if per_fix and self.output_dt is None:  # the stored states hold every fix
            per_out = next(
                k
                for k in range(1, per_fix + 1)
                if per_fix % k == 0 and per_fix / k <= output_dt * rate_hz + 1e-9
            )
            output_dt = per_fix / per_out / rate_hz
        put("output_dt_s", output_dt)
        every = _steps_per_output(output_dt, rate_hz)
        if frame == "lci" and every % 2:
            raise InputError(
                Setting("frame", "lci"),
                " steps two IMU samples at a time: the output interval "
                f"{output_dt:g} s must be an even number of samples at {rate_hz:g} Hz",
                param="frame",
            )
        put("every", every)
        if per_fix and per_fix % every:
            raise InputError(
                f"output interval {output_dt:g} s: GNSS fixes {per_fix / rate_hz:g} s apart "
                "must fall on stored states (a whole number of output intervals)",
                param="output_dt",
            )
        unit = every * (2 if every % 2 else 1)  # whole outputs, an even number of samples
        n_total = int(np.floor(duration * rate_hz / unit + 1e-9)) * unit
        if n_total < unit:
            raise InputError(
                f"flight of {duration:g} s is shorter than one output interval ({output_dt:g} s)"
            )
        put("n_samples", n_total)
        if per_fix:  # a block holds whole intervals between fixes
            unit = int(np.lcm(unit, per_fix))
        per_block = max(unit, int(self.block_s * rate_hz) // unit * unit)
        # a block's IMU synthesis is bounded (sample_count): refused here, before any work
        block = min(per_block, n_total) / float(rate_hz)
        if block * rate_hz > MAX_SAMPLES:
            raise InputError(
                f"a block of {block:g} s at {rate_hz:g} Hz is {block * rate_hz:.3g} IMU samples, "
                f"more than {MAX_SAMPLES}",
                Advice(": lower ", Keyword("rate_hz"), " or ", Keyword("block_s")),
                param="block_s",
            )
        sample_count(block, rate_hz)
        put("per_block", per_block)
        from fieldmap.nav.gravity import gravity_update_every, parse_gravity

        sh_deg = max((parse_gravity(m, model)[1] for m in self.models), default=0)
        g_every = gravity_update_every(traj, sh_deg, rate_hz, self.gravity_rate_hz) if sh_deg else 1
        put("gravity_every", g_every)
        put("gravity_terms", _gravity_terms(self, model, int(n_draws)))


def _check_gnss(study: FlightStudy, duration: float, frame: str) -> int:
    """Validate the GNSS aiding of a study; return the IMU samples between fixes (0: none)."""
    g = study.gnss
    if g is None:
        return 0
    from fieldmap.nav.aiding import GnssSpec

    if not isinstance(g, GnssSpec):
        raise InputError(
            Keyword("gnss"), f" must be a GnssSpec or None, got {type(g).__name__}", param="gnss"
        )
    if frame != "ned":
        raise InputError("GNSS aiding needs ", Setting("frame", "ned"), param="frame")
    g.check_flight(duration, float(study.rate_hz))
    return int(round(study.rate_hz / g.rate_hz))


def _gravity_terms(study: FlightStudy, model: SHModel, n_draws: int) -> GravityTerms:
    """Validate and resolve the omission and commission options of a study."""
    kind = study.omission_model
    omission = None
    if kind is not None and str(kind).strip().lower() != "none":
        from fieldmap.field.omission import Omission

        omission = Omission(int(model.lmax), kind=str(kind).strip().lower(), model=model)
    comm = study.commission
    if comm not in (None, True, False):
        raise InputError(
            Keyword("commission"), f" must be True, False or None, got {comm!r}", param="commission"
        )
    if comm is None:
        comm = model.has_sigma
    elif comm and not model.has_sigma:
        raise InputError(
            Keyword("commission"),
            f": the truth model {model.name} carries no coefficient standard deviations",
            param="commission",
        )
    return GravityTerms(omission, bool(comm), max(n_draws, GRAVITY_DRAWS), int(study.seed))


def run_flight(
    study: FlightStudy,
    *,
    device: str | None = None,
    client: Any = None,
    progress: bool = False,
) -> FlightResult | CovarianceStudyResult:
    """Fly a :class:`FlightStudy`: each gravity model and IMU draw; errors, δg, a recommendation.

    Parameters
    ----------
    study : FlightStudy
        The study (validated when it was built).
    device : str, optional
        Warp device.
    client : dask.distributed.Client, optional
        Propagate groups of runs as tasks on this cluster (the same bits; default: here).
    progress : bool
        tqdm progress bar over the time blocks.

    Returns
    -------
    FlightResult or CovarianceStudyResult
        The Monte Carlo's runs, or (``study.method == "covariance"``) the covariance analysis's
        σ(t) per source (:class:`fieldmap.nav.covariance.CovarianceStudyResult`).

    Examples
    --------
    Twenty seconds of a route at 230 m/s with an ideal IMU, navigating with J4 gravity (a
    degree-10 truth, to be quick):

    >>> import fieldmap
    >>> study = fieldmap.FlightStudy(
    ...     "49,2.55,10000;48.9,2.9,10000", speed_mps=230, models="j4", draws=1,
    ...     duration=20, rate_hz=20, truth_lmax=10, output_dt=2,
    ... )
    >>> res = fieldmap.run_flight(study)
    >>> float(res.t[-1]), res.dpos.shape  # s; (runs, stored states, north-east-down)
    (20.0, (2, 11, 3))
    """
    if not isinstance(study, FlightStudy):
        raise TypeError(
            f"run_flight() takes a FlightStudy, got {type(study).__name__}: pass "
            "run_flight(FlightStudy(trajectory, ...))"
        )
    if study.method == "covariance":
        if client is not None:
            raise InputError("a covariance study runs here: client= is for the Monte Carlo")
        from fieldmap.nav.covariance import covariance_study

        res: FlightResult | CovarianceStudyResult = covariance_study(study, device)
    else:
        res = _fly(study, device, client, progress)
    if study.conditioning is not None:  # a log file: what was done to it, as navsim writes it
        res.summary["conditioning"] = study.conditioning.report
    return res


def _is_route(text: str) -> bool:
    """Tell a route (``"47,8,500;47.3,8.3,1000"``: numbers and separators) from a file name."""
    return bool(text.strip()) and set(text) <= set("0123456789.,;+-eE \t\n")


def _fly(study: FlightStudy, device: str | None, client: Any, progress: bool) -> FlightResult:
    """Fly the study's runs block by block (``study`` is trusted: validated when built)."""
    traj = study.flight
    imu = study.imu
    model = study.truth
    names = list(study.models)
    frame, aiding, baro = study.frame, study.aiding, study.baro
    rate_hz, seed, n_gauss = study.rate_hz, study.seed, study.n_gauss
    sampling = ImuSampling(rate_hz, n_gauss)
    every, n_total, per_block = study.every, study.n_samples, study.per_block
    n_draws = study.n_draws
    err1 = sensors.draw(imu, n_draws, seed=seed)
    rows = ["imu_only"] + names
    n_runs = n_draws * len(rows)
    err = err1.repeat(len(rows))
    grav = [("j4" if r == "imu_only" else r) for r in rows for _ in range(n_draws)]
    imu_set = np.array([1 if r == "imu_only" else 0 for r in rows for _ in range(n_draws)])

    perm = balanced_order(grav)
    inv = np.argsort(perm)
    ell = traj.frame.ellipsoid
    dt = 1.0 / float(rate_hz)
    g_truth: Any
    if study.truth_evaluation == "full":
        g_truth = Gravitation("sh", model=model, device=device, ellipsoid=ell)
    else:
        from fieldmap.nav.gravity import TrackGravitation

        g_truth = TrackGravitation(model, traj, ellipsoid=ell, device=device)
    g_ref = Gravitation("j4", device=device, ellipsoid=ell)  # the navigator's J4 (same ellipsoid)

    # start state (truth at t = 0); runs in a cost-balanced order (perm), results put back
    lat0, lon0, h0, v0, C0 = geodetic_state(traj, [0.0])
    kerr = err.take(perm).kernel_errors()
    aid = None
    if aiding == "baro":
        from fieldmap.nav.mechanize import Baro, baro_gains

        rng_baro = np.random.default_rng(seed + 1)
        baro_bias = np.tile(baro.bias_m * rng_baro.standard_normal(n_draws), len(rows))[perm]
        baro_drift0 = np.tile(baro.drift_m * rng_baro.standard_normal(n_draws), len(rows))[perm]
        k1, k2, k3 = baro_gains(baro.loop_tau_s, ell)
        noise = baro.noise_m * np.sqrt(rate_hz / baro.rate_hz)
        aid = Baro(
            np.empty((0, 0)), k1, k2, k3, bias=baro_bias, noise=noise,
            gm_sigma=baro.drift_m, gm_tau=baro.drift_tau_s,
            state=np.stack([np.zeros(n_runs), baro_drift0, np.zeros(n_runs)], -1),
        )  # fmt: skip
    g_every = study.gravity_every
    nav = NavConfig(
        [grav[i] for i in perm], sh_model=model, ellipsoid=ell, imu_set=imu_set[perm],
        errors=kerr, output_every=every, baro=aid, gravity_every=g_every,
    )  # fmt: skip
    prop = Propagator(
        frame, initial_state(traj, frame, lat0, lon0, h0, v0, C0, n_runs), dt, nav,
        launch=traj.frame if frame == "lci" else None, device=device, client=client,
    )  # fmt: skip

    filt = None
    if study.gnss is not None:
        from fieldmap.nav.aiding import FeedbackFilter
        from fieldmap.nav.covariance import covariance_analysis

        t_grid = every * dt * np.arange(n_total // every + 1)
        cov = covariance_analysis(study, t_grid)
        per_fix = int(round(rate_hz / study.gnss.rate_hz))
        draw_of_run = np.tile(np.arange(n_draws), len(rows))[perm]
        filt = FeedbackFilter(cov.design, study.gnss, draw_of_run, seed,
                              (dt, every, per_fix, ell))  # fmt: skip

        def truth_at(t: np.ndarray) -> tuple:
            k = traj.kinematics(t)
            C_b_e = np.swapaxes(traj.frame.C_e_to_a(t), -1, -2) @ k.C_b_to_a
            return k.r_e[0], k.v_e[0], C_b_e[0]

    t_list: list[float] = [0.0]
    outs: dict[str, list[np.ndarray]] = {"lat": [], "lon": [], "h": [], "v": [], "C": []}
    starts = range(0, n_total, per_block)
    if progress:
        from tqdm import tqdm

        starts = tqdm(starts, desc="flight blocks", unit="block")
    secs = {"synthesis": 0.0, "propagation": 0.0}
    for s0 in starts:
        nb = min(per_block, n_total - s0)
        c0 = time.perf_counter()
        sets = cast(
            list,
            synthesize(traj, sampling, [g_truth, g_ref], duration=nb * dt, sample0=s0),
        )
        c1 = time.perf_counter()
        secs["synthesis"] += c1 - c0
        h_ref = None
        if aid is not None:  # the times of the whole record's grid, whatever the blocking
            _, _, h = traj.geodetic(dt * np.arange(s0, s0 + nb))
            h_ref = np.stack([h, h])
        dth = np.stack([x.dtheta for x in sets])
        dvel = np.stack([x.dv for x in sets])
        if filt is None:
            res = geodetic_outputs(traj.frame, prop.propagate(dth, dvel, s0, h_ref))
        else:
            res = filt.fly_block(prop, (dth, dvel, h_ref), s0, truth_at)
        secs["propagation"] += time.perf_counter() - c1
        for k in outs:
            outs[k].append(res[k][:, 1:])
        # times on the whole record's grid (tb + dt k would round differently per blocking)
        t_list.extend(dt * (s0 + every * np.arange(1, nb // every + 1)))
    t_out = np.array(t_list)
    start = {"lat": lat0, "lon": lon0, "h": h0, "v": v0, "C": C0}
    full = {
        k: np.concatenate([np.broadcast_to(start[k][None], (n_runs,) + start[k].shape)]
                          + outs[k], axis=1)[inv]
        for k in outs
    }  # fmt: skip
    truth_state = geodetic_state(traj, t_out)
    dpos, dvel, datt = ned_errors(
        full["lat"], full["lon"], full["h"], full["v"], full["C"], truth_state, ell
    )
    track = np.stack(truth_state[:3], -1)
    dg, predicted = gravity_error_along(track, t_out, names, model, ell, device)
    dg_sigma = truth_sigma_along(track, t_out, model, ell)
    c2 = time.perf_counter()
    gains = None
    if aiding == "baro":
        from fieldmap.nav.mechanize import baro_gains

        gains = baro_gains(baro.loop_tau_s, ell)
    if filt is None:
        budget = gravity_budget(t_out, track, dg, model, study.gravity_terms, ell, gains, device)
    else:  # the gravity terms through the filter's closed loop
        from fieldmap.nav.aiding import aided_response
        from fieldmap.nav.budget import gravity_inputs

        inp = gravity_inputs(t_out, track, dg, model, study.gravity_terms, ell, device)
        budget = inp.budget(aided_response(cov.design, track, inp.stack, ell))
    secs["gravity_budget"] = time.perf_counter() - c2
    labels = [f"{r}/{d}" for r in rows for d in range(n_draws)]
    run_models = [r for r in rows for _ in range(n_draws)]
    draw_idx = np.tile(np.arange(n_draws), len(rows))
    diverged = divergence(dpos, t_out, run_models, labels)
    summary = summarize(
        dpos, dvel, run_models, rows, study.fraction, diverged,
        meta={
            "trajectory": traj.name,
            "duration_s": float(n_total * dt),
            "imu": study.imu_name,
            "imu_spec": imu.__dict__,
            "imu_rate_hz": float(rate_hz),
            "draws": n_draws,
            "seed": int(seed),
            "frame": frame,
            "altitude_aiding": aiding,
            "baro": baro.__dict__ if aiding == "baro" else None,
            "gnss": None if study.gnss is None else study.gnss.__dict__,
            "truth_model": model.name,
            "truth_degree": int(model.lmax),
            "truth_tide_system": model.tide_system,
            "truth_evaluation": study.truth_evaluation,
            "gravity_update_every_samples": int(g_every),
            "gravity_rate_hz": float(rate_hz) / g_every,
            "truth_gravity": g_truth.name,
            "truth_interpolation_max_error_mgal": getattr(g_truth, "max_error_mgal", 0.0),
            # the truth model's own uncertainty along the track (commission σ, diagonal)
            "truth_commission_sigma_max_mgal": None
            if dg_sigma is None
            else dict(zip(("north", "east", "down"), (dg_sigma.max(axis=0) * 1e5).tolist())),
            "n_gauss": int(n_gauss),
            "output_dt_s": float(every * dt),
            "block_s": float(per_block * dt),
            "synthesis_seconds": secs["synthesis"],
            "propagation_seconds": secs["propagation"],
            "gravity_budget_seconds": secs["gravity_budget"],
            "gravity_terms": _terms_meta(study.gravity_terms, budget),
            "device": device or "auto",
        },
        budget=budget,
    )  # fmt: skip
    result = FlightResult(
        t_out, labels, run_models, draw_idx, dpos, dvel, datt, track, dg, predicted, summary,
        diverged, dg_sigma, budget,
    )  # fmt: skip
    if filt is not None:
        from fieldmap.nav.aiding import coasting_summary, nees_summary

        coasting_summary(summary, result, study.gnss, cov.horizontal())
        summary["gnss"]["nees"] = nees_summary(filt, imu_set[perm] == 1)
        result.sigma_h = cov.horizontal()
        result.covariance = cov
    return result


def _terms_meta(terms: GravityTerms, budget: GravityBudget) -> dict[str, Any]:
    """Describe the gravity budget's terms for the summary."""
    om = terms.omission
    sig = budget.omission_sigma
    return {
        "method": "linear error model along the true track (fieldmap.nav.linear), per draw",
        "omission_model": None if om is None else om.kind,
        "omission_degrees": None if om is None else [int(om.degree) + 1, int(om.max_degree)],
        "omission_sigma_max_mgal": None
        if sig is None
        else dict(zip(("north", "east", "down"), (np.max(sig, axis=0) * 1e5).tolist())),
        "commission": bool(terms.commission),
        "draws": int(terms.draws),
    }


def to_dataset(res: Any) -> xr.Dataset:
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


def flight_dataset(res: FlightResult) -> xr.Dataset:
    """Error curves, δg and the prediction of a flight study as an ``xarray.Dataset`` (CF-1.8).

    String labels as auxiliary coordinates, the flown path as coordinates of time
    (:mod:`fieldmap.nav.cf`).
    """
    import xarray as xr

    from fieldmap.nav.cf import flown_path, indexed_labels, labels

    models = list(res.dg)
    axis = np.array(["north", "east", "down"])
    sigma: dict[str, tuple[tuple[str, ...], Any, dict[str, str]]] = {}
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
    budget = getattr(res, "budget", None)
    coords_extra: dict[str, tuple[Any, str]] = {}
    if budget is not None and models:
        terms = ("total", "model_difference", "omission", "commission")

        curves = np.stack([budget.curves(m) for m in models])
        sigma["gravity_contribution"] = (
            ("model", "gravity_term", "time", "axis"),
            curves,
            {
                "units": "m",
                "long_name": "position error due to each gravity term through the linear error "
                "model (RMS over the budget's draws; total: root sum of their mean squares; NaN: "
                "term off), NED",
            },
        )
        coords_extra["gravity_term"] = (terms, "term of the gravity error budget")
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
        },
        coords={
            **labels(
                run=(res.labels, "run: navigation model and IMU error draw"),
                model=(models, "navigation gravity model"),
                axis=(axis, "axis of the local level frame (north, east, down)"),
                horizontal_axis=(axis[:2], "horizontal axis of the local level frame"),
                **coords_extra,
            ),
            "run_model": (
                "run",
                np.array(res.models, dtype=str),
                {"long_name": "navigation gravity model of each run (imu_only: the reference)"},
            ),
            "draw": (
                "run",
                res.draw,
                {"long_name": "Monte Carlo draw of the IMU errors of each run", "units": "1"},
            ),
            "time": ("time", res.t, {"units": "s", "long_name": "time since the first sample"}),
            **flown_path(res.track),
        },
        attrs={
            "Conventions": "CF-1.8",
            "title": "fieldmap navsim flight study",
            "source": f"truth {res.summary['meta']['truth_model']} degree "
            f"{res.summary['meta']['truth_degree']}",
            "meta": json.dumps(res.summary["meta"], default=float),
        },
    )
    if "gnss" in res.summary:
        from fieldmap.nav.aiding import add_to_dataset

        ds = add_to_dataset(ds, res.summary, res.sigma_h)
    return indexed_labels(ds)
