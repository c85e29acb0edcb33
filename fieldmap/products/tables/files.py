"""Compensation-table files: CF NetCDF, flat little-endian binary, its C header, the JSON report.

All four are written together through :func:`fieldmap.products.io.output_batch` (none appears
unless all were written). The binary file is the header struct of ``table.h`` (168 bytes,
:data:`fieldmap.products.tables.model.HEADER_FORMAT`) followed by the values, float32
little-endian, in C order ``[nh][nlat][nlon][3]`` (height slowest, the north, east, down
components of one node adjacent): a 4x4x4 stencil reads 16 runs of 4 nodes.

float32 and not float64: half the memory of a flight computer, and the rounding (2**-24 of a
value, < 2e-5 mGal on the 300 mGal largest disturbances) is 4 orders below any useful bound;
the verification interpolates the stored float32 values, so it is included in the reported
errors.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fieldmap.products.tables.model import (
    COMPONENTS,
    HEADER_BYTES,
    HEADER_FORMAT,
    MAGIC,
    VERSION,
    CompensationTable,
)

if TYPE_CHECKING:
    import xarray as xr

_LONG = {"dn": "northward", "de": "eastward", "dd": "downward"}


def header_bytes(tab: CompensationTable) -> bytes:
    """Return the 168-byte little-endian header of ``table.bin`` (struct ``fm_table_header``)."""
    nh, nlat, nlon = tab.shape
    m = tab.meta
    ver = m.get("verified", {})
    return struct.pack(
        HEADER_FORMAT,
        MAGIC,
        VERSION,
        HEADER_BYTES,
        nh,
        nlat,
        nlon,
        3,
        4,  # float32 values
        int(m.get("lmax", 0)),
        tab.lat0,
        tab.dlat,
        tab.lon0,
        tab.dlon,
        tab.h0,
        tab.dh,
        *tab.domain,
        float(m.get("max_error_mgal", 0.0)),
        float(ver.get("max_mgal", 0.0)),
        float(ver.get("rms_mgal", 0.0)),
        0.0,
    )


def binary_bytes(tab: CompensationTable) -> bytes:
    """Return the whole ``table.bin``: header then float32 values (little-endian, C order)."""
    return header_bytes(tab) + np.ascontiguousarray(tab.data, dtype="<f4").tobytes()


def to_dataset(tab: CompensationTable) -> xr.Dataset:
    """CF-1.8 ``xarray.Dataset`` of the table: dn, de, dd on (height, latitude, longitude)."""
    import xarray as xr

    from fieldmap import __version__

    m = tab.meta
    ver = m.get("verified", {})
    dims = ("height", "latitude", "longitude")
    data = {
        c: (
            dims,
            np.asarray(tab.data[..., k], dtype=np.float32),
            {
                "units": "mGal",
                "long_name": f"{_LONG[c]} component of the gravity disturbance "
                "(model gravity minus normal gravity), local geodetic NED frame",
                "comment": "1 mGal = 1e-5 m s-2",
            },
        )
        for k, c in enumerate(COMPONENTS)
    }
    coords = {
        "latitude": (
            "latitude",
            tab.latitudes,
            {
                "units": "degrees_north",
                "standard_name": "latitude",
                "long_name": "geodetic latitude",
            },
        ),
        "longitude": (
            "longitude",
            tab.longitudes,
            {"units": "degrees_east", "standard_name": "longitude", "long_name": "longitude"},
        ),
        "height": (
            "height",
            tab.heights,
            {
                "units": "m",
                "positive": "up",
                "long_name": f"height above the {m.get('ellipsoid', 'WGS84')} ellipsoid",
            },
        ),
    }
    w, e, s, n, h0, h1 = tab.domain
    attrs = {
        "Conventions": "CF-1.8",
        "title": "Gravity compensation table: disturbance north, east, down",
        "institution": f"fieldmap {__version__}",
        "source": f"{m.get('model', '?')} degree {m.get('lmax', '?')}",
        "model": str(m.get("model", "")),
        "lmax": int(m.get("lmax", 0)),
        "model_tide_system": str(m.get("tide_system", "unknown")),
        "normal_field": f"exact normal gravity of the {m.get('ellipsoid', 'WGS84')} level "
        "ellipsoid (closed form); disturbance = model gravitation - normal gravitation",
        "frame": "local geodetic north-east-down (NED) at each node; dd > 0 pulls downward",
        "interpolation": INTERPOLATION,
        "valid_domain": f"latitude {s!r}..{n!r} deg, longitude {w!r}..{e!r} deg, height "
        f"{h0!r}..{h1!r} m (one margin node on each horizontal side)",
        "lattice_lat0": tab.lat0,
        "lattice_dlat": tab.dlat,
        "lattice_lon0": tab.lon0,
        "lattice_dlon": tab.dlon,
        "lattice_h0_m": tab.h0,
        "lattice_dh_m": tab.dh,
        "max_error_mgal": float(m.get("max_error_mgal", 0.0)),
        "verified_max_error_mgal": float(ver.get("max_mgal", 0.0)),
        "verified_rms_error_mgal": float(ver.get("rms_mgal", 0.0)),
        "verification": json.dumps(ver.get("summary", {})),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


INTERPOLATION = (
    "tensor-product Catmull-Rom cubic (Keys cubic convolution, a=-0.5) in latitude, longitude "
    "and height; weights for fraction t: (-t^3+2t^2-t)/2, (3t^3-5t^2+2)/2, (-3t^3+4t^2+t)/2, "
    "(t^3-t^2)/2 of nodes i-1..i+2; one margin node on each horizontal side; in height the "
    "nodes beyond the ends are linear extrapolations 2p[0]-p[1] and 2p[n-1]-p[n-2]"
)

C_HEADER = r"""/* fieldmap gravity compensation table: layout of table.bin and its interpolation.
 *
 * table.bin = struct fm_table_header (168 bytes, little-endian, no padding) followed by
 * nh*nlat*nlon*3 values (float32 when value_bytes == 4, else float64), C order
 * [nh][nlat][nlon][3]: value(k, i, j, c) at ((k*nlat + i)*nlon + j)*3 + c,
 * c = 0 north, 1 east, 2 down: the gravity disturbance (model gravity minus exact normal
 * gravity of the WGS84 level ellipsoid) in mGal (1 mGal = 1e-5 m/s^2), local geodetic NED.
 * Node (k, i, j): height h0 + k*dh (m above the ellipsoid), geodetic latitude lat0 + i*dlat,
 * longitude lon0 + j*dlon (degrees; may exceed 180 across the antimeridian).
 * Valid domain: latitude lat0+dlat .. lat0+(nlat-2)*dlat, longitude lon0+dlon ..
 * lon0+(nlon-2)*dlon (one margin node on each horizontal side), height h0 .. h0+(nh-1)*dh.
 *
 * Interpolation: tensor-product Catmull-Rom (Keys a = -1/2) on the three axes; in height the
 * nodes beyond the ends are the linear extrapolations 2p[0]-p[1] and 2p[nh-1]-p[nh-2].
 * fm_table_interp() below is the reference; fieldmap's NumPy interpolator is the same scheme.
 */
