"""NumPy reference of the launch-centred inertial two-sample mechanization (for tests).

Written for clarity and independently of ``kernels/strapdown.py``: attitude is carried as a
direction-cosine matrix updated with Rodrigues' formula (the kernel uses quaternions), frames
come from :mod:`fieldmap.nav.frames`, gravitation from any vectorised NumPy callable.
Loops over steps, vectorised over trajectories. Chen et al. (2022) eqs. (14), (15), (20), Fig. 1.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.nav.frames import LaunchFrame

if TYPE_CHECKING:
    from fieldmap.field.ellipsoid import Ellipsoid

#: ``(dtheta, dv, dt)``: increments of shape (n, n_samples, 3) (rad, m/s), sample interval (s)
_Increments = tuple[ArrayLike, ArrayLike, float]


def rodrigues(phi: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of rotation vectors ``(..., 3)`` (rad)."""
    a = np.linalg.norm(phi, axis=-1)[..., None, None]
    K = np.zeros(phi.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -phi[..., 2], phi[..., 1], -phi[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    small = a < 1e-4
    safe = np.where(small, 1.0, a)
    s = np.where(small, 1 - a**2 / 6 + a**4 / 120, np.sin(safe) / safe)
    c = np.where(small, 0.5 - a**2 / 24 + a**4 / 720, (1 - np.cos(safe)) / safe**2)
    return np.eye(3) + s * K + c * (K @ K)


def propagate_lci_reference(
    increments: _Increments,
    start: tuple[ArrayLike, ArrayLike, ArrayLike],
    frame: LaunchFrame,
    gravitation_ecef: Callable[[np.ndarray], np.ndarray],
    t0: float = 0.0,
    output_every: int = 1,
    acc_bias: ArrayLike | None = None,
    gyro_bias: ArrayLike | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Two-sample LCI propagation of n trajectories.

    Parameters
    ----------
    increments : (dtheta, dv, dt)
        Body-frame increments ``dtheta``, ``dv`` of shape (n, n_samples, 3) (rad, m/s) and
        the sample interval ``dt`` (s; navigation step 2 dt).
    start : (P0, V0, C0)
        Initial a-frame position and inertial velocity, shape (n, 3) (m, m/s), and C_b^a,
        shape (n, 3, 3).
    frame : LaunchFrame
    gravitation_ecef : callable
        ``g(r)`` with r of shape (n, 3) in ECEF (m) -> (n, 3) gravitation (m/s²).
    t0 : float
        Time of the first sample after launch. Units: s.
    output_every : int
        Store every this many navigation steps.
    acc_bias, gyro_bias : ndarray (n, 3), optional
        Constant sensor biases added to every sample. Units: m/s², rad/s.

    Returns
    -------
    t, P, V, C : arrays (n_out,), (n, n_out, 3), (n, n_out, 3), (n, n_out, 3, 3)
    """
    dtheta, dv, dt = increments
    P0, V0, C0 = start
    dtheta = np.array(dtheta, dtype=np.float64)
    dv = np.array(dv, dtype=np.float64)
    if gyro_bias is not None:
        dtheta += np.asarray(gyro_bias)[:, None, :] * dt
    if acc_bias is not None:
        dv += np.asarray(acc_bias)[:, None, :] * dt
    P = np.array(P0, dtype=np.float64)
    V = np.array(V0, dtype=np.float64)
    C = np.array(C0, dtype=np.float64)
    T = 2.0 * dt
    n_steps = dtheta.shape[1] // 2
    Ps, Vs, Cs, ts = [P.copy()], [V.copy()], [C.copy()], [t0]
    for k in range(n_steps):
        a1, a2 = dtheta[:, 2 * k], dtheta[:, 2 * k + 1]
        v1, v2 = dv[:, 2 * k], dv[:, 2 * k + 1]
        alpha, nu = a1 + a2, v1 + v2
        coning = 2.0 / 3.0 * np.cross(a1, a2)
        rotation = 0.5 * np.cross(alpha, nu)
        sculling = 2.0 / 3.0 * (np.cross(a1, v2) + np.cross(v1, a2))
        dv_a = np.einsum("nij,nj->ni", C, nu + rotation + sculling)
        t_half = t0 + k * T + 0.5 * T
        P_mid = P + 0.5 * T * V  # eq. (15)
        r_e = frame.a_to_ecef(P_mid, t_half)
        g_a = frame.vector_e_to_a(gravitation_ecef(r_e), t_half)  # eq. (20)
        V_new = V + dv_a + g_a * T
        P = P + 0.5 * T * (V + V_new)
        V = V_new
        C = C @ rodrigues(alpha + coning)
        if (k + 1) % output_every == 0:
            Ps.append(P.copy())
            Vs.append(V.copy())
            Cs.append(C.copy())
            ts.append(t0 + (k + 1) * T)
    return np.array(ts), np.stack(Ps, 1), np.stack(Vs, 1), np.stack(Cs, 1)


def propagate_ned_reference(
    increments: _Increments,
    start: tuple[ArrayLike, ArrayLike, ArrayLike],
    gravity_ned: Callable[[np.ndarray], np.ndarray],
    ellipsoid: Ellipsoid,
    output_every: int = 1,
    attitude: str = "split",
    frame_rotation: bool = True,
    baro: dict[str, Any] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Earth-relative NED mechanization, one update per sample, n trajectories at once.

    Parameters
    ----------
    increments : (dtheta, dv, dt)
        Body-frame increments ``dtheta``, ``dv`` of shape (n, n_samples, 3) (rad, m/s) and
        the sample interval ``dt`` (s).
    start : (llh0, v0, C0)
        Geodetic latitude, longitude (rad) and height (m), shape (n, 3); Earth-relative NED
        velocity (m/s), shape (n, 3); initial C_b^n, shape (n, 3, 3).
    gravity_ned : callable
        ``g(llh)`` (n, 3) -> gravity (gravitation + centrifugal) in NED (n, 3), m/s².
    ellipsoid : Ellipsoid
        Supplies a, e2 and the rotation rate.
    attitude : {"split", "body"}
        "split": C⁺ = Rot(−ω_in dt) C Rot(dθ) (as the kernel); "body": C⁺ = C Rot(dθ − C^T ω_in dt),
        the body-frame rate difference of Titterton & Weston eq. 3.28, kept to compare with navtk.
    frame_rotation : bool
        Subtract ½ ω_in^n × C dv (rotation of the n-frame over the sample, as the kernel); navtk
        does not (False reproduces it).
    baro : dict, optional
        Third-order baro loop: ``k1, k2, k3`` (1/s, 1/s², 1/s³), ``h_ref`` (n, n_samples) baro
        heights without error (m), ``bias`` (n,) m. With δh = h − (h_ref + bias) at the start of
        each sample: ḣ = −v_D − k1 δh, v̇_D gains k2 δh + δa, δȧ = k3 δh (Widnall & Sinha 1980).

    Returns
    -------
    llh, v, C : arrays (n, n_out, 3), (n, n_out, 3), (n, n_out, 3, 3)
    """
    dtheta, dv = (np.asarray(x, dtype=np.float64) for x in increments[:2])
    dt = increments[2]
    llh0, v0, C0 = start
    a, e2, om = ellipsoid.a, ellipsoid.e2, ellipsoid.omega
    llh = np.array(llh0, dtype=np.float64)
    v = np.array(v0, dtype=np.float64)
    C = np.array(C0, dtype=np.float64)
    out_llh, out_v, out_C = [llh.copy()], [v.copy()], [C.copy()]
    delta_a = np.zeros(llh.shape[0])
    for k in range(dtheta.shape[1]):
        if baro is not None:
            dh = llh[:, 2] - (baro["h_ref"][:, k] + baro["bias"])
        else:
            dh = np.zeros(llh.shape[0])
        lat, h = llh[:, 0], llh[:, 2]
        s, c = np.sin(lat), np.cos(lat)
        R_E = a / np.sqrt(1 - e2 * s**2)  # transverse radius of curvature
        R_N = a * (1 - e2) / (1 - e2 * s**2) ** 1.5  # meridian radius of curvature
        w_ie = np.stack([om * c, 0 * c, -om * s], -1)
        w_en = np.stack(
            [v[:, 1] / (R_E + h), -v[:, 0] / (R_N + h), -v[:, 1] * np.tan(lat) / (R_E + h)], -1
        )
        th, dvk = dtheta[:, k], dv[:, k]
        f_n = np.einsum("nij,nj->ni", C, dvk + 0.5 * np.cross(th, dvk)) / dt  # T&W eq. 11.64
        if frame_rotation:
            f_n -= 0.5 * np.cross(w_ie + w_en, np.einsum("nij,nj->ni", C, dvk))
        coriolis = np.cross(2 * w_ie + w_en, v)
        v_new = v + (f_n + gravity_ned(llh) - coriolis) * dt
        k1 = 0.0
        if baro is not None:
            v_new[:, 2] += (baro["k2"] * dh + delta_a) * dt
            k1 = baro["k1"]
        vm = 0.5 * (v + v_new)
        h_rate = -vm[:, 2] - k1 * dh
        llh = llh + dt * np.stack([vm[:, 0] / (R_N + h), vm[:, 1] / ((R_E + h) * c), h_rate], -1)
        if baro is not None:
            delta_a = delta_a + baro["k3"] * dh * dt
        w_in = w_ie + w_en
        if attitude == "body":
            C = C @ rodrigues(th - np.einsum("nji,nj->ni", C, w_in) * dt)
        else:
            C = rodrigues(-w_in * dt) @ C @ rodrigues(th)
        v = v_new
        if (k + 1) % output_every == 0:
            out_llh.append(llh.copy())
            out_v.append(v.copy())
            out_C.append(C.copy())
    return np.stack(out_llh, 1), np.stack(out_v, 1), np.stack(out_C, 1)
