"""Sensor errors of the strapdown kernels: device structs and per-sample draws (Warp, float64).

Used by :mod:`fieldmap.kernels.strapdown`. Random numbers are counter-based: the draws of IMU
sample j come from ``wp.rand_init(seed, j)`` (:func:`sample_rng`), keyed on the run's seed and the
sample's global index in the flight, so a flight propagated in time blocks draws the same noise
whatever the blocking.
"""

import warp as wp

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

_ZERO = wp.constant(wp.float64(0.0))
_ONE = wp.constant(wp.float64(1.0))


@wp.struct
class SensorErrors:
    """Per-thread sensor errors, all arrays indexed by trajectory.

    Measured increments: ``dv = M_a dv_true + (b_a + β_a) dt + σ_a √dt n``,
    ``dθ = M_g dθ_true + (b_g + β_g) dt + σ_g √dt n`` with n ~ N(0, I) and β a first-order
    Gauss–Markov bias per axis, updated once per sample (after the sample used it):
    ``β⁺ = e^(−dt/τ) β + s √(1 − e^(−2dt/τ)) n`` (stationary σ = s; exact discretisation,
    Maybeck 1979 §4.9 / Brown & Hwang 2012 §2.9). Units: b_a, s_a m/s², b_g, s_g rad/s,
    σ_a m/s/√s, σ_g rad/√s, τ s (0: no Gauss–Markov term); M dimensionless (I + scale factor
    + misalignment).

    The normals n of IMU sample j (global index in the flight) come from Warp's RNG
    ``rand_init(seed, j)`` (:func:`sample_rng`), drawn in the order gyro noise, gyro
    Gauss–Markov, accelerometer noise, accelerometer Gauss–Markov (then, in the NED kernel,
    baro noise and baro drift): the same noise for a run whatever the time blocks it is
    propagated in. ``acc_gm``, ``gyro_gm`` hold the states at the start and are overwritten with
    those at the end.
    """

    acc_bias: wp.array(dtype=wp.vec3d)
    gyro_bias: wp.array(dtype=wp.vec3d)
    acc_M: wp.array(dtype=wp.mat33d)
    gyro_M: wp.array(dtype=wp.mat33d)
    acc_noise: wp.array(dtype=wp.float64)
    gyro_noise: wp.array(dtype=wp.float64)
    seed: wp.array(dtype=wp.int32)
    acc_gm_sigma: wp.array(dtype=wp.float64)
    acc_gm_tau: wp.array(dtype=wp.float64)
    gyro_gm_sigma: wp.array(dtype=wp.float64)
    gyro_gm_tau: wp.array(dtype=wp.float64)
    acc_gm: wp.array(dtype=wp.vec3d)
    gyro_gm: wp.array(dtype=wp.vec3d)


@wp.struct
class BaroAiding:
    """Third-order barometric altitude loop (Widnall & Sinha 1980; Titterton & Weston 2004 §5.3).

    With δh = h_INS − h_baro: ḣ = −v_D − k1 δh, v̇_D += k2 δh + δa, δȧ = k3 δh. Baro
    measurement per IMU sample: ``h_baro = h_ref + bias + γ + σ n`` with γ a Gauss–Markov
    drift (σ_gm, τ_gm). ``enabled`` 0: free vertical channel (the loop is skipped). ``state``
    per trajectory (δa m/s², γ m, unused) is read at the start and written at the end, so a
    flight can be propagated in time blocks. Units: k1 1/s, k2 1/s², k3 1/s³, heights m.
    """

    enabled: wp.int32
    k1: wp.float64
    k2: wp.float64
    k3: wp.float64
    h_ref: wp.array2d(dtype=wp.float64)
    bias: wp.array(dtype=wp.float64)
    noise: wp.array(dtype=wp.float64)
    gm_sigma: wp.array(dtype=wp.float64)
    gm_tau: wp.array(dtype=wp.float64)
    state: wp.array(dtype=wp.vec3d)


@wp.func
def gm_coeffs(sigma: wp.float64, tau: wp.float64, dt: wp.float64):
    """Per-sample factors (e^(−dt/τ), s √(1 − e^(−2dt/τ))) of a Gauss–Markov process; (1, 0) off."""
    if tau > _ZERO and sigma > _ZERO:
        a = wp.exp(-dt / tau)
        return a, sigma * wp.sqrt(_ONE - a * a)
    return _ONE, _ZERO


