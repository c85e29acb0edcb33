"""Navigation gravity: model names, compensation tables, and the truth along a track.

Navigation gravity model names: ``j2``/``j4``/``j6``/``exact``/``sh``/``shN``/``table:FILE``.

Parse a navigation gravity name to the kernel kind and SH degree of
:mod:`fieldmap.kernels.navgravity` (:func:`parse_gravity`) and rank the models by cost
(:func:`gravity_cost`). Shared by the LCI and NED mechanizations and the studies built on them.

Compensation tables as navigation gravity: upload, and evaluation at points (Warp).

A table (:class:`fieldmap.products.tables.model.CompensationTable`) navigates as the exact normal
gravitation plus the table's δg (``kernels/navtable.py``); the NumPy interpolator of
:mod:`fieldmap.products.tables.model` is its reference (``tests/test_navtable.py``).

Truth gravitation along a trajectory at the cost of a few SH evaluations per minute.

A spherical-harmonic model of degree L holds no wavelength shorter than 2πR/L (167 km for
L = 240); a vehicle at speed v sees its disturbance change at most at the frequency
f = v L / (2π R). :class:`TrackGravitation` evaluates the *disturbance* δg = g_SH − γ_exact
(ECEF) on a uniform grid of times along the trajectory, spaced so that f is sampled many times
per period, interpolates it with six-point Lagrange polynomials (a local quintic: each point
depends on its six nearest grid nodes only, so the result does not depend on how the record is
cut into blocks), and adds the exact normal gravitation of the level ellipsoid at every point.

The error is bounded, not assumed: at construction the interpolant is compared with the full
evaluation at the midpoints of grid intervals spread over the whole trajectory; the spacing is
halved until the largest difference is below ``tol_mgal`` (default 1e-4 mGal), and that measured
maximum is reported (:attr:`TrackGravitation.max_error_mgal`).
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Protocol

import numpy as np
import numpy.typing as npt
import warp as wp

from fieldmap import _warp
from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid, get_ellipsoid
from fieldmap.models.shmodel import SHModel

if TYPE_CHECKING:
    from fieldmap.kernels.navgravity import TableKernel
    from fieldmap.nav.trajectory import Trajectory
    from fieldmap.products.tables.model import CompensationTable


def _kernel_kinds() -> dict:
    from fieldmap.kernels import navgravity as kng

    return {
        "exact": int(kng.NAV_NORMAL_EXACT),
        "sh": int(kng.NAV_SH),
        "table": int(kng.NAV_TABLE),
        "j2": int(kng.NAV_J2),
        "j4": int(kng.NAV_J4),
        "j6": int(kng.NAV_J6),
    }


#: navigation gravity names -> kernel kind (the integer codes of kernels/navgravity.py);
#: "shN" = SH to degree N; "exact" is the closed-form level-ellipsoid field (the ``normal="exact"``
#: of :func:`fieldmap.field.normal.normal_model`: one name on the map and the navigation side)
GRAVITY_KINDS = _kernel_kinds()
_SH_NAME = re.compile(r"^sh(\d+)?$")
#: normal navigation models from the simplest to the most complete
NORMAL_MODELS = ("j2", "j4", "j6", "exact")
#: SH degrees ``auto`` tries (those up to the model's degree, and the model's own)
AUTO_DEGREES = (12, 24, 36, 72, 120, 180, 360, 720, 1080, 2190)


def auto_models(sh_model: SHModel) -> list[str]:
    """Return what ``auto`` stands for: every normal model, then SH degrees to the model's.

    ``j2 j4 j6 exact`` and ``shN`` for N in :data:`AUTO_DEGREES` below the model's degree,
    then the full model; tables are the user's (``auto,table:FILE``).
    """
    degrees = [d for d in AUTO_DEGREES if d < sh_model.lmax] + [sh_model.lmax]
    return [*NORMAL_MODELS, *(f"sh{d}" for d in degrees)]


def sh_degree(name: str) -> int | None:
    """SH degree N of a navigation name ``shN`` (None for ``sh`` or a normal model).

    The one parser of the ``shN`` spelling; :func:`parse_gravity` validates against a model.
    """
    m = _SH_NAME.match(str(name).strip().lower())
    return None if m is None or m.group(1) is None else int(m.group(1))


def table_file(name: object) -> str | None:
    """Return the file of a navigation name ``table:FILE`` (as given, case kept), else None."""
    from fieldmap.models.registry import table_path

    return table_path(name) if isinstance(name, str) else None


def gravity_cost(name: str, sh_model: SHModel | None = None) -> float:
    """Relative cost of one evaluation: (N + 1)² for SH degree N, 1 normal models, 64 a table."""
    if table_file(name) is not None:
        return 64.0  # a 4 x 4 x 4 stencil
    key = str(name).strip().lower()
    if key in GRAVITY_KINDS and key != "sh":
        return 1.0
    deg = sh_degree(key)
    if deg is None:
        deg = sh_model.lmax if sh_model is not None else 0
    return float((deg + 1) ** 2)


def is_navigation_name(name: object) -> bool:
    """Tell whether ``name`` is spelt as a navigation gravity model (j2 … exact, shN, table:).

    For the messages of a truth model given a navigation model's name (``--truth-model j2``).
    """
    key = str(name).strip().lower()
    return (
        key in NORMAL_MODELS
        or key == "auto"
        or _SH_NAME.match(key) is not None
        or table_file(str(name)) is not None
    )


def parse_gravity(name: str, sh_model: SHModel | None) -> tuple[int, int]:
    """Navigation gravity name (j2, j4, j6, exact, sh, shN, table:FILE) -> (kernel kind, degree).

    A table name is checked by loading the table
    (:func:`fieldmap.products.tables.model.load_table`).
    """
    path = table_file(name)
    if path is not None:
        from fieldmap.products.tables.model import load_table

        load_table(path)
        return GRAVITY_KINDS["table"], 0
    key = str(name).strip().lower()
    if key in NORMAL_MODELS:
        return GRAVITY_KINDS[key], 0
    m = _SH_NAME.match(key)
    if not m:
        raise InputError(
            f"unknown navigation gravity model {name!r} (j2, j4, j6, exact, sh, shN, table:FILE)"
        )
    if sh_model is None:
        raise InputError(f"navigation gravity {name!r} needs an SH model (sh_model=...)")
    deg = sh_model.lmax if m.group(1) is None else int(m.group(1))
    if deg < 2 or deg > sh_model.lmax:
        raise InputError(
            f"SH degree {deg} of {name!r} is outside 2..{sh_model.lmax} of {sh_model.name}"
        )
    return GRAVITY_KINDS["sh"], deg


class _TableLattice(Protocol):
    """What :func:`kernel_table` reads: a :class:`CompensationTable` or a placeholder lattice."""

    @property
    def data(self) -> np.ndarray: ...  # noqa: D102
    @property
    def lat0(self) -> float: ...  # noqa: D102
    @property
    def dlat(self) -> float: ...  # noqa: D102
    @property
    def lon0(self) -> float: ...  # noqa: D102
    @property
    def dlon(self) -> float: ...  # noqa: D102
    @property
    def h0(self) -> float: ...  # noqa: D102
    @property
    def dh(self) -> float: ...  # noqa: D102


def kernel_table(table: _TableLattice, device: str) -> TableKernel:
    """Return the device struct of ``table`` (its δg values as float64)."""
    from fieldmap.kernels.navgravity import TableKernel

    _warp.init()
    kt = TableKernel()
    data = np.ascontiguousarray(np.asarray(table.data, dtype=np.float64))
    kt.data = wp.array(data, dtype=wp.vec3d, device=device)
    for name in ("lat0", "dlat", "lon0", "dlon", "h0", "dh"):
        setattr(kt, name, wp.float64(float(getattr(table, name))))
    return kt


def table_points(
    table: CompensationTable,
    lat: npt.ArrayLike,
    lon: npt.ArrayLike,
    h: npt.ArrayLike,
    *,
    device: str | None = None,
) -> npt.NDArray[np.float64]:
    """δg north, east, down (mGal) at geodetic points by the kernel; shape (n, 3).

    Every point must be inside the table (checked: the NumPy interpolator's error otherwise).
    """
    from fieldmap.kernels import navgravity as knt
    from fieldmap.products.tables.model import check_inside

    lat, lon, h = (
        np.ascontiguousarray(np.ravel(v), dtype=np.float64)
        for v in np.broadcast_arrays(lat, lon, h)
    )
    check_inside(table, lat, lon, h)
    device = _warp.resolve_device(device)
    out = wp.zeros(lat.size, dtype=wp.vec3d, device=device)
    arrs: list = [wp.array(v, dtype=wp.float64, device=device) for v in (lat, lon, h)]
    wp.launch(
        knt.table_points_kernel,
        dim=lat.size,
        inputs=[kernel_table(table, device), *arrs, out],
        device=device,
    )
    return out.numpy()


def table_gravitation(
    table: CompensationTable,
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    z: npt.ArrayLike,
    *,
    ellipsoid: Ellipsoid | str = WGS84,
    device: str | None = None,
) -> npt.NDArray[np.float64]:
    """Navigation gravitation of a table at ECEF points: exact normal + δg; (n, 3) ECEF, m/s²."""
    from fieldmap.field.normal import normal_params
    from fieldmap.kernels import navgravity as knt

    ell = get_ellipsoid(ellipsoid)
    p = np.ascontiguousarray(
        np.stack(np.broadcast_arrays(x, y, z), axis=-1).reshape(-1, 3), dtype=np.float64
    )
    device = _warp.resolve_device(device)
    out = wp.zeros(len(p), dtype=wp.vec3d, device=device)
    enu = wp.zeros(len(p), dtype=wp.vec3d, device=device)
    wp.launch(
        knt.table_gravitation_kernel,
        dim=len(p),
        inputs=[
            kernel_table(table, device),
            normal_params(ell),
            wp.array(p, dtype=wp.vec3d, device=device),
            out,
            enu,
        ],
        device=device,
    )
    return out.numpy()


#: Grid spacing as a fraction of the shortest period of the disturbance seen along the path.
PERIOD_FRACTION = 0.02
#: Interval midpoints checked against the full evaluation (spread over the whole path).
CHECKS = 64
MGAL = 1e-5


def _path(traj: Trajectory, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ECEF positions and velocities of ``traj`` at times ``t`` (m, m/s; Earth-fixed)."""
    try:
        r, v, _ = traj._ecef(t)
        return r, v
    except (AttributeError, NotImplementedError):
        r = traj.kinematics(t).r_e
        return r, np.gradient(r, t, axis=0)


def highest_frequency(traj: Trajectory, degree: int) -> float:
    """Highest frequency (Hz) of a degree-``degree`` field seen along ``traj``: v_max L / (2πR).

    The shortest wavelength of the field is 2πR/L (R the Earth's mean radius); the path's fastest
    Earth-relative speed v_max (from 2001 points along it) crosses it in 2πR/(L v_max) seconds.
    """
    t = np.linspace(0.0, float(traj.duration), 2001)
    speed = float(np.max(np.linalg.norm(_path(traj, t)[1], axis=1)))
    return max(speed, 1.0) * max(int(degree), 2) / (2.0 * math.pi * 6_371_000.0)


def _lagrange6(u: np.ndarray) -> np.ndarray:
    """Weights of the nodes -2..3 for a point at fraction ``u`` in [0, 1) of interval 0..1."""
    nodes = np.arange(-2, 4, dtype=np.float64)
    w = np.ones((u.size, 6))
    for j in range(6):
        for m in range(6):
            if m != j:
                w[:, j] *= (u - nodes[m]) / (nodes[j] - nodes[m])
    return w


class TrackGravitation:
    """ECEF gravitation of an SH model along ``traj``: exact normal field + interpolated δg.

    Parameters
    ----------
    model : SHModel
        Truth model (its own GM and radius).
    traj : Trajectory
        The path (its closed-form positions place the grid nodes).
    lmax : int, optional
        Degree (default: the model's).
    ellipsoid : Ellipsoid or str
        Level ellipsoid of the exact normal part.
    device : str, optional
        Warp device.
    step_s : float, optional
        Grid spacing (default: :data:`PERIOD_FRACTION` of the shortest period, from L and the
        fastest speed of the path). Units: s.
    tol_mgal : float
        Largest interpolation error allowed at the checked midpoints. Units: mGal.
    """

    def __init__(
        self, model: SHModel, traj: Trajectory, *, lmax: int | None = None,
        ellipsoid: Ellipsoid | str = "WGS84", device: str | None = None,
        step_s: float | None = None, tol_mgal: float = 1e-4,
    ) -> None:  # fmt: skip
        from fieldmap.nav.imu import Gravitation

        self.sh = Gravitation("sh", model=model, lmax=lmax, device=device)
        self.normal = Gravitation("exact", device=device, ellipsoid=ellipsoid)
        self.traj = traj
        self.duration = float(traj.duration)
        if step_s is None:
            step_s = PERIOD_FRACTION / highest_frequency(traj, self.sh.lmax)
        step_s = float(step_s)
        if not (math.isfinite(step_s) and step_s > 0):
            raise InputError(
                f"truth gravity step must be a positive number of seconds, got {step_s}"
            )
        self._cache: dict[int, np.ndarray] = {}
        for _ in range(12):
            self._set_step(step_s)
            self.max_error_mgal = self._check()
            if self.max_error_mgal <= tol_mgal:
                break
            step_s /= 2.0
        else:
            raise InputError(
                f"the truth disturbance cannot be interpolated to {tol_mgal:g} mGal along this "
                "path: use the full evaluation"
            )
        self.name = f"{self.sh.name}, disturbance every {self.step_s:.3g} s + exact normal"

    def _set_step(self, step_s: float) -> None:
        # nodes on both ends of the path: an integer number of intervals
        self.n_int = max(5, math.ceil(self.duration / step_s))
        self.step_s = self.duration / self.n_int
        self._cache = {}

    def _positions(self, t: npt.ArrayLike) -> np.ndarray:
        return _path(self.traj, np.asarray(t, dtype=np.float64))[0]

    def _disturbance(self, r: np.ndarray) -> np.ndarray:
        return np.asarray(self.sh(r), dtype=np.float64) - np.asarray(self.normal(r), np.float64)

    def _nodes(self, ks: np.ndarray) -> np.ndarray:
        """δg at grid nodes ``ks`` (ECEF, m/s²), evaluated once each."""
        missing = np.array(sorted({int(k) for k in ks} - set(self._cache)), dtype=np.int64)
        if missing.size:
            vals = self._disturbance(self._positions(missing * self.step_s))
            for k, v in zip(missing, vals):
                self._cache[int(k)] = v
        return np.stack([self._cache[int(k)] for k in ks])

    def disturbance_at(self, t: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Interpolated δg (ECEF, m/s²) at times ``t`` (s) within the path."""
        t = np.asarray(t, dtype=np.float64)
        x = np.clip(t / self.step_s, 0.0, float(self.n_int))
        i = np.floor(x).astype(np.int64)
        first = np.clip(i - 2, 0, self.n_int - 5)  # the six nodes, shifted inside at the ends
        u = x - (first + 2)
        w = _lagrange6(u)
        idx = first[:, None] + np.arange(6)[None, :]
        uniq, inv = np.unique(idx, return_inverse=True)
        vals = self._nodes(uniq)[inv.reshape(idx.shape)]  # (n, 6, 3)
        return np.einsum("nj,njc->nc", w, vals)

    def at_times(self, t: npt.ArrayLike, r_e: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """Gravitation at ECEF points ``r_e`` (on the path at times ``t``): γ_exact + δg(t)."""
        return np.asarray(self.normal(r_e), dtype=np.float64) + self.disturbance_at(t)

    def __call__(self, r_e: np.ndarray) -> np.ndarray:
        """Full evaluation at arbitrary points (no interpolation)."""
        return np.asarray(self.sh(r_e), dtype=np.float64)

    def _check(self) -> float:
        """Largest |interpolated − full| δg (mGal) at interval midpoints along the path."""
        k = np.unique(np.linspace(0, self.n_int - 1, min(CHECKS, self.n_int)).round().astype(int))
        t = (k + 0.5) * self.step_s
        full = self._disturbance(self._positions(t))
        err = np.linalg.norm(self.disturbance_at(t) - full, axis=1)
        return float(err.max() / MGAL)


#: Default gravity rate: (2π f T)² ≤ this, f the highest frequency of the navigation model along
#: the path and T the update interval (the linear extrapolation's relative error is of that order).
GRAVITY_RATE_ERROR = 1e-3


def gravity_update_every(
    traj: Trajectory, degree: int, rate_hz: float, gravity_rate_hz: float | str | None = None
) -> int:
    """IMU samples between SH disturbance updates of an SH navigation model of ``degree``.

    ``gravity_rate_hz`` None: the slowest rate whose linear extrapolation error stays below
    :data:`GRAVITY_RATE_ERROR` of the disturbance (0.1 %, well below 1 % of the model's own
    effect); ``"full"`` or 0: every sample; a number: that rate (Hz).
    """
    if gravity_rate_hz in ("full", 0, 0.0):
        return 1
    if gravity_rate_hz is None:
        f = highest_frequency(traj, degree)
        interval = math.sqrt(GRAVITY_RATE_ERROR) / (2.0 * math.pi * f)
    else:
        try:
            g = float(gravity_rate_hz)
        except (TypeError, ValueError):
            g = math.nan
        if not (math.isfinite(g) and g > 0):
            raise InputError(
                f"gravity rate must be a positive number of Hz, got {gravity_rate_hz!r}"
            )
        interval = 1.0 / g
    return max(1, int(math.floor(interval * float(rate_hz) + 1e-9)))
