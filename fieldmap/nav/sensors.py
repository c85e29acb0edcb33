r"""IMU sensor errors: error specs and draws, presets and TOML files, Allan deviation.

IMU error models of Chen et al. (2022) Tables 2 and 4: bias, noise, scale factor, misalignment.

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

IMU grades by name and custom IMUs from TOML files with unit-carrying keys.

Presets (1σ, typical datasheet values of each grade; ``ideal`` has no errors):

===========  ========  ========  ======  =========  ========  =========  =====  =======
grade        acc bias  acc VRW   acc BI  gyro bias  gyro ARW  gyro BI    scale  misalign
             µg        µg/√Hz    µg      °/h        °/√h      °/h        ppm    arcsec
===========  ========  ========  ======  =========  ========  =========  =====  =======
consumer     5000      150       100     360        0.6       10         5000   1800
industrial   500       25        10      10         0.2       2          500    300
tactical     1000      100       50      1          0.125     0.3        300    100
navigation   25        10        5       0.003      0.002     0.001      30     10
strategic    1         1         0.5     0.0001     0.0001    0.00005    1      1
===========  ========  ========  ======  =========  ========  =========  =====  =======

Bias-instability correlation time: 3600 s for every preset. Sources of the ranges: Groves (2013)
*Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., §4.4
(Tables 4.1 and 4.2: accelerometer and gyro biases by grade: marine/strategic ≤ 10 µg and
0.0001 °/h, aviation/navigation 25–50 µg and 0.001–0.01 °/h, tactical 100–1000 µg and 1–100 °/h,
consumer > 3000 µg and > 100 °/h; ARW 0.002 °/√h for aviation, 0.03–0.5 °/√h for tactical) and
datasheets of representative units: consumer — Bosch BMI088 and TDK InvenSense ICM-20948 (noise
densities 150–230 µg/√Hz, 0.014–0.015 °/s/√Hz, zero-rate offsets of degrees per second before
calibration); industrial — Analog Devices ADIS16470/ADIS16495 (in-run bias stability 0.8–8 °/h
and 3–13 µg, ARW 0.1–0.34 °/√h); tactical — Honeywell HG1700/HG1930 (1 mg, 1–20 °/h,
0.125 °/√h); navigation — Honeywell HG9900 class ring-laser units (25 µg, 0.003 °/h,
0.002 °/√h); strategic — submarine/ICBM-class systems as tabulated by Titterton & Weston (2004)
*Strapdown Inertial Navigation Technology*, 2nd ed., Table 4.1 and §10.

Also named: ``table2-group1`` … ``table2-group4`` and ``table4`` (Chen et al. 2022 Tables 2 and
4, see :mod:`fieldmap.nav.sensors`).

TOML keys (each optional, unknown keys are an error; ``name`` and ``description`` are text)::

    accel_bias_ug, accel_vrw_ug_per_sqrt_hz, accel_bias_instability_ug,
    accel_bias_instability_tau_s, accel_scale_factor_ppm, accel_misalignment_arcsec,
    gyro_bias_deg_per_h, gyro_arw_deg_per_sqrt_h, gyro_bias_instability_deg_per_h,
    gyro_bias_instability_tau_s, gyro_scale_factor_ppm, gyro_misalignment_arcsec,
    scale_factor_ppm, misalignment_arcsec, bias_instability_tau_s   (both sensor triads)

A file must set at least one error term (a key other than the correlation times): an empty file
is refused rather than read as a perfect IMU; the preset ``ideal`` (``--imu ideal``) asks for one.

Allowed ranges (:data:`RANGES`; a value outside, NaN or infinite is refused with the key, the
value, the file and the range). Zero means the source is absent. The upper limits lie well above
the worst consumer MEMS part before calibration, so that no real unit is refused while a typo in
the exponent (``1e300``, a value in the wrong unit by 10⁶) is (``*`` stands for ``accel_``,
``gyro_`` and the shared key of both triads):

==================================  ===========  =============================================
key                                 range        upper limit
==================================  ===========  =============================================
accel_bias_ug                       0 … 1e5      100 mg: 5x the ±20 mg zero-g offset of an
                                                 uncalibrated consumer part (BMI088), 20x
                                                 ``consumer``
accel_vrw_ug_per_sqrt_hz            0 … 1e4      10 mg/√Hz: 25x the noisiest consumer parts
                                                 (≈ 400 µg/√Hz), 70x ``consumer``
accel_bias_instability_ug           0 … 1e4      10 mg: 100x ``consumer``
gyro_bias_deg_per_h                 0 … 1e5      ≈ 28 °/s: above the ±20 °/s zero-rate offset
                                                 of an uncalibrated consumer part (MPU-6050)
gyro_arw_deg_per_sqrt_h             0 … 30       0.5 °/s/√Hz: 10x the noisiest consumer parts
                                                 (≈ 0.05 °/s/√Hz = 3 °/√h), 50x ``consumer``
gyro_bias_instability_deg_per_h     0 … 1000     20x the ≈ 50 °/h of low-cost MEMS gyros,
                                                 100x ``consumer``
``*scale_factor_ppm``               0 … 1e5      10 %: 3x the ±3 % sensitivity tolerance of an
                                                 uncalibrated consumer part, 20x ``consumer``
``*misalignment_arcsec``            0 … 18000    5°: 4x the ±2 % (≈ 1.1°) cross-axis
                                                 sensitivity of consumer parts, 10x
                                                 ``consumer``
``*bias_instability_tau_s``         0.01 … 1e6   > 0; below 0.01 s the Gauss–Markov bias is
                                                 white noise (a noise-density key), above
                                                 11.6 days a constant bias over any flight
==================================  ===========  =============================================

Allan deviation of simulated IMU sensors at rest (to hold against a datasheet).

The sensors of :mod:`fieldmap.nav.sensors` are run at rest (zero true increments, so scale
factor and misalignment do not show and the constant bias cancels in the Allan variance): their
rate outputs are ``(Δθ̃/dt, Δṽ/dt)``. The overlapping Allan deviation (IEEE Std 952-1997 Annex C,
eq. C.11) of a rate record ω_k at averaging time τ = m dt, from the integrated angle
θ_k = Σ ω dt:

.. math::
    \sigma^2(\tau) = \frac{1}{2\tau^2 (N - 2m)} \sum_k (\theta_{k+2m} - 2\theta_{k+m} +
    \theta_k)^2

For white noise of density N the deviation is N/√τ (slope −1/2, value N at τ = 1 s); a
Gauss–Markov bias instability peaks at the spec's floor B near τ = 1.89 τ_c
(:data:`fieldmap.nav.sensors.GM_ADEV_PEAK`).
"""

