"""GeographicLib gravity-model files and the ``Gravity`` command-line tool, for cross-checks.

GeographicLib (Karney) reads a gravity model ``NAME`` from two files in a folder:

* ``NAME.egm`` — text: ``EGMF-1`` then ``key value`` lines (``ModelRadius``, ``ModelMass``,
  ``AngularVelocity``, ``ReferenceRadius``, ``ReferenceMass``, ``Flattening``, ``Normalization``,
  ``ByteOrder``, ``ID`` of exactly 8 characters, ...);
* ``NAME.egm.cof`` — binary little-endian: the 8-character ID, int32 N, M, then C̄nm as float64
  column by column (m = 0..M, n = m..N), then S̄nm likewise for m = 1..M, then the correction
  field (int32 −1, −1: none). The degree-0 coefficient is stored as 0: the tool adds the GM/r
  term itself (GeographicLib's GravityModel rejects a non-zero C̄00).

``Gravity -n NAME -d DIR -D`` prints the disturbance east north up (mGal), ``-G`` the gravity
east north up including the centrifugal term (m/s²), in the local geodetic frame at each point,
with GeographicLib's own exact normal field of the reference ellipsoid for ``-D``. The tool is
independent of fieldmap's engine (Clenshaw summation with scaling, Karney 2011), which makes it a
check of the spherical-harmonic evaluation.

This module writes a model in that format (:func:`write_egm`) and runs the tool
(:func:`run_gravity_tool`). Reading such a model, one of the formats of
:func:`fieldmap.models.registry.load_model`, is :mod:`fieldmap.models.egm`; its names
(:func:`~fieldmap.models.egm.read_egm`, :func:`~fieldmap.models.egm.find_egm`...) are importable
from here too.
"""

from __future__ import annotations

import os
import re
import shutil
import struct
import subprocess

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.errors import FieldmapError, InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.models.egm import (  # noqa: F401 - the reader, importable from here too
    MAX_DEGREE,
    READER_VERSION,
    default_gravity_dirs,
    find_egm,
    read_egm,
    read_egm_metadata,
)
from fieldmap.models.shmodel import SHModel

GRAVITY_EXE = "Gravity"
_MODES = {
    "disturbance": "-D",
    "gravity": "-G",
    "anomaly": "-A",
    "geoid": "-H",
    "D": "-D",
    "G": "-G",
    "A": "-A",
    "H": "-H",
}


def egm_id(name: str) -> str:
    """Return an 8-character ID derived from a model name (upper-case letters and digits)."""
    core = re.sub(r"[^A-Z0-9]", "", name.upper()) or "FIELDMAP"
    return (core + "XXXXXXXX")[:8]


def write_egm(
    model: SHModel,
    folder: str | os.PathLike[str],
    name: str | None = None,
    reference: Ellipsoid = WGS84,
    description: str | None = None,
    order: int | None = None,
    correction: SHModel | None = None,
    height_offset: float | None = None,
) -> str:
    """Write ``model`` as GeographicLib ``NAME.egm`` and ``NAME.egm.cof`` in ``folder``.

    Parameters
    ----------
    model : SHModel
        Fully normalised coefficients; its ``gm`` and ``radius`` become ``ModelMass`` and
        ``ModelRadius``. C̄00 is written as 0 (GeographicLib adds the central term).
    folder : str or os.PathLike
        Output folder (created if needed).
    name : str, optional
        Model name for ``Gravity -n`` (default: the model's name, lower case, safe characters).
    reference : Ellipsoid
        Normal field subtracted by ``Gravity -D`` (``Reference*``, ``Flattening``,
        ``AngularVelocity``); default WGS84.
    description : str, optional
        ``Description`` line.
    order : int, optional
        Highest order M written (the .cof header's M; default: the degree N). Orders above M
        are left out (GeographicLib treats them as zero).
    correction : SHModel, optional
        Correction series (GeographicLib's ζ-to-N field, summed on the unit sphere); its C, S
        are written after the model's. Default: none (``-1 -1``).
    height_offset : float, optional
        ``HeightOffset`` key (m, added to the geoid height).

    Returns
    -------
    str
        The model name to pass to ``Gravity -n``.
    """
    name = name or re.sub(r"[^a-z0-9_-]", "", model.name.lower()) or "fieldmap"
    os.makedirs(folder, exist_ok=True)
    ident = egm_id(model.name)
    N = model.lmax
    if N < 0 or model.C.shape != (N + 1, N + 1):
        raise InputError(f"model {model.name}: coefficient arrays are not (lmax+1)^2")
    meta = [
        "EGMF-1",
        f"Name {name}",
        f"Description {description or model.name + ' (written by fieldmap)'}",
        f"ModelRadius {model.radius!r}",
        f"ModelMass {model.gm!r}",
        f"AngularVelocity {reference.omega!r}",
        f"ReferenceRadius {reference.a!r}",
        f"ReferenceMass {reference.GM!r}",
        f"Flattening {reference.f!r}",
        "Normalization full",
        "ByteOrder little",
        f"ID {ident}",
    ]
    if height_offset is not None:
        meta.insert(-1, f"HeightOffset {float(height_offset)!r}")
    with open(os.path.join(folder, f"{name}.egm"), "w", encoding="ascii", errors="replace") as f:
        f.write("\n".join(meta) + "\n")
    M = N if order is None else int(order)
    if not 0 <= M <= N:
        raise InputError(f"order {order} is outside 0..{N}")
    C = model.C.copy()
    C[0, 0] = 0.0  # GeographicLib adds the 1/r term itself
    with open(os.path.join(folder, f"{name}.egm.cof"), "wb") as f:
        f.write(ident.encode("ascii"))
        f.write(_cof_block(C, model.S, N, M))
        if correction is None:
            f.write(struct.pack("<ii", -1, -1))  # no correction field
        else:
            f.write(_cof_block(correction.C, correction.S, correction.lmax, correction.lmax))
    return name