#ifndef FIELDMAP_TABLE_H
#define FIELDMAP_TABLE_H
#include <math.h>
#include <stdint.h>

#define FM_TABLE_MAGIC "FMGTAB\0\1"
#define FM_TABLE_VERSION 1u

typedef struct {
    char magic[8];         /* "FMGTAB\0\1" */
    uint32_t version;      /* 1 */
    uint32_t header_bytes; /* 168: the values start here */
    uint32_t nh, nlat, nlon;
    uint32_t ncomp;        /* 3: north, east, down */
    uint32_t value_bytes;  /* 4: float32 */
    uint32_t lmax;         /* degree of the gravity model */
    double lat0, dlat;     /* degrees */
    double lon0, dlon;     /* degrees */
    double h0, dh;         /* m */
    double west, east, south, north, hmin, hmax; /* valid domain, degrees and m */
    double max_error_mgal;      /* requested bound */
    double verified_max_mgal;   /* largest error found on the check set */
    double verified_rms_mgal;
    double reserved;
} fm_table_header;

typedef char fm_table_header_size_check[(sizeof(fm_table_header) == 168) ? 1 : -1];

static inline void fm_cr_weights(double t, double w[4]) {
    double t2 = t * t, t3 = t2 * t;
    w[0] = 0.5 * (-t3 + 2.0 * t2 - t);
    w[1] = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0);
    w[2] = 0.5 * (-3.0 * t3 + 4.0 * t2 + t);
    w[3] = 0.5 * (t3 - t2);
}

