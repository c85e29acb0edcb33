"""Strapdown mechanizations as Warp kernels: one thread propagates one trajectory.

* :func:`lci_kernel` — launch-centred inertial a-frame, Chen et al. (2022) eq. (14) with the
  two-sample algorithm of their Fig. 1 (coning, rotation and sculling corrections after
  Savage 1998 / Ignagni 1990), gravity at the predicted mid-point, eq. (15), rotated into the
  a-frame with eq. (20).
* :func:`ned_kernel` — Earth-relative local-level (NED) mechanization (Titterton & Weston ch. 3,
  Groves ch. 5), one update per IMU sample.

Each thread picks its increments set (``imu_set[i]``, sets may be shared), applies its own sensor
errors (bias, scale/misalignment matrix, white noise), its own navigation gravity kind and SH
degree, loops over its steps and writes every ``output_every``-th state.

Random numbers are counter-based: the draws of IMU sample j come from
``wp.rand_init(seed, sample0 + j)`` (:func:`sample_rng`), keyed on the run's seed and the sample's
global index in the flight (``sample0`` = index of the record's first sample), so a flight
propagated in time blocks draws the same noise whatever the blocking.

The sensor errors (:class:`SensorErrors`, :class:`BaroAiding`, :func:`thread_errors`,
:func:`measured_sample`) are the first section; the mechanizations follow.
"""

import warp as wp

from .frames import C_e_to_t, LaunchParams, ecef_to_enu, enu_to_ned, geodetic_to_ecef
from .navgravity import TableKernel, held_gravitation_ecef
from .normal import NormalParams, centrifugal_ecef, normal_field_ecef
from .sh import SHKernelModel

# forward kernels only: fieldmap never differentiates through them (faster builds, whatever
# the import order relative to fieldmap._warp.init())
wp.set_module_options({"enable_backward": False})

_ZERO = wp.constant(wp.float64(0.0))
_HALF = wp.constant(wp.float64(0.5))
_ONE = wp.constant(wp.float64(1.0))
_TWO_THIRDS = wp.constant(wp.float64(2.0 / 3.0))


# ------------------------------------------------------------------------------------ sensor errors


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


# ------------------------------------------------------------------------------- the mechanizations


@wp.func
def quat_from_rotvec(phi: wp.vec3d):
    """Quaternion of the rotation vector ``phi`` (rad); series near zero (error < 1e-17)."""
    a2 = wp.dot(phi, phi)
    w = _ZERO
    k = _ZERO
    if a2 < wp.float64(1.0e-6):
        # cos(a/2) and sin(a/2)/a to a^6 / a^4 terms: truncation < a^8/10^7 < 1e-30
        w = (
            _ONE
            - a2 / wp.float64(8.0)
            + a2 * a2 / wp.float64(384.0)
            - a2 * a2 * a2 / wp.float64(46080.0)
        )
        k = _HALF - a2 / wp.float64(48.0) + a2 * a2 / wp.float64(3840.0)
    else:
        a = wp.sqrt(a2)
        w = wp.cos(_HALF * a)
        k = wp.sin(_HALF * a) / a
    return wp.quatd(k * phi[0], k * phi[1], k * phi[2], w)


