"""calc_force_ned against NavToolKit's compiled implementation (Titterton & Weston 11.64)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fieldmap.nav.frames import calc_force_ned

navtk_inertial = pytest.importorskip("navtk.inertial")


def test_equals_navtk_on_random_inputs():
    rng = np.random.default_rng(1234)
    C = Rotation.random(200, random_state=rng).as_matrix()
    dt = rng.uniform(1e-3, 0.1, 200)
    dth = rng.normal(0.0, 0.05, (200, 3))
    dv = rng.normal(0.0, 2.0, (200, 3))
    ours = calc_force_ned(C, dt, dth, dv)
    ref = np.array(
        [navtk_inertial.calc_force_ned(C[k], float(dt[k]), dth[k], dv[k]) for k in range(200)]
    ).reshape(200, 3)
    scale = np.abs(ref).max(axis=1, keepdims=True)
    assert np.all(np.abs(ours - ref) <= 1e-12 * scale)


def test_rotation_correction_is_present():
    # Pure rotation about z with dv along x: the ½ dθ×dv term adds a y component of ½·dθ·dv.
    f = calc_force_ned(np.eye(3), 1.0, [0.0, 0.0, 0.2], [1.0, 0.0, 0.0])
    np.testing.assert_allclose(f, [1.0, 0.1, 0.0], rtol=0, atol=1e-15)
