"""Gravity gradient tensor (Marussi tensor) at geodetic points, in Eötvös (1 E = 1e-9 s⁻²).

:func:`gradient_tensor` returns T[i, j] = ∂g_i/∂x_j, the second derivatives of the potential,
of the spherical-harmonic model's gravity (incl. centrifugal), of its gravitation, of the
gravity disturbance (model minus exact normal gravitation) or of normal gravity (exact, j2, j4,
j6, incl. centrifugal), in the local ENU (default) or NED frame at the point, or in ECEF.

Implementation: central differences of fieldmap's own float64 gravity vector in ECEF, from the
existing Warp point kernels (spherical harmonics: :func:`fieldmap.field.sh.sh_gravitation`;
normal field: :func:`fieldmap.field.normal.normal_gravitation_ecef`; centrifugal ω²(x, y, 0)),
all 12 displaced points of every input point in one batched launch. The step is h = 1 m along
each ECEF axis, with one Richardson step (steps h and 2h):

    D(s) = (g(x + s e_j) − g(x − s e_j)) / 2s,    ∂g/∂x_j = (4 D(h) − D(2h)) / 3,

whose truncation error, O(h⁴ ∂⁵V), is negligible for degrees up to ~2000 (wavelengths ≥ 20 km);
the roundoff of float64 gravity (~1e-15 m/s² over 2 m) is ~1e-15 s⁻² = 1e-6 E. The tensor is
symmetrised, (T + Tᵀ)/2 (the potential's Hessian is symmetric); the removed antisymmetric
part, max |T − Tᵀ|/2 per point, is returned with ``return_asymmetry=True`` as a check of the
differencing. The ECEF tensor is rotated to ENU with the rotation C at the geodetic point,
C T Cᵀ, and to NED by reordering (north, east, −up).

Checks (tests/test_gradient.py): the point-mass closed form GM (3 x_i x_j − r² δ_ij)/r⁵, Laplace
(trace 0 for gravitation, 2ω² for gravity), and the free-air gradient of normal gravity.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap import limits
from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec

__all__ = ["EOTVOS", "QUANTITIES", "STEP", "gradient_tensor"]

#: 1 Eötvös. Units: s⁻².
EOTVOS = 1e-9
#: Finite-difference step along each ECEF axis (the second step is twice this). Units: m.
STEP = 1.0
QUANTITIES = ("gravity", "gravitation", "disturbance", "normal")
FRAMES = ("enu", "ned", "ecef")
#: ENU -> NED reordering (north, east, -up)
_ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def _vector_ecef(
    quantity: str,
    model: SHModel | None,
    lmax: int | None,
    normal: str,
    ell: Ellipsoid,
    device: str | None,
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    z: NDArray[np.float64],
) -> np.ndarray:
    """Return the gravity vector of ``quantity`` at ECEF points (flat arrays), ECEF. Units: m/s²."""
    from fieldmap.field.normal import normal_gravitation_ecef

    if quantity == "normal":
        g = normal_gravitation_ecef(x, y, z, normal=normal, ellipsoid=ell, device=device)
    else:
        from fieldmap.field.sh import sh_gravitation

        assert model is not None  # loaded for every quantity but normal
        g = sh_gravitation(model, x, y, z, lmax=lmax, device=device)
        if quantity == "disturbance":
            g = g - normal_gravitation_ecef(x, y, z, normal=normal, ellipsoid=ell, device=device)
    if quantity in ("gravity", "normal"):
        g = g + frames.centrifugal_ecef(x, y, z, ell.omega)
    return g


@overload
def gradient_tensor(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str = "eigen-6s",
    lmax: int | None = None,
    quantity: str = "gravity",
    normal: str = "exact",
    ellipsoid: Ellipsoid | str = WGS84,
    frame: str = "enu",
    epoch: float | str | None = None,
    device: str | None = None,
    return_asymmetry: Literal[False] = False,
) -> NDArray[np.float64]: ...


@overload
def gradient_tensor(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str = "eigen-6s",
    lmax: int | None = None,
    quantity: str = "gravity",
    normal: str = "exact",
    ellipsoid: Ellipsoid | str = WGS84,
    frame: str = "enu",
    epoch: float | str | None = None,
    device: str | None = None,
    return_asymmetry: Literal[True],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...


def gradient_tensor(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str = "eigen-6s",
    lmax: int | None = None,
    quantity: str = "gravity",
    normal: str = "exact",
    ellipsoid: Ellipsoid | str = WGS84,
    frame: str = "enu",
    epoch: float | str | None = None,
    device: str | None = None,
    return_asymmetry: bool = False,
) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gradient tensor ∂g_i/∂x_j of gravity, gravitation, disturbance or normal gravity.

    Central differences (steps 1 m and 2 m, one Richardson step) of fieldmap's float64 gravity
    vector in ECEF, symmetrised, rotated at the geodetic point (see the module docstring).

    Parameters
    ----------
    latitude, longitude, height : array_like
        Geodetic latitude in [-90, 90], longitude in [-540, 540), height above ``ellipsoid``
        (broadcast together). Units: degrees, degrees, m.
    model : SHModel or str
        A model, a bundled model name or a model file (unused by ``quantity="normal"``).
    lmax : int, optional
        Truncation degree (default: the model's).
    quantity : {"gravity", "gravitation", "disturbance", "normal"}
        Model gravity incl. centrifugal ω²(x, y, 0); model gravitation; disturbance δg = model
        gravitation − normal gravitation (``normal``, exact by default); normal gravity of
        ``normal`` incl. centrifugal.
    normal : {"exact", "j2", "j4", "j6", "groves-j2"}
        Normal field of ``quantity="normal"`` and ``"disturbance"``.
    ellipsoid : Ellipsoid or str
        Ellipsoid of the coordinates, of ω and of the normal field (default WGS84).
    frame : {"enu", "ned", "ecef"}
        Frame of both indices: local geodetic ENU/NED at the point, or ECEF.
    epoch : float or str, optional
        Epoch of time-variable terms when ``model`` is a name or file.
    device : str, optional
        Warp device (default: first CUDA device, else CPU).
    return_asymmetry : bool
        Also return max |T − Tᵀ|/2 per point (the part removed by symmetrising). Units: E.

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(latitude, longitude, height).shape + (3, 3)``, component ``[i, j]`` =
        ∂g_i/∂x_j. Units: E (1e-9 s⁻²). With ``return_asymmetry``: ``(tensor, asymmetry)``,
        the latter of the broadcast shape.
    """
    from fieldmap.field.normal import normal_model

    q = str(quantity).lower()
    if q not in QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}")
    f = str(frame).lower()
    if f not in FRAMES:
        raise InputError(f"frame must be one of {', '.join(FRAMES)}, got {frame!r}")
    key = normal_model(normal)
    if key != "exact" and q not in ("normal", "disturbance"):
        raise InputError(f"normal= applies to quantity normal or disturbance, not to {q}")
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = limits.check_geodetic(latitude, longitude, height)
    shape = lat.shape
    if lat.size == 0:
        empty = np.zeros(shape + (3, 3))
        return (empty, np.zeros(shape)) if return_asymmetry else empty
    sh_model = None
    if q != "normal":
        if isinstance(model, SHModel):
            sh_model = model
        else:
            from fieldmap.models.registry import load_model

            sh_model = load_model(model, epoch=epoch)
    x, y, z = (np.ravel(v) for v in frames.geodetic_to_ecef(lat, lon, h, ell))
    p0 = np.stack([x, y, z], axis=-1)  # (n, 3)
    # displaced points: axis j, offsets (+h, -h, +2h, -2h) -> (3, 4, n, 3)
    offsets = np.array([STEP, -STEP, 2 * STEP, -2 * STEP])
    eye = np.eye(3)
    pts = p0[None, None, :, :] + offsets[None, :, None, None] * eye[:, None, None, :]
    flat = pts.reshape(-1, 3)
    g = _vector_ecef(q, sh_model, lmax, key, ell, device, flat[:, 0], flat[:, 1], flat[:, 2])
    g = g.reshape(3, 4, -1, 3)
    d1 = (g[:, 0] - g[:, 1]) / (2 * STEP)  # (j, n, i)
    d2 = (g[:, 2] - g[:, 3]) / (4 * STEP)
    d = (4.0 * d1 - d2) / 3.0
    t = np.transpose(d, (1, 2, 0)) / EOTVOS  # (n, i, j)
    asym = np.max(np.abs(t - np.swapaxes(t, -1, -2)), axis=(-1, -2)) / 2.0
    t = (t + np.swapaxes(t, -1, -2)) / 2.0
    if f != "ecef":
        c = frames.C_e_to_enu(lat.ravel(), lon.ravel())
        t = c @ t @ np.swapaxes(c, -1, -2)
        if f == "ned":
            t = _ENU_TO_NED @ t @ _ENU_TO_NED.T
        t = (t + np.swapaxes(t, -1, -2)) / 2.0  # exactly symmetric after the rotation too
    t = t.reshape(shape + (3, 3))
    return (t, asym.reshape(shape)) if return_asymmetry else t


