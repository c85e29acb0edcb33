"""Gravity compensation tables: the data class, the interpolator and the readers (pure NumPy).

A compensation table holds δg north, east, down (mGal, the local geodetic NED frame of an INS)
on a regular latitude-longitude-height lattice: the gravity disturbance δg = g_model − γ_exact
that an INS adds to its normal gravity. It is written by :mod:`fieldmap.products.tables.build`
and read here, by ``fieldmap point --model table:FILE``,
``fieldmap.disturbance(..., model="table:FILE")`` and (later) the navigation simulator.

The lattice
    Node (k, i, j) sits at height ``h0 + k*dh`` (m above the ellipsoid), geodetic latitude
    ``lat0 + i*dlat`` and longitude ``lon0 + j*dlon`` (degrees; the longitudes may run beyond
    180 for a table across the antimeridian). Horizontally the lattice carries one margin node
    on each side of the valid domain: the valid domain is ``lat0 + dlat .. lat0 + (nlat-2)*dlat``
    and ``lon0 + dlon .. lon0 + (nlon-2)*dlon``; vertically it is every node height
    ``h0 .. h0 + (nh-1)*dh`` (no margin: below the lowest height a margin node could lie too far
    below the ellipsoid for the model to be meant for it).

The interpolation scheme (the same in the C header written with every table)
    Tensor-product Catmull-Rom cubic (Keys cubic convolution, a = -1/2) on all three axes.
    On an axis with fractional index ``u = i + t`` (``i = floor(u)`` clamped to the valid cells,
    ``0 <= t <= 1``) the value is ``w0*p[i-1] + w1*p[i] + w2*p[i+1] + w3*p[i+2]`` with

        w0 = (-t³ + 2t² - t)/2,  w1 = (3t³ - 5t² + 2)/2,
        w2 = (-3t³ + 4t² + t)/2, w3 = (t³ - t²)/2.

    Horizontally ``p[i-1]`` and ``p[i+2]`` always exist (the margin). In height the nodes beyond
    the ends are the linear extrapolations ``p[-1] = 2 p[0] - p[1]`` and
    ``p[nh] = 2 p[nh-1] - p[nh-2]`` (a one-sided end slope); with two heights the scheme is
    linear in height. The interpolant is continuous with a continuous first derivative and
    reproduces quadratics (error O(spacing³)).

Points within ``EDGE_TOL`` of a grid cell (in units of the spacing) of the valid domain count
as inside; others are outside: an error, or NaN with ``outside="nan"``.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from fieldmap.errors import InputError

#: Prefix of a table model name: ``model="table:FILE"``.
#: Components of the tables, in storage order: north, east, down (mGal).
COMPONENTS = ("dn", "de", "dd")
#: Tolerance of the domain edges, in units of the node spacing (rounding of user coordinates).
EDGE_TOL = 1e-9
#: Binary layout: magic, version and the header struct (see :mod:`fieldmap.products.tables.files`).
MAGIC = b"FMGTAB\x00\x01"
VERSION = 1
HEADER_FORMAT = "<8s8I16d"  # 8 + 32 + 128 = 168 bytes
HEADER_BYTES = struct.calcsize(HEADER_FORMAT)
#: points interpolated per NumPy batch (bounds the 4x4x4x3 gather to ~100 MB)
_CHUNK = 65536


@dataclass
class CompensationTable:
    """A gravity compensation table: δg north, east, down on a lat-lon-height lattice.

    Attributes
    ----------
    lat0, dlat : float
        First node latitude and spacing (margin node included). Units: degrees.
    lon0, dlon : float
        First node longitude and spacing (margin node included). Units: degrees.
    h0, dh : float
        Lowest node height and spacing, above the ellipsoid. Units: m.
    data : numpy.ndarray
        Shape (nh, nlat, nlon, 3): δg north, east, down. float32 (as stored) or float64.
        Units: mGal.
    meta : dict
        Model, degree, ellipsoid, the error bound and the verified errors (free-form).
    """

    lat0: float
    dlat: float
    lon0: float
    dlon: float
    h0: float
    dh: float
    data: np.ndarray
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        d = np.asarray(self.data)
        if d.ndim != 4 or d.shape[3] != 3 or d.shape[1] < 4 or d.shape[2] < 4 or d.shape[0] < 2:
            raise InputError(
                f"a compensation table needs (nh >= 2, nlat >= 4, nlon >= 4, 3) values, got "
                f"shape {d.shape}"
            )
        vals = (self.lat0, self.dlat, self.lon0, self.dlon, self.h0, self.dh)
        if not all(np.isfinite(vals)) or min(self.dlat, self.dlon, self.dh) <= 0:
            raise InputError(f"compensation table: bad lattice origin or spacing {vals}")
        if not np.all(np.isfinite(d)):
            raise InputError("compensation table: values not finite")
        self.data = d

    @property
    def shape(self) -> tuple[int, int, int]:
        """(nh, nlat, nlon) of the lattice, margin nodes included."""
        nh, nlat, nlon, _ = self.data.shape
        return nh, nlat, nlon

    @property
    def latitudes(self) -> np.ndarray:
        """Node latitudes (margin included). Units: degrees."""
        return self.lat0 + self.dlat * np.arange(self.shape[1], dtype=np.float64)

    @property
    def longitudes(self) -> np.ndarray:
        """Node longitudes (margin included). Units: degrees."""
        return self.lon0 + self.dlon * np.arange(self.shape[2], dtype=np.float64)

    @property
    def heights(self) -> np.ndarray:
        """Node heights above the ellipsoid. Units: m."""
        return self.h0 + self.dh * np.arange(self.shape[0], dtype=np.float64)

    @property
    def domain(self) -> tuple[float, float, float, float, float, float]:
        """Valid domain (west, east, south, north, hmin, hmax). Units: degrees, m."""
        nh, nlat, nlon = self.shape
        return (
            self.lon0 + self.dlon,
            self.lon0 + (nlon - 2) * self.dlon,
            self.lat0 + self.dlat,
            self.lat0 + (nlat - 2) * self.dlat,
            self.h0,
            self.h0 + (nh - 1) * self.dh,
        )

    def contains(self, lat: ArrayLike, lon: ArrayLike, h: ArrayLike) -> np.ndarray:
        """Boolean mask of the points inside the valid domain."""
        return _coordinates(self, lat, lon, h)[3]

    def interpolate(
        self, lat: ArrayLike, lon: ArrayLike, h: ArrayLike, *, outside: str = "raise"
    ) -> np.ndarray:
        """δg north, east, down (mGal) at the points: :func:`interpolate`."""
        return interpolate(self, lat, lon, h, outside=outside)


def catmull_rom_weights(t: np.ndarray) -> np.ndarray:
    """Catmull-Rom (Keys a = -1/2) weights of nodes i-1, i, i+1, i+2; shape ``t.shape + (4,)``."""
    t = np.asarray(t, dtype=np.float64)
    t2, t3 = t * t, t * t * t
    return 0.5 * np.stack(
        [-t3 + 2.0 * t2 - t, 3.0 * t3 - 5.0 * t2 + 2.0, -3.0 * t3 + 4.0 * t2 + t, t3 - t2],
        axis=-1,
    )


def _cell(u: np.ndarray, lo: int, hi: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell index clamped to lo..hi and the fraction within it (0..1 inside the domain)."""
    i = np.clip(np.floor(u), lo, hi).astype(np.int64)
    return i, np.clip(u - i, 0.0, 1.0)


