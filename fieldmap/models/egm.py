"""Reader of GeographicLib gravity models: ``NAME.egm`` (metadata) and ``NAME.egm.cof``.

One of the model formats of :func:`fieldmap.models.registry.load_model`, beside ICGEM
(:mod:`.icgem`) and NGA (:mod:`.nga`). The files are described in
:mod:`fieldmap.models.geographiclib` (which also writes them): ``NAME.egm`` is text, ``EGMF-1``
then ``key value`` lines (:func:`read_egm_metadata`); ``NAME.egm.cof`` is binary little-endian,
the 8-character ID, then int32 N, M and the fully normalised (or Schmidt semi-normalised)
coefficients column by column, then an optional correction series (:func:`read_egm`). A model
given by name is looked for as GeographicLib's ``Gravity -n NAME -d DIR`` does
(:func:`find_egm`, :func:`default_gravity_dirs`).
"""

from __future__ import annotations

import os
import re
import struct
from typing import Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel

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


def find_egm(name: str, model_dir: str | os.PathLike[str] | None = None) -> str | None:
    """Path of ``NAME.egm`` in ``model_dir`` (or, if None, in :func:`default_gravity_dirs`)."""
    if not re.fullmatch(r"[A-Za-z0-9_.+-]+", str(name)):
        return None
    dirs = [os.fspath(model_dir)] if model_dir is not None else default_gravity_dirs()
    for d in dirs:
        path = os.path.join(d, f"{name}.egm")
        if os.path.isfile(path):
            return path
    return None


def _number(path: str | os.PathLike[str], line: int, key: str, text: str) -> float:
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


def read_egm_metadata(path: str | os.PathLike[str]) -> dict[str, Any]:
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


def _read_block(
    cof: str | os.PathLike[str], raw: bytes, pos: int, what: str, allow_empty: bool
) -> tuple[np.ndarray | None, np.ndarray | None, int, int, int]:
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


def _schmidt_to_full(C: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Schmidt semi-normalised -> fully normalised: divide degree n by sqrt(2n+1)."""
    f = np.sqrt(2.0 * np.arange(C.shape[0]) + 1.0)[:, None]
    return C / f, S / f


def read_egm(path: str | os.PathLike[str], lmax: int | None = None) -> SHModel:
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
    assert C is not None and S is not None  # allow_empty=False
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
        assert CS is not None  # read together with CC
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
        nominal_degree=N,
        tide_system="unknown",
        epoch=None,
        source=path,
        header=header,
    )
