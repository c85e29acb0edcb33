r"""Linear covariance analysis of a flight: σ(t) of the navigation errors, source by source.

The standard tool of INS design beside Monte Carlo: the error state of the navigator is
propagated along the true trajectory with its linear model, P⁺ = Φ P Φᵀ + Q, giving the standard
deviation of every error in one pass, and, the model being linear and the sources independent,
an **error budget**: each source's own covariance, which add up to the whole.

Error state (Earth-fixed axes; Groves 2013 §14.2, Titterton & Weston 2004 §12.2), 36 states:

==============  =====================================================================  =========
states          meaning                                                                units
==============  =====================================================================  =========
0–2, 3–5        δr, δv: position and Earth-relative velocity error (ECEF)              m, m/s
6               a: the baro loop’s acceleration correction (fieldmap.nav.linear)       m/s²
7–9             ψ: attitude error, Ĉ_b^e = (I − [ψ×]) C_b^e                            rad
10–12           accelerometer constant bias (body)                                     m/s²
13–15           gyro constant bias (body)                                              rad/s
16–18           accelerometer bias instability, first-order Gauss–Markov (body)        m/s²
19–21           gyro bias instability, Gauss–Markov (body)                             rad/s
22–24, 25–27    accelerometer scale factor, misalignment (body)                        1, rad
28–30, 31–33    gyro scale factor, misalignment (body)                                 1, rad
34, 35          baro bias, baro drift (Gauss–Markov)                                   m, m
==============  =====================================================================  =========

with (f the specific force, ω the body rate w.r.t. inertial space, both of the true flight;
δf = b_a + β_a + s_a ⊙ f − f × θ_a + w_a, δω likewise)

.. math::
    \delta\dot v = \Gamma\delta r - 2\Omega\times\delta v - \Omega\times\Omega\times\delta r
        + (C_b^e f)\times\psi + C_b^e\,\delta f,\qquad
    \dot\psi = -\Omega\times\psi - C_b^e\,\delta\omega ,

the core (δr, δv, a) being :func:`fieldmap.nav.linear.core_dynamics` (Γ the point mass's
gradient, the baro loop on the height error less the baro's own error). The sensor model is the
Monte Carlo's (:mod:`fieldmap.nav.sensors`, ``kernels/sensor_errors.py``): constant errors
drawn once per run, Gauss–Markov biases started from their stationary law, white noises of
density σ. The flight study starts at the truth, so the initial navigation errors are zero.

Discretisation: the transition of one RK4 step on the study's output grid, F evaluated from the
trajectory's exact kinematics at both ends and the middle of each step
(:func:`fieldmap.nav.linear.rk4_transition`); the white noise integrated over the step to third
order in h (Q = GQGᵀh + (FGQGᵀ + GQGᵀFᵀ)h²/2 + (F²GQGᵀ + 2FGQGᵀFᵀ + GQGᵀF²ᵀ)h³/6: a velocity
random walk's h³/3 in position is exact). Constant sources are carried as sensitivity columns
of Φ(t, 0); Gauss–Markov and white sources as their own covariance recursions.

Limits: the gravity gradient is the point mass's (the J2 part changes it by 1e-3); gravity
model errors are not states here (their contributions come from :mod:`fieldmap.nav.budget`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from fieldmap.errors import InputError, Keyword
from fieldmap.nav.linear import core_dynamics, rk4_transition

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "SOURCES", "CovarianceResult", "CovarianceStudyResult", "covariance_analysis",
    "covariance_study",
]  # fmt: skip

N_STATES = 36
R, V, A, PSI = slice(0, 3), slice(3, 6), 6, slice(7, 10)
BA, BG, GA, GG = slice(10, 13), slice(13, 16), slice(16, 19), slice(19, 22)
SA, TA, SG, TG = slice(22, 25), slice(25, 28), slice(28, 31), slice(31, 34)
BARO_BIAS, BARO_DRIFT = 34, 35

#: the error sources of the budget, in the order reported
SOURCES = (
    "accelerometer bias", "gyro bias", "accelerometer bias instability",
    "gyro bias instability", "accelerometer scale factor", "accelerometer misalignment",
    "gyro scale factor", "gyro misalignment", "velocity random walk", "angle random walk",
    "baro bias", "baro drift", "baro noise", "GNSS noise", "GNSS bias",
)  # fmt: skip


def _skew(v: np.ndarray) -> np.ndarray:
    """[v×] of vectors v (n, 3) → (n, 3, 3)."""
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], -1),
            np.stack([v[..., 2], z, -v[..., 0]], -1),
            np.stack([-v[..., 1], v[..., 0], z], -1),
        ],
        -2,
    )


@dataclass
class _Flight:
    """What the error model needs of the true flight at some times (ECEF)."""

    r: np.ndarray
    up: np.ndarray
    C_b_e: np.ndarray
    f_b: np.ndarray
    w_b: np.ndarray
    ned: np.ndarray  # rows north, east, down in ECEF


def _flight_at(traj: Any, t: np.ndarray) -> _Flight:
    from fieldmap.field.frames import ecef_to_geodetic
    from fieldmap.field.normal import normal_gravitation_ecef
    from fieldmap.nav.frames import C_n_to_e

    k = traj.kinematics(t)
    fr = traj.frame
    w = np.array([0.0, 0.0, fr.omega])
    C_b_e = np.swapaxes(fr.C_e_to_a(t), -1, -2) @ k.C_b_to_a
    g = np.asarray(
        normal_gravitation_ecef(
            k.r_e[:, 0], k.r_e[:, 1], k.r_e[:, 2], normal="j2", ellipsoid=fr.ellipsoid
        )
    )
    f_e = k.a_e + 2.0 * np.cross(w, k.v_e) + np.cross(w, np.cross(w, k.r_e)) - g
    f_b = np.einsum("nji,nj->ni", C_b_e, f_e)
    lat, lon, _ = ecef_to_geodetic(k.r_e[:, 0], k.r_e[:, 1], k.r_e[:, 2], fr.ellipsoid)
    ned = np.swapaxes(C_n_to_e(lat, lon), -1, -2)  # rows north, east, down in ECEF
    return _Flight(k.r_e, -ned[:, 2, :], C_b_e, f_b, k.w_b, ned)


def _dynamics(
    fl: _Flight, ell: Any, gains: tuple[float, float, float], spec: Any, baro: Any
) -> np.ndarray:
    """F (n, 36, 36) of the whole error state along the flight."""
    n = fl.r.shape[0]
    F = np.zeros((n, N_STATES, N_STATES))
    F[:, :7, :7] = core_dynamics(fl.r, fl.up, ell.GM, ell.omega, gains)
    W = np.zeros((3, 3))
    W[0, 1], W[1, 0] = -ell.omega, ell.omega
    C = fl.C_b_e
    f_e = np.einsum("nij,nj->ni", C, fl.f_b)
    F[:, V, PSI] = _skew(f_e)
    F[:, PSI, PSI] = -W
    for rows, sign in ((V, 1.0), (PSI, -1.0)):
        acc = rows == V
        x = fl.f_b if acc else fl.w_b
        b, gm, s, th = (BA, GA, SA, TA) if acc else (BG, GG, SG, TG)
        F[:, rows, b] = sign * C
        F[:, rows, gm] = sign * C
        F[:, rows, s] = sign * C * x[:, None, :]  # C diag(x)
        F[:, rows, th] = -sign * C @ _skew(x)
    if spec.accel_bias_instability_ug:
        F[:, GA, GA] = -np.eye(3) / spec.accel_bias_instability_tau_s
    if spec.gyro_bias_instability_deg_per_h:
        F[:, GG, GG] = -np.eye(3) / spec.gyro_bias_instability_tau_s
    k1, k2, k3 = gains
    if k1 or k2 or k3:
        for j in (BARO_BIAS, BARO_DRIFT):  # δh = e_u − (bias + drift + noise)
            F[:, R, j] = k1 * fl.up
            F[:, V, j] = k2 * fl.up
            F[:, A, j] = -k3
        F[:, BARO_DRIFT, BARO_DRIFT] = -1.0 / baro.drift_tau_s
    return F


@dataclass
class CovarianceResult:
    """σ(t) of the NED errors of a flight, in total and per source.

    ``t`` (n,) s; ``position``, ``velocity`` {source: (n, 3)} σ north, east, down (m, m/s);
    ``attitude`` {source: (n, 3)} σ about N, E, D (rad); ``total_*`` their root sum of
    squares (the sources are independent); ``sources`` the sources present.
    """

    t: np.ndarray
    sources: list
    position: dict
    velocity: dict
    attitude: dict
    #: the GNSS filter of an aided study (:class:`fieldmap.nav.aiding.FilterDesign`) or None
    design: Any = None

    def total(self, what: str = "position") -> np.ndarray:
        """(n, 3) σ of all sources together."""
        d = getattr(self, what)
        return np.sqrt(sum((v**2 for v in d.values()), np.zeros((self.t.size, 3))))

    def horizontal(self, source: str | None = None) -> np.ndarray:
        """(n,) horizontal position σ, √(σ_N² + σ_E²), of a source or (None) of all."""
        s = self.total() if source is None else self.position[source]
        return np.hypot(s[:, 0], s[:, 1])


def _reachable(reach: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Return the states a source entering at ``start`` can move (closure of F's graph)."""
    have = np.zeros(reach.shape[0], bool)
    have[start] = True
    while True:
        more = have | np.any(reach[:, have], axis=1)
        if np.array_equal(more, have):
            return np.flatnonzero(have)
        have = more


