r"""Navigation study on a user's flight: what each gravity model costs next to the IMU's errors.

For a :class:`~fieldmap.nav.trajectory.Trajectory` (usually a
:class:`~fieldmap.nav.flight.FlightTrajectory`), an IMU spec and a list of navigation gravity
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
:mod:`fieldmap.nav.flighterrors` (re-exported here); this module runs the study.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from fieldmap.errors import InputError
from fieldmap.nav import imu_errors
from fieldmap.nav.flight import geodetic_state
from fieldmap.nav.flightblocks import geodetic_outputs, initial_state
from fieldmap.nav.flighterrors import gravity_error_along as gravity_error_along
from fieldmap.nav.flighterrors import ned_errors, truth_sigma_along
from fieldmap.nav.flighterrors import simplicity_order as simplicity_order
from fieldmap.nav.flighterrors import summarize as summarize
from fieldmap.nav.imu import Gravitation, load_truth_model, sample_count, synthesize
from fieldmap.nav.propagator import EARTH_RADIUS, Propagator, divergence, final_stats  # noqa: F401
from fieldmap.nav.trajectory import Trajectory

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

    def to_dataset(self):
        """Return the results as an ``xarray.Dataset`` over (run, time) with units (CF-1.8)."""
        from fieldmap.nav.datasets import flight_dataset

        return flight_dataset(self)


def _steps_per_output(output_dt: float, rate_hz: float) -> int:
    k = output_dt * rate_hz
    every = int(round(k))
    if every < 1 or abs(k - every) > 1e-9 * max(k, 1.0):
        raise InputError(
            f"output interval {output_dt:g} s is not a whole number of IMU samples at "
            f"{rate_hz:g} Hz"
        )
    return every


def default_output_dt(duration: float) -> float:
    """About 3600 stored states per run, at least one per second. Units: s."""
    return float(max(1.0, np.ceil(duration / 3600.0)))


#: a compensation table must hold the flight's path this far above and below it (m): room for
#: the navigator's own height error
TABLE_HEIGHT_MARGIN = 50.0


def check_tables_cover(names, traj, duration: float) -> None:
    """Refuse (one line) a compensation table that does not cover the flight's path.

    The path is checked every second (and at its end), with 50 m of height margin each way for
    the navigator's own height error.
    """
    from fieldmap.nav.navgravity import table_file
    from fieldmap.products.tables.model import load_table, outside_message

    files = [f for f in (table_file(m) for m in names) if f is not None]
    if not files:
        return
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


def run_flight(
    traj: Trajectory,
    *,
    imu: imu_errors.ImuErrorSpec = imu_errors.ImuErrorSpec(),
    imu_name: str = "ideal",
    models=("j2", "j4", "j6", "exact", "sh18", "sh200"),
    draws: int = 20,
    seed: int = 0,
    rate_hz: float = 200.0,
    frame: str = "ned",
    altitude_aiding: str = "auto",
    baro: BaroSpec = BaroSpec(),
    truth: str = "eigen-6s",
    truth_lmax: int | None = None,
    truth_evaluation: str = "interpolated",
    gravity_rate_hz=None,
    n_gauss: int = 3,
    duration: float | None = None,
    output_dt: float | None = None,
    block_s: float = 600.0,
    fraction: float = 0.1,
    device: str | None = None,
    progress: bool = False,
    client=None,
) -> FlightResult:
    """Navigate ``traj`` with each gravity model and IMU draw; errors, δg and a recommendation.

    Parameters
    ----------
    traj : Trajectory
        The flight (its kinematics are the truth).
    imu : ImuErrorSpec
        1σ sensor errors (:mod:`fieldmap.nav.imu_specs` has presets and TOML files).
    imu_name : str
        Label of the IMU in the outputs.
    models : sequence of str
        Navigation gravity models (j2 j4 j6 exact sh shN; ``normal``, the deprecated name of
        ``exact``, is read as ``exact`` with a ``DeprecationWarning``).
    draws : int
        Monte Carlo draws (1 for an ideal IMU).
    seed : int
        Seed of the draws.
    rate_hz : float
        IMU rate. Units: Hz.
    frame : {"ned", "lci"}
        Mechanization: Earth-relative NED or the launch-centred inertial frame (first sample).
    altitude_aiding : {"auto", "none", "baro"}
        Baro loop on the vertical channel (NED only); ``auto``: baro for flights over 15 min.
    baro : BaroSpec
        Baro error model and loop time constant.
    truth, truth_lmax : str, int
    gravity_rate_hz : float or "full", optional
        SH navigation models: rate of the disturbance update (the exact normal field every
        step; :func:`fieldmap.nav.trackgravity.gravity_update_every`). None (default): the
        slowest rate whose extrapolation error stays below 0.1 % of the disturbance; "full":
        the whole model every step.
    truth_evaluation : {"interpolated", "full"}
        ``interpolated`` (default): the truth disturbance on a time grid along the path plus
        the exact normal field at every quadrature node
        (:class:`fieldmap.nav.trackgravity.TrackGravitation`, its measured interpolation error
        in the summary); ``full``: the SH model at every node.
        Truth gravity model (name or ICGEM file) and degree.
    n_gauss : int
        Gauss–Legendre nodes per IMU sample in the synthesis.
    duration : float, optional
        Part of the flight to simulate (default all). Units: s.
    output_dt : float, optional
        Interval of the stored errors (default :func:`default_output_dt`). Units: s.
    block_s : float
        Length of a synthesis/propagation block. Units: s.
    fraction : float
        ``recommended_model``: the simplest model whose added horizontal error (RMS over draws)
        stays below ``fraction`` × the IMU-only horizontal error.
    device : str, optional
        Warp device.
    progress : bool
        tqdm progress bar over the blocks.
    client : dask.distributed.Client, optional
        Propagate groups of runs as tasks on this cluster (the same bits; default: here).

    Returns
    -------
    FlightResult
    """
    from fieldmap.nav.scenario import check_model_names

    if truth_evaluation not in ("interpolated", "full"):
        raise InputError(
            f"truth evaluation must be 'interpolated' or 'full', got {truth_evaluation!r}"
        )
    frame = str(frame).lower()
    if frame not in ("ned", "lci"):
        raise InputError(f"frame must be 'ned' or 'lci', got {frame!r}")
    aiding = str(altitude_aiding).lower()
    if aiding not in ("auto", "none", "baro"):
        raise InputError(f"altitude aiding must be auto, none or baro, got {altitude_aiding!r}")
    if not 0 < fraction < 1:
        raise InputError(f"fraction must be in (0, 1), got {fraction}")
    for what, v in (("IMU rate", rate_hz), ("block length", block_s)):
        if isinstance(v, (str, bool)) or not np.isfinite(v) or v <= 0:
            raise InputError(f"{what} must be a positive number, got {v!r}")
    model = load_truth_model(truth, truth_lmax)
    names = check_model_names(models, model)
    duration = traj.duration if duration is None else float(duration)
    if not 0 < duration <= traj.duration * (1 + 1e-12):
        raise InputError(f"duration {duration:g} s does not fit the flight ({traj.duration:g} s)")
    check_tables_cover(names, traj, duration)
    if aiding == "auto":
        aiding = "baro" if duration > BARO_AFTER_S and frame == "ned" else "none"
    if aiding == "baro" and frame != "ned":
        raise InputError("baro altitude aiding needs --frame ned")
    output_dt = default_output_dt(duration) if output_dt is None else float(output_dt)
    every = _steps_per_output(output_dt, rate_hz)
    if frame == "lci" and every % 2:
        raise InputError(
            f"--frame lci steps two IMU samples at a time: the output interval {output_dt:g} s "
            f"must be an even number of samples at {rate_hz:g} Hz"
        )
    unit = every * (2 if every % 2 else 1)  # whole outputs, an even number of samples
    n_total = int(np.floor(duration * rate_hz / unit + 1e-9)) * unit
    if n_total < unit:
        raise InputError(
            f"flight of {duration:g} s is shorter than one output interval ({output_dt:g} s)"
        )
    per_block = max(unit, int(block_s * rate_hz) // unit * unit)
    # a block's IMU synthesis is bounded (sample_count): refused here, before any work
    sample_count(min(per_block, n_total) / float(rate_hz), rate_hz)
    n_draws = 1 if imu.is_ideal else int(draws)
    err1 = imu_errors.draw(imu, n_draws, seed=seed)
    rows = ["imu_only"] + names
    n_runs = n_draws * len(rows)
    err = err1.repeat(len(rows))
    grav = [("j4" if r == "imu_only" else r) for r in rows for _ in range(n_draws)]
    imu_set = np.array([1 if r == "imu_only" else 0 for r in rows for _ in range(n_draws)])
    from fieldmap.nav.scenario import balanced_order

    perm = balanced_order(grav)
    inv = np.argsort(perm)
    ell = traj.frame.ellipsoid
    dt = 1.0 / float(rate_hz)
    g_truth: Any
    if truth_evaluation == "full":
        g_truth = Gravitation("sh", model=model, device=device, ellipsoid=ell)
    else:
        from fieldmap.nav.trackgravity import TrackGravitation

        g_truth = TrackGravitation(model, traj, ellipsoid=ell, device=device)
    g_ref = Gravitation("j4", device=device, ellipsoid=ell)  # the navigator's J4 (same ellipsoid)

    # start state (truth at t = 0); runs in a cost-balanced order (perm), results put back
    lat0, lon0, h0, v0, C0 = geodetic_state(traj, [0.0])
    kerr = err.take(perm).kernel_errors()
    aid = None
    if aiding == "baro":
        from fieldmap.nav.strapdown_ned import Baro, baro_gains

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
    from fieldmap.nav.navgravity import parse_gravity
    from fieldmap.nav.trackgravity import gravity_update_every

    sh_deg = max((parse_gravity(m, model)[1] for m in names), default=0)
    g_every = gravity_update_every(traj, sh_deg, rate_hz, gravity_rate_hz) if sh_deg else 1
    prop = Propagator(
        frame, initial_state(traj, frame, lat0, lon0, h0, v0, C0, n_runs),
        [grav[i] for i in perm], dt, launch=traj.frame if frame == "lci" else None,
        ellipsoid=ell, sh_model=model, imu_set=imu_set[perm], errors=kerr,
        output_every=every, baro=aid, device=device, client=client, gravity_every=g_every,
    )  # fmt: skip

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
            synthesize(
                traj, rate_hz, [g_truth, g_ref], n_gauss=n_gauss, duration=nb * dt, sample0=s0
            ),
        )
        c1 = time.perf_counter()
        secs["synthesis"] += c1 - c0
        h_ref = None
        if aid is not None:  # the times of the whole record's grid, whatever the blocking
            _, _, h = traj.geodetic(dt * np.arange(s0, s0 + nb))
            h_ref = np.stack([h, h])
        dth = np.stack([x.dtheta for x in sets])
        dvel = np.stack([x.dv for x in sets])
        res = geodetic_outputs(traj.frame, prop.propagate(dth, dvel, s0, h_ref))
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
    labels = [f"{r}/{d}" for r in rows for d in range(n_draws)]
    run_models = [r for r in rows for _ in range(n_draws)]
    draw_idx = np.tile(np.arange(n_draws), len(rows))
    diverged = divergence(dpos, t_out, run_models, labels)
    summary = summarize(
        dpos, dvel, run_models, rows, n_draws, fraction, diverged,
        meta={
            "trajectory": traj.name,
            "duration_s": float(n_total * dt),
            "imu": imu_name,
            "imu_spec": imu.__dict__,
            "imu_rate_hz": float(rate_hz),
            "draws": n_draws,
            "seed": int(seed),
            "frame": frame,
            "altitude_aiding": aiding,
            "baro": baro.__dict__ if aiding == "baro" else None,
            "truth_model": model.name,
            "truth_degree": int(model.lmax),
            "truth_evaluation": truth_evaluation,
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
            "device": device or "auto",
        },
    )  # fmt: skip
    return FlightResult(
        t_out, labels, run_models, draw_idx, dpos, dvel, datt, track, dg, predicted, summary,
        diverged, dg_sigma,
    )  # fmt: skip
