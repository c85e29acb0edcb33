"""LCI strapdown kernel: NumPy reference, closed forms (bias, gravity offset, coning), inputs."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84
from fieldmap.nav.frames import LaunchFrame
from fieldmap.nav.mechanize import (
    LciStart,
    NavConfig,
    NedStart,
    dcm_to_quat,
    propagate_lci,
    quat_to_dcm,
)
from fieldmap.reference import normal as rnorm
from fieldmap.reference.strapdown import propagate_lci_reference

FRAME = LaunchFrame(105.3, 27.1, 63.0, h0=0.0)


def _g_ref(kind):
    """Independent NumPy gravitation callables (fieldmap.reference.normal, Groves eq. 3.7.7)."""
    if kind == "j2":
        return lambda r: rnorm.groves_j2_gravitation(
            r[:, 0], r[:, 1], r[:, 2], WGS84.GM, WGS84.J2, WGS84.a
        )
    if kind == "exact":
        return lambda r: rnorm.exact_gravitation_ecef(r[:, 0], r[:, 1], r[:, 2], WGS84)
    order = int(kind[1])
    return lambda r: rnorm.jn_gravitation(r[:, 0], r[:, 1], r[:, 2], WGS84, order)


def _random_motion(n, ns, dt, seed=0):
    rng = np.random.default_rng(seed)
    dth = rng.normal(0, 0.2, (n, ns, 3)) * dt
    dv = (rng.normal(0, 3, (n, ns, 3)) + [0, 9.8, 0]) * dt
    P0 = rng.normal(0, 100, (n, 3)) + [0, 20e3, 0]
    V0 = rng.normal(0, 300, (n, 3))
    q0 = dcm_to_quat(Rotation.random(n, random_state=rng).as_matrix())
    return dth, dv, P0, V0, q0


def test_kernel_equals_reference(device):
    kinds = ["j2", "j4", "j6", "exact"]
    n, ns, dt = 8, 1200, 0.005
    dth, dv, P0, V0, q0 = _random_motion(n, ns, dt)
    sets = np.arange(n) % 4  # trajectories share increment sets
    res = propagate_lci(
        dth[:4],
        dv[:4],
        dt,
        LciStart(P0, V0, q0, FRAME),
        NavConfig(kinds * 2, imu_set=sets, output_every=50, t0=12.5),
        device=device,
    )
    for kind in kinds:
        sel = [i for i in range(n) if res.gravity[i] == kind]
        ts, P, V, C = propagate_lci_reference(
            (dth[sets[sel]], dv[sets[sel]], dt),
            (P0[sel], V0[sel], quat_to_dcm(q0[sel])),
            FRAME,
            _g_ref(kind),
            t0=12.5,
            output_every=50,
        )
        np.testing.assert_allclose(res.t, ts, rtol=1e-15)
        scale = np.abs(P).max()
        assert np.abs(res.P[sel] - P).max() <= 1e-12 * scale + 1e-9, kind
        assert np.abs(res.V[sel] - V).max() <= 1e-12 * np.abs(V).max(), kind
        assert np.abs(quat_to_dcm(res.q[sel]) - C).max() <= 1e-12, kind


def test_sh_kind_equals_reference(device):
    from fieldmap.models.registry import load_model
    from fieldmap.reference import sh as rsh

    model = load_model("eigen-6s", lmax=24)
    n, ns, dt = 2, 200, 0.01
    dth, dv, P0, V0, q0 = _random_motion(n, ns, dt, seed=3)
    res = propagate_lci(
        dth,
        dv,
        dt,
        LciStart(P0, V0, q0, FRAME),
        NavConfig(["sh12", "sh"], sh_model=model, output_every=25),
        device=device,
    )
    for i, L in enumerate([12, 24]):
        g = lambda r, L=L: rsh.gravitation_ecef(model, r[:, 0], r[:, 1], r[:, 2], lmax=L)  # noqa: E731
        _, P, V, C = propagate_lci_reference(
            (dth[i : i + 1], dv[i : i + 1], dt),
            (P0[i : i + 1], V0[i : i + 1], quat_to_dcm(q0[i : i + 1])),
            FRAME,
            g,
            output_every=25,
        )
        assert np.abs(res.P[i] - P[0]).max() <= 1e-12 * np.abs(P).max() + 1e-9
        assert np.abs(res.V[i] - V[0]).max() <= 1e-12 * np.abs(V).max()


def _inertially_fixed(P0, kind, n_samples, dt, C_b_a=np.eye(3)):
    """Increments of a body at rest in the a-frame: dθ = 0, dv = −C_a^b g^a dt.

    For a zonal field the gravitation at an inertially fixed point is constant in the a-frame
    (the Earth turns about its symmetry axis), so these increments are exact.
    """
    r = FRAME.a_to_ecef(P0, 0.0)
    g_a = FRAME.vector_e_to_a(_g_ref(kind)(r[None])[0], 0.0)
    dv = np.broadcast_to(-(C_b_a.T @ g_a) * dt, (n_samples, 3)).copy()
    return np.zeros((n_samples, 3)), dv, g_a


def _gradient_a(P0, kind, step=1.0):
    """Gravity gradient ∂g^a/∂P (1/s²) by central differences of the reference gravitation."""
    G = np.empty((3, 3))
    for j in range(3):
        d = np.zeros(3)
        d[j] = step
        gp = FRAME.vector_e_to_a(_g_ref(kind)(FRAME.a_to_ecef(P0 + d, 0.0)[None])[0], 0.0)
        gm = FRAME.vector_e_to_a(_g_ref(kind)(FRAME.a_to_ecef(P0 - d, 0.0)[None])[0], 0.0)
        G[:, j] = (gp - gm) / (2 * step)
    return G


def test_accel_bias_gives_half_b_t2(device):
    P0 = np.array([0.0, 30e3, 0.0])
    dt, ns = 0.01, 4000  # 40 s
    C = Rotation.from_euler("xyz", [0.3, -0.2, 1.1]).as_matrix()
    dth, dv, _ = _inertially_fixed(P0, "j4", ns, dt, C)
    b = np.array([1e-3, -2e-3, 5e-4])  # m/s² (100-200 µg)
    res = propagate_lci(
        np.stack([dth, dth]),
        np.stack([dv, dv]),
        dt,
        LciStart(P0, np.zeros(3), dcm_to_quat(C), FRAME),
        NavConfig("j4", errors={"acc_bias": np.stack([np.zeros(3), b])}, output_every=100),
        device=device,
    )
    # no bias: the body stays put (exact increments; floor of the algorithm, 1.3e-12 m measured)
    assert np.abs(res.P[0] - P0).max() < 1e-10
    t = res.t[:, None]
    err = res.P[1] - res.P[0]
    bA = C @ b
    G = _gradient_a(P0, "j4")
    # δP̈ = bA + G δP  ->  δP = ½ bA t² + G bA t⁴/24 + O(G² t⁶)
    predicted = 0.5 * bA * t**2 + (G @ bA) * t**4 / 24
    np.testing.assert_allclose(err, predicted, rtol=0, atol=1e-7 * np.abs(predicted).max())
    # the leading term alone is good to ~G t²/12 (a few 1e-4 at 40 s): short-time ½ b t²
    np.testing.assert_allclose(err[-1], 0.5 * bA * t[-1] ** 2, rtol=1e-3)
    assert np.abs(err[-1] - 0.5 * bA * t[-1] ** 2).max() > 1e-6  # and the t⁴ term is resolved


def test_constant_gravity_offset_gives_half_dg_t2(device):
    # truth: at rest in the a-frame under J2; navigation with J6: the model difference at a fixed
    # inertial point is a constant offset δg (both fields are zonal).
    P0 = np.array([0.0, 25e3, 0.0])
    dt, ns = 0.01, 4000
    dth, dv, g2 = _inertially_fixed(P0, "j2", ns, dt)
    g6 = FRAME.vector_e_to_a(_g_ref("j6")(FRAME.a_to_ecef(P0, 0.0)[None])[0], 0.0)
    dg = g6 - g2
    res = propagate_lci(
        dth,
        dv,
        dt,
        LciStart(P0, np.zeros(3), [1.0, 0, 0, 0], FRAME),
        NavConfig("j6", output_every=100),
        device=device,
    )
    t = res.t[:, None]
    G = _gradient_a(P0, "j6")
    predicted = 0.5 * dg * t**2 + (G @ dg) * t**4 / 24
    np.testing.assert_allclose(
        res.P[0] - P0, predicted, rtol=0, atol=1e-6 * np.abs(predicted).max()
    )
    assert np.linalg.norm(dg) > 1e-5  # a real offset (4 mGal, the J4 term): the test can fail


def _coning_increments(alpha, Om, t):
    """Exact gyro increments of the coning motion C_b^a(t) = rotvec(0, α cos Ωt, α sin Ωt).

    Body rate ω = (−2Ω sin²(α/2), −Ω sin α sin Ωt, Ω sin α cos Ωt) integrated over [t_k, t_k+1].
    """
    s = np.sin(alpha)
    return np.stack(
        [
            -2 * Om * np.sin(alpha / 2) ** 2 * np.diff(t),
            s * np.diff(np.cos(Om * t)),
            s * np.diff(np.sin(Om * t)),
        ],
        -1,
    )


def _coning_attitude(alpha, Om, t):
    return Rotation.from_rotvec(
        np.stack([0 * t, alpha * np.cos(Om * t), alpha * np.sin(Om * t)], -1)
    )


def _two_sample_drift_rate(alpha, Om, T):
    """Exact attitude drift rate of the two-sample algorithm on coning (closed form).

    With C(t) = R_x(Ωt) R_y(α) R_x(−Ωt), step k's increments are step 0's turned by R_x(kΩT), so
    the computed attitude after N steps is C(0) (E R_x(ΩT))^N R_x(−NΩT) with E = Rot(φ_0), the
    truth C(0) (R_y(−α) R_x(ΩT) R_y(α))^N R_x(−NΩT): the error angle grows at
    (|E R_x(ΩT)| − ΩT)/T, ≈ −Ω α² (ΩT)⁴/960 for small ΩT (Ignagni 1990).
    """
    inc = _coning_increments(alpha, Om, np.array([0.0, T / 2, T]))
    phi = inc[0] + inc[1] + 2.0 / 3.0 * np.cross(inc[0], inc[1])
    M = Rotation.from_rotvec(phi) * Rotation.from_rotvec([Om * T, 0, 0])
    return (M.magnitude() - Om * T) / T, M


def test_coning_closed_form_series():
    # the exact drift approaches the classic −Ω α² (ΩT)⁴/960 as ΩT -> 0
    Om, alpha = 2 * np.pi, 0.01
    ratios = [
        _two_sample_drift_rate(alpha, Om, T)[0] / (-Om * alpha**2 * (Om * T) ** 4 / 960)
        for T in (0.1, 0.05, 0.025)
    ]
    assert abs(ratios[-1] - 1) < 2e-3 and abs(ratios[-1] - 1) < abs(ratios[0] - 1)


def test_coning_drift_matches_closed_form(device):
    alpha, Om, dt = 0.02, 2 * np.pi, 0.05  # T = 0.1 s, ΩT = 0.63 rad
    ns = 20000  # 1000 s
    t = np.arange(ns + 1) * dt
    dth = _coning_increments(alpha, Om, t)
    C0 = _coning_attitude(alpha, Om, np.array([0.0]))
    res = propagate_lci(
        dth,
        np.zeros_like(dth),
        dt,
        LciStart([0, 1e5, 0], np.zeros(3), dcm_to_quat(C0.as_matrix()), FRAME),
        NavConfig("j2", output_every=1000),
        device=device,
    )
    rate, M = _two_sample_drift_rate(alpha, Om, 2 * dt)
    N = np.arange(res.t.size) * 1000
    # the algorithm's attitude in closed form: C(0) M^N R_x(−NΩT)
    closed = [
        C0[0]
        * Rotation.from_rotvec(M.as_rotvec() * k)
        * Rotation.from_rotvec([-k * Om * 2 * dt, 0, 0])
        for k in N
    ]
    comp = Rotation.from_matrix(quat_to_dcm(res.q[0]))
    for k in range(res.t.size):
        assert (closed[k].inv() * comp[k]).magnitude() < 1e-11
    # error against the true attitude grows linearly at the closed-form rate (plus a bounded part)
    truth = _coning_attitude(alpha, Om, res.t)
    err = (truth.inv() * comp).magnitude()
    slope = np.polyfit(res.t[5:], err[5:], 1)[0]
    np.testing.assert_allclose(slope, abs(rate), rtol=1e-6)  # measured 2e-9
    assert abs(rate) > 1e-7  # about 0.08 °/h: resolved far above rounding


def test_noise_is_seeded_and_scaled(device):
    n, ns, dt = 256, 400, 0.01
    P0 = np.array([0.0, 1e4, 0.0])
    dth, dv, _ = _inertially_fixed(P0, "j2", ns, dt)
    sig = 1e-3  # m/s/√s
    err = {"acc_noise": np.full(n, sig), "seed": np.arange(n) + 7}
    a, b = (
        propagate_lci(
            dth,
            dv,
            dt,
            LciStart(P0, 0.0 * P0, [1.0, 0, 0, 0], FRAME),
            NavConfig("j2", errors=err, output_every=ns // 2),
            device=device,
        )
        for _ in range(2)
    )
    np.testing.assert_array_equal(a.V, b.V)  # same seeds, same draws
    dV = a.V[:, -1] - a.V[:, -1].mean(axis=0)
    # velocity random walk: var = σ² t per axis; 768 samples -> ±10 % at 2σ
    np.testing.assert_allclose(dV.var(), sig**2 * a.t[-1], rtol=0.12)


#: a start state at rest at the launch point
START = LciStart(np.zeros(3), np.zeros(3), [1.0, 0, 0, 0], FRAME)


def test_input_validation():
    dth = np.zeros((10, 3))
    bad = dth.copy()
    bad[3, 1] = np.nan
    with pytest.raises(InputError, match="non-finite"):
        propagate_lci(bad, dth, 0.01, START)
    with pytest.raises(InputError, match="must match"):
        propagate_lci(dth, dth[:8], 0.01, START)
    with pytest.raises(InputError, match="even"):
        propagate_lci(dth[:9], dth[:9], 0.01, START)
    with pytest.raises(InputError, match="dt must be > 0"):
        propagate_lci(dth, dth, 0.0, START)
    with pytest.raises(InputError, match="dt must be > 0"):
        propagate_lci(dth, dth, -1.0, START)
    with pytest.raises(InputError, match="unknown navigation gravity"):
        propagate_lci(dth, dth, 0.01, START, NavConfig("j3"))
    with pytest.raises(InputError, match="needs an SH model"):
        propagate_lci(dth, dth, 0.01, START, NavConfig("sh18"))
    with pytest.raises(InputError, match="unit quaternions"):
        propagate_lci(dth, dth, 0.01, LciStart(np.zeros(3), np.zeros(3), [1.0, 1.0, 0, 0], FRAME))


def test_input_validation_models_and_errors():
    from fieldmap.models.registry import load_model

    dth = np.zeros((10, 3))
    model = load_model("eigen-6s", lmax=24)
    with pytest.raises(InputError, match="outside"):
        propagate_lci(dth, dth, 0.01, START, NavConfig("sh200", sh_model=model))
    with pytest.raises(InputError, match="unknown sensor error"):
        propagate_lci(dth, dth, 0.01, START, NavConfig(errors={"acc_bais": np.zeros(3)}))
    with pytest.raises(InputError, match="imu_set"):
        propagate_lci(dth, dth, 0.01, START, NavConfig(imu_set=[0, 1]))
    with pytest.raises(InputError, match="P0"):
        propagate_lci(
            dth, dth, 0.01, LciStart([0.0, np.inf, 0.0], np.zeros(3), [1.0, 0, 0, 0], FRAME)
        )


def test_several_sets_without_imu_set_raise():
    """Two increment sets for three trajectories: no silent use of set 0."""
    from fieldmap.errors import InputError
    from fieldmap.nav.frames import LaunchFrame

    dth = np.zeros((2, 4, 3))
    dv = np.zeros((2, 4, 3))
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    frame = LaunchFrame(lon0=10.0, B0=40.0, A0=0.0)
    with pytest.raises(InputError, match="2 increment sets for 3 trajectories"):
        propagate_lci(
            dth,
            dv,
            0.01,
            LciStart(np.zeros(3), np.zeros(3), q0, frame),
            NavConfig(["j2", "j4", "j6"]),
        )
    res = propagate_lci(
        dth,
        dv,
        0.01,
        LciStart(np.zeros(3), np.zeros(3), q0, frame),
        NavConfig(["j2", "j4", "j6"], imu_set=[0, 1, 1]),
    )
    assert res.P.shape == (3, 3, 3)


def test_lci_ellipsoid_conflicting_with_launch_frame_raises():
    """``ellipsoid=`` is not silently ignored when the launch frame has another one."""
    from fieldmap.errors import InputError
    from fieldmap.field.ellipsoid import GRS80
    from fieldmap.nav.frames import LaunchFrame

    frame = LaunchFrame(lon0=10.0, B0=40.0, A0=0.0)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    z = np.zeros((2, 3))
    with pytest.raises(InputError, match="differs from the launch frame"):
        propagate_lci(
            z, z, 0.01, LciStart(np.zeros(3), np.zeros(3), q0, frame), NavConfig(ellipsoid=GRS80)
        )


def test_lci_launch_tuple_of_wrong_length_raises():
    """A launch given as a tuple takes (lon0, B0, A0[, h0]); five values are bad input."""
    from fieldmap.errors import InputError

    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    z = np.zeros((2, 3))
    with pytest.raises(InputError, match=r"\(lon0, B0, A0\[, h0\]\), got 5 values"):
        propagate_lci(
            z, z, 0.01, LciStart(np.zeros(3), np.zeros(3), q0, (10.0, 40.0, 0.0, 0.0, "GRS80"))
        )
    with pytest.raises(InputError, match="got 2 values"):
        propagate_lci(z, z, 0.01, LciStart(np.zeros(3), np.zeros(3), q0, (10.0, 40.0)))


def test_quat_to_dcm_zero_quaternion_raises():
    """A zero quaternion is an error, not a matrix of NaNs."""
    from fieldmap.errors import InputError

    with pytest.raises(InputError, match="non-zero"):
        quat_to_dcm(np.zeros(4))


def test_plain_kernels_give_the_bits_of_the_general_ones(device, monkeypatch):
    """A launch without sensor errors, baro or SH runs a kernel stripped of that code: same bits."""
    from fieldmap.kernels import strapdown as ksd

    from fieldmap.nav.mechanize import LciStart, NavConfig, propagate_ned

    n, ns, dt = 6, 400, 0.005
    dth, dv, P0, V0, q0 = _random_motion(n, ns, dt, seed=3)
    kinds = ["j2", "j4", "j6", "exact", "j4", "exact"]

    def both():
        lci = propagate_lci(
            dth,
            dv,
            dt,
            LciStart(P0, V0, q0, FRAME),
            NavConfig(kinds, output_every=7),
            device=device,
        )
        ned = propagate_ned(
            dth,
            dv,
            dt,
            NedStart(27.1 + np.arange(n), 105.3, 1000.0, V0 * 0.3, q0),
            NavConfig(kinds, output_every=7),
            device=device,
        )
        return lci, ned

    used = []
    for name in ("lci_kernel_for", "ned_kernel_for"):
        orig = getattr(ksd, name)
        monkeypatch.setattr(
            ksd, name, lambda e, s, orig=orig: used.append(orig(e, s)) or orig(e, s)
        )
    lci_p, ned_p = both()
    assert used == [ksd.lci_kernel_plain, ksd.ned_kernel_plain]
    monkeypatch.setattr(ksd, "lci_kernel_for", lambda e, s: ksd.lci_kernel)
    monkeypatch.setattr(ksd, "ned_kernel_for", lambda e, s: ksd.ned_kernel)
    lci_g, ned_g = both()
    for a, b in ((lci_p.P, lci_g.P), (lci_p.V, lci_g.V), (lci_p.q, lci_g.q)):
        np.testing.assert_array_equal(a, b)
    for key in ("lat", "lon", "h", "v_ned", "q"):
        np.testing.assert_array_equal(getattr(ned_p, key), getattr(ned_g, key))
    assert np.ptp(lci_p.P[:, -1, 0]) > 1.0  # the runs differ: a real comparison