def _noise_q(F: np.ndarray, GQG: np.ndarray, h: np.ndarray) -> np.ndarray:
    """∫₀ʰ Φ(s) GQGᵀ Φ(s)ᵀ ds to third order in h, per interval (n, k, k)."""
    hs = h[:, None, None]
    FG = F @ GQG
    FGF = FG @ np.swapaxes(F, -1, -2)
    F2G = F @ FG
    return (
        GQG * hs
        + (FG + np.swapaxes(FG, -1, -2)) * hs**2 / 2.0
        + (F2G + 2.0 * FGF + np.swapaxes(F2G, -1, -2)) * hs**3 / 6.0
    )


def _aided(
    t: np.ndarray,
    gnss: Any,
    Phi: np.ndarray,
    Fq: np.ndarray,
    h: np.ndarray,
    const: list,
    stoch: list,
    noise_baro: np.ndarray | None,
    store: Any,
) -> Any:
    """GNSS-aided: the filter's covariance, then each source through its gains (Joseph form).

    Returns the :class:`fieldmap.nav.aiding.FilterDesign`; ``store`` receives each source's
    a priori covariance and that of the GNSS noise.
    """
    from fieldmap.nav.aiding import design_filter

    step = 1.0 / gnss.rate_hz
    dt = np.diff(t)
    k = step / dt
    if t.size < 2 or np.any(np.abs(k - np.round(k)) > 1e-6 * k) or np.any(k < 1 - 1e-9):
        raise InputError(
            f"the covariance grid must hold every GNSS fix ({step:g} s apart): ",
            Keyword("output_dt"),
            f" {dt.max():g} s",
            param="output_dt",
        )
    names, P0s, gqgs = [], [], []
    for name, sl, sigma in const:
        p0 = np.zeros((N_STATES, N_STATES))
        ix = np.arange(N_STATES)[sl]
        p0[ix, ix] = sigma**2
        names.append(name)
        P0s.append(p0)
        gqgs.append(np.zeros((1, N_STATES, N_STATES)))
    for name, p0, q in stoch:
        names.append(name)
        P0s.append(np.diag(p0))
        gqgs.append(np.diag(q)[None])
    if noise_baro is not None:
        names.append("baro noise")
        P0s.append(np.zeros((N_STATES, N_STATES)))
        gqgs.append(0.5 * (noise_baro[:-1] + noise_baro[1:]))
    names.append("GNSS noise")
    P0s.append(np.zeros((N_STATES, N_STATES)))
    gqgs.append(np.zeros((1, N_STATES, N_STATES)))
    nb = 3 if gnss.bias_m > 0 else 0  # the GNSS bias: 3 states after the 36
    k = N_STATES + nb
    P0 = np.zeros((len(P0s) + (1 if nb else 0), k, k))
    P0[: len(P0s), :N_STATES, :N_STATES] = np.stack(P0s)
    if nb:
        names.append("GNSS bias")
        P0[-1, N_STATES:, N_STATES:] = gnss.bias_m**2 * np.eye(3)
        steps = [gnss.bias_step(float(x)) for x in h]
        Phi_b = np.zeros((Phi.shape[0], k, k))
        Phi_b[:, :N_STATES, :N_STATES] = Phi
        Phi_b[:, N_STATES:, N_STATES:] = np.array([a for a, _ in steps])[:, None, None] * np.eye(3)
        Phi = Phi_b

    def q_src(i: int) -> np.ndarray:
        G = np.stack([g[min(i, g.shape[0] - 1)] for g in gqgs])
        Q = _noise_q(np.broadcast_to(Fq[i], G.shape), G, np.full(G.shape[0], h[i]))
        if not nb:
            return Q
        out = np.zeros((Q.shape[0] + 1, k, k))
        out[:-1, :N_STATES, :N_STATES] = Q
        out[-1, N_STATES:, N_STATES:] = steps[i][1] ** 2 * np.eye(3)
        return out

    update = gnss.updates(t)
    noise = np.array([nm == "GNSS noise" for nm in names])
    design, blocks = design_filter(t, update, Phi, (P0, q_src, noise), gnss, [R, V, PSI])
    # fed back into the navigator; the other states stay estimates (propagated open loop)
    design.layout = {"dr": R, "dv": V, "psi": PSI, "acc_bias": BA, "gyro_bias": BG,
                     "acc_gm": GA, "gyro_gm": GG}  # fmt: skip
    for j, name in enumerate(names):
        store(name, blocks[j])
    return design


