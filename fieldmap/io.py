"""Atomic output: NetCDF, JSON and PNG files never appear half-written.

Each writer writes to a temporary file in the destination folder and renames it over the final
name with :func:`os.replace` (atomic on POSIX within one file system), so an interrupted run
leaves either the previous file or the new one, never a truncated file. Temporary files are
removed on any error.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path

from .errors import InputError


def prepare_out_dir(out) -> Path:
    """Create (if needed) and check the output folder; raise :class:`InputError` if unusable.

    Call this only after every other input has been validated, so that bad input writes nothing.
    """
    path = Path(out).expanduser()
    if path.exists() and not path.is_dir():
        raise InputError(f"output path {str(path)!r} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder {str(path)!r}: {exc.strerror}") from None
    try:
        fd, probe = tempfile.mkstemp(prefix=".fieldmap-probe-", dir=path)
    except OSError as exc:
        raise InputError(f"output folder {str(path)!r} is not writable: {exc.strerror}") from None
    os.close(fd)
    os.unlink(probe)
    return path


def check_out_dir(out) -> None:
    """Validate an output folder without creating anything (raises :class:`InputError`).

    The folder must exist and be writable, or be creatable under a writable existing parent.
    """
    path = Path(out).expanduser().absolute()
    if path.exists():
        if not path.is_dir():
            raise InputError(f"output path {str(path)!r} exists and is not a folder")
        if not os.access(path, os.W_OK | os.X_OK):
            raise InputError(f"output folder {str(path)!r} is not writable")
        return
    parent = path.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(
            f"cannot create output folder {str(path)!r}: {str(parent)!r} is not writable"
        )


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path next to ``path``; on success rename it to ``path``."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_netcdf(ds, path) -> Path:
    """Write an ``xarray.Dataset`` as NetCDF-4 atomically; return the final path."""
    path = Path(path)
    encoding = {
        name: {"zlib": True, "complevel": 4}
        for name in ds.data_vars
        if ds[name].dtype.kind == "f" and ds[name].ndim >= 2
    }
    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)
    return path


def write_json(obj, path) -> Path:
    """Write ``obj`` as indented JSON (UTF-8) atomically; return the final path."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(obj, fh, indent=2, sort_keys=False)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
    return path


def write_png(fig, path, dpi: int = 130) -> Path:
    """Save a matplotlib figure as PNG atomically and close it; return the final path."""
    import matplotlib.pyplot as plt

    path = Path(path)
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight")
    finally:
        plt.close(fig)
    return path