#: map quantity -> (gradient_tensor quantity, description); the ENU components kept (symmetric)
GRID_QUANTITIES = {
    "gradient": ("gravity", "gravity (model gravitation + centrifugal)"),
    "gradient-disturbance": ("disturbance", "gravity disturbance (model - exact normal)"),
    "gradient-normal": ("normal", "exact normal gravity (incl. centrifugal)"),
}
#: variable name -> (i, j) of the ENU tensor: the six independent components
GRID_COMPONENTS = {
    "T_ee": (0, 0),
    "T_en": (0, 1),
    "T_eu": (0, 2),
    "T_nn": (1, 1),
    "T_nu": (1, 2),
    "T_uu": (2, 2),
}


def grid_gradient(
    model: SHModel,
    grid: GridSpec,
    quantity: str,
    *,
    ellipsoid: Ellipsoid | str = WGS84,
    device: str | None = None,
) -> dict[str, np.ndarray]:
    """Return the six ENU components of the gradient tensor on every node of a grid, in Eötvös.

    :func:`gradient_tensor` at each node (every node on its own, so a block of rows gives the
    bits of the whole grid). ``quantity``: ``"gradient"`` (gravity), ``"gradient-disturbance"``
    or ``"gradient-normal"`` (the exact normal gravity of ``ellipsoid``).
    Returns {``T_ee``, ``T_en``, ``T_eu``, ``T_nn``, ``T_nu``, ``T_uu``: array ``grid.shape``}.
    """
    if quantity not in GRID_QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(GRID_QUANTITIES)}, got {quantity!r}")
    lat2, lon2 = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    out = {name: np.empty(grid.shape) for name in GRID_COMPONENTS}
    for k, h in enumerate(np.asarray(grid.heights, dtype=np.float64)):
        t = gradient_tensor(
            lat2, lon2, h, model=model, quantity=GRID_QUANTITIES[quantity][0],
            ellipsoid=ellipsoid, device=device,
        )  # fmt: skip
        for name, (i, j) in GRID_COMPONENTS.items():
            out[name][k] = t[..., i, j]
    return out
