"""Kernel-vs-NumPy comparisons that a user can run on their own machine (``fieldmap verify``).

The sub-command itself (:func:`register`, :func:`run_verify`) is at the end of this module.

Each check evaluates one Warp kernel path and its independent NumPy reference
(:mod:`fieldmap.reference`) on the same random inputs and reports the largest absolute and
relative difference (relative to the largest magnitude of the reference, per output vector) and
the time of both. Each row has one of three statuses: ``ok`` (within :data:`RTOL`), ``FAIL``
(beyond it, or the check raised, or a module it needs cannot be imported: a missing part of
fieldmap or of its dependencies is a broken install, never a skipped check) and ``skipped`` (the
check cannot run here and says why, :class:`SkipCheck`); a skipped check is not counted as passed.
"""

from __future__ import annotations

import argparse
import importlib
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

#: default largest accepted relative difference of a kernel and its NumPy reference
RTOL = 1e-12


class SkipCheck(Exception):
    """Raised by a check that cannot run here (the message says why); reported as skipped."""


@dataclass
class CheckResult:
    """One row of the verification table (``note``: why it was skipped or failed to run)."""

    quantity: str
    device: str
    max_abs: float = float("nan")
    max_rel: float = float("nan")
    kernel_s: float = float("nan")
    numpy_s: float = float("nan")
    unit: str = ""
    note: str = ""
    skipped: bool = False

    @property
    def ok(self) -> bool:
        """True when the check ran and its relative difference is within :data:`RTOL`."""
        return not self.skipped and not self.note and bool(self.max_rel <= RTOL)

    @property
    def status(self) -> str:
        """``"ok"``, ``"skipped"`` or ``"FAIL"``."""
        return "skipped" if self.skipped else ("ok" if self.ok else "FAIL")


def _timed(fn: Callable[[], Any], repeats: int = 1) -> tuple[Any, float]:
    """Return (result, best wall time of ``repeats`` calls)."""
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def _diff(got: npt.ArrayLike, want: npt.ArrayLike) -> tuple[float, float]:
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    if got.shape != want.shape or not np.all(np.isfinite(got)):
        return float("inf"), float("inf")
    err = np.abs(got - want)
    if want.ndim and want.shape[-1] == 3:  # vectors: error norm over the reference norm
        err = np.linalg.norm(got - want, axis=-1)
        scale = np.linalg.norm(want, axis=-1)
    else:
        scale = np.abs(want)
    max_abs = float(err.max()) if err.size else 0.0
    ref = float(scale.max()) if scale.size else 0.0
    return max_abs, (max_abs / ref if ref > 0 else max_abs)


def _compare(
    quantity: str,
    device: str,
    kernel: Callable[..., npt.ArrayLike],
    numpy_ref: Callable[..., npt.ArrayLike],
    unit: str,
) -> CheckResult:
    kernel()  # warm-up: compiles or loads the module, builds cached tables
    got, tk = _timed(kernel, repeats=3)
    want, tn = _timed(numpy_ref)
    a, r = _diff(got, want)
    return CheckResult(quantity, device, a, r, tk, tn, unit)