def covariance_analysis(study: Any, t: np.ndarray | None = None) -> CovarianceResult:
    """σ(t) of a flight study's navigation errors by linear covariance analysis.

    Parameters
    ----------
    study : FlightStudy
        The flight, its IMU, frame and altitude aiding (validated when it was built); the
        gravity models do not enter (see :mod:`fieldmap.nav.budget` for their terms).
    t : numpy.ndarray, optional
        Times (s, from 0, increasing): default the study's output grid.

    Returns
    -------
    CovarianceResult
    """
    from fieldmap.nav import sensors

    traj = study.flight
    ell = traj.frame.ellipsoid
    spec = study.imu
    baro = study.baro
    if t is None:
        dt = study.every / float(study.rate_hz)
        t = dt * np.arange(int(round(study.n_samples / study.every)) + 1)
    t = np.asarray(t, dtype=np.float64)
    gains = (0.0, 0.0, 0.0)
    if study.aiding == "baro":
        from fieldmap.nav.mechanize import baro_gains

        gains = baro_gains(baro.loop_tau_s, ell)
    tm = 0.5 * (t[1:] + t[:-1])
    fl = _flight_at(traj, np.concatenate([t, tm]))
    F_all = _dynamics(fl, ell, gains, spec, baro)
    n = t.size
    F0, F1, Fm = F_all[: n - 1], F_all[1:n], F_all[n:]
    h = np.diff(t)
    Phi = rk4_transition(F0, Fm, F1, h)
    Fq = 0.5 * (F0 + F1)  # F over a step for the noise integral (third order)
    ned = fl.ned[:n]

    gm_a = spec.accel_bias_instability_ug * sensors.UG / sensors.GM_ADEV_PEAK
    gm_g = spec.gyro_bias_instability_deg_per_h * sensors.DEG_H / sensors.GM_ADEV_PEAK
    aided = study.aiding == "baro"
    # constant sources: (name, states, σ)
    const = [
        ("accelerometer bias", BA, spec.accel_bias_ug * sensors.UG),
        ("gyro bias", BG, spec.gyro_bias_deg_per_h * sensors.DEG_H),
        ("accelerometer scale factor", SA, spec.accel_scale_factor_ppm * 1e-6),
        ("accelerometer misalignment", TA, spec.accel_misalignment_arcsec * sensors.ARCSEC),
        ("gyro scale factor", SG, spec.gyro_scale_factor_ppm * 1e-6),
        ("gyro misalignment", TG, spec.gyro_misalignment_arcsec * sensors.ARCSEC),
        ("baro bias", slice(BARO_BIAS, BARO_BIAS + 1), baro.bias_m if aided else 0.0),
    ]
    const = [c for c in const if c[2] > 0]
    # stochastic sources: (name, P0 diagonal (36,), continuous noise GQGᵀ diagonal (36,))
    stoch = []

    def diag(*pairs: tuple[Any, float]) -> np.ndarray:
        d = np.zeros(N_STATES)
        for idx, v in pairs:
            d[idx] = v
        return d

    if gm_a > 0:
        stoch.append(("accelerometer bias instability", diag((GA, gm_a**2)),
                      diag((GA, 2 * gm_a**2 / spec.accel_bias_instability_tau_s))))  # fmt: skip
    if gm_g > 0:
        stoch.append(("gyro bias instability", diag((GG, gm_g**2)),
                      diag((GG, 2 * gm_g**2 / spec.gyro_bias_instability_tau_s))))  # fmt: skip
    vrw = spec.accel_vrw_ug_per_sqrt_hz * sensors.UG
    arw = spec.gyro_arw_deg_per_sqrt_h * sensors.DEG_RTH
    if vrw > 0:
        stoch.append(("velocity random walk", diag(), diag((V, vrw**2))))
    if arw > 0:
        stoch.append(("angle random walk", diag(), diag((PSI, arw**2))))
    if aided and baro.drift_m > 0:
        stoch.append(("baro drift", diag((BARO_DRIFT, baro.drift_m**2)),
                      diag((BARO_DRIFT, 2 * baro.drift_m**2 / baro.drift_tau_s))))  # fmt: skip
    noise_baro = None
    if aided and baro.noise_m > 0:
        # white height noise of density noise_m²/rate (the kernel's per-sample draws) entering
        # the loop as the baro bias does: G = the bias column of F
        gcol = F_all[:n, :, BARO_BIAS].copy()
        noise_baro = (baro.noise_m**2 / baro.rate_hz) * gcol[:, :, None] * gcol[:, None, :]

    pos: dict[str, np.ndarray] = {}
    vel: dict[str, np.ndarray] = {}
    att: dict[str, np.ndarray] = {}

    def store(name: str, P: np.ndarray) -> None:
        """P (n, 36, 36), or its blocks (n, 3, 3, 3) → σ NED of position, velocity, attitude."""
        for b, (d, sl) in enumerate(((pos, R), (vel, V), (att, PSI))):
            blk = P[:, b] if P.ndim == 4 else P[:, sl, sl]
            d[name] = np.sqrt(np.maximum(np.einsum("nij,njk,nik->ni", ned, blk, ned), 0.0))

    gnss = getattr(study, "gnss", None)
    if gnss is not None:
        design = _aided(t, gnss, Phi, Fq, h, const, stoch, noise_baro, store)
        present = [s for s in SOURCES if s in pos]
        return CovarianceResult(
            t, present, {s: pos[s] for s in present}, {s: vel[s] for s in present},
            {s: att[s] for s in present}, design,
        )  # fmt: skip
    # constant sources: sensitivity columns S = Φ(t, 0)[:, cols]
    if const:
        cols = np.concatenate([np.arange(N_STATES)[c[1]] for c in const])
        S = np.zeros((n, N_STATES, cols.size))
        S[0, cols, np.arange(cols.size)] = 1.0
        for i in range(n - 1):
            S[i + 1] = Phi[i] @ S[i]
        j = 0
        for name, sl, sigma in const:
            k = len(np.arange(N_STATES)[sl])
            Sk = S[:, :, j : j + k]
            store(name, sigma**2 * Sk @ np.swapaxes(Sk, -1, -2))
            j += k
    # stochastic sources: each its own recursion, on the states it can reach (F's graph)
    reach = np.any(F_all != 0.0, axis=0)  # reach[i, j]: state j feeds state i
    PhiT = np.swapaxes(Phi, -1, -2)
    runs: list[tuple[str, np.ndarray, np.ndarray]] = [
        (name, p0, np.broadcast_to(np.diag(q), (1, N_STATES, N_STATES))) for name, p0, q in stoch
    ]
    if noise_baro is not None:
        runs.append(("baro noise", np.zeros(N_STATES), 0.5 * (noise_baro[:-1] + noise_baro[1:])))
    for name, p0, gqg in runs:
        seed = (p0 != 0) | np.any(np.diagonal(gqg, axis1=1, axis2=2) != 0, axis=0)
        idx = _reachable(reach, np.flatnonzero(seed))
        ix = np.ix_(idx, idx)
        Ph, PhT = Phi[:, idx][:, :, idx], PhiT[:, idx][:, :, idx]
        Qs = _noise_q(Fq[:, idx][:, :, idx], gqg[:, idx][:, :, idx], h)
        P = np.diag(p0[idx])
        out = np.zeros((n, N_STATES, N_STATES))
        out[0][ix] = P
        for i in range(n - 1):
            P = Ph[i] @ P @ PhT[i] + Qs[i]
            out[i + 1][ix] = P
        store(name, out)
    present = [s for s in SOURCES if s in pos]
    return CovarianceResult(
        t,
        present,
        {s: pos[s] for s in present},
        {s: vel[s] for s in present},
        {s: att[s] for s in present},
    )


