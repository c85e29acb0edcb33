r"""GNSS-aided navigation through outages: a loosely coupled error-state Kalman filter.

The navigator integrates its IMU (:mod:`fieldmap.nav.mechanize`) and, at each GNSS epoch,
compares its position (and velocity) with the receiver's fix; a Kalman filter on the error state
of :mod:`fieldmap.nav.covariance` (36 states: position, velocity, attitude, sensor biases, scale
factors, misalignments, baro loop) estimates the errors, and the estimates of the navigation
state and of the IMU biases are **fed back** (Groves 2013 §14.1.1, "closed-loop" correction):
the strapdown is corrected and goes on from the corrected state, the filter's estimate of those
states set back to zero. During an outage no fix arrives: the navigator coasts on its IMU, and
the gravity model's error shows in how fast its error grows.

Measurement model (ECEF, loosely coupled; Groves 2013 eq. 14.101 without the lever arm):

.. math::
    z_r = \hat r - \tilde r_\mathrm{GNSS} = \delta r - n_r,\qquad
    z_v = \hat v - \tilde v_\mathrm{GNSS} = \delta v - n_v ,

n white, σ per axis (``sigma_m``, ``velocity_sigma_mps``; isotropic, so the same in NED and
ECEF). Update (Joseph form, Bucy & Joseph 1968; Groves 2013 eq. 3.25):

.. math::
    K = P^- H^\mathsf{T} (H P^- H^\mathsf{T} + R)^{-1},\qquad
    P^+ = (I - K H) P^- (I - K H)^\mathsf{T} + K R K^\mathsf{T} .

The Joseph form holds for any gain, so with the gains of the whole filter each error source's
own covariance goes through the same recursion (R entering only the GNSS noise's): the sources
still add up to the total, and the error budget of a free-inertial flight carries over to an
aided one. A deterministic input (a gravity model's error) goes through the closed loop
x⁺ = (I − K H) x⁻ (:func:`closed_loop`).

The filter is designed on the true trajectory (a simulation: the gains of every Monte Carlo draw
are the same, and equal to those of the covariance analysis); the Monte Carlo draws differ in
their errors, GNSS noise and feedback (:class:`FeedbackFilter`).

Outages: intervals ``START:DURATION`` (seconds, or with a unit ``s``, ``min``, ``h``:
``20min:5min``), comma-separated, or a pattern ``every PERIOD:DURATION`` (an outage of DURATION
starting at PERIOD, 2·PERIOD, … while it ends within the flight: ``every 30min:5min``). No
update happens at an epoch t with START ≤ t < START + DURATION; the *coasting error* of an
outage is the error just before the first update after it, at START + DURATION.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fieldmap.errors import InputError, Keyword, Label

__all__ = [
    "FeedbackFilter", "FilterDesign", "GnssSpec", "add_to_dataset", "aided_response",
    "closed_loop", "coasting_summary", "design_filter", "format_gnss",
    "nees_bounds", "nees_summary", "outage_ends", "parse_outages",
]  # fmt: skip


def _seconds(text: str, what: str) -> float:
    """Return a start, duration or period of ``outages`` in s (:mod:`fieldmap.durations`)."""
    from fieldmap.durations import seconds

    try:
        v = seconds(text, param="gnss.outages", what=what)
    except InputError as exc:
        raise InputError(Keyword("gnss.outages"), f": {exc}", param="gnss.outages") from None
    if not np.isfinite(v):
        raise InputError(
            Keyword("gnss.outages"),
            f": {what} {text.strip()!r} is not finite",
            param="gnss.outages",
        )
    return v


def parse_outages(text: str) -> tuple[tuple[tuple[float, float], ...], tuple[float, float] | None]:
    """Parse ``"START:DURATION[,...]"`` or ``"every PERIOD:DURATION"`` → (intervals, pattern).

    Units: s (a number, or with a unit ``s``, ``min``, ``h``).
    """
    s = str(text).strip()
    if not s or s.lower() == "none":
        return (), None
    every = s.lower().startswith("every")
    body = s[5:] if every else s
    pairs = []
    for part in body.split(","):
        bits = part.split(":")
        if len(bits) != 2:
            raise InputError(
                Keyword("gnss.outages"),
                f": {part.strip()!r} is not START:DURATION (e.g. 600:300, "
                "20min:5min, or every 30min:5min)",
                param="gnss.outages",
            )
        pairs.append(
            (_seconds(bits[0], "period" if every else "start"), _seconds(bits[1], "duration"))
        )
    if every:
        if len(pairs) != 1:
            raise InputError(
                Keyword("gnss.outages"),
                ": one PERIOD:DURATION after 'every'",
                param="gnss.outages",
            )
        return (), pairs[0]
    return tuple(pairs), None


@dataclass(frozen=True)
class GnssSpec:
    """GNSS aiding of a flight study: fix rate, noise and outages (validated once).

    Parameters
    ----------
    rate_hz : float
        Fix rate; at most the IMU's, a whole number of IMU samples apart (checked by the
        study). Units: Hz.
    sigma_m : float
        White noise of each position component (N, E, D), 1σ. Units: m.
    velocity_sigma_mps : float or None
        White noise of each velocity component, 1σ; None: position fixes only. Units: m/s.
    outages : str or sequence of (start, duration)
        ``"600:300,2400:300"``, ``"every 30min:5min"`` (see the module docstring), or pairs in
        seconds. Checked against the flight by the study (inside it, not overlapping).
    bias_m : float
        A Gauss–Markov bias of each position component (first order, stationary), 1σ, besides
        the white noise; 0: none. Units: m.
    bias_tau_s : float
        Its correlation time. Units: s.
    """

    rate_hz: float = 1.0
    sigma_m: float = 2.0
    velocity_sigma_mps: float | None = 0.05
    outages: Any = ()
    bias_m: float = 0.0
    bias_tau_s: float = 600.0
    #: a pattern (period, duration) in s, or None (resolved from ``outages``)
    every: tuple[float, float] | None = field(init=False, default=None)

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        b = self.bias_m
        if (
            isinstance(b, (str, bool))
            or not isinstance(b, (int, float, np.number))
            or not (np.isfinite(b) and b >= 0)
        ):
            raise InputError(
                Keyword("gnss.bias_m"), f" must be a number >= 0, got {b!r}", param="gnss.bias_m"
            )
        put("bias_m", float(b))
        for name, v in (("rate_hz", self.rate_hz), ("sigma_m", self.sigma_m),
                        ("velocity_sigma_mps", self.velocity_sigma_mps),
                        ("bias_tau_s", self.bias_tau_s)):  # fmt: skip
            if name == "velocity_sigma_mps" and v is None:
                continue
            if isinstance(v, (str, bool)) or not isinstance(v, (int, float, np.number)):
                raise InputError(
                    Keyword(f"gnss.{name}"), f" must be a number, got {v!r}", param=f"gnss.{name}"
                )
            if not np.isfinite(v) or v <= 0:
                raise InputError(
                    Keyword(f"gnss.{name}"),
                    f" must be a positive number, got {v:g}",
                    param=f"gnss.{name}",
                )
            put(name, float(v))
        out = self.outages
        if isinstance(out, str):
            pairs, every = parse_outages(out)
        else:
            try:
                pairs = tuple((float(a), float(b)) for a, b in (out or ()))
            except (TypeError, ValueError):
                raise InputError(
                    Keyword("gnss.outages"),
                    " must be a string or (start, duration) pairs in s",
                    param="gnss.outages",
                ) from None
            every = None
        for a, d in pairs + ((every,) if every else ()):
            if not (np.isfinite(a) and np.isfinite(d)) or d <= 0 or a < 0:
                raise InputError(
                    Keyword("gnss.outages"),
                    f": an outage starts at {a:g} s and lasts {d:g} s: the start "
                    "must be >= 0 and the duration > 0",
                    param="gnss.outages",
                )
        order = sorted(pairs)
        for (a0, d0), (a1, _) in zip(order, order[1:]):
            if a1 < a0 + d0:
                raise InputError(
                    Keyword("gnss.outages"),
                    f": the outages {a0:g}:{d0:g} and {a1:g}:{_:g} overlap",
                    param="gnss.outages",
                )
        if every is not None and every[1] >= every[0]:
            raise InputError(
                Keyword("gnss.outages"),
                f": every {every[0]:g}:{every[1]:g} s: outages as long as their period "
                "overlap (no fix at all)",
                param="gnss.outages",
            )
        put("outages", tuple(order))
        put("every", every)

    def intervals(self, duration: float) -> np.ndarray:
        """(k, 2) start and end (s) of the outages of a flight of ``duration`` s."""
        if self.every is None:
            return np.array(self.outages, dtype=np.float64).reshape(-1, 2) @ np.array(
                [[1.0, 1.0], [0.0, 1.0]]
            )
        p, d = self.every
        starts = p * np.arange(1, int(np.floor(duration / p + 1e-9)) + 1)
        starts = starts[starts + d <= duration * (1 + 1e-12)]
        return np.stack([starts, starts + d], -1).reshape(-1, 2)

    def check_flight(self, duration: float, imu_rate_hz: float) -> None:
        """Refuse (one line) a rate above the IMU's and outages outside a flight of ``duration``."""
        if self.rate_hz > imu_rate_hz * (1 + 1e-12):
            raise InputError(
                Keyword("gnss.rate_hz"),
                f" {self.rate_hz:g} Hz is above the IMU rate {imu_rate_hz:g} Hz",
                Label("rate_hz"),
                param="gnss.rate_hz",
            )
        k = imu_rate_hz / self.rate_hz
        if abs(k - round(k)) > 1e-9 * k:
            raise InputError(
                Keyword("gnss.rate_hz"),
                f" {self.rate_hz:g} Hz: its fixes are not a whole number of IMU "
                f"samples apart at {imu_rate_hz:g} Hz",
                Label("rate_hz"),
                param="gnss.rate_hz",
            )
        iv = self.intervals(duration)
        if self.every is not None and iv.shape[0] == 0:
            raise InputError(
                Keyword("gnss.outages"),
                f": every {self.every[0]:g}:{self.every[1]:g} s has no outage within "
                f"the flight's {duration:g} s",
                param="gnss.outages",
            )
        for a, b in iv:
            if b > duration * (1 + 1e-12):
                raise InputError(
                    Keyword("gnss.outages"),
                    f": the outage {a:g}:{b - a:g} s ends after the flight's {duration:g} s",
                    Label("duration"),
                    param="gnss.outages",
                )

    def updates(self, t: np.ndarray) -> np.ndarray:
        """Mask of the times ``t`` (on the fix grid) at which a fix arrives (not t = 0)."""
        t = np.asarray(t, dtype=np.float64)
        k = t * self.rate_hz
        on = (np.abs(k - np.round(k)) < 1e-6) & (t > 0)
        for a, b in self.intervals(float(t[-1]) if t.size else 0.0):
            on &= ~((t >= a - 1e-9) & (t < b - 1e-9))
        return on

    def fix_noise(self, seed: int, i: int, n_draws: int) -> np.ndarray:
        """Errors (n_draws, 3 or 6) of the fix at output index ``i``: position, velocity (ECEF).

        White, σ per axis; drawn from ``numpy.random.default_rng([seed, 7, i])`` (standard
        normals, one row per draw, scaled), the same for every gravity model of a draw.
        Units: m, m/s.
        """
        rng = np.random.default_rng([int(seed), 7, int(i)])
        return rng.standard_normal((n_draws, self.n_meas)) * np.sqrt(np.diag(self.r_matrix()))

    @property
    def n_meas(self) -> int:
        """Measurement components per fix (3 or 6)."""
        return 3 if self.velocity_sigma_mps is None else 6

    def r_matrix(self) -> np.ndarray:
        """R (m, m) of one fix (m², m²/s²)."""
        d = [self.sigma_m**2] * 3
        if self.velocity_sigma_mps is not None:
            d += [self.velocity_sigma_mps**2] * 3
        return np.diag(d)

    def h_matrix(self, n_states: int) -> np.ndarray:
        """H (m, n_states): δr in states 0–2, δv in 3–5; with a bias, its 3 states last."""
        H = np.zeros((self.n_meas, n_states))
        H[:, : self.n_meas] = np.eye(self.n_meas)
        if self.bias_m > 0:
            H[0:3, n_states - 3 :] = np.eye(3)
        return H

    def bias_step(self, h: float) -> tuple[float, float]:
        """Return the bias's Gauss–Markov step over h s: (e^(−h/τ), σ √(1 − e^(−2h/τ)))."""
        a = float(np.exp(-h / self.bias_tau_s))
        return a, self.bias_m * float(np.sqrt(-np.expm1(-2.0 * h / self.bias_tau_s)))