def random_points(
    n: int, seed: int = 0, hmax: float = 100e3
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Geodetic points uniform on the sphere, heights 0..hmax, including the poles and ±89.99°.

    Units: degrees, degrees, m.
    """
    rng = np.random.default_rng(seed)
    lat = np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, n)))
    lon = rng.uniform(-180.0, 180.0, n)
    h = rng.uniform(0.0, hmax, n)
    special = np.array([90.0, -90.0, 89.99, -89.99, 0.0])[:n]
    lat[: special.size] = special
    return lat, lon, h


def _sh_checks(device: str, lmax: int, npoints: int) -> Iterator[CheckResult]:
    from fieldmap.field.frames import geodetic_to_ecef
    from fieldmap.field.sh import sh_gravitation, sh_potential
    from fieldmap.models.registry import load_model
    from fieldmap.reference import sh as ref

    model = load_model("eigen-6s", lmax=lmax)
    x, y, z = geodetic_to_ecef(*random_points(npoints, seed=1))
    tag = f"degree {model.lmax}, {npoints} points"
    yield _compare(
        f"SH gravitation ({tag})",
        device,
        lambda: sh_gravitation(model, x, y, z, device=device),
        lambda: ref.gravitation_ecef(model, x, y, z),
        "m/s²",
    )
    yield _compare(
        f"SH potential ({tag})",
        device,
        lambda: sh_potential(model, x, y, z, device=device),
        lambda: ref.potential(model, x, y, z),
        "m²/s²",
    )


def _normal_checks(device: str, npoints: int) -> Iterator[CheckResult]:
    from fieldmap.field.ellipsoid import WGS84
    from fieldmap.field.normal import normal_gravity
    from fieldmap.reference import normal as ref

    lat, lon, h = random_points(npoints, seed=2)
    for kind in ("exact", "j2", "j4", "j6"):
        yield _compare(
            f"normal gravitation {kind} ({npoints} points)",
            device,
            lambda kind=kind: normal_gravity(
                lat,
                lon,
                h,
                normal=kind,
                ellipsoid=WGS84,
                centrifugal=False,
                frame="ecef",
                device=device,
            ),
            lambda kind=kind: ref.normal_gravity(
                lat, lon, h, WGS84, kind=kind, centrifugal=False, frame="ecef"
            ),
            "m/s²",
        )


def _grid_checks(device: str, lmax: int) -> Iterator[CheckResult]:
    from fieldmap.field.frames import ecef_to_enu_vector, geodetic_to_ecef
    from fieldmap.grids.synthesis import make_grid, synthesize
    from fieldmap.models.registry import load_model
    from fieldmap.reference import sh as ref

    model = load_model("eigen-6s", lmax=lmax)
    grid = make_grid(step_deg=10.0, lat_max=80.0, heights_m=(20e3, 100e3))
    H, LAT, LON = np.meshgrid(grid.heights, grid.lat, grid.lon, indexing="ij")

    def numpy_ref() -> np.ndarray:
        x, y, z = geodetic_to_ecef(LAT.ravel(), LON.ravel(), H.ravel())
        g = ref.gravitation_ecef(model, x, y, z)
        return ecef_to_enu_vector(g, LAT.ravel(), LON.ravel()).reshape(H.shape + (3,))

    yield _compare(
        f"SH grid gravitation (degree {model.lmax}, {H.size} nodes)",
        device,
        lambda: synthesize(model, grid, quantity="gravitation", device=device, progress=False),
        numpy_ref,
        "m/s²",
    )


def _strapdown_checks(device: str) -> Iterator[CheckResult]:
    from fieldmap.field.ellipsoid import WGS84
    from fieldmap.nav.frames import LaunchFrame
    from fieldmap.nav.mechanize import (
        LciStart,
        NavConfig,
        dcm_to_quat,
        propagate_lci,
        quat_to_dcm,
    )
    from fieldmap.reference import normal as rnorm
    from fieldmap.reference.strapdown import propagate_lci_reference

    rng = np.random.default_rng(4)
    n, ns, dt = 4, 400, 0.005
    dth = rng.normal(0, 0.2, (n, ns, 3)) * dt
    dv = (rng.normal(0, 3, (n, ns, 3)) + [0, 9.8, 0]) * dt
    P0 = rng.normal(0, 100, (n, 3)) + [0, 20e3, 0]
    V0 = rng.normal(0, 300, (n, 3))
    C0 = np.array([np.eye(3)] * n)
    frame = LaunchFrame(105.3, 27.1, 63.0, h0=0.0)

    def kernel() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        res = propagate_lci(
            dth,
            dv,
            dt,
            LciStart(P0, V0, dcm_to_quat(C0), frame),
            NavConfig("j4", output_every=20),
            device=device,
        )
        return res.P, res.V, quat_to_dcm(res.q)

    def numpy_ref() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        _, P, V, C = propagate_lci_reference(
            (dth, dv, dt),
            (P0, V0, C0),
            frame,
            lambda r: rnorm.jn_gravitation(r[:, 0], r[:, 1], r[:, 2], WGS84, 4),
            output_every=20,
        )
        return P, V, C

    kernel()  # warm-up
    got, tk = _timed(kernel, repeats=3)
    want, tn = _timed(numpy_ref)
    tag = f"strapdown LCI J4 ({n} traj. x {ns // 2} steps)"
    for what, unit, k in (("position", "m", 0), ("velocity", "m/s", 1), ("attitude DCM", "", 2)):
        a, r = _diff(got[k].reshape(-1, 3), want[k].reshape(-1, 3))
        yield CheckResult(f"{tag}: {what}", device, a, r, tk, tn, unit)


def _strapdown_ned_checks(device: str) -> Iterator[CheckResult]:
    from fieldmap.field.ellipsoid import WGS84
    from fieldmap.field.frames import C_e_to_enu, enu_to_ned, geodetic_to_ecef
    from fieldmap.nav.mechanize import NavConfig, NedStart, propagate_ned, quat_to_dcm
    from fieldmap.reference import normal as rnorm
    from fieldmap.reference.strapdown import propagate_ned_reference

    N, dt = 600, 0.01
    t = (np.arange(N) + 0.5) * dt  # smooth aircraft-like body rates and specific forces
    dth = np.stack([0.05 * np.sin(0.7 * t), 0.03 * np.cos(0.3 * t), 0.02 + 0 * t], -1) * dt
    dv = np.stack([2 + 0.5 * np.sin(t), 0.3 * np.cos(2 * t), -9.8 + 0.2 * np.sin(0.5 * t)], -1) * dt
    v0 = np.array([150.0, 80.0, -5.0])

    def g_ned(
        llh: np.ndarray,
    ) -> np.ndarray:  # Groves (2013) eq. 3.7.7 J2 gravitation + centrifugal, NED
        lat, lon = np.degrees(llh[:, 0]), np.degrees(llh[:, 1])
        r = np.stack(geodetic_to_ecef(lat, lon, llh[:, 2]), -1)
        g = rnorm.groves_j2_gravitation(r[:, 0], r[:, 1], r[:, 2], WGS84.GM, WGS84.J2, WGS84.a)
        g = g + WGS84.omega**2 * r * [1.0, 1.0, 0.0]
        return enu_to_ned(np.einsum("nij,nj->ni", C_e_to_enu(lat, lon), g))

    def kernel() -> tuple[np.ndarray, np.ndarray]:
        res = propagate_ned(
            dth,
            dv,
            dt,
            NedStart(30.0, 100.0, 1000.0, v0, np.array([1.0, 0, 0, 0])),
            NavConfig("j2", output_every=50),
            device=device,
        )
        return res.v_ned[0], quat_to_dcm(res.q[0])

    def numpy_ref() -> tuple[np.ndarray, np.ndarray]:
        _, V, C = propagate_ned_reference(
            (dth[None], dv[None], dt),
            (np.array([[np.radians(30.0), np.radians(100.0), 1000.0]]), v0[None], np.eye(3)[None]),
            g_ned,
            WGS84,
            output_every=50,
        )
        return V[0], C[0]

    kernel()
    got, tk = _timed(kernel, repeats=3)
    want, tn = _timed(numpy_ref)
    for what, unit, k in (("velocity", "m/s", 0), ("attitude DCM", "", 1)):
        a, r = _diff(got[k].reshape(-1, 3), want[k].reshape(-1, 3))
        yield CheckResult(f"strapdown NED J2 ({N} steps): {what}", device, a, r, tk, tn, unit)


CHECKS = (
    ("fieldmap.field.sh", lambda d, o: _sh_checks(d, o["lmax"], o["points"])),
    ("fieldmap.field.normal", lambda d, o: _normal_checks(d, o["points"])),
    ("fieldmap.grids.synthesis", lambda d, o: _grid_checks(d, min(o["lmax"], 120))),
    ("fieldmap.nav.mechanize", lambda d, o: _strapdown_checks(d)),
    ("fieldmap.nav.mechanize", lambda d, o: _strapdown_ned_checks(d)),
)


def run_checks(
    devices: Sequence[str] | None = None, lmax: int = 240, points: int = 200
) -> list[CheckResult]:
    """Run every available kernel-vs-NumPy comparison.

    Parameters
    ----------
    devices : list of str, optional
        Warp devices (default: every device present).
    lmax : int
        Degree of the EIGEN-6S checks (0..240).
    points : int
        Number of random points of the point checks (5..1000000).

    Raises
    ------
    InputError
        A device not present, or ``lmax``/``points`` out of range.

    Returns
    -------
    list of CheckResult
    """
    from fieldmap import _warp
    from fieldmap.errors import InputError
    from fieldmap.models.icgem import as_degree

    if isinstance(devices, str):
        devices = [devices]
    devices = [_warp.resolve_device(d) for d in devices] if devices else _warp.devices()
    degree = as_degree(lmax)
    try:
        ok = not isinstance(points, (bool, str)) and int(points) == points
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise InputError(f"points must be an integer, got {points!r}")
    points = int(points)
    if degree is None or not 0 <= degree <= 240:
        raise InputError(f"lmax must be within 0..240 (EIGEN-6S), got {lmax}")
    if not 5 <= points <= 1_000_000:
        raise InputError(f"points must be within 5..1000000, got {points}")
    opts = {"lmax": degree, "points": points}
    rows: list[CheckResult] = []
    for device in devices:
        for module, make in CHECKS:
            try:
                importlib.import_module(module)
                rows.extend(make(device, opts))
            except SkipCheck as exc:
                rows.append(CheckResult(module, device, note=f"skipped: {exc}", skipped=True))
            except Exception as exc:  # report, keep going: a broken check is a failure
                # ImportError: a part of fieldmap or a dependency is missing
                what = "broken install" if isinstance(exc, ImportError) else "error"
                note = f"{what}: {type(exc).__name__}: {exc}"
                rows.append(CheckResult(module, device, float("inf"), float("inf"), note=note))
    return rows


def format_table(rows: list[CheckResult]) -> str:
    """Render the rows as a plain-text table."""
    head = (
        "quantity",
        "device",
        "max abs diff",
        "max rel diff",
        "kernel [ms]",
        "NumPy [ms]",
        "status",
    )
    body = []
    for r in rows:
        if r.note:
            body.append((r.quantity, r.device, "", "", "", "", f"{r.status}: {r.note}"))
            continue
        body.append(
            (
                r.quantity,
                r.device,
                f"{r.max_abs:.2e} {r.unit}",
                f"{r.max_rel:.2e}",
                f"{1e3 * r.kernel_s:.2f}",
                f"{1e3 * r.numpy_s:.1f}",
                "ok" if r.ok else f"FAIL (> {RTOL:g})",
            )
        )
    widths = [max(len(str(x[i])) for x in (head, *body)) for i in range(len(head))]
    lines = [
        "  ".join(str(c).ljust(w) for c, w in zip(row, widths)).rstrip() for row in (head, *body)
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


# -- the sub-command ``fieldmap verify`` --------------------------------------------------------
def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``verify`` sub-command."""
    v = subparsers.add_parser(
        "verify",
        help="compare the Warp kernels with their NumPy references on this machine",
        description="Run kernel-vs-NumPy comparisons and print max differences and timings; "
        "exit status 1 if a relative difference exceeds 1e-12, a part of fieldmap cannot be "
        "imported, or no check passed (a check that cannot run here is shown as skipped).",
    )
    v.add_argument(
        "--device",
        action="append",
        default=None,
        help="device to check (repeatable; default: every device present)",
    )
    v.add_argument("--lmax", type=int, default=240, help="degree of the EIGEN-6S checks (≤ 240)")
    v.add_argument(
        "--points", type=int, default=200, help="random points per check, 5..1000000 (default 200)"
    )
    v.set_defaults(func=run_verify)


def run_verify(args: argparse.Namespace) -> int:
    """Run ``fieldmap verify``; return 1 if a check failed (or none passed), else 0."""
    from fieldmap import _warp
    from fieldmap.errors import InputError

    if not 0 <= args.lmax <= 240:
        raise InputError(f"--lmax must be within 0..240 (EIGEN-6S), got {args.lmax}")
    if not 5 <= args.points <= 1_000_000:
        raise InputError(f"--points must be within 5..1000000, got {args.points}")
    devices = None
    if args.device:
        devices = [_warp.resolve_device(d) for d in args.device]
    rows = run_checks(devices, lmax=args.lmax, points=args.points)
    print(format_table(rows))
    count = {s: sum(r.status == s for r in rows) for s in ("ok", "skipped", "FAIL")}
    print(
        f"\n{count['ok']} of {len(rows)} checks within {RTOL:g} relative"
        + (f"; {count['skipped']} skipped" if count["skipped"] else "")
        + (f"; {count['FAIL']} FAILED" if count["FAIL"] else "")
    )
    # a skipped check is no pass: nothing verified is a failure too
    return 1 if count["FAIL"] or not count["ok"] else 0
