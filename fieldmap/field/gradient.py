r"""Gravity gradient tensor (Marussi tensor) at geodetic points and on grids, in Eötvös (1e-9 s⁻²).

:func:`gradient_tensor` returns T[i, j] = ∂g_i/∂x_j, the second derivatives of the potential,
of the spherical-harmonic model's gravity (incl. centrifugal), of its gravitation, of the
gravity disturbance (model minus normal gravitation) or of normal gravity (exact, j2, j4, j6,
groves-j2, incl. centrifugal), in the local ENU (default) or NED frame at the point, or in ECEF;
:func:`grid_gradient` the six ENU components on every node of a grid, and
:func:`gradient_invariants` the invariants and eigenvalues of any tensor.

Implementation: direct synthesis. The second derivatives of the series come from the row-wise
Legendre pass of :mod:`fieldmap.kernels.grid_tensor` (one row per point for points, FFT
longitude sums on grids; :func:`fieldmap.grids.synthesis.synthesize_tensor`). The normal
field enters as its zonal series: the normal gravitational potential of a level ellipsoid is

.. math::
    U = \frac{GM}{r}\Big[1 - \sum_{n\ge1} J_{2n}\Big(\frac{a}{r}\Big)^{2n} P_{2n}(\sin\varphi)\Big],
    \qquad \bar C_{2n,0} = -J_{2n}/\sqrt{4n+1}

(Heiskanen & Moritz 1967 eqs. 2-80, 2-92), convergent outside the focal sphere (radius E,
521 km): with J2n up to n = 12 (|J_24| ≈ 1e-27) it is the closed form to float64 precision at
any height fieldmap accepts (``exact``); ``j2``, ``j4``, ``j6`` keep J2..J6 (the truncations of
Chen et al. 2022 eqs. 7-13), ``groves-j2`` Groves' (2013) printed J2. A disturbance is the
synthesis of the model's coefficients minus these (in the model's GM and radius). The
centrifugal tensor, ∂²(ω²(x² + y²)/2) = ω² diag(1, 1, 0) in ECEF, is
ω² [[1, 0, 0], [0, sin²φ, −sin φ cos φ], [0, −sin φ cos φ, cos²φ]] in geodetic ENU.

The central-difference tensor of fieldmap 0.3 (12 evaluations of the gravity vector per point)
is the independent reference: :mod:`fieldmap.reference.gradient`; :func:`gradient_asymmetry`
still reports its antisymmetric part as a check of the differencing.

Checks (tests/test_gradient*.py): central differences of GeographicLib's gravity (0.05 E, poles
included), of fieldmap's own gravity vector, the point-mass closed form, Laplace (trace 0 for
gravitation, 2ω² for gravity), pyshtools' ``SHGravCoeffs.tensor`` on its own grid, and the
same bits for any block of rows.
"""

from __future__ import annotations

import os
import threading
import weakref
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap import limits
from fieldmap.errors import InputError
from fieldmap.field import frames
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec

__all__ = [
    "EOTVOS",
    "QUANTITIES",
    "gradient_asymmetry",
    "gradient_invariants",
    "gradient_tensor",
    "grid_gradient",
]

#: 1 Eötvös. Units: s⁻².
EOTVOS = 1e-9
QUANTITIES = ("gravity", "gravitation", "disturbance", "normal")
FRAMES = ("enu", "ned", "ecef")
#: ENU -> NED reordering (north, east, -up)
_ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


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


#: J2n terms of the ``exact`` normal field's zonal series (|J_24| ≈ 1e-27: float64 precision)
EXACT_ZONAL_TERMS = 12
#: J2n terms of the truncated normal fields (``groves-j2`` also takes Groves' J2)
_ZONAL_TERMS = {"exact": EXACT_ZONAL_TERMS, "j2": 1, "j4": 2, "j6": 3, "groves-j2": 1}
_model_cache: dict[tuple, tuple[Any, SHModel]] = {}
_model_lock = threading.Lock()