@dataclass
class FilterDesign:
    """The filter of an aided study on its time grid (a priori covariances, gains).

    ``t`` (n,) s; ``update`` (n,) bool: a fix is used at t_i (after storing P⁻_i); ``Phi``
    (n−1, k, k) the transitions between grid times; ``P`` (n, k, k) the a priori covariance;
    ``K`` (n, k, m) the gains (zero where no update); ``H`` (m, k); ``R`` (m, m).
    """

    t: np.ndarray
    update: np.ndarray
    Phi: np.ndarray
    P: np.ndarray
    K: np.ndarray
    H: np.ndarray
    R: np.ndarray
    #: where the fed-back errors sit in the state ({"dr": slice, "dv", "psi", "acc_bias",
    #: "gyro_bias", "acc_gm", "gyro_gm"}), set by the model's owner (fieldmap.nav.covariance)
    layout: dict = field(default_factory=dict)


def design_filter(
    t: np.ndarray, update: np.ndarray, Phi: np.ndarray, sources: tuple, gnss: Any, keep: list
) -> tuple[FilterDesign, np.ndarray]:
    """Run the Kalman filter's covariance along the grid, and each error source's through it.

    ``sources`` = ``(P0, q, noise)``: P0 (s, k, k) each source's covariance at t[0]; ``q(i)``
    (s, k, k) each source's process noise over step i; ``noise`` (s,) bool, the source that
    takes the fixes' K R Kᵀ (the GNSS noise). The filter's P is their sum; its gains K come
    from it (Joseph-form updates at the times of ``update``, module docstring), and each
    source goes through the same gains, P_s⁺ = (I − K H) P_s (I − K H)ᵀ (+ K R Kᵀ), so the
    sources add up to the filter's P at every time. ``keep`` (slices): the diagonal blocks of
    each source's a priori covariance returned, shape (s, n, len(keep), 3, 3).
    """
    P0s, q, noise = sources
    n, k = t.size, P0s.shape[-1]
    H, R = gnss.h_matrix(k), gnss.r_matrix()
    I = np.eye(k)  # noqa: E741
    P = P0s.sum(0)
    Psrc = P0s.copy()
    w = np.asarray(noise, dtype=np.float64)[:, None, None]
    Ps = np.empty((n, k, k))
    Ks = np.zeros((n, k, H.shape[0]))
    blocks = np.empty((P0s.shape[0], n, len(keep), 3, 3))
    for i in range(n):
        Ps[i] = P
        for b, sl in enumerate(keep):
            blocks[:, i, b] = Psrc[:, sl, sl]
        if i == n - 1:
            break
        Qi = q(i)
        F = Phi[i]
        if update[i]:
            S = H @ P @ H.T + R
            K = np.linalg.solve(S, H @ P).T  # P Hᵀ S⁻¹ (S, P symmetric)
            Ks[i] = K
            A = F @ (I - K @ H)  # the update and the step in one transition
            FK = F @ K
            KRK = FK @ R @ FK.T
            P = A @ P @ A.T + KRK
            Psrc = A @ Psrc @ A.T + w * KRK
        else:
            P = F @ P @ F.T
            Psrc = F @ Psrc @ F.T
        Psrc = Psrc + Qi
        P = P + Qi.sum(0)
        P = 0.5 * (P + P.T)
    return FilterDesign(t, update, Phi, Ps, Ks, H, R), blocks


