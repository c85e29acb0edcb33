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
"""

from __future__ import annotations

import os
import re
import shutil
import struct
import subprocess

import numpy as np

from fieldmap.errors import FieldmapError, InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
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
    folder,
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


def _cof_block(C, S, N: int, M: int) -> bytes:
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
    points,
    model_dir,
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
    text = "".join(f"{a!r} {b!r} {c!r}\n" for a, b, c in pts.tolist())
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


#: version of :func:`read_egm`, part of the key of the on-disk cache (bump when output changes)
READER_VERSION = 1
#: keys whose values are numbers (possibly fractions ``1/298.257223563``, as GeographicLib's
#: ``Utility::fract``)
_NUMERIC = (
    "ModelRadius",
    "ModelMass",
    "AngularVelocity",
    "ReferenceRadius",
    "ReferenceMass",
    "Flattening",
    "DynamicalFormFactor",
    "HeightOffset",
    "CorrectionMultiplier",
)
_REQUIRED = ("ModelRadius", "ModelMass", "ID")
#: largest degree accepted in a .cof header (as the ICGEM reader)
MAX_DEGREE = 10800


def default_gravity_dirs() -> list[str]:
    """Return the folders where ``Gravity`` looks for models.

    ``$GEOGRAPHICLIB_GRAVITY_PATH`` or ``$GEOGRAPHICLIB_DATA/gravity``, then the compiled-in
    defaults of Debian and of a source install (``/usr/share/GeographicLib/gravity``,
    ``/usr/local/share/GeographicLib/gravity``).
    """
    out = []
    if os.environ.get("GEOGRAPHICLIB_GRAVITY_PATH"):
        out.append(os.environ["GEOGRAPHICLIB_GRAVITY_PATH"])
    elif os.environ.get("GEOGRAPHICLIB_DATA"):
        out.append(os.path.join(os.environ["GEOGRAPHICLIB_DATA"], "gravity"))
    out += ["/usr/share/GeographicLib/gravity", "/usr/local/share/GeographicLib/gravity"]
    return out


def find_egm(name: str, model_dir=None) -> str | None:
    """Path of ``NAME.egm`` in ``model_dir`` (or, if None, in :func:`default_gravity_dirs`)."""
    if not re.fullmatch(r"[A-Za-z0-9_.+-]+", str(name)):
        return None
    dirs = [os.fspath(model_dir)] if model_dir is not None else default_gravity_dirs()
    for d in dirs:
        path = os.path.join(d, f"{name}.egm")
        if os.path.isfile(path):
            return path
    return None


def _number(path, line, key, text) -> float:
    from fieldmap.errors import ModelFileError

    try:
        if "/" in text:
            num, den = text.split("/", 1)
            val = float(num) / float(den)
        else:
            val = float(text)
    except (ValueError, ZeroDivisionError):
        raise ModelFileError(f"{path}, line {line}: {key} {text!r} is not a number") from None
    if not np.isfinite(val):
        raise ModelFileError(f"{path}, line {line}: {key} {text!r} is not finite")
    return val


def read_egm_metadata(path) -> dict:
    """Parse a GeographicLib ``.egm`` metadata file (``EGMF-1`` then ``key value`` lines).

    Returns
    -------
    dict
        Key -> value (strings; the keys of ``_NUMERIC`` as floats), plus ``_line`` (key -> line).

    Raises
    ------
    ModelFileError
        Not an ``EGMF-1`` file, a bad or missing value (file and line named).
    """
    from fieldmap.errors import ModelFileError

    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            raw = f.read(1 << 20)
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read ({exc.strerror or exc})") from None
    text = raw.decode("latin-1")
    lines = text.splitlines()
    if not lines or lines[0].strip() != "EGMF-1":
        raise ModelFileError(
            f"{path}, line 1: not a GeographicLib gravity model ('EGMF-1' expected)"
        )
    meta: dict = {"_line": {}}
    for k, line in enumerate(lines[1:], start=2):
        body = line.split("#", 1)[0].strip()
        if not body:
            continue
        if any(ord(c) < 32 and c != "\t" for c in body):
            raise ModelFileError(f"{path}, line {k}: control characters in the metadata")
        parts = body.split(None, 1)
        key, value = parts[0], (parts[1].strip() if len(parts) > 1 else "")
        if key in _NUMERIC:
            meta[key] = _number(path, k, key, value)
        else:
            meta[key] = value
        meta["_line"][key] = k
    for key in _REQUIRED:
        if key not in meta:
            raise ModelFileError(f"{path}: no {key} line")
    for key in ("ModelRadius", "ModelMass"):
        if meta[key] <= 0:
            raise ModelFileError(f"{path}, line {meta['_line'][key]}: {key} must be positive")
    if len(meta["ID"]) != 8:
        raise ModelFileError(f"{path}, line {meta['_line']['ID']}: ID must have 8 characters")
    norm = meta.get("Normalization", "full").lower()
    if norm not in ("full", "schmidt"):
        raise ModelFileError(
            f"{path}, line {meta['_line']['Normalization']}: Normalization must be full or "
            f"schmidt, got {norm!r}"
        )
    if meta.get("ByteOrder", "little").lower() != "little":
        raise ModelFileError(
            f"{path}, line {meta['_line']['ByteOrder']}: only ByteOrder little is supported "
            "(as GeographicLib)"
        )
    return meta


def _read_block(cof, raw: bytes, pos: int, what: str, allow_empty: bool):
    """Read ``N M C S`` at byte ``pos``; return (C, S, N, M, new pos); (None, ...) if N = -1."""
    from fieldmap.errors import ModelFileError

    if len(raw) < pos + 8:
        raise ModelFileError(f"{cof}, byte {pos}: file ends before the {what} degree and order")
    N, M = struct.unpack_from("<ii", raw, pos)
    if N == -1 and M == -1 and allow_empty:
        return None, None, -1, -1, pos + 8
    if not (0 <= M <= N <= MAX_DEGREE):
        raise ModelFileError(
            f"{cof}, byte {pos}: bad {what} degree and order N={N} M={M} "
            f"(need 0 <= M <= N <= {MAX_DEGREE})"
        )
    nc = (M + 1) * (2 * N - M + 2) // 2
    ns = M * (2 * N - M + 1) // 2
    start = pos + 8
    end = start + 8 * (nc + ns)
    if len(raw) < end:
        raise ModelFileError(
            f"{cof}, byte {len(raw)}: file ends inside the {what} coefficients "
            f"(N={N} M={M} needs {end} bytes)"
        )
    vals = np.frombuffer(raw, dtype="<f8", count=nc + ns, offset=start).astype(np.float64)
    bad = np.flatnonzero(~np.isfinite(vals))
    if bad.size:
        raise ModelFileError(f"{cof}, byte {start + 8 * int(bad[0])}: coefficient is not finite")
    C = np.zeros((N + 1, N + 1))
    S = np.zeros((N + 1, N + 1))
    k = 0
    for m in range(M + 1):
        C[m:, m] = vals[k : k + N + 1 - m]
        k += N + 1 - m
    for m in range(1, M + 1):
        S[m:, m] = vals[k : k + N + 1 - m]
        k += N + 1 - m
    return C, S, N, M, end


def _schmidt_to_full(C, S):
    """Schmidt semi-normalised -> fully normalised: divide degree n by sqrt(2n+1)."""
    f = np.sqrt(2.0 * np.arange(C.shape[0]) + 1.0)[:, None]
    return C / f, S / f


def read_egm(path, lmax: int | None = None) -> SHModel:
    """Read a GeographicLib gravity model (``NAME.egm`` and ``NAME.egm.cof``).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.egm`` metadata file (or the ``.egm.cof`` next to it).
    lmax : int, optional
        Keep degrees 0..lmax (default: the file's N).

    Returns
    -------
    SHModel
        ``gm``/``radius`` from ``ModelMass``/``ModelRadius``; C̄00 = 1 (the file stores 0, the
        central term being implied); orders above the file's M are zero. ``header`` holds the
        metadata, ``HeightOffset`` and ``CorrectionMultiplier`` as floats, the .cof header
        ``N``, ``M`` and, if the file has one, the correction series as ``header["correction"]``
        (an SHModel with gm = radius = 1, summed on the unit sphere by
        :func:`fieldmap.field.geodesy.correction_height`).

    Raises
    ------
    ModelFileError
        Malformed metadata (file and line named) or coefficients (file and byte offset named).
    InputError
        ``lmax`` beyond the file's degree.
    """
    from fieldmap.errors import ModelFileError

    path = os.fspath(path)
    if path.endswith(".egm.cof"):
        path = path[:-4]
    meta = read_egm_metadata(path)
    cof = path + ".cof"
    try:
        with open(cof, "rb") as f:
            raw = f.read()
    except OSError as exc:
        raise ModelFileError(f"{cof}: cannot read ({exc.strerror or exc})") from None
    if len(raw) < 8 or raw[:8] != meta["ID"].encode("latin-1"):
        raise ModelFileError(
            f"{cof}, byte 0: ID {raw[:8]!r} does not match ID {meta['ID']} of {path}"
        )
    C, S, N, M, pos = _read_block(cof, raw, 8, "model", allow_empty=False)
    if C[0, 0] != 0.0:
        raise ModelFileError(
            f"{cof}, byte 16: C00 must be 0 (GeographicLib adds the central term), got {C[0, 0]!r}"
        )
    CC, CS, NC, MC, pos = _read_block(cof, raw, pos, "correction", allow_empty=True)
    if pos != len(raw):
        raise ModelFileError(f"{cof}, byte {pos}: {len(raw) - pos} bytes of extra data")
    schmidt = meta.get("Normalization", "full").lower() == "schmidt"
    if schmidt:
        C, S = _schmidt_to_full(C, S)
    C[0, 0] = 1.0
    if lmax is not None:
        lmax = int(lmax)
        if not 0 <= lmax <= N:
            raise InputError(f"lmax {lmax} is outside 0..{N}, the degree range of {path}")
        C, S = C[: lmax + 1, : lmax + 1].copy(), S[: lmax + 1, : lmax + 1].copy()
    header = {k: v for k, v in meta.items() if k != "_line"}
    header.update({"format": "egm", "N": N, "M": M})
    if CC is not None:
        if schmidt:
            CC, CS = _schmidt_to_full(CC, CS)
        header["correction"] = SHModel(
            f"{meta.get('Name', 'egm')} correction", 1.0, 1.0, CC, CS, NC, source=cof
        )
    return SHModel(
        name=meta.get("Name") or os.path.basename(path)[:-4],
        gm=float(meta["ModelMass"]),
        radius=float(meta["ModelRadius"]),
        C=np.ascontiguousarray(C),
        S=np.ascontiguousarray(S),
        max_degree=N,
        tide_system="unknown",
        epoch=None,
        source=path,
        header=header,
    )