def _coordinates(
    tab: CompensationTable, lat: ArrayLike, lon: ArrayLike, h: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    from fieldmap import limits

    lat, lon, h = (np.ravel(v) for v in limits.check_geodetic(lat, lon, h))
    nh, nlat, nlon = tab.shape
    y = (lat - tab.lat0) / tab.dlat
    x = np.mod(lon - tab.lon0, 360.0) / tab.dlon
    z = (h - tab.h0) / tab.dh
    inside = (y >= 1 - EDGE_TOL) & (y <= nlat - 2 + EDGE_TOL)
    inside &= (x >= 1 - EDGE_TOL) & (x <= nlon - 2 + EDGE_TOL)
    inside &= (z >= -EDGE_TOL) & (z <= nh - 1 + EDGE_TOL)
    return y, x, z, inside


def interpolate(
    table: CompensationTable,
    lat: ArrayLike,
    lon: ArrayLike,
    h: ArrayLike,
    *,
    outside: str = "raise",
) -> np.ndarray:
    """Interpolate a compensation table at geodetic points (the scheme of the module docstring).

    Parameters
    ----------
    table : CompensationTable
    lat, lon, h : array_like
        Geodetic latitude and longitude (degrees), height above the ellipsoid (m); broadcast.
    outside : {"raise", "nan"}
        A point outside the valid domain raises :class:`InputError` (naming the first one), or
        gives NaN.

    Returns
    -------
    numpy.ndarray
        Shape (n, 3), n the number of points (flattened): δg north, east, down. Units: mGal.
    """
    if outside not in ("raise", "nan"):
        raise InputError(f"outside must be 'raise' or 'nan', got {outside!r}")
    y, x, z, inside = _coordinates(table, lat, lon, h)
    if outside == "raise":
        _raise_outside(table, lat, lon, h, inside)
    out = np.full((y.size, 3), np.nan)
    for s in range(0, y.size, _CHUNK):
        sel = slice(s, s + _CHUNK)
        ok = inside[sel]
        out[s : s + ok.size][ok] = _interp(table, y[sel][ok], x[sel][ok], z[sel][ok])
    return out


def check_inside(table: CompensationTable, lat: ArrayLike, lon: ArrayLike, h: ArrayLike) -> None:
    """Raise :class:`InputError` naming the first point outside the table's valid domain."""
    _raise_outside(table, lat, lon, h, table.contains(lat, lon, h))


def _raise_outside(
    table: CompensationTable, lat: ArrayLike, lon: ArrayLike, h: ArrayLike, inside: np.ndarray
) -> None:
    if not np.all(inside):
        k = int(np.flatnonzero(~inside)[0])
        raise InputError(outside_message(table, *_point(lat, lon, h, k)))


def _point(lat: ArrayLike, lon: ArrayLike, h: ArrayLike, k: int) -> tuple[float, float, float]:
    lat, lon, h = (np.ravel(v) for v in np.broadcast_arrays(lat, lon, h))
    return float(lat[k]), float(lon[k]), float(h[k])


def outside_message(table: CompensationTable, lat: float, lon: float, h: float) -> str:
    """One line: the point is outside the table's valid domain (which is named)."""
    w, e, s, n, h0, h1 = table.domain
    return (
        f"point {lat:g} {lon:g} {h:g} is outside the table (latitude {s:g}..{n:g}, "
        f"longitude {w:g}..{e:g}, height {h0:g}..{h1:g} m)"
    )


def _interp(tab: CompensationTable, y: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
    nh, nlat, nlon = tab.shape
    i, ty = _cell(y, 1, nlat - 3)
    j, tx = _cell(x, 1, nlon - 3)
    k, tz = _cell(z, 0, nh - 2)
    wy, wx, wz = catmull_rom_weights(ty), catmull_rom_weights(tx), catmull_rom_weights(tz)
    off = np.arange(-1, 3)
    rows = (i[:, None] + off)[:, :, None]
    cols = (j[:, None] + off)[:, None, :]

    def level(kk: np.ndarray) -> np.ndarray:  # horizontal bicubic at height node kk: (n, 3)
        block = tab.data[kk[:, None, None], rows, cols].astype(np.float64)  # (n, 4, 4, 3)
        return np.einsum("na,nb,nabc->nc", wy, wx, block)

    lo = level(np.maximum(k - 1, 0))
    v0, v1 = level(k), level(k + 1)
    hi = level(np.minimum(k + 2, nh - 1))
    lo = np.where((k == 0)[:, None], 2.0 * v0 - v1, lo)  # ghost node below the lowest height
    hi = np.where((k == nh - 2)[:, None], 2.0 * v1 - v0, hi)  # and above the highest
    return wz[:, 0, None] * lo + wz[:, 1, None] * v0 + wz[:, 2, None] * v1 + wz[:, 3, None] * hi


# --------------------------------------------------------------------------------- reading
def read_binary(path: str | os.PathLike[str]) -> CompensationTable:
    """Read a table written as ``table.bin`` (layout: the C header, ``table.h``)."""
    path = Path(path)
    raw = path.read_bytes()
    if len(raw) < HEADER_BYTES or raw[:8] != MAGIC:
        raise InputError(f"{path}: not a fieldmap compensation table (bad magic)")
    fields = struct.unpack(HEADER_FORMAT, raw[:HEADER_BYTES])
    _, version, hbytes, nh, nlat, nlon, ncomp, vbytes, lmax = fields[:9]
    lat0, dlat, lon0, dlon, h0, dh, *_rest = fields[9:]
    if version != VERSION or hbytes != HEADER_BYTES or ncomp != 3 or vbytes not in (4, 8):
        raise InputError(
            f"{path}: unsupported table (version {version}, header {hbytes} bytes, "
            f"{ncomp} components of {vbytes} bytes)"
        )
    count = nh * nlat * nlon * 3
    if len(raw) != hbytes + count * vbytes:
        raise InputError(
            f"{path}: {len(raw)} bytes, the header says {hbytes + count * vbytes} (truncated?)"
        )
    dtype = "<f4" if vbytes == 4 else "<f8"
    data = np.frombuffer(raw, dtype=dtype, count=count, offset=hbytes).reshape(nh, nlat, nlon, 3)
    meta = {"lmax": lmax, "max_error_mgal": fields[21], "verified_max_mgal": fields[22]}
    return CompensationTable(lat0, dlat, lon0, dlon, h0, dh, data, meta)


def read_netcdf(path: str | os.PathLike[str]) -> CompensationTable:
    """Read a table written as ``table.nc`` (the lattice from its ``lattice_*`` attributes)."""
    import xarray as xr

    path = Path(path)
    try:
        with xr.open_dataset(path) as ds:
            a = ds.attrs
            lattice = [float(a[f"lattice_{k}"]) for k in ("lat0", "dlat", "lon0", "dlon")]
            lattice += [float(a["lattice_h0_m"]), float(a["lattice_dh_m"])]
            data = np.stack(
                [ds[c].transpose("height", "latitude", "longitude").values for c in COMPONENTS],
                axis=-1,
            )
            meta = {k: a[k] for k in ("model", "lmax", "max_error_mgal") if k in a}
            meta["tide_system"] = str(a.get("model_tide_system", "unknown"))
    except (KeyError, ValueError, OSError) as exc:
        raise InputError(f"{path}: not a fieldmap compensation table ({exc})") from None
    lat0, dlat, lon0, dlon, h0, dh = lattice
    return CompensationTable(lat0, dlat, lon0, dlon, h0, dh, data, meta)


#: tables read by :func:`load_table`: (path, mtime, size) -> table (the last few)
_LOADED: dict = {}


def load_table(path: str | os.PathLike[str]) -> CompensationTable:
    """Read a table from its NetCDF or binary file (recognised by content).

    A file read before and unchanged since (same modification time and size) is not read again.
    """
    path = Path(str(path)).expanduser()
    if not path.is_file():
        raise InputError(f"{path}: compensation table not found")
    st = path.stat()
    key = (str(path.resolve()), st.st_mtime_ns, st.st_size)
    if key not in _LOADED:
        if len(_LOADED) >= 4:
            _LOADED.pop(next(iter(_LOADED)))
        _LOADED[key] = _read(path)
    return _LOADED[key]


def _read(path: Path) -> CompensationTable:
    try:
        return _read_file(path)
    except InputError as exc:  # the table's own checks (finite values...) name the file too
        if str(path) in str(exc):
            raise
        raise InputError(f"{path}: {exc}") from None


def _read_file(path: Path) -> CompensationTable:
    with open(path, "rb") as fh:
        head = fh.read(8)
    if head == MAGIC:
        return read_binary(path)
    if head[:4] in (b"\x89HDF", b"CDF\x01", b"CDF\x02"):
        return read_netcdf(path)
    raise InputError(f"{path}: not a compensation table (neither table.bin nor NetCDF)")