@dataclass
class CovarianceStudyResult:
    """A flight study by covariance analysis: σ(t) per source, the gravity budget, a summary.

    ``t`` (n,) s; ``track`` the true lat, lon, h (n, 3); ``covariance`` the IMU's (and baro's)
    :class:`CovarianceResult`; ``dg`` {model: (n, 3)} the model difference g_model − g_truth
    (NED, m/s²); ``budget`` the gravity terms through the linear error model
    (:class:`fieldmap.nav.budget.GravityBudget`); ``summary`` the JSON document.
    """

    t: np.ndarray
    track: np.ndarray
    covariance: CovarianceResult
    dg: dict
    budget: Any
    summary: dict
    diverged: list = field(default_factory=list)

    def plot(self, kind: str = "errors") -> Figure:
        """Draw the study as a :class:`matplotlib.figure.Figure` (``fig.savefig("f.png")``).

        Parameters
        ----------
        kind : {"errors", "budget", "track"}
            ``"errors"`` (default): σ(t) of the horizontal and vertical position error per
            error source, with the gravity terms, the recommendation as the caption
            (``navsim_flight.png``); ``"budget"``: the error budget, one bar per error source,
            sorted, the gravity terms (a) model difference, (b) omission, (c) commission beside
            the IMU's, at the flight's end or at the end of the worst GNSS outage
            (``navsim_flight_budget.png``); ``"track"``: the ground track.
            See :mod:`fieldmap.nav.plots`.
        """
        from fieldmap.nav.plots import flight_figure

        return flight_figure(self, kind)

    def to_dataset(self) -> Any:
        """σ(t) per source and the gravity terms as an ``xarray.Dataset`` (CF-1.8)."""
        import json

        import xarray as xr

        from fieldmap.nav.cf import flown_path, indexed_labels, labels

        cov = self.covariance
        src = list(cov.sources)
        models = list(self.dg)
        axis = np.array(["north", "east", "down"])

        def stack(d: dict) -> np.ndarray:
            return np.stack([d[s] for s in src]) if src else np.zeros((0, self.t.size, 3))

        b = self.budget
        grav = (
            np.stack([b.curves(m)[1:] for m in models])  # (a), (b), (c)
            if models
            else np.zeros((0, 3, self.t.size, 3))
        )
        ds = xr.Dataset(
            {
                "position_sigma": (
                    ("source", "time", "axis"),
                    stack(cov.position),
                    {
                        "units": "m",
                        "long_name": "standard deviation of the "
                        "position error due to each source, NED",
                    },
                ),
                "velocity_sigma": (
                    ("source", "time", "axis"),
                    stack(cov.velocity),
                    {
                        "units": "m s-1",
                        "long_name": "standard deviation of the "
                        "velocity error due to each source, NED",
                    },
                ),
                "attitude_sigma": (
                    ("source", "time", "axis"),
                    stack(cov.attitude),
                    {
                        "units": "rad",
                        "long_name": "standard deviation of the "
                        "attitude error due to each source, about N, E, D",
                    },
                ),
                "gravity_contribution": (
                    ("model", "gravity_term", "time", "axis"),
                    grav,
                    {
                        "units": "m",
                        "long_name": "position error due to "
                        "each gravity term (RMS over draws), NED",
                    },
                ),
            },  # fmt: skip
            coords={
                "time": ("time", self.t, {"units": "s", "long_name": "time since the start"}),
                **flown_path(self.track),
                **labels(
                    source=(src, "error source of the IMU (and of the baro loop)"),
                    model=(models, "navigation gravity model"),
                    gravity_term=(
                        ("model_difference", "omission", "commission"),
                        "term of the gravity error budget",
                    ),
                    axis=(axis, "axis of the local level frame (north, east, down)"),
                ),
            },  # fmt: skip
            attrs={
                "Conventions": "CF-1.8",
                "title": "fieldmap navsim flight study, linear covariance analysis",
                "meta": json.dumps(self.summary["meta"], default=float),
            },
        )
        if "gnss" in self.summary:
            from fieldmap.nav.aiding import add_to_dataset

            ds = add_to_dataset(ds, self.summary, self.covariance.horizontal())
        return indexed_labels(ds)