def _cof_block(C: np.ndarray, S: np.ndarray, N: int, M: int) -> bytes:
    """int32 N, M, then C column-major (m = 0..M, n = m..N), then S likewise for m = 1..M."""
    c_cols = np.concatenate([C[m : N + 1, m] for m in range(M + 1)])
    s_cols = np.concatenate([S[m : N + 1, m] for m in range(1, M + 1)]) if M else np.zeros(0)
    return (
        struct.pack("<ii", N, M)
        + np.ascontiguousarray(c_cols, dtype="<f8").tobytes()
        + np.ascontiguousarray(s_cols, dtype="<f8").tobytes()
    )


def gravity_tool() -> str | None:
    """Path of GeographicLib's ``Gravity`` executable (Debian ``geographiclib-tools``) or None."""
    return shutil.which(GRAVITY_EXE)


def run_gravity_tool(
    points: ArrayLike,
    model_dir: str | os.PathLike[str],
    name: str,
    mode: str = "disturbance",
    nmax: int | None = None,
    precision: int = 12,
    timeout: float = 600.0,
) -> np.ndarray:
    """Evaluate a model with GeographicLib's ``Gravity`` at ``lat lon h`` points.

    Parameters
    ----------
    points : array_like
        Shape ``(n, 3)``: geodetic latitude, longitude (degrees) and height above WGS84 (m).
    model_dir : str or os.PathLike
        Folder holding ``NAME.egm`` and ``NAME.egm.cof``.
    name : str
        Model name.
    mode : {"disturbance", "gravity", "anomaly", "geoid"}
        ``-D``: disturbance east, north, up in mGal; ``-G``: gravity incl. centrifugal,
        east, north, up in m/s²; ``-A``: gravity anomaly (mGal), deflection ξ north and η east
        (arcsec), spherical approximation; ``-H``: geoid height (m), needs h = 0.
    nmax : int, optional
        Truncation degree (``-N``).
    precision : int
        Output precision (``-p``).
    timeout : float
        Units: s.

    Returns
    -------
    numpy.ndarray
        Shape ``(n, 3)`` (``(n, 1)`` for ``geoid``), the tool's columns.
    """
    exe = gravity_tool()
    if exe is None:
        raise FieldmapError("GeographicLib's Gravity tool is not installed (geographiclib-tools)")
    flag = _MODES.get(mode)
    if flag is None:
        raise InputError(f"mode must be one of {', '.join(_MODES)}, got {mode!r}")
    pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError("points must have shape (n, 3): lat, lon, h")
    cmd = [exe, "-n", name, "-d", os.fspath(model_dir), flag, "-p", str(int(precision))]
    if nmax is not None:
        cmd += ["-N", str(int(nmax))]
    # fixed-point: Gravity reads coordinates as DMS, where the 'e' of 8.98e-06 is a hemisphere
    text = "".join(f"{a:.17f} {b:.17f} {c:.17f}\n" for a, b, c in pts.tolist())
    proc = subprocess.run(cmd, input=text, capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0:
        msg = (proc.stderr or proc.stdout).strip().splitlines()
        raise FieldmapError(f"Gravity failed: {msg[-1] if msg else proc.returncode}")
    out = np.array(
        [[float(v) for v in line.split()] for line in proc.stdout.splitlines() if line.strip()]
    )
    if out.shape != (pts.shape[0], 1 if flag == "-H" else 3):
        raise FieldmapError(f"Gravity returned {out.shape[0]} lines for {pts.shape[0]} points")
    return out