def normal_zonal_model(normal: str = "exact", ellipsoid: Ellipsoid | str = WGS84) -> SHModel:
    """Return the normal gravitational potential (no centrifugal term) as a zonal SH model.

    C̄00 = 1 and C̄_{2n,0} = −J2n/√(4n+1) in the ellipsoid's GM and a (Heiskanen & Moritz 1967
    eqs. 2-80, 2-92; see the module docstring), J2n for n up to :data:`EXACT_ZONAL_TERMS`
    (``exact``) or as the truncation ``normal`` says.
    """
    from fieldmap.field.normal import GROVES_J2, normal_model

    key = normal_model(normal)
    ell = get_ellipsoid(ellipsoid)
    terms = _ZONAL_TERMS[key]
    L = 2 * terms
    C = np.zeros((L + 1, L + 1))
    C[0, 0] = 1.0
    for n in range(1, terms + 1):
        j2n = GROVES_J2 if key == "groves-j2" else ell.J2n(n)
        C[2 * n, 0] = -j2n / np.sqrt(4.0 * n + 1.0)
    return SHModel(f"{ell.name} normal field ({key})", ell.GM, ell.a, C, np.zeros_like(C), L)


def _minus_normal(model: SHModel, key: str, ell: Ellipsoid) -> SHModel:
    """Return the model's coefficients minus the normal field's (the model's GM and radius)."""
    nor = normal_zonal_model(key, ell)
    L = max(model.lmax, nor.lmax)
    C = np.zeros((L + 1, L + 1))
    S = np.zeros((L + 1, L + 1))
    C[: model.lmax + 1, : model.lmax + 1] = model.C
    S[: model.lmax + 1, : model.lmax + 1] = model.S
    n = np.arange(nor.lmax + 1)
    scale = (nor.gm / model.gm) * (nor.radius / model.radius) ** n
    C[: nor.lmax + 1, 0] -= nor.C[:, 0] * scale
    return SHModel(
        f"{model.name} minus {nor.name}", model.gm, model.radius, C, S, model.nominal_degree
    )


def synthesis_model(quantity: str, model: SHModel | None, normal: str, ell: Ellipsoid) -> SHModel:
    """Return the model whose gravitation tensor :func:`gradient_tensor` sums for ``quantity``.

    ``gravity``/``gravitation``: the model; ``disturbance``: the model minus the normal field
    (:func:`normal_zonal_model`); ``normal``: the normal field. Cached for the model object's
    life (a map calls this once per block of rows).
    """
    if quantity == "normal":
        key: tuple = (None, normal, ell)
    elif quantity == "disturbance":
        assert model is not None
        key = (id(model), normal, ell)
    else:
        assert model is not None
        return model
    with _model_lock:  # the blocks of a map may run on several threads
        hit = _model_cache.get(key)
        if hit is not None and (hit[0] is None or hit[0]() is model):
            return hit[1]
        if quantity == "normal":
            out, ref = normal_zonal_model(normal, ell), None
        else:
            assert model is not None
            out, ref = _minus_normal(model, normal, ell), weakref.ref(model)
        if len(_model_cache) >= 8:
            _model_cache.pop(next(iter(_model_cache)))
        _model_cache[key] = (ref, out)
        return out


def centrifugal_tensor(latitude: ArrayLike, omega: float) -> NDArray[np.float64]:
    """Tensor of the centrifugal acceleration in geodetic ENU at geodetic ``latitude`` (deg).

    ω² C diag(1, 1, 0) Cᵀ = ω² (I − k kᵀ), k = (0, cos φ, sin φ) the rotation axis in ENU.
    Units: s⁻². Shape ``latitude.shape + (3, 3)``.
    """
    phi = np.radians(np.asarray(latitude, dtype=np.float64))
    k = np.stack([np.zeros_like(phi), np.cos(phi), np.sin(phi)], axis=-1)
    return omega**2 * (np.eye(3) - k[..., :, None] * k[..., None, :])


def _from_components(c: NDArray[np.float64]) -> NDArray[np.float64]:
    """(..., 6) components ee, en, eu, nn, nu, uu -> symmetric (..., 3, 3)."""
    t = np.empty(c.shape[:-1] + (3, 3))
    for k, (i, j) in enumerate(GRID_COMPONENTS.values()):
        t[..., i, j] = c[..., k]
        t[..., j, i] = c[..., k]
    return t


def _load(q: str, model: SHModel | str | os.PathLike[str]) -> SHModel | None:
    """Return the SH model of a quantity (none for the normal field)."""
    if q == "normal":
        return None
    if isinstance(model, SHModel):
        return model
    from fieldmap.models.registry import load_model

    return load_model(model)