def covariance_study(study: Any, device: str | None = None) -> CovarianceStudyResult:
    """Answer a :class:`~fieldmap.nav.study.FlightStudy` by covariance analysis (no Monte Carlo).

    The IMU's (and baro's) error σ(t) by :func:`covariance_analysis`, each navigation model's
    gravity contribution by :func:`fieldmap.nav.budget.gravity_budget`, and the same
    recommendation as the Monte Carlo study (:func:`fieldmap.nav.study.recommend`), the IMU's
    own error being the covariance's final horizontal σ.
    """
    import time

    from fieldmap.nav.budget import gravity_budget, gravity_error_along, recommend, simplicity_order
    from fieldmap.nav.trajectory import geodetic_state

    c0 = time.perf_counter()
    traj = study.flight
    ell = traj.frame.ellipsoid
    dt = study.every / float(study.rate_hz)
    cov = covariance_analysis(study)  # on the study's output grid
    t = cov.t
    c1 = time.perf_counter()
    lat, lon, h, _, _ = geodetic_state(traj, t)
    track = np.stack([lat, lon, h], -1)
    names = list(study.models)
    dg, _ = gravity_error_along(track, t, names, study.truth, ell, device)
    gains = None
    if study.aiding == "baro":
        from fieldmap.nav.mechanize import baro_gains

        gains = baro_gains(study.baro.loop_tau_s, ell)
    if study.gnss is None:
        budget = gravity_budget(t, track, dg, study.truth, study.gravity_terms, ell, gains, device)
    else:  # the gravity terms through the filter's closed loop
        from fieldmap.nav.aiding import aided_response
        from fieldmap.nav.budget import gravity_inputs

        inp = gravity_inputs(t, track, dg, study.truth, study.gravity_terms, ell, device)
        budget = inp.budget(aided_response(cov.design, track, inp.stack, ell))
    c2 = time.perf_counter()
    tot = cov.total()[-1]
    imu_h = float(np.hypot(tot[0], tot[1]))
    imu_v = float(tot[2])
    doc: dict[str, Any] = {
        "meta": {
            "method": "covariance",
            "trajectory": traj.name,
            "duration_s": float(t[-1]),
            "imu": study.imu_name,
            "imu_spec": study.imu.__dict__,
            "frame": study.frame,
            "altitude_aiding": study.aiding,
            "baro": study.baro.__dict__ if study.aiding == "baro" else None,
            "gnss": None if study.gnss is None else study.gnss.__dict__,
            "truth_model": study.truth.name,
            "truth_degree": int(study.truth.lmax),
            "truth_tide_system": study.truth.tide_system,
            "output_dt_s": float(dt),
            "covariance_seconds": c1 - c0,
            "gravity_budget_seconds": c2 - c1,
        },
        "fraction": study.fraction,
        "sources": {
            s: {
                "final_horizontal_sigma_m": float(cov.horizontal(s)[-1]),
                "final_vertical_sigma_m": float(cov.position[s][-1, 2]),
            }
            for s in cov.sources
        },
        "imu_only_horizontal_error_m": imu_h,
        "imu_only_vertical_error_m": imu_v,
        "models": {},
    }
    for m in names:
        g = budget.summary(m)
        doc["models"][m] = {
            "gravity": g,
            "final_horizontal_error_m": float(np.hypot(imu_h, g["horizontal_m"])),
            "final_vertical_error_m": float(np.hypot(imu_v, g["vertical_m"])),
            "diverged": False,
        }
    recommend(doc, simplicity_order(names), imu_h, study.fraction, True, study.truth.lmax)
    doc["diverged"] = []
    res = CovarianceStudyResult(t, track, cov, dg, budget, doc)
    if study.gnss is not None:
        from fieldmap.nav.aiding import coasting_summary

        coasting_summary(doc, res, study.gnss, cov.horizontal())
    return res
