r"""Allan deviation of simulated IMU sensors at rest (to hold against a datasheet).

The sensors of :mod:`fieldmap.nav.imu_errors` are run at rest (zero true increments, so scale
factor and misalignment do not show and the constant bias cancels in the Allan variance): their
rate outputs are ``(Δθ̃/dt, Δṽ/dt)``. The overlapping Allan deviation (IEEE Std 952-1997 Annex C,
eq. C.11) of a rate record ω_k at averaging time τ = m dt, from the integrated angle
θ_k = Σ ω dt:

.. math::
    \sigma^2(\tau) = \frac{1}{2\tau^2 (N - 2m)} \sum_k (\theta_{k+2m} - 2\theta_{k+m} +
    \theta_k)^2

For white noise of density N the deviation is N/√τ (slope −1/2, value N at τ = 1 s); a
Gauss–Markov bias instability peaks at the spec's floor B near τ = 1.89 τ_c
(:data:`fieldmap.nav.imu_errors.GM_ADEV_PEAK`).
"""

from __future__ import annotations

import numpy as np

from fieldmap.errors import InputError
from fieldmap.nav import imu_errors
from fieldmap.nav.imu_errors import DEG_H, UG, ImuErrorSpec


def allan_deviation(rate, dt: float, taus=None):
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


def simulate_at_rest(spec: ImuErrorSpec, duration: float, rate_hz: float, seed: int = 0):
    """Sensor outputs at rest: gyro (n, 3) in °/h and accelerometer (n, 3) in µg, and dt (s).

    One Monte Carlo run of :func:`fieldmap.nav.imu_errors.apply` on zero true increments.
    """
    n = int(round(duration * rate_hz))
    n += n % 2
    if n < 20:
        raise InputError("duration × rate gives fewer than 20 samples")
    if n > 50_000_000:
        raise InputError(f"{n} samples is too many for the Allan simulation (max 5e7)")
    dt = 1.0 / rate_hz
    draws = imu_errors.draw(spec, 1, seed=seed)
    z = np.zeros((n, 3))
    th, dv = imu_errors.apply(z, z, dt, draws, 0)
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
        "gyro_arw_at_1s_deg_h": spec.gyro_arw_deg_rth * 60.0,
        "accel_vrw_at_1s_ug": spec.acc_noise_ug_rthz,
        "gyro_bias_instability_deg_h": spec.gyro_bi_deg_h,
        "accel_bias_instability_ug": spec.acc_bi_ug,
        "gyro_bi_tau_s": spec.gyro_bi_tau_s,
        "accel_bi_tau_s": spec.acc_bi_tau_s,
    }
