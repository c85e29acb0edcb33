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
part, max |T − Tᵀ|/2 per point, is returned by :func:`gradient_asymmetry` as a check of the
differencing. The ECEF tensor is rotated to ENU with the rotation C at the geodetic point,
C T Cᵀ, and to NED by reordering (north, east, −up).

Checks (tests/test_gradient.py): the point-mass closed form GM (3 x_i x_j − r² δ_ij)/r⁵, Laplace
(trace 0 for gravitation, 2ω² for gravity), and the free-air gradient of normal gravity.
"""

from __future__ import annotations

import inspect
import os
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap import _compat, limits
from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.field.gravity import apply_model_options
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec

__all__ = ["EOTVOS", "QUANTITIES", "STEP", "gradient_asymmetry", "gradient_tensor"]

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
        g = sh_gravitation(model, x, y, z, device=device)
        if quantity == "disturbance":
            g = g - normal_gravitation_ecef(x, y, z, normal=normal, ellipsoid=ell, device=device)
    if quantity in ("gravity", "normal"):
        g = g + frames.centrifugal_ecef(x, y, z, ell.omega)
    return g


def parse_quantity(quantity: str) -> tuple[str, str]:
    """Split a :func:`gradient_tensor` quantity into (quantity, normal model).

    ``"gravity"``, ``"gravitation"``, ``"disturbance"``, ``"normal"``; the last two take the
    normal field after a colon (``"normal:j4"``, ``"disturbance:j2"``; default ``exact``, any
    name of :data:`fieldmap.field.normal.NORMAL_MODELS`).
    """
    from fieldmap.field.normal import normal_model

    q, _, normal = str(quantity).lower().partition(":")
    if q not in QUANTITIES:
        raise InputError(
            f"quantity must be one of {', '.join(QUANTITIES)}, got {quantity!r}", param="quantity"
        )
    key = normal_model(normal or "exact")
    if normal and q not in ("normal", "disturbance"):
        raise InputError(
            f"a normal field ({quantity!r}) applies to quantity normal or disturbance, not to {q}",
            param="quantity",
        )
    return q, key


def _tensor(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    model: SHModel | str | os.PathLike[str],
    quantity: str,
    ellipsoid: Ellipsoid | str,
    frame: str,
    device: str | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Return the tensor of :func:`gradient_tensor` and its :func:`gradient_asymmetry`."""
    q, key = parse_quantity(quantity)
    f = str(frame).lower()
    if f not in FRAMES:
        raise InputError(f"frame must be one of {', '.join(FRAMES)}, got {frame!r}")
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = limits.check_geodetic(latitude, longitude, height)
    shape = lat.shape
    if lat.size == 0:
        return np.zeros(shape + (3, 3)), np.zeros(shape)
    sh_model = None
    if q != "normal":
        if isinstance(model, SHModel):
            sh_model = model
        else:
            from fieldmap.models.registry import load_model

            sh_model = load_model(model)
    x, y, z = (np.ravel(v) for v in frames.geodetic_to_ecef(lat, lon, h, ell))
    p0 = np.stack([x, y, z], axis=-1)  # (n, 3)
    # displaced points: axis j, offsets (+h, -h, +2h, -2h) -> (3, 4, n, 3)
    offsets = np.array([STEP, -STEP, 2 * STEP, -2 * STEP])
    eye = np.eye(3)
    pts = p0[None, None, :, :] + offsets[None, :, None, None] * eye[:, None, None, :]
    flat = pts.reshape(-1, 3)
    g = _vector_ecef(q, sh_model, key, ell, device, flat[:, 0], flat[:, 1], flat[:, 2])
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
    return t.reshape(shape + (3, 3)), asym.reshape(shape)


def _fold_old(old: dict[str, Any], kwargs: dict[str, Any]) -> Any:
    """Rewrite a 0.2 call of :func:`gradient_tensor`; return the warning's advice.

    ``lmax``/``epoch`` go to the model, ``normal`` into the quantity; ``return_asymmetry=True``
    also returns the call to make instead (the tensor and its asymmetry, from one pass).
    """
    from fieldmap.field.normal import normal_model

    notes = []
    quantity = str(kwargs.get("quantity", "gravity"))
    if "lmax" in old or "epoch" in old:
        sub = {k: old[k] for k in ("lmax", "epoch") if k in old}
        if quantity.lower() != "normal":  # the normal field took no model options
            kwargs["model"] = apply_model_options(kwargs.get("model", "eigen-6s"), **sub)
        notes.append(" and ".join(f"{k}=" for k in sub) + " " + _compat.MODEL_OPTIONS_ADVICE)
    if "normal" in old:
        key = normal_model(old["normal"])
        if key != "exact":
            kwargs["quantity"] = f"{quantity}:{key}"
        notes.append(f"normal= is now quantity={kwargs['quantity']!r}")
    if "return_asymmetry" in old:
        notes.append("return_asymmetry= is now gradient_asymmetry(...)")
    advice = "; ".join(notes)
    return (advice, _with_asymmetry) if old.get("return_asymmetry") else advice