def _make_lci_kernel(general: bool):
    """Build the general LCI kernel, or the plain one without sensor errors and SH gravity.

    ``general`` False drops the sensor errors and the SH navigation gravity (for launches where
    no trajectory needs either: runs without those sources do not pay for them). The plain
    kernel gives the bits of the general one for the trajectories it accepts: the skipped code
    would add exact zeros (``M = I``, ``b = 0``, no draws) or is a branch never taken. (A kernel
    with only one of the two was never needed: a launch with errors or SH takes the general
    one.)
    """

    @wp.kernel
    def lci_kernel(
        dtheta: wp.array2d(dtype=wp.vec3d),
        dvel: wp.array2d(dtype=wp.vec3d),
        imu_set: wp.array(dtype=wp.int32),
        err: SensorErrors,
        P0: wp.array(dtype=wp.vec3d),
        V0: wp.array(dtype=wp.vec3d),
        q0: wp.array(dtype=wp.quatd),
        kind: wp.array(dtype=wp.int32),
        lmax: wp.array(dtype=wp.int32),
        lp: LaunchParams,
        ell: NormalParams,
        sh: SHKernelModel,
        tab: TableKernel,
        dt: wp.float64,
        t0: wp.float64,
        n_steps: wp.int32,
        output_every: wp.int32,
        sample0: wp.int32,
        grav_every: wp.int32,
        grav_hold: wp.array2d(dtype=wp.vec3d),
        P_out: wp.array2d(dtype=wp.vec3d),
        V_out: wp.array2d(dtype=wp.vec3d),
        q_out: wp.array2d(dtype=wp.quatd),
        offset: wp.int32,
    ):
        """Two-sample launch-centred inertial mechanization, Chen et al. (2022) eq. (14), Fig. 1.

        Per step k (T = 2 dt, samples 2k and 2k+1 of set ``imu_set[i]``):
        φ = Δθ1 + Δθ2 + ⅔ Δθ1×Δθ2 (coning), q_k = q_{k-1} ⊗ q(φ);
        Δv_b = Δv + ½ Δθ×Δv + ⅔ (Δθ1×Δv2 + Δv1×Δθ2) (rotation, sculling), rotated by q_{k-1};
        g^a at P̃ = P + V T/2 (eq. 15) and t_{k-1/2}: ECEF via R_a^e(t), gravitation, back with
        eq. (20); V_k = V + Δv_a + g^a T; P_k = P + (V_{k-1} + V_k) T/2.
        ``sample0``: global index of the first sample (keys the noise, :func:`sample_rng`); ``t0``
        the time of global sample 0 (sample 2k is at t0 + (sample0 + 2k) dt).
        """
        i = wp.tid() + offset
        s = imu_set[i]
        model = sh
        model.lmax = lmax[i]
        gk = kind[i]
        P = P0[i]
        V = V0[i]
        q = q0[i]
        T = dt + dt
        C_a_t = wp.transpose(lp.C_t_to_a)
        te = thread_errors(err, i, dt)
        beta_g = err.gyro_gm[i]
        beta_a = err.acc_gm[i]
        gh = grav_hold[i, 0]
        gs = grav_hold[i, 1]
        gl = grav_hold[i, 2]
        P_out[i, 0] = P
        V_out[i, 0] = V
        q_out[i, 0] = q
        for k in range(n_steps):
            # each sample its own stream; per sensor the order of the sequential draws is kept
            # (th1 with β_g, β_g update, th2 with the updated β_g, β_g update; likewise dv, β_a)
            j = 2 * k
            th1 = dtheta[s, j]
            dv1 = dvel[s, j]
            th2 = dtheta[s, j + 1]
            dv2 = dvel[s, j + 1]
            if wp.static(general):
                th1, dv1, beta_g, beta_a, _s1 = measured_sample(
                    te, th1, dv1, beta_g, beta_a, dt, sample0 + j
                )
                th2, dv2, beta_g, beta_a, _s2 = measured_sample(
                    te, th2, dv2, beta_g, beta_a, dt, sample0 + j + 1
                )
            th = th1 + th2
            dvb = dv1 + dv2
            phi = th + _TWO_THIRDS * wp.cross(th1, th2)
            dvb = (
                dvb
                + _HALF * wp.cross(th, dvb)
                + _TWO_THIRDS * (wp.cross(th1, dv2) + wp.cross(dv1, th2))
            )
            dv_a = wp.quat_rotate(q, dvb)
            # mid-step time from the global index: t0 is the time of sample 0 of the whole record
            t_mid = t0 + dt * wp.float64(sample0 + j + 1)
            # R_e^t(t) once per step: r_e = R_t^e (R_a^t P~ + r_launch),
            # g^a = R_t^a R_e^t g^e (eq. 20)
            C_et = C_e_to_t(t_mid, lp.omega)
            r_e = wp.transpose(C_et) * (C_a_t * (P + V * (_HALF * T)) + lp.r_launch)
            g_e = wp.vec3d()
            if wp.static(general):
                g_e, gh, gs, gl = held_gravitation_ecef(
                    gk, r_e, ell, model, tab, sample0 + j + 1, grav_every, gh, gs, gl
                )
            else:
                g_e = normal_field_ecef(r_e, ell, gk, 0)
            g_a = lp.C_t_to_a * (C_et * g_e)
            V_new = V + dv_a + g_a * T
            P = P + (V + V_new) * (_HALF * T)
            V = V_new
            q = wp.normalize(q * quat_from_rotvec(phi))
            if (k + 1) % output_every == 0:
                j = (k + 1) // output_every
                P_out[i, j] = P
                V_out[i, j] = V
                q_out[i, j] = q
        err.gyro_gm[i] = beta_g
        err.acc_gm[i] = beta_a
        grav_hold[i, 0] = gh
        grav_hold[i, 1] = gs
        grav_hold[i, 2] = gl

    return lci_kernel