def closed_loop(design: FilterDesign, u: np.ndarray) -> np.ndarray:
    """States (s, n, k) driven by accelerations ``u`` (s, n, 3) on the velocity error (ECEF).

    x_{i+1} = Φ_i x_i⁺ + h_i/2 (Φ_i B u_i + B u_{i+1}) (the trapezoid rule, B the velocity
    rows), x_i⁺ = (I − K_i H) x_i where a fix is used at t_i, x_i elsewhere; x_0 = 0; a priori
    values stored. Units: m/s² → the state's.
    """
    d = design
    s, n, k = u.shape[0], d.t.size, d.H.shape[1]
    h = np.diff(d.t)
    x = np.zeros((s, k))
    out = np.zeros((s, n, k))
    for i in range(n - 1):
        if d.update[i]:
            x = x - (x @ d.H.T) @ d.K[i].T
        x = x @ d.Phi[i].T + 0.5 * h[i] * (u[:, i] @ d.Phi[i][:, 3:6].T)
        x[:, 3:6] += 0.5 * h[i] * u[:, i + 1]
        out[:, i + 1] = x
    return out


def aided_response(design: FilterDesign, track: np.ndarray, dg_ned: np.ndarray, ell: Any) -> Any:
    """NED position errors (k, n, 3) of aided navigators whose only error is ``dg_ned`` (k, n, 3).

    The gravity errors (m/s², north/east/down at the true ``track`` points, degrees, degrees,
    m) drive the velocity error through the filter's closed loop (:func:`closed_loop`): the
    aided counterpart of :func:`fieldmap.nav.linear.position_response`. Units: m.
    """
    from fieldmap.nav.frames import C_n_to_e

    Cne = C_n_to_e(track[:, 0], track[:, 1])  # (n, 3, 3) columns N, E, D in ECEF
    u = np.einsum("nij,knj->kni", Cne, np.asarray(dg_ned, dtype=np.float64))
    x = closed_loop(design, u)
    return np.einsum("nji,knj->kni", Cne, x[..., 0:3])