from __future__ import annotations

import math
import numbers
import os
import sys
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from fieldmap.errors import InputError
from fieldmap.units import STANDARD_GRAVITY

#: 1 µg in m/s² (the paper's "g" is standard gravity, Chen et al. 2022 §4.1).
UG = STANDARD_GRAVITY * 1e-6
DEG_H = np.pi / 180.0 / 3600.0  #: 1 °/h in rad/s.
DEG_RTH = np.pi / 180.0 / 60.0  #: 1 °/√h in rad/√s.
ARCSEC = np.pi / 180.0 / 3600.0  #: 1 arcsec in rad.
MODES = ("gauss", "sign", "fixed")


@dataclass(frozen=True)
class ImuErrorSpec:
    """1σ values of the error sources of one IMU grade (zero: source absent).

    Parameters
    ----------
    accel_bias_ug : float
        Accelerometer constant bias. Units: µg.
    accel_vrw_ug_per_sqrt_hz : float
        Accelerometer white-noise density. Units: µg/√Hz.
    accel_scale_factor_ppm : float
        Accelerometer scale-factor error. Units: ppm.
    accel_misalignment_arcsec : float
        Accelerometer triad installation error. Units: arcsec.
    gyro_bias_deg_per_h : float
        Gyro constant bias. Units: °/h.
    gyro_arw_deg_per_sqrt_h : float
        Gyro angle random walk. Units: °/√h.
    gyro_scale_factor_ppm : float
        Gyro scale-factor error. Units: ppm.
    gyro_misalignment_arcsec : float
        Gyro triad installation error. Units: arcsec.
    accel_bias_instability_ug : float
        Accelerometer bias instability (Allan floor). Units: µg.
    accel_bias_instability_tau_s : float
        Its Gauss–Markov correlation time. Units: s.
    gyro_bias_instability_deg_per_h : float
        Gyro bias instability (Allan floor). Units: °/h.
    gyro_bias_instability_tau_s : float
        Its Gauss–Markov correlation time. Units: s.
    """

    accel_bias_ug: float = 0.0
    accel_vrw_ug_per_sqrt_hz: float = 0.0
    accel_scale_factor_ppm: float = 0.0
    accel_misalignment_arcsec: float = 0.0
    gyro_bias_deg_per_h: float = 0.0
    gyro_arw_deg_per_sqrt_h: float = 0.0
    gyro_scale_factor_ppm: float = 0.0
    gyro_misalignment_arcsec: float = 0.0
    accel_bias_instability_ug: float = 0.0
    accel_bias_instability_tau_s: float = 3600.0
    gyro_bias_instability_deg_per_h: float = 0.0
    gyro_bias_instability_tau_s: float = 3600.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            try:
                ok = not isinstance(v, (bool, str, bytes)) and np.isfinite(v) and v >= 0
            except TypeError:
                ok = False
            if not ok:
                raise InputError(f"IMU error {f.name} must be finite and >= 0, got {v!r}")
        for key in ("accel_bias_instability_tau_s", "gyro_bias_instability_tau_s"):
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
    1: ImuErrorSpec(accel_bias_ug=100.0, accel_vrw_ug_per_sqrt_hz=10.0),
    2: ImuErrorSpec(accel_bias_ug=10.0, accel_vrw_ug_per_sqrt_hz=1.0),
    3: ImuErrorSpec(accel_bias_ug=1.0, accel_vrw_ug_per_sqrt_hz=0.1),
    4: ImuErrorSpec(),
}

