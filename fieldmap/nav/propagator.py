"""One batched strapdown propagator for every navigation study: state in, increments in, state out.

:class:`Propagator` holds the configuration of many runs (navigation gravity, increment set,
sensor errors, baro loop: one row per run) and their state (position, velocity, attitude,
Gauss–Markov biases, baro loop), in the spirit of pyins' ``Integrator``: each call of
:meth:`Propagator.propagate` takes a block of IMU increments (shared by all runs) and the global
index of its first sample, advances every run through it and returns the stored states;
:meth:`~Propagator.get_state` / :meth:`~Propagator.set_state` expose the state between blocks.
The paper's studies (:mod:`fieldmap.nav.paper`, the whole record in one block, LCI) and the
flight studies (:mod:`fieldmap.nav.study`, time blocks, NED or LCI) both use it.

Where the runs go is said explicitly: ``client=None`` here (one Warp launch over every core),
or a ``dask.distributed.Client`` (the runs split into groups, one task each; the block's
increments shipped once per worker). Each run is one Warp thread that depends on no other run
and its sensor noise is keyed on (run seed, global sample index), so the results are the same
bits whatever the executor, the grouping of the runs and the time blocks.

:func:`divergence` is the one check of runs that left physical meaning.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fieldmap.errors import InputError, Keyword, Setting

if TYPE_CHECKING:
    from distributed import Client

    from fieldmap.models.shmodel import SHModel
    from fieldmap.nav.frames import LaunchFrame
    from fieldmap.nav.mechanize import Baro, NavConfig

__all__ = ["EARTH_RADIUS", "STAT_KEYS", "Propagator", "divergence", "final_stats"]

#: An error beyond an Earth radius (m) has left physical meaning.
EARTH_RADIUS = 6_371_000.0


@dataclasses.dataclass
class _Config:
    """Everything of a propagation but the per-run state and the increments (picklable)."""

    frame: str  # "ned" or "lci"
    launch: Any  # the LaunchFrame (LCI) or None
    ellipsoid: Any
    gravity: list
    imu_set: np.ndarray
    errors: dict  # kernel sensor errors, one row per run (Gauss–Markov states excluded)
    sh_model: Any
    dt: float
    t_start: float  # time of global sample 0 (LCI: Earth rotation angle)
    output_every: int  # in IMU samples
    baro: Any  # fieldmap.nav.mechanize.Baro template (h_ref unset) or None
    device: str | None
    gravity_every: int = 1  # samples between SH disturbance updates (1: every step)

    def rows(self, a: int, b: int) -> _Config:
        """Return the configuration of runs ``a:b``."""
        return dataclasses.replace(
            self,
            gravity=self.gravity[a:b],
            imu_set=self.imu_set[a:b],
            errors={k: _cut(v, a, b, len(self.gravity)) for k, v in self.errors.items()},
            baro=None if self.baro is None else _baro_rows(self.baro, a, b, len(self.gravity)),
        )


def _cut(value: npt.ArrayLike, a: int, b: int, n: int) -> npt.ArrayLike:
    v = np.asarray(value)
    return v[a:b] if v.ndim >= 1 and v.shape[0] == n else value


def _baro_rows(baro: Baro, a: int, b: int, n: int) -> Baro:
    return dataclasses.replace(
        baro,
        bias=_cut(baro.bias, a, b, n),
        noise=_cut(baro.noise, a, b, n),
        gm_sigma=_cut(baro.gm_sigma, a, b, n),
        gm_tau=_cut(baro.gm_tau, a, b, n),
    )


def check_mechanization(frame: str, *, baro: bool = False) -> str:
    """Check the mechanization of a study or a propagator; return it in lower case.

    The one place of the rules of ``frame`` (``"ned"`` or ``"lci"``) and of baro altitude
    aiding (NED only), for :class:`Propagator` and :class:`fieldmap.nav.study.FlightStudy`.
    """
    name = str(frame).lower()
    if name not in ("ned", "lci"):
        raise InputError(Keyword("frame"), f" must be 'ned' or 'lci', got {frame!r}", param="frame")
    if baro and name != "ned":
        raise InputError("baro altitude aiding needs ", Setting("frame", "ned"), param="frame")
    return name


class Propagator:
    """Batched NED or launch-centred inertial (LCI) strapdown propagation in blocks of samples.

    Parameters
    ----------
    frame : {"ned", "lci"}
        Mechanization (:func:`fieldmap.nav.mechanize.propagate_ned`,
        :func:`fieldmap.nav.mechanize.propagate_lci`).
    start : dict
        Start state, one row per run: NED ``llh`` (rad, rad, m), ``v`` (m/s), ``q`` (q_b^n,
        scalar first); LCI ``P``, ``V`` (m, m/s, a-frame), ``q`` (q_b^a).
    dt : float
        IMU sample interval. Units: s.
    nav : NavConfig
        How the runs navigate (:class:`fieldmap.nav.mechanize.NavConfig`): the navigation
        gravity of each run (``j2 j4 j6 exact sh shN``), ``sh_model``, the NED ``ellipsoid``
        (default WGS84; LCI: the launch frame's), the increment set of each run ``imu_set``
        (default 0), the kernel sensor ``errors``
        (:meth:`fieldmap.nav.sensors.ErrorDraws.kernel_errors`, one row per run; their
        Gauss–Markov states start the state), ``t0`` the time of global sample 0 (LCI: Earth
        rotation angle ω t), ``output_every`` (stored states every this many IMU samples; LCI:
        even), ``baro`` (NED: gains, bias, noise, drift per run; its ``h_ref`` is given per
        block to :meth:`propagate` and its ``state`` starts the loop state) and
        ``gravity_every`` (SH models: the disturbance updated every this many samples, the
        exact normal field every step; see
        :func:`fieldmap.kernels.navgravity.held_gravitation_ecef`). Its ``sample0`` and
        ``gravity_hold`` are the propagator's own (the state).
    launch : LaunchFrame, optional
        The a-frame (LCI; its ellipsoid is the navigation ellipsoid).
    device : str, optional
        Warp device.
    client : dask.distributed.Client, optional
        Run groups of runs as tasks on this cluster (default: here); ``runs_per_task`` (the
        attribute, default four tasks per worker) sets the groups.
    """

    def __init__(
        self,
        frame: str,
        start: dict,
        dt: float,
        nav: NavConfig,
        *,
        launch: LaunchFrame | None = None,
        device: str | None = None,
        client: Client | None = None,
    ) -> None:
        from fieldmap.field.ellipsoid import WGS84
        from fieldmap.nav.mechanize import NavConfig

        if not isinstance(nav, NavConfig):
            raise TypeError(f"nav must be a NavConfig, got {type(nav).__name__}")
        frame = check_mechanization(frame, baro=nav.baro is not None)
        if frame == "lci" and launch is None:
            raise InputError(
                "the LCI mechanization needs its launch frame (launch=)", param="launch"
            )
        if frame == "lci" and nav.output_every % 2:
            raise InputError(
                "the LCI mechanization stores states every even number of samples", param="nav"
            )
        gravity = nav.gravity
        gravity = [gravity] if isinstance(gravity, str) else list(gravity)
        n = len(gravity)
        errors = dict(nav.errors or {})
        baro = nav.baro
        state = {k: np.array(v, dtype=np.float64) for k, v in start.items()}
        for key in ("acc_gm", "gyro_gm"):
            gm = errors.pop(key, None)
            state[key] = np.zeros((n, 3)) if gm is None else np.array(gm, dtype=np.float64)
        if baro is not None:
            bs = baro.state
            state["baro"] = np.zeros((n, 3)) if bs is None else np.array(bs, dtype=np.float64)
        state["gravity_hold"] = np.zeros((n, 3, 3))
        imu_set = nav.imu_set
        self._cfg = _Config(
            frame=frame,
            launch=launch,
            ellipsoid=(launch.ellipsoid if launch is not None else nav.ellipsoid) or WGS84,
            gravity=gravity,
            imu_set=(
                np.zeros(n, dtype=np.int64)
                if imu_set is None
                else np.broadcast_to(np.asarray(imu_set, dtype=np.int64), (n,)).copy()
            ),
            errors=errors,
            sh_model=nav.sh_model,
            dt=float(dt),
            t_start=float(0.0 if nav.t0 is None else nav.t0),
            output_every=int(nav.output_every),
            baro=None if baro is None else dataclasses.replace(baro, state=None),
            device=device,
            gravity_every=int(nav.gravity_every),
        )
        self._state = state
        self.client = client
        #: runs per task on a cluster (None: four tasks per worker)
        self.runs_per_task: int | None = None

    @property
    def n_runs(self) -> int:
        """Number of runs."""
        return len(self._cfg.gravity)

    @property
    def gravity(self) -> list:
        """Navigation gravity of each run."""
        return list(self._cfg.gravity)

    def get_state(self) -> dict:
        """Copy of the state (one row per run): position, velocity, attitude, GM and baro."""
        return {k: v.copy() for k, v in self._state.items()}

    def set_state(self, state: dict) -> None:
        """Replace the state (the keys and shapes of :meth:`get_state`)."""
        missing = set(self._state) - set(state)
        if missing:
            raise InputError(f"state lacks {sorted(missing)}", param="state")
        for k, v in self._state.items():
            a = np.array(state[k], dtype=np.float64)
            if a.shape != v.shape:
                raise InputError(
                    f"state[{k!r}] has shape {a.shape}, expected {v.shape}", param="state"
                )
            self._state[k] = a

    def correct_errors(self, **estimates: npt.ArrayLike) -> None:
        """Remove estimated sensor errors from the runs (a filter's feedback of its estimates).

        ``acc_bias=`` (n_runs, 3) m/s², ``gyro_bias=`` (n_runs, 3) rad/s: subtracted from the
        runs' constant biases (what the navigator compensates from then on).
        """
        for key, value in estimates.items():
            if key not in ("acc_bias", "gyro_bias") or key not in self._cfg.errors:
                raise InputError(f"no sensor error {key!r} to correct", param="state")
            self._cfg.errors[key] = np.asarray(self._cfg.errors[key], np.float64) - np.asarray(
                value, np.float64
            )

    def propagate(
        self,
        dtheta: npt.ArrayLike,
        dv: npt.ArrayLike,
        sample0: int = 0,
        h_ref: npt.ArrayLike | None = None,
    ) -> dict:
        """Advance every run through one block of IMU samples; return the stored states.

        Parameters
        ----------
        dtheta, dv : array_like, shape (n_sets, n_samples, 3)
            Body increments of the block (rad, m/s), shared by the runs (``imu_set``).
        sample0 : int
            Global index of the block's first sample (keys the noise; fixes the times).
        h_ref : array_like, shape (n_sets, n_samples) or (n_samples,), optional
            Reference heights of the baro loop (m), needed with ``baro``.

        Returns
        -------
        dict
            Stored states at the block's start and every ``output_every`` samples, one row per
            run: NED ``lat``, ``lon`` (degrees), ``h`` (m), ``v`` (m/s), ``q``; LCI ``P``,
            ``V``, ``q`` and ``t`` (the times, s).
        """
        cfg = self._cfg
        if cfg.baro is not None and h_ref is None:
            raise InputError(
                "the baro loop needs the block's reference heights (h_ref=)", param="h_ref"
            )
        n = self.n_runs
        if self.client is None:
            out, nxt = _propagate_runs(cfg, self._state, dtheta, dv, int(sample0), h_ref)
        else:
            out, nxt = self._on_cluster(dtheta, dv, int(sample0), h_ref, n)
        self._state = nxt
        return out

    def _on_cluster(
        self,
        dtheta: npt.ArrayLike,
        dv: npt.ArrayLike,
        sample0: int,
        h_ref: npt.ArrayLike | None,
        n: int,
    ) -> tuple[dict, dict]:
        from fieldmap.cluster import scattered

        client = self.client
        assert client is not None  # propagate() runs here without one
        nworkers = max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
        per = self.runs_per_task or max(1, math.ceil(n / (4 * nworkers)))
        cfg = self._cfg
        model_f = scattered(client, cfg.sh_model) if cfg.sh_model is not None else None
        (block_f,) = client.scatter([(dtheta, dv, h_ref)], broadcast=True, hash=False)
        futures = [
            client.submit(
                _task,
                dataclasses.replace(cfg.rows(a, a + per), sh_model=None),
                model_f,
                {k: v[a : a + per] for k, v in self._state.items()},
                block_f,
                sample0,
                pure=False,
            )
            for a in range(0, n, per)
        ]
        try:
            parts = client.gather(futures)
        finally:
            block_f.release()
        out = {
            k: parts[0][0][k] if k == "t" else np.concatenate([p[0][k] for p in parts])
            for k in parts[0][0]
        }
        nxt = {k: np.concatenate([p[1][k] for p in parts]) for k in parts[0][1]}
        return out, nxt


def _task(
    cfg: _Config,
    model: SHModel | None,
    state: dict,
    block: tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike | None],
    sample0: int,
) -> tuple[dict, dict]:
    from fieldmap.cluster import worker_setup

    worker_setup()
    dtheta, dv, h_ref = block
    return _propagate_runs(
        dataclasses.replace(cfg, sh_model=model), state, dtheta, dv, sample0, h_ref
    )


def _propagate_runs(
    cfg: _Config,
    state: dict,
    dtheta: npt.ArrayLike,
    dv: npt.ArrayLike,
    sample0: int,
    h_ref: npt.ArrayLike | None,
) -> tuple[dict, dict]:
    """Propagate the runs of ``cfg`` from ``state`` through one block: (stored, next state)."""
    errors = {**cfg.errors, "acc_gm": state["acc_gm"], "gyro_gm": state["gyro_gm"]}
    if cfg.frame == "ned":
        from fieldmap.nav.mechanize import NavConfig, NedStart, propagate_ned

        aid = None
        if cfg.baro is not None:
            h = np.asarray(h_ref, dtype=np.float64)
            h = h if h.ndim == 2 else np.broadcast_to(h, (np.shape(dtheta)[0], h.size))
            aid = dataclasses.replace(cfg.baro, h_ref=h, state=state["baro"])
        llh = state["llh"]
        start = NedStart(llh[:, 0], llh[:, 1], llh[:, 2], state["v"], state["q"], degrees=False)
        nav = NavConfig(
            cfg.gravity, sh_model=cfg.sh_model, ellipsoid=cfg.ellipsoid, imu_set=cfg.imu_set,
            errors=errors, output_every=cfg.output_every, baro=aid, sample0=sample0,
            gravity_every=cfg.gravity_every, gravity_hold=state["gravity_hold"],
        )  # fmt: skip
        ned = propagate_ned(dtheta, dv, cfg.dt, start, nav, device=cfg.device)
        final = ned.final or {}
        nxt = {"llh": final["llh"], "v": ned.v_ned[:, -1], "q": ned.q[:, -1]}
        if cfg.baro is not None:
            nxt["baro"] = final["baro"]
        out = {"lat": ned.lat, "lon": ned.lon, "h": ned.h, "v": ned.v_ned, "q": ned.q}
    else:
        from fieldmap.nav.mechanize import LciStart, NavConfig, propagate_lci

        nav = NavConfig(
            cfg.gravity, sh_model=cfg.sh_model, imu_set=cfg.imu_set, errors=errors,
            t0=cfg.t_start + cfg.dt * sample0, output_every=cfg.output_every // 2,
            sample0=sample0, gravity_every=cfg.gravity_every, gravity_hold=state["gravity_hold"],
        )  # fmt: skip
        a_start = LciStart(state["P"], state["V"], state["q"], cfg.launch)
        lci = propagate_lci(dtheta, dv, cfg.dt, a_start, nav, device=cfg.device)
        final = lci.final or {}
        nxt = {"P": lci.P[:, -1], "V": lci.V[:, -1], "q": lci.q[:, -1]}
        out = {"P": lci.P, "V": lci.V, "q": lci.q, "t": lci.t}
    nxt["acc_gm"] = final["acc_gm"]
    nxt["gyro_gm"] = final["gyro_gm"]
    nxt["gravity_hold"] = final["gravity_hold"]
    return out, nxt


def divergence(
    err: npt.ArrayLike,
    t: Sequence[float] | npt.NDArray[np.float64],
    models: Sequence[str],
    labels: Sequence[object] | None = None,
    stacklevel: int = 3,
) -> list[dict]:
    """Find the runs whose error is non-finite or beyond an Earth radius; warn for each.

    Parameters
    ----------
    err : array_like, shape (n_runs, n_t) or (n_runs, n_t, 3)
        Position error norms or vectors (m).
    t : array_like (n_t,)
        Times (s).
    models : sequence of str
        Navigation gravity of each run.
    labels : sequence, optional
        Name of each run (default its index).

    Returns
    -------
    list of dict
        ``{"run": label, "model": name, "time_s": first bad time}`` per diverged run.
    """
    e = np.asarray(err, dtype=np.float64)
    finite = np.isfinite(e).all(-1) if e.ndim == 3 else np.isfinite(e)
    with np.errstate(invalid="ignore", over="ignore"):
        size = np.linalg.norm(np.where(np.isfinite(e), e, 0.0), axis=-1) if e.ndim == 3 else e
        bad = ~finite | (np.where(finite, size, 0.0) > EARTH_RADIUS)
    out = []
    for i in np.flatnonzero(bad.any(axis=1)).tolist():
        k = int(np.argmax(bad[i]))
        run = labels[i] if labels is not None else int(i)
        out.append({"run": run, "model": models[i], "time_s": float(t[k])})
        warnings.warn(
            f"navigation run {run} (model {models[i]}) diverged at t = {t[k]:.0f} s "
            "(error non-finite or beyond an Earth radius)",
            RuntimeWarning,
            stacklevel=stacklevel,
        )
    return out


#: The statistics of final errors over runs, in every study's summary.
STAT_KEYS = ("mean", "rms", "p05", "p50", "p95", "max")


def final_stats(x: npt.ArrayLike, keys: Iterable[str] = STAT_KEYS) -> dict[str, float | None]:
    """Statistics of final errors over runs; ``None`` for each when any run is not finite.

    ``keys`` among mean, rms, p05, p50, p95, max (percentiles by linear interpolation).
    """
    x = np.asarray(x, dtype=np.float64)
    if not np.all(np.isfinite(x)):
        return {k: None for k in keys}
    fns = {
        "mean": lambda: np.mean(x),
        "rms": lambda: np.sqrt(np.mean(x * x)),
        "p05": lambda: np.percentile(x, 5),
        "p50": lambda: np.percentile(x, 50),
        "p95": lambda: np.percentile(x, 95),
        "max": lambda: np.max(x),
    }
    return {k: float(fns[k]()) for k in keys}
