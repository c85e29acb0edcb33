"""NumPy reference of the launch-centred inertial two-sample mechanization (for tests).

Written for clarity and independently of ``kernels/strapdown.py``: attitude is carried as a
direction-cosine matrix updated with Rodrigues' formula (the kernel uses quaternions), frames
come from :mod:`fieldmap.launch_frames`, gravitation from any vectorised NumPy callable.
Loops over steps, vectorised over trajectories. Chen et al. (2022) eqs. (14), (15), (20), Fig. 1.
"""

from __future__ import annotations

import numpy as np

from ..launch_frames import LaunchFrame


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
    dtheta,
    dv,
    dt,
    P0,
    V0,
    C0,
    frame: LaunchFrame,
    gravitation_ecef,
    t0=0.0,
    output_every=1,
    acc_bias=None,
    gyro_bias=None,
):
    """Two-sample LCI propagation of n trajectories.

    Parameters
    ----------
    dtheta, dv : ndarray, shape (n, n_samples, 3)
        Body-frame increments. Units: rad, m/s.
    dt : float
        Sample interval (navigation step 2 dt). Units: s.
    P0, V0 : ndarray, shape (n, 3)
        Initial a-frame position and inertial velocity. Units: m, m/s.
    C0 : ndarray, shape (n, 3, 3)
        Initial C_b^a.
    frame : LaunchFrame
    gravitation_ecef : callable
        ``g(r)`` with r of shape (n, 3) in ECEF (m) -> (n, 3) gravitation (m/s²).
    acc_bias, gyro_bias : ndarray (n, 3), optional
        Constant sensor biases added to every sample. Units: m/s², rad/s.

    Returns
    -------
    t, P, V, C : arrays (n_out,), (n, n_out, 3), (n, n_out, 3), (n, n_out, 3, 3)
    """
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
