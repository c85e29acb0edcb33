"""The scenario of a navigation study and the propagation of its runs against the truth.

A :class:`Scenario` holds the reference trajectory, its exact IMU increments under the truth
gravitation and the exact states at the output times (:func:`build_scenario`);
:func:`propagate` runs many navigation runs (gravity models × IMU error draws × increment sets)
through one :class:`fieldmap.nav.propagator.Propagator` and returns their errors against the
truth. The tables of :mod:`fieldmap.nav.studies` are built on these.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

import numpy as np

from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel
from fieldmap.nav import imu_errors
from fieldmap.nav.imu import (
    Gravitation,
    ImuIncrements,
    load_truth_model,
    sample_count,
    synthesize,
)
from fieldmap.nav.propagator import Propagator, divergence
from fieldmap.nav.trajectory import BoostGlide, Kinematics, Trajectory

#: normal navigation models -> the ``normal=`` name of :mod:`fieldmap.field.normal` (the same
#: names: the exact level-ellipsoid field is ``"exact"`` on both sides)
NORMAL_KINDS = {"j2": "j2", "j4": "j4", "j6": "j6", "exact": "exact"}


def check_model_names(names, sh_model) -> list[str]:
    """Validate navigation gravity names (``j2 j4 j6 exact sh shN table:FILE auto``).

    Returns the names in lower case (a table's file name as given), ``sh`` as ``sh<lmax>``,
    ``auto`` as :func:`fieldmap.nav.navgravity.auto_models` (a model ``auto`` adds appears
    once, also when named besides); the deprecated
    ``"normal"`` becomes ``"exact"`` with one ``DeprecationWarning``. Raises
    :class:`InputError` for an unknown name, an unreadable table, or a model named twice
    (``j4,j4``, ``sh,sh200`` with a degree-200 model, one table file under two names).
    """
    from fieldmap.nav.navgravity import auto_models, gravity_names, parse_gravity, table_file

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
    for given_name, name in zip(given, gravity_names(given)):
        path = table_file(name)
        if path is not None:  # a file name keeps its case
            parse_gravity(name, sh_model)
            key, same = f"table:{path}", os.path.realpath(path)
        else:
            key = str(name).strip().lower()
            parse_gravity(key, sh_model)
            key = same = key if key != "sh" else f"sh{sh_model.lmax}"
        typed = str(given_name).strip()
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
    steps = sample_count(duration, rate_hz) // 2  # the synthesis's: checked before it runs
    every = output_steps(output_dt, steps, 2.0 / float(rate_hz))
    traj = trajectory or BoostGlide(duration=max(float(duration), 1.0))
    model = load_truth_model(truth, truth_lmax)
    g = Gravitation("sh", model=model, device=device, ellipsoid=traj.frame.ellipsoid)
    imu = synthesize(traj, rate_hz, g, n_gauss=n_gauss, duration=duration, progress=progress)
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

        from fieldmap.nav.navgravity import gravity_cost

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
    from fieldmap.nav.navgravity import gravity_cost

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