#: the general kernel (any sensor errors, any navigation gravity)
lci_kernel = _make_lci_kernel(True)
#: no sensor errors, normal navigation gravity only
lci_kernel_plain = _make_lci_kernel(False)


def lci_kernel_for(errors: bool, sh_gravity: bool):
    """Return the LCI kernel for a launch: the plain one when no trajectory needs errors or SH."""
    return lci_kernel if errors or sh_gravity else lci_kernel_plain


@wp.func
def force_ned(q_b_n: wp.quatd, dt: wp.float64, dth: wp.vec3d, dv: wp.vec3d):
    """Specific force in NED, C_b^n (dv + ½ dθ×dv)/dt (Titterton & Weston 2004 eq. 11.64). m/s²."""
    return wp.quat_rotate(q_b_n, dv + _HALF * wp.cross(dth, dv)) / dt


def _make_ned_kernel(general: bool):
    """Build the NED kernel specialised as :func:`_make_lci_kernel`.

    ``general`` False drops the sensor errors, the baro aiding and the SH navigation gravity.
    """

    @wp.kernel
    def ned_kernel(
        dtheta: wp.array2d(dtype=wp.vec3d),
        dvel: wp.array2d(dtype=wp.vec3d),
        imu_set: wp.array(dtype=wp.int32),
        err: SensorErrors,
        llh0: wp.array(dtype=wp.vec3d),
        v0: wp.array(dtype=wp.vec3d),
        q0: wp.array(dtype=wp.quatd),
        kind: wp.array(dtype=wp.int32),
        lmax: wp.array(dtype=wp.int32),
        ell: NormalParams,
        baro: BaroAiding,
        sh: SHKernelModel,
        tab: TableKernel,
        dt: wp.float64,
        n_steps: wp.int32,
        output_every: wp.int32,
        sample0: wp.int32,
        grav_every: wp.int32,
        grav_hold: wp.array2d(dtype=wp.vec3d),
        llh_out: wp.array2d(dtype=wp.vec3d),
        v_out: wp.array2d(dtype=wp.vec3d),
        q_out: wp.array2d(dtype=wp.quatd),
        offset: wp.int32,
    ):
        """Earth-relative NED mechanization, one update per IMU sample (T&W ch. 3, 11).

        With ω_ie^n = Ω(cos L, 0, −sin L),
        ω_en^n = (v_E/(R_E+h), −v_N/(R_N+h), −v_E tan L/(R_E+h)) at the start of the sample:
        f^n = C_b^n (dv + ½ dθ×dv)/dt − ½ ω_in^n × C_b^n dv (the rotation correction of
        Titterton & Weston eq. 11.64 plus the n-frame rotation, Savage 1998);
        v⁺ = v + [f^n + g^n − (2ω_ie^n + ω_en^n) × v] dt (gravity at the start position);
        L, λ, h from the trapezoidal mean velocity; q_b^n⁺ = q(−ω_in^n dt) ⊗ q_b^n ⊗ q(dθ).
        With ``baro.enabled`` the vertical channel is damped by :class:`BaroAiding` (δh from the
        start of the sample: v_D += (k2 δh + δa) dt, h −= k1 δh dt, δa += k3 δh dt).
        ``sample0``: global index of the first sample (keys the noise, :func:`sample_rng`).
        """
        i = wp.tid() + offset
        s = imu_set[i]
        model = sh
        model.lmax = lmax[i]
        gk = kind[i]
        llh = llh0[i]
        v = v0[i]
        q = q0[i]
        te = thread_errors(err, i, dt)
        beta_g = err.gyro_gm[i]
        beta_a = err.acc_gm[i]
        gh = grav_hold[i, 0]
        gs = grav_hold[i, 1]
        gl = grav_hold[i, 2]
        aid = baro.state[i]
        da = aid[0]
        drift = aid[1]
        ba_a, ba_b = gm_coeffs(baro.gm_sigma[i], baro.gm_tau[i], dt)
        b_bias = baro.bias[i]
        b_noise = baro.noise[i]
        if baro.enabled != 0 and (b_noise != _ZERO or ba_b != _ZERO):
            te.noisy = 1
        llh_out[i, 0] = llh
        v_out[i, 0] = v
        q_out[i, 0] = q
        for k in range(n_steps):
            th = dtheta[s, k]
            dv = dvel[s, k]
            dh = _ZERO
            if wp.static(general):
                th, dv, beta_g, beta_a, state = measured_sample(
                    te, th, dv, beta_g, beta_a, dt, sample0 + k
                )
                if baro.enabled != 0:
                    h_b = baro.h_ref[s, k] + b_bias + drift
                    if b_noise != _ZERO:
                        h_b = h_b + b_noise * wp.float64(wp.randn(state))
                    if ba_b != _ZERO:
                        drift = ba_a * drift + ba_b * wp.float64(wp.randn(state))
                    dh = llh[2] - h_b
            sl = wp.sin(llh[0])
            cl = wp.cos(llh[0])
            w = _ONE - ell.e2 * sl * sl
            re = ell.a / wp.sqrt(w) + llh[2]
            rn = ell.a * (_ONE - ell.e2) / (w * wp.sqrt(w)) + llh[2]
            w_ie = wp.vec3d(ell.omega * cl, _ZERO, -ell.omega * sl)
            w_en = wp.vec3d(v[1] / re, -v[0] / rn, -v[1] * sl / (cl * re))
            # navtk's calc_force_ned omits the n-frame term: without it a body at rest on the
            # rotating Earth sees a spurious ½ ω_ie × f dt (0.36 mGal at dt = 10 ms); with it
            # rest is exact
            f = force_ned(q, dt, th, dv) - _HALF * wp.cross(w_ie + w_en, wp.quat_rotate(q, dv))
            r_g = geodetic_to_ecef(llh[0], llh[1], llh[2], ell.a, ell.e2)
            g_e = wp.vec3d()
            if wp.static(general):
                g_e, gh, gs, gl = held_gravitation_ecef(
                    gk, r_g, ell, model, tab, sample0 + k, grav_every, gh, gs, gl
                )
            else:
                g_e = normal_field_ecef(r_g, ell, gk, 0)
            g = enu_to_ned(ecef_to_enu(g_e + centrifugal_ecef(r_g, ell.omega), llh[0], llh[1]))
            v_new = v + (f + g - wp.cross(w_ie + w_ie + w_en, v)) * dt
            if wp.static(general):
                if baro.enabled != 0:
                    v_new = v_new + wp.vec3d(_ZERO, _ZERO, (baro.k2 * dh + da) * dt)
            vm = _HALF * (v + v_new)
            llh = llh + wp.vec3d(vm[0] / rn, vm[1] / (re * cl), -vm[2] - baro.k1 * dh) * dt
            da = da + baro.k3 * dh * dt
            v = v_new
            q = wp.normalize(quat_from_rotvec(-(w_ie + w_en) * dt) * q * quat_from_rotvec(th))
            if (k + 1) % output_every == 0:
                j = (k + 1) // output_every
                llh_out[i, j] = llh
                v_out[i, j] = v
                q_out[i, j] = q
        err.gyro_gm[i] = beta_g
        err.acc_gm[i] = beta_a
        grav_hold[i, 0] = gh
        grav_hold[i, 1] = gs
        grav_hold[i, 2] = gl
        baro.state[i] = wp.vec3d(da, drift, _ZERO)

    return ned_kernel


#: the general kernel (any sensor errors, baro aiding, any navigation gravity)
ned_kernel = _make_ned_kernel(True)
#: no sensor errors, no baro aiding, normal navigation gravity only
ned_kernel_plain = _make_ned_kernel(False)


def ned_kernel_for(errors: bool, sh_gravity: bool):
    """Return the NED kernel for a launch: the plain one without errors, baro and SH."""
    return ned_kernel if errors or sh_gravity else ned_kernel_plain