@wp.func
def sample_rng(noisy: wp.int32, seed: wp.int32, index: wp.int32):
    """RNG state of IMU sample ``index`` (global in the flight) of the run seeded ``seed``.

    ``rand_init(seed, index)``: a counter-based stream, independent of how the flight is cut
    into launches. ``noisy`` 0 (no noise source in the thread, so no draw follows): 0 without
    hashing.
    """
    if noisy != 0:
        return wp.rand_init(seed, index)
    return wp.uint32(0)


@wp.func
def gm_step(beta: wp.vec3d, a: wp.float64, b: wp.float64, state: wp.uint32):
    """One Gauss–Markov update of three axes; draws normals only when ``b`` ≠ 0."""
    if b != _ZERO:
        beta = a * beta + b * wp.vec3d(
            wp.float64(wp.randn(state)), wp.float64(wp.randn(state)), wp.float64(wp.randn(state))
        )
    return beta, state


@wp.func
def measured(M: wp.mat33d, x: wp.vec3d, bias_dt: wp.vec3d, sigma: wp.float64, state: wp.uint32):
    """One measured increment of :class:`SensorErrors`: ``M x + b dt + σ √dt n``.

    ``bias_dt`` = b dt and ``sigma`` = σ √dt (hoisted per thread); n draws three normals from
    ``state`` only when ``sigma`` ≠ 0. Returns the increment and the advanced RNG state.
    """
    y = M * x + bias_dt
    if sigma != _ZERO:
        y = y + sigma * wp.vec3d(
            wp.float64(wp.randn(state)), wp.float64(wp.randn(state)), wp.float64(wp.randn(state))
        )
    return y, state


@wp.struct
class ThreadErrors:
    """The sensor errors of one thread, hoisted out of its loop (:func:`thread_errors`).

    ``Mg``, ``Ma`` the scale/misalignment matrices; ``bg``, ``ba`` the biases times dt;
    ``sg``, ``sa`` σ √dt of the white noise; (``ga``, ``gb``), (``aa``, ``ab``) the per-sample
    Gauss–Markov factors of :func:`gm_coeffs`; ``seed`` the run's seed; ``noisy`` 1 when a draw
    can follow (then every sample hashes its RNG state, :func:`sample_rng`).
    """

    Mg: wp.mat33d
    Ma: wp.mat33d
    bg: wp.vec3d
    ba: wp.vec3d
    sg: wp.float64
    sa: wp.float64
    ga: wp.float64
    gb: wp.float64
    aa: wp.float64
    ab: wp.float64
    seed: wp.int32
    noisy: wp.int32


@wp.func
def thread_errors(err: SensorErrors, i: int, dt: wp.float64):
    """Hoist the sensor errors of trajectory ``i`` (one IMU sample of ``dt`` s) for its loop."""
    e = ThreadErrors()
    e.sg = err.gyro_noise[i] * wp.sqrt(dt)
    e.sa = err.acc_noise[i] * wp.sqrt(dt)
    e.Mg = err.gyro_M[i]
    e.Ma = err.acc_M[i]
    e.bg = err.gyro_bias[i] * dt
    e.ba = err.acc_bias[i] * dt
    e.seed = err.seed[i]
    ga, gb = gm_coeffs(err.gyro_gm_sigma[i], err.gyro_gm_tau[i], dt)
    aa, ab = gm_coeffs(err.acc_gm_sigma[i], err.acc_gm_tau[i], dt)
    e.ga = ga
    e.gb = gb
    e.aa = aa
    e.ab = ab
    e.noisy = wp.int32(0)
    if e.sg != _ZERO or e.sa != _ZERO or e.gb != _ZERO or e.ab != _ZERO:
        e.noisy = 1
    return e


@wp.func
def measured_sample(
    e: ThreadErrors,
    th: wp.vec3d,
    dv: wp.vec3d,
    beta_g: wp.vec3d,
    beta_a: wp.vec3d,
    dt: wp.float64,
    index: wp.int32,
):
    """Measured increments of IMU sample ``index`` (global in the flight), and the GM updates.

    The draws in their fixed order: gyro noise, gyro Gauss–Markov, accelerometer noise,
    accelerometer Gauss–Markov (the sample's noise uses the biases β before their update).
    Returns (dθ, dv, β_g, β_a, RNG state), the state for the baro draws that may follow.
    """
    state = sample_rng(e.noisy, e.seed, index)
    th, state = measured(e.Mg, th, e.bg + beta_g * dt, e.sg, state)
    beta_g, state = gm_step(beta_g, e.ga, e.gb, state)
    dv, state = measured(e.Ma, dv, e.ba + beta_a * dt, e.sa, state)
    beta_a, state = gm_step(beta_a, e.aa, e.ab, state)
    return th, dv, beta_g, beta_a, state