def nees_bounds(n_draws: int, dim: int, p: float = 0.95) -> tuple[float, float]:
    """Two-sided ``p`` bounds of the mean NEES over ``n_draws`` draws (χ²(n·dim)/n)."""
    from scipy.stats import chi2

    a = (1.0 - p) / 2.0
    nd = n_draws * dim
    return float(chi2.ppf(a, nd) / n_draws), float(chi2.ppf(1.0 - a, nd) / n_draws)


class FeedbackFilter:
    """The Monte Carlo's filter: one estimate per run, the design's gains, feedback at fixes.

    ``design`` the :class:`FilterDesign` (gains common to all runs); ``draw`` (n_runs,) the
    draw of each run (runs of one draw see the same GNSS noise); ``seed`` of the GNSS noise;
    ``n_draws`` the draws.
    """

    def __init__(
        self, design: FilterDesign, gnss: GnssSpec, draw: np.ndarray, seed: int, grid: tuple
    ) -> None:
        self.d = design
        #: IMU sample interval (s), samples per stored state and per fix, the ellipsoid
        self.dt, self.every, self.per_fix, self.ellipsoid = grid
        self.gnss = gnss
        self.draw = np.asarray(draw)
        self.seed = int(seed)
        n, k = self.draw.size, design.H.shape[1]
        self.x = np.zeros((n, k))
        self.i_last = 0  # grid index of the estimate
        #: the GNSS bias of each draw (n_draws, 3) m at time ``t_bias`` s (None: not started)
        self.bias: np.ndarray | None = None
        self.t_bias = 0.0
        #: NEES of position and velocity at each fix (n_fix, n_runs), and the fix indices
        self.nees: list[np.ndarray] = []
        self.nees_at: list[int] = []

    def propagate_to(self, i: int) -> None:
        """Carry the estimate from grid index ``i_last`` to ``i`` (open loop, Φ)."""
        for j in range(self.i_last, i):
            self.x = self.x @ self.d.Phi[j].T
        self.i_last = i

    def update(self, i: int, err: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Use the fix at grid index ``i`` given the runs' true errors; return the corrections.

        ``err``: ``dr``, ``dv`` (n_runs, 3) ECEF errors of the navigated state (m, m/s);
        ``psi`` the attitude errors (rad). Returns the estimated errors to remove: ``dr``,
        ``dv``, ``psi``, ``acc_bias``, ``gyro_bias``, ``acc_gm``, ``gyro_gm`` (n_runs, 3).
        """
        self.propagate_to(i)
        d, g = self.d, self.gnss
        nd = int(self.draw.max()) + 1 if self.draw.size else 0
        noise = g.fix_noise(self.seed, i, nd)
        if g.bias_m > 0:  # the bias of each draw, carried from fix to fix (stationary start)
            if self.bias is None:
                rng = np.random.default_rng([self.seed, 8])
                self.bias = g.bias_m * rng.standard_normal((nd, 3))
                self.t_bias = 0.0
            a, q = g.bias_step(float(d.t[i]) - self.t_bias)
            rng = np.random.default_rng([self.seed, 8, i])
            self.bias = a * self.bias + q * rng.standard_normal((nd, 3))
            self.t_bias = float(d.t[i])
            noise[:, 0:3] += self.bias
        noise = noise[self.draw]
        true = np.concatenate([err["dr"], err["dv"]], -1)[:, : g.n_meas]
        z = true - noise
        # NEES of δr, δv (the filter's a priori error: truth less estimate)
        rv = np.r_[
            np.arange(self.x.shape[1])[d.layout["dr"]], np.arange(self.x.shape[1])[d.layout["dv"]]
        ]
        e = np.concatenate([err["dr"], err["dv"]], -1) - self.x[:, rv]
        P = d.P[i][np.ix_(rv, rv)]
        # pseudo-inverse: with few error sources P may be singular (the NEES then on its range)
        self.nees.append(np.einsum("ni,ij,nj->n", e, np.linalg.pinv(P, hermitian=True), e))
        self.nees_at.append(i)
        self.x = self.x + (z - self.x @ d.H.T) @ d.K[i].T
        fb = {k: self.x[:, sl].copy() for k, sl in d.layout.items()}
        for sl in d.layout.values():
            self.x[:, sl] = 0.0
        return fb

    def fly_block(self, prop: Any, block: tuple, s0: int, truth: Any) -> dict[str, np.ndarray]:
        """Propagate a block of increments in segments between fixes, feeding back at each.

        ``prop`` the :class:`~fieldmap.nav.propagator.Propagator` (NED; its runs those of the
        filter); ``block`` ``(dtheta, dv, h_ref)`` of the block (``h_ref`` None without baro);
        ``s0`` its first sample; ``truth(t)`` the true ECEF position, velocity and C_b^e at a
        time (1,)-array. Returns the stored states as :meth:`Propagator.propagate` does
        (``lat``, ``lon`` deg, ``h``, ``v``, ``C`` C_b^n), each the navigator's output: the
        strapdown's state less the filter's estimate of its error at that time (nonzero between
        fixes where states not fed back, e.g. scale factors, drive it); at a fix, before its
        update (a priori).
        """
        from fieldmap.nav.mechanize import quat_to_dcm

        dth, dvel, h_ref = block
        every, per_fix = self.every, self.per_fix
        nb = np.shape(dth)[1]
        cuts = [a for a in range(s0 + 1, s0 + nb) if a % per_fix == 0] + [s0 + nb]
        parts: list[dict[str, np.ndarray]] = []
        a = s0
        for b in cuts:
            sl = slice(a - s0, b - s0)
            href = None if h_ref is None else np.asarray(h_ref)[..., sl]
            out = prop.propagate(dth[:, sl], dvel[:, sl], a, href)
            out = {"lat": out["lat"], "lon": out["lon"], "h": out["h"], "v": out["v"],
                   "C": quat_to_dcm(out["q"])}  # fmt: skip
            first = 0 if not parts else 1
            out = {k: v[:, first:] for k, v in out.items()}
            idx = a // every + first + np.arange(out["h"].shape[1])
            lay = self.d.layout
            xs = np.empty((self.x.shape[0], idx.size, 9))
            for j, gi in enumerate(idx):
                self.propagate_to(int(gi))
                xs[:, j] = np.concatenate([self.x[:, lay["dr"]], self.x[:, lay["dv"]],
                                           self.x[:, lay["psi"]]], -1)  # fmt: skip
            if np.any(xs):
                shp = out["h"].shape
                new = self._apply(
                    {k: v.reshape((-1,) + v.shape[2:]) for k, v in out.items()},
                    xs.reshape(-1, 9),
                )
                out = {k: v.reshape(shp + v.shape[1:]) for k, v in new.items()}
            parts.append(out)
            i = b // every
            if b % per_fix == 0 and self.d.update[i]:
                self._feedback(prop, i, truth(np.array([b * self.dt])))
            a = b
        return {k: np.concatenate([p[k] for p in parts], axis=1) for k in parts[0]}

    def _apply(self, nav: dict[str, np.ndarray], x: np.ndarray) -> dict[str, np.ndarray]:
        """Remove estimated errors x (n, 9: δr, δv ECEF, ψ) from NED states (n,)."""
        from scipy.spatial.transform import Rotation

        from fieldmap.field.frames import ecef_to_geodetic, geodetic_to_ecef
        from fieldmap.nav.frames import C_n_to_e

        r = np.stack(geodetic_to_ecef(nav["lat"], nav["lon"], nav["h"], self.ellipsoid), -1)
        Cne = C_n_to_e(nav["lat"], nav["lon"])
        v = np.einsum("nij,nj->ni", Cne, nav["v"]) - x[:, 3:6]
        C = Rotation.from_rotvec(x[:, 6:9]).as_matrix() @ (Cne @ nav["C"])
        r = r - x[:, 0:3]
        lat, lon, h = ecef_to_geodetic(r[:, 0], r[:, 1], r[:, 2], self.ellipsoid)
        Cen = np.swapaxes(C_n_to_e(lat, lon), -1, -2)
        return {"lat": lat, "lon": lon, "h": h, "v": np.einsum("nij,nj->ni", Cen, v),
                "C": Cen @ C}  # fmt: skip

    def _feedback(self, prop: Any, i: int, truth: tuple) -> None:
        """Update at grid index ``i`` and apply the corrections to the propagator's runs."""
        from fieldmap.field.frames import geodetic_to_ecef
        from fieldmap.nav.frames import C_n_to_e
        from fieldmap.nav.mechanize import dcm_to_quat, quat_to_dcm

        r_t, v_t, C_t = truth
        st = prop.get_state()
        nav = {"lat": np.degrees(st["llh"][:, 0]), "lon": np.degrees(st["llh"][:, 1]),
               "h": st["llh"][:, 2], "v": st["v"], "C": quat_to_dcm(st["q"])}  # fmt: skip
        r = np.stack(geodetic_to_ecef(nav["lat"], nav["lon"], nav["h"], self.ellipsoid), -1)
        Cne = C_n_to_e(nav["lat"], nav["lon"])
        v = np.einsum("nij,nj->ni", Cne, nav["v"])
        E = (Cne @ nav["C"]) @ C_t.T  # Ĉ Cᵀ = I − [ψ×]
        S = 0.5 * (np.swapaxes(E, -1, -2) - E)
        psi = np.stack([S[:, 2, 1], S[:, 0, 2], S[:, 1, 0]], -1)
        fb = self.update(i, {"dr": r - r_t, "dv": v - v_t, "psi": psi})
        new = self._apply(nav, np.concatenate([fb["dr"], fb["dv"], fb["psi"]], -1))
        st["llh"] = np.stack([np.radians(new["lat"]), np.radians(new["lon"]), new["h"]], -1)
        st["v"] = new["v"]
        st["q"] = dcm_to_quat(new["C"])
        st["acc_gm"] = st["acc_gm"] - fb["acc_gm"]
        st["gyro_gm"] = st["gyro_gm"] - fb["gyro_gm"]
        prop.set_state(st)
        prop.correct_errors(acc_bias=fb["acc_bias"], gyro_bias=fb["gyro_bias"])


def outage_ends(t: np.ndarray, gnss: GnssSpec) -> list[tuple[float, float, int]]:
    """(start, end, index) of each outage: ``index`` the first stored time at or after its end."""
    t = np.asarray(t, dtype=np.float64)
    out = []
    for a, b in gnss.intervals(float(t[-1])):
        out.append((float(a), float(b), int(min(np.searchsorted(t, b - 1e-9), t.size - 1))))
    return out


def coasting_summary(doc: dict[str, Any], res: Any, gnss: GnssSpec, sigma_h: np.ndarray) -> None:
    """Add the GNSS block (errors at the end of each outage, over the flight) to a summary.

    ``doc`` the study's summary (its ``models`` entries, ``fraction``, ``meta``); ``res`` the
    result: ``t``, ``budget`` (the gravity terms through the aided loop), and for a Monte Carlo
    ``dpos``, ``models`` (the row of each run); ``sigma_h`` (n,) the filter's horizontal σ
    of the IMU's (and GNSS's) errors. Sets ``doc["gnss"]`` and replaces the recommendation by
    the one for coasting through the worst outage (the largest IMU-only error at its end;
    the flight's end without outages): the simplest model whose gravity contribution there
    stays below ``fraction`` × the IMU-only error (:func:`fieldmap.nav.budget.recommend`).
    """
    from fieldmap.nav.budget import recommend, simplicity_order

    t = res.t
    names = [m for m in doc["models"] if m != "imu_only"]
    mc = getattr(res, "dpos", None)
    curves: dict[str, np.ndarray] = {}
    added: dict[str, np.ndarray] = {}
    if mc is not None:
        rows = np.array(res.models)
        ref = mc[rows == "imu_only"]
        curves["imu_only"] = np.sqrt(np.mean(np.sum(ref[..., :2] ** 2, -1), 0))
        for m in names:
            d = mc[rows == m]
            curves[m] = np.sqrt(np.mean(np.sum(d[..., :2] ** 2, -1), 0))
            added[m] = np.sqrt(np.mean(np.sum((d - ref)[..., :2] ** 2, -1), 0))
    imu_h = curves.get("imu_only", sigma_h)
    ends = outage_ends(t, gnss)
    block: dict[str, Any] = {
        "rate_hz": gnss.rate_hz,
        "sigma_m": gnss.sigma_m,
        "velocity_sigma_mps": gnss.velocity_sigma_mps,
        "bias_m": gnss.bias_m,
        "bias_tau_s": gnss.bias_tau_s,
        "outages_s": [[a, b] for a, b, _ in ends],
        "outages": [],
    }

    def at(i: int) -> dict[str, Any]:
        e: dict[str, Any] = {
            "time_s": float(t[i]),
            "filter_horizontal_sigma_m": float(sigma_h[i]),
            "imu_only_horizontal_error_m": float(imu_h[i]),
            "models": {},
        }
        for m in names:
            g = res.budget.summary(m, at=i)
            em: dict[str, Any] = {"gravity": g}
            if mc is not None:
                em["horizontal_error_m"] = float(curves[m][i])
                em["added_horizontal_error_m"] = float(added[m][i])
            else:
                em["horizontal_error_m"] = float(np.hypot(sigma_h[i], g["horizontal_m"]))
            e["models"][m] = em
        return e

    for a, b, i in ends:
        block["outages"].append({"start_s": a, "end_s": b, **at(i)})
    k = int(np.argmax(imu_h))
    block["flight_max"] = at(k)
    doc["gnss"] = block
    iw = max(ends, key=lambda e: imu_h[e[2]])[2] if ends else t.size - 1
    rec: dict[str, Any] = {
        "models": {
            m: {
                "gravity": res.budget.summary(m, at=iw),
                "diverged": bool(doc["models"][m].get("diverged", False)),
            }
            for m in names
        }  # fmt: skip
    }
    recommend(rec, simplicity_order(names), float(imu_h[iw]), doc["fraction"], True,
              doc["meta"].get("truth_degree", "L"))  # fmt: skip
    what = f"the outage ending at {t[iw]:g} s" if ends else "the aided flight's end"
    doc["recommended_model"] = rec["recommended_model"]
    doc["recommendation"] = f"coasting through {what}: {rec['recommendation']}"
    if "gravity_floor_horizontal_m" in rec:
        doc["gravity_floor_horizontal_m"] = rec["gravity_floor_horizontal_m"]


def nees_summary(filt: FeedbackFilter, imu_only: np.ndarray) -> dict[str, Any]:
    """Return the filter's NEES of position and velocity (6 states) over the IMU-only runs.

    ``imu_only`` (n_runs,) bool in the filter's run order (runs with a gravity model carry an
    error the filter does not model). Mean over draws at each fix, its 95 % χ² bounds, the
    fraction of fixes within them and the mean over the flight.
    """
    if not filt.nees:
        return {"fixes": 0}
    v = np.stack(filt.nees)[:, imu_only]  # (fixes, draws)
    mean = v.mean(axis=1)
    lo, hi = nees_bounds(v.shape[1], 6)
    return {
        "dimension": 6,
        "draws": int(v.shape[1]),
        "fixes": int(v.shape[0]),
        "mean": float(mean.mean()),
        "bounds_95": [lo, hi],
        "fraction_within": float(np.mean((mean >= lo) & (mean <= hi))),
    }


def add_to_dataset(ds: Any, doc: dict[str, Any], sigma_h: np.ndarray | None) -> Any:
    """Add the GNSS block of a summary to a study's ``xarray.Dataset`` (CF-1.8 attributes).

    ``outage_start``, ``outage_end`` (outage) s; ``coasting_horizontal_error`` (coasting_row,
    outage): IMU-only and each model's horizontal error at the end of each outage (m; Monte
    Carlo RMS over draws, covariance σ); ``coasting_gravity_contribution`` (model, outage) m;
    ``filter_horizontal_sigma`` (time) m, the filter's a priori σ; ``nees_mean`` (attribute).
    """
    g = doc.get("gnss")
    if g is None:
        return ds
    out = g["outages"]
    models = [m for m in doc["models"] if m != "imu_only"]
    rows = ["imu_only"] + models
    err = np.array(
        [[o["imu_only_horizontal_error_m"] for o in out]]
        + [[o["models"][m]["horizontal_error_m"] for o in out] for m in models]
    ).reshape(len(rows), len(out))
    grav = np.array(
        [[o["models"][m]["gravity"]["horizontal_m"] for o in out] for m in models]
    ).reshape(len(models), len(out))
    new = {
        "outage_start": ("outage", np.array([o["start_s"] for o in out], dtype=np.float64),
                         {"units": "s", "long_name": "start of each GNSS outage"}),
        "outage_end": ("outage", np.array([o["end_s"] for o in out], dtype=np.float64),
                       {"units": "s", "long_name": "end of each GNSS outage"}),
        "coasting_horizontal_error": (("coasting_row", "outage"), err, {
            "units": "m", "long_name": "horizontal position error at the end of each GNSS "
            "outage (IMU only and with each gravity model)"}),
        "coasting_gravity_contribution": (("model", "outage"), grav, {
            "units": "m", "long_name": "gravity model's contribution to the horizontal error at "
            "the end of each GNSS outage (model difference, omission, commission through the "
            "filter's closed loop)"}),
    }  # fmt: skip
    if sigma_h is not None:
        new["filter_horizontal_sigma"] = (
            "time",
            np.asarray(sigma_h),
            {"units": "m", "long_name": "GNSS/INS filter's a priori horizontal position sigma"},
        )
    from fieldmap.nav.cf import labels

    ds = ds.assign(new).assign_coords(
        labels(coasting_row=(rows, "IMU only, then each navigation gravity model"))
    )
    nees = g.get("nees")
    if nees and nees.get("fixes"):
        ds.attrs["gnss_nees_mean"] = nees["mean"]
        ds.attrs["gnss_nees_bounds_95"] = list(nees["bounds_95"])
        ds.attrs["gnss_nees_fraction_within"] = nees["fraction_within"]
    return ds


def format_gnss(doc: dict[str, Any]) -> list[str]:
    """Text lines of the GNSS block of a summary (empty without GNSS aiding)."""
    g = doc.get("gnss")
    if g is None:
        return []
    vel = g["velocity_sigma_mps"]
    lines = [
        f"GNSS aiding: fixes at {g['rate_hz']:g} Hz, position sigma {g['sigma_m']:g} m"
        + (f", velocity sigma {vel:g} m/s" if vel is not None else ", no velocity")
        + f"; {len(g['outages'])} outage(s)"
    ]
    models = [m for m in doc["models"] if m != "imu_only"]
    if g["outages"]:
        w = max(10, *(len(m) for m in models)) if models else 10
        lines.append(
            f"{'coasting (horiz m)':{w + 8}s} " + " ".join(
                f"{o['start_s']:>6g}-{o['end_s']:<6g}" for o in g["outages"]
            )
        )  # fmt: skip
        lines.append(
            f"{'IMU only':{w + 8}s} "
            + " ".join(f"{o['imu_only_horizontal_error_m']:13.3f}" for o in g["outages"])
        )
        for m in models:
            lines.append(
                f"{m:{w}s} total  "
                + " ".join(f"{o['models'][m]['horizontal_error_m']:13.3f}" for o in g["outages"])
            )
            lines.append(
                f"{m:{w}s} grav.  "
                + " ".join(
                    f"{o['models'][m]['gravity']['horizontal_m']:13.3f}" for o in g["outages"]
                )
            )
    fm = g["flight_max"]
    lines.append(
        "largest IMU-only horizontal error over the flight: "
        f"{fm['imu_only_horizontal_error_m']:.3f} m at {fm['time_s']:g} s"
    )
    nees = g.get("nees")
    if nees and nees.get("fixes"):
        lo, hi = nees["bounds_95"]
        lines.append(
            f"filter consistency: NEES (position, velocity; {nees['draws']} draws) mean "
            f"{nees['mean']:.2f} (expected 6), within its 95 % bounds [{lo:.2f}, {hi:.2f}] at "
            f"{nees['fraction_within']:.0%} of {nees['fixes']} fixes"
        )
    return lines