static inline long fm_cell(double u, long lo, long hi, double *t) {
    long i = (long)floor(u);
    if (i < lo) i = lo;
    if (i > hi) i = hi;
    *t = u - (double)i;
    if (*t < 0.0) *t = 0.0;
    if (*t > 1.0) *t = 1.0;
    return i;
}

/* delta g north, east, down (mGal) at geodetic lat, lon (degrees), h (m above the ellipsoid).
 * data: the float32 values following the header. Returns 0, or -1 outside the valid domain. */
static inline int fm_table_interp(const fm_table_header *hd, const float *data, double lat,
                                  double lon, double h, double out[3]) {
    const double tol = 1e-9;
    double y = (lat - hd->lat0) / hd->dlat;
    double x = fmod(lon - hd->lon0, 360.0);
    if (x < 0.0) x += 360.0;
    x /= hd->dlon;
    double z = (h - hd->h0) / hd->dh;
    long nh = (long)hd->nh, nlat = (long)hd->nlat, nlon = (long)hd->nlon;
    if (!(y >= 1 - tol && y <= nlat - 2 + tol && x >= 1 - tol && x <= nlon - 2 + tol &&
          z >= -tol && z <= nh - 1 + tol))
        return -1;
    double ty, tx, tz, wy[4], wx[4], wz[4], lev[4][3];
    long i = fm_cell(y, 1, nlat - 3, &ty), j = fm_cell(x, 1, nlon - 3, &tx);
    long k = fm_cell(z, 0, nh - 2, &tz);
    fm_cr_weights(ty, wy);
    fm_cr_weights(tx, wx);
    fm_cr_weights(tz, wz);
    for (int a = 0; a < 4; a++) {
        long kk = k - 1 + a;
        if (kk < 0) kk = 0;
        if (kk > nh - 1) kk = nh - 1;
        for (int c = 0; c < 3; c++) lev[a][c] = 0.0;
        for (int b = 0; b < 4; b++)
            for (int d = 0; d < 4; d++) {
                const float *p = data + (((kk * nlat) + (i - 1 + b)) * nlon + (j - 1 + d)) * 3;
                double w = wy[b] * wx[d];
                for (int c = 0; c < 3; c++) lev[a][c] += w * (double)p[c];
            }
    }
    for (int c = 0; c < 3; c++) {
        if (k == 0) lev[0][c] = 2.0 * lev[1][c] - lev[2][c];
        if (k == nh - 2) lev[3][c] = 2.0 * lev[2][c] - lev[1][c];
        out[c] = wz[0] * lev[0][c] + wz[1] * lev[1][c] + wz[2] * lev[2][c] + wz[3] * lev[3][c];
    }
    return 0;
}
#endif /* FIELDMAP_TABLE_H */
"""


def write_table(
    tab: CompensationTable, report: dict[str, Any], out: str | os.PathLike[str]
) -> list[Path]:
    """Write table.nc, table.bin, table.h and table.json into ``out``, all or none.

    Returns the final paths.
    """
    from fieldmap.products.io import output_batch

    ds = to_dataset(tab)
    blob = binary_bytes(tab)
    with output_batch(out) as batch:
        batch.netcdf(ds, "table.nc", dtype="float32")
        with open(batch.path("table.bin"), "wb") as fh:
            fh.write(blob)
        batch.text(C_HEADER, "table.h")
        batch.json(report, "table.json")
    return [batch.folder / n for n in ("table.nc", "table.bin", "table.h", "table.json")]