def _tensor(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    model: SHModel | str | os.PathLike[str],
    quantity: str,
    ellipsoid: Ellipsoid | str,
    frame: str,
    device: str | None,
) -> NDArray[np.float64]:
    """Return the tensor of :func:`gradient_tensor` (by synthesis)."""
    from fieldmap.grids.synthesis import tensor_points

    q, key = parse_quantity(quantity)
    f = str(frame).lower()
    if f not in FRAMES:
        raise InputError(f"frame must be one of {', '.join(FRAMES)}, got {frame!r}")
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = limits.check_geodetic(latitude, longitude, height)
    shape = lat.shape
    if lat.size == 0:
        return np.zeros(shape + (3, 3))
    sh_model = _load(q, model)
    syn = synthesis_model(q, sh_model, key, ell)
    t = _from_components(tensor_points(syn, lat, lon, h, ell, device))
    if q in ("gravity", "normal"):
        t = t + centrifugal_tensor(lat.ravel(), ell.omega)
    t = t / EOTVOS
    if f == "ned":
        t = _ENU_TO_NED @ t @ _ENU_TO_NED.T
    elif f == "ecef":
        c = frames.C_e_to_enu(lat.ravel(), lon.ravel())
        t = np.swapaxes(c, -1, -2) @ t @ c
        t = (t + np.swapaxes(t, -1, -2)) / 2.0  # exactly symmetric after the rotation too
    return t.reshape(shape + (3, 3))


def _asymmetry(
    latitude: ArrayLike,
    longitude: ArrayLike,
    height: ArrayLike,
    model: SHModel | str | os.PathLike[str],
    quantity: str,
    ellipsoid: Ellipsoid | str,
    device: str | None,
) -> NDArray[np.float64]:
    """:func:`gradient_asymmetry`: the central-difference reference's antisymmetric part."""
    from fieldmap.reference.gradient import central_difference_tensor

    q, key = parse_quantity(quantity)
    ell = get_ellipsoid(ellipsoid)
    lat, lon, h = limits.check_geodetic(latitude, longitude, height)
    sh_model = _load(q, model) if lat.size else None
    return central_difference_tensor(lat, lon, h, sh_model, f"{q}:{key}", ell, "ecef", device)[1]


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

    By synthesis of the second derivatives of the series, one row of Fourier coefficients in
    longitude per point (see the module docstring); the normal field as its zonal series, the
    centrifugal tensor in closed form. Degrees up to 2700.

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
        gravitation; ``"disturbance"``: model gravitation − exact normal gravitation
        (the model's coefficients minus the normal field's zonal ones);
        ``"normal"``: exact normal gravity incl. centrifugal. The last two take another normal
        field after a colon, a name of :data:`fieldmap.field.normal.NORMAL_MODELS`:
        ``"normal:j4"``, ``"disturbance:j2"``, ``"normal:groves-j2"``.
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
    return _tensor(latitude, longitude, height, model, quantity, ellipsoid, frame, device)


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
    """Antisymmetric part of the central-difference reference tensor: a check of its differencing.

    max |T − Tᵀ|/2 per point of the central-difference tensor of
    :func:`fieldmap.reference.gradient.central_difference_tensor` before it is symmetrised (the
    potential's Hessian is symmetric: what is left measures the differencing; the synthesised
    :func:`gradient_tensor` is symmetric by construction). Parameters as
    :func:`gradient_tensor` (the asymmetry does not depend on the frame).

    Returns
    -------
    numpy.ndarray
        Broadcast shape of the points. Units: E (1e-9 s⁻²).
    """
    return _asymmetry(latitude, longitude, height, model, quantity, ellipsoid, device)


