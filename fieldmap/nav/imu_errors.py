r"""IMU error models of Chen et al. (2022) Tables 2 and 4: bias, noise, scale factor, misalignment.

Units used here (standard, unambiguous) and how the paper's printed units are read:

=====================================  =================  =========================================
quantity                               unit here          paper (Tables 2, 4) and interpretation
=====================================  =================  =========================================
accelerometer constant bias            µg                 "µg" (Table 2); "µg/h" (Table 4) is read
                                                          as µg — a constant bias has no time unit
                                                          (bias *repeatability* run to run, as in
                                                          the QA-3000 quote of §5.2)
accelerometer white noise              µg/√Hz             "µg/h": read as the noise density µg/√Hz
                                                          (velocity random walk; 1 µg/√Hz =
                                                          9.80665e-6 m/s/√s)
gyro constant bias                     °/h                "°/h"
gyro white noise (angle random walk)   °/√h               "°/h": read as °/√h (1 °/√h = π/180/60
                                                          rad/√s)
scale factor                           ppm                "×10⁻⁶"
installation misalignment              arcsec             "″": a small rotation of the sensor triad
=====================================  =================  =========================================

Measurement model (applied per IMU sample of length dt, as :func:`apply` and the strapdown kernel
``fieldmap.kernels.strapdown.lci_kernel`` do):

.. math::
    \Delta\tilde v = M_a\,\Delta v + b_a\,dt + \sigma_a\sqrt{dt}\,n,\qquad
    \Delta\tilde\theta = M_g\,\Delta\theta + b_g\,dt + \sigma_g\sqrt{dt}\,n,\qquad
    M = (I + \mathrm{diag}(s))\,R(\varepsilon)

with n ~ N(0, I) independent per sample and axis (so the noise of a mean over τ seconds falls as
σ/√τ: σ in units/√Hz), s the per-axis scale-factor errors and R(ε) the rotation by the small
misalignment vector ε (Rodrigues). The bias ``b`` may add a first-order Gauss–Markov term β
(bias instability) per axis: ``β⁺ = e^(−dt/τ_c) β + σ_β √(1 − e^(−2dt/τ_c)) n``, started from its
stationary distribution N(0, σ_β²).

Bias instability. Datasheets quote the *floor* B of the Allan deviation (IEEE Std 952-1997
Annex C; e.g. Analog Devices' "in-run bias stability"). A first-order Gauss–Markov process of
stationary σ_β and correlation time τ_c has the Allan deviation
σ_A(T) = σ_β √((2/x)(1 − (3 − 4e^(−x) + e^(−2x))/(2x))), x = T/τ_c, whose maximum
0.617 σ_β at T ≈ 1.89 τ_c (see :func:`gm_allan_deviation`) is set equal to B:
σ_β = B / 0.617 (:data:`GM_ADEV_PEAK`).

Monte Carlo draws (deterministic for a given seed, :class:`numpy.random.Generator`): per run the
bias, scale-factor and misalignment of every axis are drawn once (constant over the run) according
to ``mode``: ``"gauss"`` (default) N(0, σ²) — the spec value is the 1σ of the run-to-run
repeatability; ``"sign"`` ±σ with a random sign; ``"fixed"`` +σ on every axis (one deterministic
run, closest to a single simulation as printed). The white-noise sequence of each run gets its own
seed drawn from the same generator.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from fieldmap.errors import InputError

G0 = 9.80665  #: standard gravity used by the paper for "g" (Chen et al. 2022 §4.1). Units: m/s².
UG = G0 * 1e-6  #: 1 µg in m/s².
DEG_H = np.pi / 180.0 / 3600.0  #: 1 °/h in rad/s.
DEG_RTH = np.pi / 180.0 / 60.0  #: 1 °/√h in rad/√s.
ARCSEC = np.pi / 180.0 / 3600.0  #: 1 arcsec in rad.
MODES = ("gauss", "sign", "fixed")


@dataclass(frozen=True)
class ImuErrorSpec:
    """1σ values of the error sources of one IMU grade (zero: source absent).

    Parameters
    ----------
    acc_bias_ug : float
        Accelerometer constant bias. Units: µg.
    acc_noise_ug_rthz : float
        Accelerometer white-noise density. Units: µg/√Hz.
    acc_scale_ppm : float
        Accelerometer scale-factor error. Units: ppm.
    acc_misalign_arcsec : float
        Accelerometer triad installation error. Units: arcsec.
    gyro_bias_deg_h : float
        Gyro constant bias. Units: °/h.
    gyro_arw_deg_rth : float
        Gyro angle random walk. Units: °/√h.
    gyro_scale_ppm : float
        Gyro scale-factor error. Units: ppm.
    gyro_misalign_arcsec : float
        Gyro triad installation error. Units: arcsec.
    acc_bi_ug : float
        Accelerometer bias instability (Allan floor). Units: µg.
    acc_bi_tau_s : float
        Its Gauss–Markov correlation time. Units: s.
    gyro_bi_deg_h : float
        Gyro bias instability (Allan floor). Units: °/h.
    gyro_bi_tau_s : float
        Its Gauss–Markov correlation time. Units: s.
    """

    acc_bias_ug: float = 0.0
    acc_noise_ug_rthz: float = 0.0
    acc_scale_ppm: float = 0.0
    acc_misalign_arcsec: float = 0.0
    gyro_bias_deg_h: float = 0.0
    gyro_arw_deg_rth: float = 0.0
    gyro_scale_ppm: float = 0.0
    gyro_misalign_arcsec: float = 0.0
    acc_bi_ug: float = 0.0
    acc_bi_tau_s: float = 3600.0
    gyro_bi_deg_h: float = 0.0
    gyro_bi_tau_s: float = 3600.0

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            try:
                ok = not isinstance(v, (bool, str, bytes)) and np.isfinite(v) and v >= 0
            except TypeError:
                ok = False
            if not ok:
                raise InputError(f"IMU error {f.name} must be finite and >= 0, got {v!r}")
        for key in ("acc_bi_tau_s", "gyro_bi_tau_s"):
            if getattr(self, key) <= 0:
                raise InputError(f"IMU error {key} must be > 0, got {getattr(self, key)!r}")

    @property
    def is_ideal(self) -> bool:
        """True when every error source is absent."""
        return all(
            getattr(self, f.name) == 0 for f in fields(self) if not f.name.endswith("_tau_s")
        )


#: Table 2 of Chen et al. (2022): accelerometer error groups (gyro perfect).
TABLE2_GROUPS = {
    1: ImuErrorSpec(acc_bias_ug=100.0, acc_noise_ug_rthz=10.0),
    2: ImuErrorSpec(acc_bias_ug=10.0, acc_noise_ug_rthz=1.0),
    3: ImuErrorSpec(acc_bias_ug=1.0, acc_noise_ug_rthz=0.1),
    4: ImuErrorSpec(),
}

#: Table 4 of Chen et al. (2022): the full IMU error model.
TABLE4 = ImuErrorSpec(
    acc_bias_ug=10.0,
    acc_noise_ug_rthz=1.0,
    acc_scale_ppm=10.0,
    acc_misalign_arcsec=0.5,
    gyro_bias_deg_h=0.003,
    gyro_arw_deg_rth=0.0003,
    gyro_scale_ppm=10.0,
    gyro_misalign_arcsec=0.5,
)


@dataclass(frozen=True)
class ErrorDraws:
    """Sensor errors of ``n`` Monte Carlo runs in SI units (arrays indexed by run).

    Attributes: ``acc_bias`` (n, 3) m/s²; ``gyro_bias`` (n, 3) rad/s; ``acc_M``, ``gyro_M``
    (n, 3, 3); ``acc_noise`` (n,) m/s/√s; ``gyro_noise`` (n,) rad/√s; ``seed`` (n,) int32;
    Gauss–Markov bias instability ``acc_gm_sigma`` (n,) m/s², ``gyro_gm_sigma`` (n,) rad/s,
    correlation times ``acc_gm_tau``, ``gyro_gm_tau`` (n,) s and initial states ``acc_gm``,
    ``gyro_gm`` (n, 3).
    """

    acc_bias: np.ndarray
    gyro_bias: np.ndarray
    acc_M: np.ndarray
    gyro_M: np.ndarray
    acc_noise: np.ndarray
    gyro_noise: np.ndarray
    seed: np.ndarray
    acc_gm_sigma: np.ndarray
    acc_gm_tau: np.ndarray
    gyro_gm_sigma: np.ndarray
    gyro_gm_tau: np.ndarray
    acc_gm: np.ndarray
    gyro_gm: np.ndarray

    @property
    def n(self) -> int:
        """Number of runs."""
        return self.acc_bias.shape[0]

    def kernel_errors(self) -> dict:
        """Return the ``errors=`` dictionary of :func:`fieldmap.nav.strapdown.propagate_lci`."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @staticmethod
    def concat(parts: list["ErrorDraws"]) -> "ErrorDraws":
        """Stack several sets of runs (e.g. one per IMU grade) into one launch."""
        return ErrorDraws(
            **{
                f.name: np.concatenate([getattr(p, f.name) for p in parts])
                for f in fields(ErrorDraws)
            }
        )

    def take(self, idx) -> "ErrorDraws":
        """Return the runs ``idx`` (any integer index array), in that order."""
        idx = np.asarray(idx, dtype=np.int64)
        return ErrorDraws(**{f.name: getattr(self, f.name)[idx] for f in fields(ErrorDraws)})

    def repeat(self, k: int) -> "ErrorDraws":
        """Each run repeated ``k`` times in a block (same errors for k gravity models)."""
        return ErrorDraws(
            **{
                f.name: np.tile(
                    getattr(self, f.name), (k,) + (1,) * (getattr(self, f.name).ndim - 1)
                )
                for f in fields(ErrorDraws)
            }
        )