#: Table 4 of Chen et al. (2022): the full IMU error model.
TABLE4 = ImuErrorSpec(
    accel_bias_ug=10.0,
    accel_vrw_ug_per_sqrt_hz=1.0,
    accel_scale_factor_ppm=10.0,
    accel_misalignment_arcsec=0.5,
    gyro_bias_deg_per_h=0.003,
    gyro_arw_deg_per_sqrt_h=0.0003,
    gyro_scale_factor_ppm=10.0,
    gyro_misalignment_arcsec=0.5,
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
        """Return the ``errors=`` dictionary of :func:`fieldmap.nav.mechanize.propagate_lci`."""
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

    def take(self, idx: npt.ArrayLike) -> "ErrorDraws":
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


def _axes(rng: np.random.Generator, sigma: float, n: int, mode: str) -> np.ndarray:
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
    acc_b = _axes(rng, spec.accel_bias_ug * UG, n, mode)
    gyro_b = _axes(rng, spec.gyro_bias_deg_per_h * DEG_H, n, mode)
    acc_M = (1.0 + _axes(rng, spec.accel_scale_factor_ppm * 1e-6, n, mode))[:, :, None] * rotation(
        _axes(rng, spec.accel_misalignment_arcsec * ARCSEC, n, mode)
    )
    gyro_M = (1.0 + _axes(rng, spec.gyro_scale_factor_ppm * 1e-6, n, mode))[:, :, None] * rotation(
        _axes(rng, spec.gyro_misalignment_arcsec * ARCSEC, n, mode)
    )
    seeds = rng.integers(0, 2**31 - 1, size=n, dtype=np.int64).astype(np.int32)
    acc_gm_sigma = spec.accel_bias_instability_ug * UG / GM_ADEV_PEAK
    gyro_gm_sigma = spec.gyro_bias_instability_deg_per_h * DEG_H / GM_ADEV_PEAK
    # drawn after everything else so that specs without bias instability draw as before
    acc_gm = acc_gm_sigma * rng.standard_normal((n, 3)) if acc_gm_sigma else np.zeros((n, 3))
    gyro_gm = gyro_gm_sigma * rng.standard_normal((n, 3)) if gyro_gm_sigma else np.zeros((n, 3))
    return ErrorDraws(
        acc_b,
        gyro_b,
        acc_M,
        gyro_M,
        np.full(n, spec.accel_vrw_ug_per_sqrt_hz * UG),
        np.full(n, spec.gyro_arw_deg_per_sqrt_h * DEG_RTH),
        seeds,
        np.full(n, acc_gm_sigma),
        np.full(n, spec.accel_bias_instability_tau_s if acc_gm_sigma else 0.0),
        np.full(n, gyro_gm_sigma),
        np.full(n, spec.gyro_bias_instability_tau_s if gyro_gm_sigma else 0.0),
        acc_gm,
        gyro_gm,
    )


def gm_allan_deviation(
    T: npt.ArrayLike, sigma: float = 1.0, tau_c: float = 1.0
) -> npt.NDArray[np.float64]:
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


def apply(
    dtheta: npt.ArrayLike,
    dv: npt.ArrayLike,
    dt: float,
    draws: ErrorDraws,
    run: int = 0,
    rng: np.random.Generator | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
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


def gauss_markov(
    n: int, sigma: float, tau: float, dt: float, beta0: npt.ArrayLike, rng: np.random.Generator
) -> np.ndarray:
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


def _integer(value: Any, what: str) -> int:
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


def _grade(
    ab: float,
    avrw: float,
    abi: float,
    gb: float,
    garw: float,
    gbi: float,
    sf: float,
    mis: float,
) -> ImuErrorSpec:
    return ImuErrorSpec(
        accel_bias_ug=ab,
        accel_vrw_ug_per_sqrt_hz=avrw,
        accel_bias_instability_ug=abi,
        accel_scale_factor_ppm=sf,
        accel_misalignment_arcsec=mis,
        gyro_bias_deg_per_h=gb,
        gyro_arw_deg_per_sqrt_h=garw,
        gyro_bias_instability_deg_per_h=gbi,
        gyro_scale_factor_ppm=sf,
        gyro_misalignment_arcsec=mis,
    )


#: named IMUs (see the module docstring for the sources)
PRESETS: dict[str, ImuErrorSpec] = {
    "ideal": ImuErrorSpec(),
    "consumer": _grade(5000.0, 150.0, 100.0, 360.0, 0.6, 10.0, 5000.0, 1800.0),
    "industrial": _grade(500.0, 25.0, 10.0, 10.0, 0.2, 2.0, 500.0, 300.0),
    "tactical": _grade(1000.0, 100.0, 50.0, 1.0, 0.125, 0.3, 300.0, 100.0),
    "navigation": _grade(25.0, 10.0, 5.0, 0.003, 0.002, 0.001, 30.0, 10.0),
    "strategic": _grade(1.0, 1.0, 0.5, 0.0001, 0.0001, 0.00005, 1.0, 1.0),
    **{f"table2-group{k}": v for k, v in TABLE2_GROUPS.items()},
    "table4": TABLE4,
}

#: TOML key -> ImuErrorSpec field(s): a field's own name (one vocabulary: the keys of a TOML
#: file, of :class:`ImuErrorSpec` and of the ``imu_spec`` a study's JSON records, so that a run's
#: spec copied into a TOML file loads as the same spec), and the keys shared by both triads
TOML_KEYS = {
    "accel_bias_ug": ("accel_bias_ug",),
    "accel_vrw_ug_per_sqrt_hz": ("accel_vrw_ug_per_sqrt_hz",),
    "accel_bias_instability_ug": ("accel_bias_instability_ug",),
    "accel_bias_instability_tau_s": ("accel_bias_instability_tau_s",),
    "accel_scale_factor_ppm": ("accel_scale_factor_ppm",),
    "accel_misalignment_arcsec": ("accel_misalignment_arcsec",),
    "gyro_bias_deg_per_h": ("gyro_bias_deg_per_h",),
    "gyro_arw_deg_per_sqrt_h": ("gyro_arw_deg_per_sqrt_h",),
    "gyro_bias_instability_deg_per_h": ("gyro_bias_instability_deg_per_h",),
    "gyro_bias_instability_tau_s": ("gyro_bias_instability_tau_s",),
    "gyro_scale_factor_ppm": ("gyro_scale_factor_ppm",),
    "gyro_misalignment_arcsec": ("gyro_misalignment_arcsec",),
    "scale_factor_ppm": ("accel_scale_factor_ppm", "gyro_scale_factor_ppm"),
    "misalignment_arcsec": ("accel_misalignment_arcsec", "gyro_misalignment_arcsec"),
    "bias_instability_tau_s": ("accel_bias_instability_tau_s", "gyro_bias_instability_tau_s"),
}
_TEXT_KEYS = ("name", "description")

#: TOML key -> (lowest, highest, unit) accepted; see the module docstring for the reasons
RANGES: dict[str, tuple[float, float, str]] = {
    "accel_bias_ug": (0.0, 1e5, "µg"),
    "accel_vrw_ug_per_sqrt_hz": (0.0, 1e4, "µg/√Hz"),
    "accel_bias_instability_ug": (0.0, 1e4, "µg"),
    "accel_bias_instability_tau_s": (0.01, 1e6, "s"),
    "accel_scale_factor_ppm": (0.0, 1e5, "ppm"),
    "accel_misalignment_arcsec": (0.0, 18000.0, "arcsec"),
    "gyro_bias_deg_per_h": (0.0, 1e5, "°/h"),
    "gyro_arw_deg_per_sqrt_h": (0.0, 30.0, "°/√h"),
    "gyro_bias_instability_deg_per_h": (0.0, 1000.0, "°/h"),
    "gyro_bias_instability_tau_s": (0.01, 1e6, "s"),
    "gyro_scale_factor_ppm": (0.0, 1e5, "ppm"),
    "gyro_misalignment_arcsec": (0.0, 18000.0, "arcsec"),
    "scale_factor_ppm": (0.0, 1e5, "ppm"),
    "misalignment_arcsec": (0.0, 18000.0, "arcsec"),
    "bias_instability_tau_s": (0.01, 1e6, "s"),
}
_SHARED_KEYS = ("scale_factor_ppm", "misalignment_arcsec", "bias_instability_tau_s")


def _check_value(key: str, val: Any, source: str) -> float:
    """Return ``val`` of ``key`` as a float, or raise the one-line InputError naming it."""
    if isinstance(val, bool) or not isinstance(val, numbers.Real):
        raise InputError(f"{source}: {key} = {val!r} is not a number")
    if type(val) not in (int, float):  # a NumPy scalar (mapping from Python): shown as a number
        val = int(val) if isinstance(val, numbers.Integral) else float(val)
    if isinstance(val, float) and not math.isfinite(val):
        raise InputError(f"{source}: {key} = {val!r} is not a finite number")
    lo, hi, unit = RANGES[key]
    if not lo <= val <= hi:
        raise InputError(
            f"{source}: {key} = {val!r} is outside the allowed range {lo:.15g} … {hi:.15g} {unit} "
            "(see fieldmap.nav.sensors)"
        )
    return float(val)


def spec_from_mapping(data: dict, source: str = "IMU spec") -> ImuErrorSpec:
    """Build an :class:`ImuErrorSpec` from TOML-style keys (see the module docstring).

    Raises
    ------
    InputError
        An unknown key, a value that is no number, not finite or outside its range
        (:data:`RANGES`), or no error term at all (``{}`` is no ideal IMU: use the preset).
    """
    unknown = sorted(k for k in data if k not in TOML_KEYS and k not in _TEXT_KEYS)
    if unknown:
        raise InputError(
            f"{source}: unknown key(s) {', '.join(unknown)} (known: {', '.join(TOML_KEYS)})"
        )
    values: dict[str, float] = {}
    for key, val in data.items():
        if key in _TEXT_KEYS:
            continue
        number = _check_value(key, val, source)
        for field in TOML_KEYS[key]:
            if field in values and key in _SHARED_KEYS:
                continue  # a specific accel_/gyro_ key wins over the shared one
            values[field] = number
    if not any(k in data and not k.endswith("_tau_s") for k in TOML_KEYS):
        raise InputError(
            f"{source} sets no error terms (no key such as accel_bias_ug or "
            "gyro_arw_deg_per_sqrt_h); for an IMU without errors use the preset 'ideal' "
            "(--imu ideal)"
        )
    return replace(ImuErrorSpec(), **values)


def load_imu(name_or_path: str | os.PathLike[str]) -> tuple[str, ImuErrorSpec]:
    """Return ``(label, spec)`` for a preset name or a TOML file path.

    Raises
    ------
    InputError
        Unknown name, unreadable or malformed file, unknown key or bad value.

    Examples
    --------
    >>> import fieldmap
    >>> name, spec = fieldmap.load_imu("tactical")
    >>> name, spec.accel_bias_ug, spec.gyro_bias_deg_per_h  # µg, °/h
    ('tactical', 1000.0, 1.0)
    """
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # Python 3.10: the same parser, from PyPI
        import tomli as tomllib

    key = str(name_or_path).strip()
    if key.lower() in PRESETS:
        return key.lower(), PRESETS[key.lower()]
    path = Path(key)
    if not path.suffix.lower() == ".toml" and not path.is_file():
        raise InputError(f"unknown IMU {key!r}: a preset ({', '.join(PRESETS)}) or a .toml file")
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: IMU file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the IMU file ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    spec = spec_from_mapping(data, str(path))
    return str(data.get("name", path.stem)), spec


def allan_deviation(
    rate: npt.ArrayLike, dt: float, taus: npt.ArrayLike | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Overlapping Allan deviation of a rate record (n,) or (n, k) sampled every ``dt`` s.

    Returns ``(taus, adev)`` with ``adev`` (len(taus),) or (len(taus), k), in the rate's units.
    ``taus`` default: ~10 per decade from dt to a tenth of the record.
    """
    x = np.asarray(rate, dtype=np.float64)
    n = x.shape[0]
    if n < 20:
        raise InputError("Allan deviation needs at least 20 samples")
    if taus is None:
        m = np.unique(np.round(np.logspace(0, np.log10(n / 10), 40)).astype(np.int64))
    else:
        m = np.unique(np.maximum(1, np.round(np.asarray(taus) / dt)).astype(np.int64))
        m = m[2 * m < n]
    theta = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0) * dt])
    out = []
    for mi in m:
        d = theta[2 * mi :] - 2.0 * theta[mi:-mi] + theta[: -2 * mi]
        tau = mi * dt
        out.append(np.sqrt(np.sum(d * d, axis=0) / (2.0 * tau * tau * (n + 1 - 2 * mi))))
    return m * dt, np.array(out)


def simulate_at_rest(
    spec: ImuErrorSpec, duration: float, rate_hz: float, seed: int = 0
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], float]:
    """Sensor outputs at rest: gyro (n, 3) in °/h and accelerometer (n, 3) in µg, and dt (s).

    One Monte Carlo run of :func:`fieldmap.nav.sensors.apply` on zero true increments.
    """
    n = int(round(duration * rate_hz))
    n += n % 2
    if n < 20:
        raise InputError("duration × rate gives fewer than 20 samples")
    if n > 50_000_000:
        raise InputError(f"{n} samples is too many for the Allan simulation (max 5e7)")
    dt = 1.0 / rate_hz
    draws = draw(spec, 1, seed=seed)
    z = np.zeros((n, 3))
    th, dv = apply(z, z, dt, draws, 0)
    return th / dt / DEG_H, dv / dt / UG, dt


def allan_table(spec: ImuErrorSpec, duration: float, rate_hz: float, seed: int = 0) -> dict:
    """Allan deviations of the simulated gyros (°/h) and accelerometers (µg), axis x.

    Returns a dict with ``tau_s``, ``gyro_adev_deg_h``, ``accel_adev_ug`` (arrays) and the
    spec's expectations ``gyro_arw_at_1s_deg_h`` (= ARW·60), ``accel_vrw_at_1s_ug`` (= VRW) and
    the bias-instability floors.
    """
    g, a, dt = simulate_at_rest(spec, duration, rate_hz, seed)
    taus, ag = allan_deviation(g[:, 0], dt)
    _, aa = allan_deviation(a[:, 0], dt)
    return {
        "tau_s": taus,
        "gyro_adev_deg_h": ag,
        "accel_adev_ug": aa,
        "gyro_arw_at_1s_deg_h": spec.gyro_arw_deg_per_sqrt_h * 60.0,
        "accel_vrw_at_1s_ug": spec.accel_vrw_ug_per_sqrt_hz,
        "gyro_bias_instability_deg_per_h": spec.gyro_bias_instability_deg_per_h,
        "accel_bias_instability_ug": spec.accel_bias_instability_ug,
        "gyro_bias_instability_tau_s": spec.gyro_bias_instability_tau_s,
        "accel_bias_instability_tau_s": spec.accel_bias_instability_tau_s,
    }
