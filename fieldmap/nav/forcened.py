"""Delta-velocity to NED specific force with the rotation correction ½ dθ×dv.

Same formula as NavToolKit's ``navtk::inertial::calc_force_ned`` (Titterton & Weston 2004,
eq. 11.64 without the high-rate sculling integral).
"""

from __future__ import annotations

import numpy as np


def calc_force_ned(C_s_to_n, dt, dth, dv):
    r"""Specific force in NED from one delta-velocity / delta-rotation sample.

    .. math:: f^n = C_s^n\left(\delta v + \tfrac12\,\delta\theta \times \delta v\right)/\delta t

    Parameters
    ----------
    C_s_to_n : array_like, shape (..., 3, 3)
        DCM rotating sensor-frame vectors into NED.
    dt : float or array_like
        Interval over which ``dv`` and ``dth`` were collected. Units: s.
    dth : array_like, shape (..., 3)
        Delta rotation in the sensor frame. Units: rad.
    dv : array_like, shape (..., 3)
        Delta velocity in the sensor frame. Units: m/s.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        Specific force in NED. Units: m/s².
    """
    C = np.asarray(C_s_to_n, dtype=np.float64)
    dth = np.asarray(dth, dtype=np.float64)
    dv = np.asarray(dv, dtype=np.float64)
    dt = np.asarray(dt, dtype=np.float64)
    corrected = dv + 0.5 * np.cross(dth, dv)
    return np.einsum("...ij,...j->...i", C, corrected) / dt[..., None]