def _axes(rng, sigma: float, n: int, mode: str) -> np.ndarray:
    if mode == "gauss":
        return sigma * rng.standard_normal((n, 3))
    if mode == "sign":
        return sigma * rng.choice([-1.0, 1.0], size=(n, 3))
    return np.full((n, 3), float(sigma))


def rotation(eps: np.ndarray) -> np.ndarray:
    """Rotation matrices of rotation vectors ``eps`` (n, 3) (Rodrigues). Units: rad."""
    a = np.linalg.norm(eps, axis=-1)[:, None, None]
    K = np.zeros(eps.shape[:-1] + (3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -eps[:, 2], eps[:, 1], -eps[:, 0]
    K = K - np.swapaxes(K, -1, -2)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(a > 1e-8, np.sin(a) / np.where(a > 0, a, 1), 1.0 - a * a / 6)
        c = np.where(a > 1e-8, (1 - np.cos(a)) / np.where(a > 0, a * a, 1), 0.5 - a * a / 24)
    return np.eye(3) + s * K + c * (K @ K)


def draw(spec: ImuErrorSpec, n: int, seed: int = 0, mode: str = "gauss") -> ErrorDraws:
    """Draw the sensor errors of ``n`` Monte Carlo runs (deterministic for ``seed``).

    Parameters
    ----------
    spec : ImuErrorSpec
        1σ values.
    n : int
        Number of runs.
    seed : int
        Seed of the :class:`numpy.random.Generator` (PCG64).
    mode : {"gauss", "sign", "fixed"}
        How bias, scale factor and misalignment are drawn (see the module docstring).

    Returns
    -------
    ErrorDraws
    """
    if mode not in MODES:
        raise InputError(f"unknown bias mode {mode!r} (known: {', '.join(MODES)})")
    n = _integer(n, "number of Monte Carlo draws")
    if n < 1:
        raise InputError(f"number of Monte Carlo draws must be >= 1, got {n}")
    seed = _integer(seed, "seed")
    if seed < 0:
        raise InputError(f"seed must be >= 0, got {seed}")
    rng = np.random.default_rng(seed)
    acc_b = _axes(rng, spec.acc_bias_ug * UG, n, mode)
    gyro_b = _axes(rng, spec.gyro_bias_deg_h * DEG_H, n, mode)
    acc_M = (1.0 + _axes(rng, spec.acc_scale_ppm * 1e-6, n, mode))[:, :, None] * rotation(
        _axes(rng, spec.acc_misalign_arcsec * ARCSEC, n, mode)
    )
    gyro_M = (1.0 + _axes(rng, spec.gyro_scale_ppm * 1e-6, n, mode))[:, :, None] * rotation(
        _axes(rng, spec.gyro_misalign_arcsec * ARCSEC, n, mode)
    )
    seeds = rng.integers(0, 2**31 - 1, size=n, dtype=np.int64).astype(np.int32)
    acc_gm_sigma = spec.acc_bi_ug * UG / GM_ADEV_PEAK
    gyro_gm_sigma = spec.gyro_bi_deg_h * DEG_H / GM_ADEV_PEAK
    # drawn after everything else so that specs without bias instability draw as before
    acc_gm = acc_gm_sigma * rng.standard_normal((n, 3)) if acc_gm_sigma else np.zeros((n, 3))
    gyro_gm = gyro_gm_sigma * rng.standard_normal((n, 3)) if gyro_gm_sigma else np.zeros((n, 3))
    return ErrorDraws(
        acc_b,
        gyro_b,
        acc_M,
        gyro_M,
        np.full(n, spec.acc_noise_ug_rthz * UG),
        np.full(n, spec.gyro_arw_deg_rth * DEG_RTH),
        seeds,
        np.full(n, acc_gm_sigma),
        np.full(n, spec.acc_bi_tau_s if acc_gm_sigma else 0.0),
        np.full(n, gyro_gm_sigma),
        np.full(n, spec.gyro_bi_tau_s if gyro_gm_sigma else 0.0),
        acc_gm,
        gyro_gm,
    )


def gm_allan_deviation(T, sigma: float = 1.0, tau_c: float = 1.0):
    """Allan deviation of a first-order Gauss–Markov process (stationary σ, correlation τ_c).

    σ_A(T)² = σ² (2/x)(1 − (3 − 4e^(−x) + e^(−2x))/(2x)), x = T/τ_c (IEEE Std 952-1997 Annex C;
    with q_c = 2σ²/τ_c). Units: T, τ_c s; σ any.
    """
    x = np.asarray(T, dtype=np.float64) / tau_c
    return sigma * np.sqrt(
        (2.0 / x) * (1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2 * x))
    )


def _gm_peak() -> float:
    from scipy.optimize import minimize_scalar

    return float(-minimize_scalar(lambda x: -gm_allan_deviation(x), bounds=(0.5, 5.0)).fun)


#: maximum of the Gauss–Markov Allan deviation per unit σ (0.617, at T ≈ 1.89 τ_c)
GM_ADEV_PEAK = _gm_peak()


def apply(dtheta, dv, dt: float, draws: ErrorDraws, run: int = 0, rng=None):
    """Corrupt exact increments with the errors of one run (NumPy; the kernel does the same).

    Parameters
    ----------
    dtheta, dv : ndarray (n_samples, 3)
        Exact increments. Units: rad, m/s.
    dt : float
        Sample interval. Units: s.
    draws : ErrorDraws
        Monte Carlo draws.
    run : int
        Which run of ``draws``.
    rng : numpy.random.Generator, optional
        Noise generator (default: seeded with the run's noise seed).

    Returns
    -------
    tuple of ndarray
        Measured ``(dtheta, dv)``.
    """
    from fieldmap.nav.imu import validate_increments

    validate_increments(dtheta, dv, dt)
    run = _integer(run, "run")
    if not 0 <= run < draws.n:
        raise InputError(f"run {run} is outside the {draws.n} draws")
    rng = np.random.default_rng(int(draws.seed[run])) if rng is None else rng
    dtheta, dv = np.asarray(dtheta, float), np.asarray(dv, float)
    th = dtheta @ draws.gyro_M[run].T + draws.gyro_bias[run] * dt
    v = dv @ draws.acc_M[run].T + draws.acc_bias[run] * dt
    th = th + draws.gyro_noise[run] * np.sqrt(dt) * rng.standard_normal(th.shape)
    v = v + draws.acc_noise[run] * np.sqrt(dt) * rng.standard_normal(v.shape)
    for x, sig, tau, b0 in (
        (th, draws.gyro_gm_sigma[run], draws.gyro_gm_tau[run], draws.gyro_gm[run]),
        (v, draws.acc_gm_sigma[run], draws.acc_gm_tau[run], draws.acc_gm[run]),
    ):
        if sig > 0 and tau > 0:
            x += gauss_markov(x.shape[0], sig, tau, dt, b0, rng) * dt
    return th, v


def gauss_markov(n: int, sigma: float, tau: float, dt: float, beta0, rng) -> np.ndarray:
    """``n`` samples (n, 3) of a first-order Gauss–Markov process, exact discretisation.

    β_0 = ``beta0``; β_{k+1} = a β_k + σ √(1 − a²) n_k, a = e^(−dt/τ) (Brown & Hwang 2012 §2.9).
    The recursion is a first-order IIR filter (``scipy.signal.lfilter``). Units: σ and β any,
    τ and dt s.
    """
    from scipy.signal import lfilter

    a = np.exp(-dt / tau)
    w = sigma * np.sqrt(1.0 - a * a) * rng.standard_normal((n, 3))
    w[0] += a * np.asarray(beta0, dtype=np.float64)
    out = np.empty((n, 3))
    out[0] = beta0
    out[1:] = lfilter([1.0], [1.0, -a], w, axis=0)[:-1]
    return out


def _integer(value, what: str) -> int:
    """Return ``value`` as an int; raise :class:`InputError` unless it is a whole number."""
    try:
        out = int(value)
        ok = not isinstance(value, (bool, np.bool_)) and float(value) == out
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise InputError(f"{what} must be an integer, got {value!r}")
    return out


def scaled(spec: ImuErrorSpec, factor: float) -> ImuErrorSpec:
    """Every 1σ value multiplied by ``factor``."""
    return replace(spec, **{f.name: getattr(spec, f.name) * factor for f in fields(spec)})