#: map quantity -> (gradient_tensor quantity, description); the ENU components kept (symmetric)
GRID_QUANTITIES = {
    "gradient": ("gravity", "gravity (model gravitation + centrifugal)"),
    "gradient-disturbance": ("disturbance", "gravity disturbance (model - exact normal)"),
    "gradient-normal": ("normal", "exact normal gravity (incl. centrifugal)"),
    "gradient-invariants": ("gravitation", "model gravitation (no centrifugal)"),
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
#: variables of :func:`gradient_invariants` (and of the map quantity ``gradient-invariants``)
INVARIANTS = ("I1", "I2", "eig_1", "eig_2", "eig_3")


def gradient_invariants(tensor: ArrayLike) -> dict[str, NDArray[np.float64]]:
    r"""Invariants and eigenvalues of gradient tensors (..., 3, 3), as GOCE users read them.

    .. math::
        I_1 = T_{xx}T_{yy} + T_{yy}T_{zz} + T_{xx}T_{zz} - T_{xy}^2 - T_{yz}^2 - T_{xz}^2,
        \qquad I_2 = \det T

    (Pedersen & Rasmussen 1990, *Geophysics* 55:1558-1566, eqs. 8-9; the trace I0 is zero for a
    harmonic field, so I1 and I2 are the two that carry information; Baur et al. 2008, *J.
    Geodesy* 82:279-293, for GOCE), and the three eigenvalues of the symmetric tensor in
    decreasing order. They do not depend on the frame (ENU, NED or ECEF alike).

    Parameters
    ----------
    tensor : array_like
        Shape (..., 3, 3), symmetric (e.g. :func:`gradient_tensor`). Units: E.

    Returns
    -------
    dict
        ``I1`` (E²), ``I2`` (E³), ``eig_1`` ≥ ``eig_2`` ≥ ``eig_3`` (E), each of shape (...).

    Examples
    --------
    >>> import numpy as np
    >>> from fieldmap.field.gradient import gradient_invariants
    >>> inv = gradient_invariants(np.diag([-1.0, -1.0, 2.0]))  # a point mass overhead, in GM/r³
    >>> float(inv["I1"]), float(inv["I2"]), float(inv["eig_1"])
    (-3.0, 2.0, 2.0)
    """
    t = np.asarray(tensor, dtype=np.float64)
    if t.shape[-2:] != (3, 3):
        raise InputError(f"a gradient tensor has shape (..., 3, 3), got {t.shape}")
    xx, yy, zz = t[..., 0, 0], t[..., 1, 1], t[..., 2, 2]
    xy, yz, xz = t[..., 0, 1], t[..., 1, 2], t[..., 0, 2]
    i1 = xx * yy + yy * zz + xx * zz - xy**2 - yz**2 - xz**2
    i2 = xx * (yy * zz - yz**2) + xy * (yz * xz - xy * zz) + xz * (xy * yz - xz * yy)
    eig = np.asarray(np.linalg.eigvalsh(t)[..., ::-1], dtype=np.float64)
    return {"I1": i1, "I2": i2, "eig_1": eig[..., 0], "eig_2": eig[..., 1], "eig_3": eig[..., 2]}


def grid_gradient(
    model: SHModel | None,
    grid: GridSpec,
    quantity: str,
    *,
    ellipsoid: Ellipsoid | str = WGS84,
    device: str | None = None,
) -> dict[str, np.ndarray]:
    """Return the six ENU components of the gradient tensor on every node of a grid, in Eötvös.

    By grid synthesis (:func:`fieldmap.grids.synthesis.synthesize_tensor`: one Legendre pass
    per row and its mirror, FFT longitude sums; each row on its own, so a block of rows gives
    the bits of the whole grid), the normal field as its zonal series and the centrifugal
    tensor in closed form (see the module docstring). ``quantity``: ``"gradient"`` (gravity),
    ``"gradient-disturbance"``, ``"gradient-normal"`` (the exact normal gravity of
    ``ellipsoid``) or ``"gradient-invariants"`` (:func:`gradient_invariants` of the model's
    gravitation tensor). Returns {``T_ee``, ``T_en``, ``T_eu``, ``T_nn``, ``T_nu``, ``T_uu``:
    array ``grid.shape``} (E), or {:data:`INVARIANTS`} for the invariants.
    """
    from fieldmap.grids.synthesis import synthesize_tensor

    if quantity not in GRID_QUANTITIES:
        raise InputError(f"quantity must be one of {', '.join(GRID_QUANTITIES)}, got {quantity!r}")
    q = GRID_QUANTITIES[quantity][0]
    ell = get_ellipsoid(ellipsoid)
    syn = synthesis_model(q, model, "exact", ell)
    t = synthesize_tensor(syn, grid, ell, device, progress=False)  # (nh, nlat, nlon, 6)
    if q in ("gravity", "normal"):
        cen = centrifugal_tensor(grid.lat, ell.omega)  # (nlat, 3, 3)
        for k, (i, j) in enumerate(GRID_COMPONENTS.values()):
            t[..., k] += cen[None, :, None, i, j]
    if quantity == "gradient-invariants":
        return gradient_invariants(_from_components(t) / EOTVOS)
    return {name: t[..., k] / EOTVOS for k, name in enumerate(GRID_COMPONENTS)}