def _with_asymmetry(*args: Any, **kwargs: Any) -> tuple[np.ndarray, np.ndarray]:
    """(tensor, asymmetry) of one :func:`gradient_tensor` call (0.2 ``return_asymmetry=True``)."""
    bound = inspect.signature(gradient_tensor).bind(*args, **kwargs)
    bound.apply_defaults()
    a = bound.arguments
    return _tensor(
        a["latitude"], a["longitude"], a["height"], a["model"], a["quantity"], a["ellipsoid"],
        a["frame"], a["device"],
    )  # fmt: skip


@_compat.folded(("lmax", "epoch", "normal", "return_asymmetry"), _fold_old)
def gradient_tensor(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    quantity: str = "gravity",
    ellipsoid: Ellipsoid | str = WGS84,
    frame: str = "enu",
    device: str | None = None,
) -> NDArray[np.float64]:
    """Gradient tensor ∂g_i/∂x_j of gravity, gravitation, disturbance or normal gravity.

    Central differences (steps 1 m and 2 m, one Richardson step) of fieldmap's float64 gravity
    vector in ECEF, symmetrised, rotated at the geodetic point (see the module docstring).

    Parameters
    ----------
    latitude, longitude, height : array_like
        Geodetic latitude in [-90, 90], longitude in [-540, 540), height above ``ellipsoid``
        (broadcast together). Units: degrees, degrees, m.
    model : SHModel or str
        A model (:func:`fieldmap.models.registry.load_model`, which applies a truncation
        degree ``lmax=`` and an epoch ``epoch=``), a bundled model name or a model file
        (unused by ``quantity="normal"``).
    quantity : str
        ``"gravity"``: model gravity incl. centrifugal ω²(x, y, 0); ``"gravitation"``: model
        gravitation; ``"disturbance"``: model gravitation − exact normal gravitation;
        ``"normal"``: exact normal gravity incl. centrifugal. The last two take another normal
        field after a colon, a name of :data:`fieldmap.field.normal.NORMAL_MODELS`:
        ``"normal:j4"``, ``"disturbance:j2"``, ``"normal:groves-j2"`` (0.2: ``normal=``).
    ellipsoid : Ellipsoid or str
        Ellipsoid of the coordinates, of ω and of the normal field (default WGS84).
    frame : {"enu", "ned", "ecef"}
        Frame of both indices: local geodetic ENU/NED at the point, or ECEF.
    device : str, optional
        Warp device (default: first CUDA device, else CPU).

    Returns
    -------
    numpy.ndarray
        Shape ``broadcast(latitude, longitude, height).shape + (3, 3)``, component ``[i, j]`` =
        ∂g_i/∂x_j. Units: E (1e-9 s⁻²).

    Examples
    --------
    The free-air gradient of exact normal gravity on the equator, about 3088 E (0.3088 mGal/m):

    >>> import numpy as np
    >>> from fieldmap.field.gradient import gradient_tensor
    >>> t = gradient_tensor(0.0, 0.0, 0.0, quantity="normal", device="cpu")
    >>> t.shape, round(float(t[2, 2]))  # ENU; ∂g_up/∂up in E
    ((3, 3), 3088)
    """
    return _tensor(latitude, longitude, height, model, quantity, ellipsoid, frame, device)[0]


def gradient_asymmetry(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    *,
    model: SHModel | str | os.PathLike[str] = "eigen-6s",
    quantity: str = "gravity",
    ellipsoid: Ellipsoid | str = WGS84,
    device: str | None = None,
) -> NDArray[np.float64]:
    """Return what :func:`gradient_tensor` removes by symmetrising: a check of the differencing.

    max |T − Tᵀ|/2 per point of the central-difference tensor before it is symmetrised (the
    potential's Hessian is symmetric: what is left measures the differencing). Parameters as
    :func:`gradient_tensor` (the asymmetry does not depend on the frame).

    Returns
    -------
    numpy.ndarray
        Broadcast shape of the points. Units: E (1e-9 s⁻²).
    """
    return _tensor(latitude, longitude, height, model, quantity, ellipsoid, "ecef", device)[1]


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
