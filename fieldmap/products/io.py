"""Atomic output: NetCDF, JSON and PNG files never appear half-written.

Each writer writes to a temporary file in the destination folder and renames it over the final
name with :func:`os.replace` (atomic on POSIX within one file system), so an interrupted run
leaves either the previous file or the new one, never a truncated file. Temporary files are
removed on any error, ``KeyboardInterrupt`` included (the CLI turns SIGTERM into one too; only a
SIGKILL can leave a hidden ``.NAME.*.tmp`` file, never a truncated ``NAME``).
:func:`output_batch` extends this to a set of files: none of them appears unless all of them
were written.

Output folders: a missing ``--out`` folder is created with its parents (like ``mkdir -p``), but
only after all input was validated; :func:`check_out_dir` checks beforehand, leaving nothing
behind, that it can be.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import signal
import tempfile
import threading
from collections.abc import Hashable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fieldmap.errors import InputError

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure


def prepare_out_dir(out: str | os.PathLike[str]) -> Path:
    """Create (if needed) and check the output folder; raise :class:`InputError` if unusable.

    Call this only after every other input has been validated, so that bad input writes nothing.
    """
    path = _folder(out)
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


def _folder(out: str | os.PathLike[str]) -> Path:
    if not str(out).strip():
        raise InputError("output folder name is empty")
    return Path(out).expanduser()


def check_out_dir(out: str | os.PathLike[str]) -> None:
    """Validate an output folder without leaving anything behind (raises :class:`InputError`).

    The folder must exist and be writable, or be creatable under an existing ancestor folder.
    Writability is probed by creating and removing a temporary file (``os.access`` is not
    enough: it says yes to root on read-only mounts and in ``/proc``). A missing folder is not
    created here; :func:`prepare_out_dir` creates it, with its parents, just before writing.
    """
    path = _folder(out).absolute()
    if path.exists():
        if not path.is_dir():
            raise InputError(f"output path {str(path)!r} exists and is not a folder")
        probe_dir = path
    else:
        probe_dir = path.parent
        while not probe_dir.exists() and probe_dir != probe_dir.parent:
            probe_dir = probe_dir.parent
        if not probe_dir.is_dir():
            raise InputError(
                f"cannot create output folder {str(path)!r}: {str(probe_dir)!r} is not a folder"
            )
    try:
        fd, probe = tempfile.mkstemp(prefix=".fieldmap-probe-", dir=probe_dir)
    except OSError as exc:
        if probe_dir == path:
            raise InputError(
                f"output folder {str(path)!r} is not writable ({exc.strerror})"
            ) from None
        raise InputError(
            f"cannot create output folder {str(path)!r}: {str(probe_dir)!r} is not writable "
            f"({exc.strerror})"
        ) from None
    os.close(fd)
    os.unlink(probe)
    if probe_dir != path:
        _probe_mkdir(path, probe_dir)


def _probe_mkdir(path: Path, parent: Path) -> None:
    """Check that the first missing folder of ``path`` can be made under ``parent``; undo it."""
    first = path
    while first.parent != parent:
        first = first.parent
    try:
        first.mkdir()
    except OSError as exc:
        raise InputError(f"cannot create output folder {str(path)!r}: {exc.strerror}") from None
    first.rmdir()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
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


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM until the block ends, then deliver them (main thread only).

    A ``KeyboardInterrupt`` raised inside the NetCDF/HDF5 writer can leave one of its locks
    held; the cleanup that follows then waits on that lock for ever (seen with a 185 MB file).
    Writing one file is short, so the signal waits for it; the caller's cleanup then removes
    the temporary file as usual.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    old = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        old[sig] = signal.signal(sig, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
        for signum in dict.fromkeys(caught):
            signal.raise_signal(signum)  # the restored handler runs now


#: zlib level of the NetCDF variables. On double-precision maps, whose low mantissa bytes are
#: noise, levels 4 and 6 save < 1 % more than level 1 and take 1.5x and 2.2x as long (measured
#: on the 0.25° global map: 30.9, 30.7, 30.6 MB in 2.0, 3.0, 4.4 s).
COMPLEVEL = 1
#: dtypes a NetCDF file may store its maps in (``dtype=`` of the writers).
DTYPES = ("float64", "float32")


def netcdf_encoding(ds: xr.Dataset, dtype: str = "float64") -> dict[Hashable, dict[str, Any]]:
    """Return the NetCDF-4 encoding of ``ds``: compressed maps, coordinates without fill values.

    Float variables of two or more dimensions are compressed with zlib (level
    :data:`COMPLEVEL`) after the HDF5 byte shuffle. Double-precision maps compress little
    (their low mantissa bytes are noise): the 0.5° global map (321 x 720, five variables) is
    7.9 MB instead of 9.3 MB.

    ``dtype="float32"`` stores the maps (variables on latitude and longitude) in single
    precision, half the size (3.8 MB for that map). Rounding to nearest float32 changes a
    value x by at most 2**-24 |x| = 6.0e-8 |x|: at most 1.6e-5 mGal on the 261.5 mGal maximum
    of the EIGEN-6S degree-240 disturbance at 20 km, and 5.8e-7 m s-2 (0.058 mGal) on the
    9.8 m s-2 components of :func:`fieldmap.products.maps.component_maps`; keep float64 for
    those. Coordinates and statistics stay float64.

    Coordinate variables carry no ``_FillValue``: CF coordinates have no missing values
    (CF 1.8 §5). Text variables (labels) are written as character arrays (CF 1.8 §2.2).
    """
    if dtype not in DTYPES:
        raise InputError(f"NetCDF dtype must be one of {', '.join(DTYPES)}, got {dtype!r}")
    enc: dict[Hashable, dict[str, Any]] = {name: {"_FillValue": None} for name in ds.coords}
    for name, var in ds.variables.items():
        if var.dtype.kind in "OUS":  # text as char arrays: CF has no variable-length strings
            enc.setdefault(name, {})["dtype"] = "S1"
    for name, arr in ds.data_vars.items():
        if arr.dtype.kind == "f" and arr.ndim >= 2:
            enc[name] = {"zlib": True, "shuffle": True, "complevel": COMPLEVEL}
            if dtype != "float64" and {"latitude", "longitude"} <= set(arr.dims):
                enc[name]["dtype"] = dtype
    return enc


#: errno values of a failed write to storage (full disk, quota, I/O, read-only, too big, denied)
_STORAGE_ERRNOS = frozenset(
    getattr(errno, n)
    for n in ("ENOSPC", "EDQUOT", "EIO", "EROFS", "EFBIG", "EACCES", "EPERM")
    if hasattr(errno, n)
)


@contextlib.contextmanager
def writing(path: str | os.PathLike[str]) -> Iterator[None]:
    """Let a failed write name the file (``path``, the final name), e.g. on a full disk.

    A storage error (:data:`_STORAGE_ERRNOS`) without a file name, or naming a hidden temporary
    path, gets ``path`` (the same exception, re-raised); the NetCDF library's own error on a
    failed write (``RuntimeError: NetCDF: HDF error``) becomes an ``OSError`` naming ``path``.
    Other errors (a lost worker, a timeout) pass as they are. The CLI prints either as one line,
    exit status 2.
    """
    try:
        yield
    except OSError as exc:
        name = exc.filename
        temporary = name is None or any(p.endswith(".tmp") for p in Path(str(name)).parts)
        if exc.errno in _STORAGE_ERRNOS and temporary:
            exc.filename = str(path)
        raise
    except RuntimeError as exc:
        if not str(exc).startswith("NetCDF"):
            raise
        raise OSError(errno.EIO, f"{exc} while writing (is the disk full?)", str(path)) from exc


def _netcdf_to(ds: xr.Dataset, tmp: str | os.PathLike[str], dtype: str = "float64") -> None:
    encoding = netcdf_encoding(ds, dtype)
    with signals_deferred():
        ds.to_netcdf(tmp, engine="netcdf4", encoding=encoding)


def _text_to(text: str, tmp: str | os.PathLike[str]) -> None:
    with open(tmp, "w", encoding="utf-8", newline="") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())


def _json_text(obj: Any) -> str:
    return json.dumps(obj, indent=2, sort_keys=False) + "\n"


#: Resolution of the PNG files (dots per inch); map figures grow with their grid instead.
PNG_DPI = 130


def _png_to(fig: Figure, tmp: str | os.PathLike[str], dpi: int) -> None:
    import matplotlib.pyplot as plt

    try:
        with signals_deferred():
            fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight")
    finally:
        plt.close(fig)


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike[str], dtype: str = "float64") -> Path:
    """Write an ``xarray.Dataset`` as compressed NetCDF-4 atomically; return the final path.

    ``dtype="float32"`` stores the maps in single precision (relative error ≤ 6e-8, see
    :func:`netcdf_encoding`).
    """
    path = Path(path)
    netcdf_encoding(ds, dtype)  # a bad dtype fails here, before any temporary file exists
    with writing(path), atomic_path(path) as tmp:
        _netcdf_to(ds, tmp, dtype)
    return path


def write_json(obj: Any, path: str | os.PathLike[str]) -> Path:
    """Write ``obj`` as indented JSON (UTF-8) atomically; return the final path."""
    path = Path(path)
    text = _json_text(obj)  # serialise first: a bad value leaves no temporary file behind
    with writing(path), atomic_path(path) as tmp:
        _text_to(text, tmp)
    return path


def write_png(fig: Figure, path: str | os.PathLike[str], dpi: int = PNG_DPI) -> Path:
    """Save a matplotlib figure as PNG atomically and close it; return the final path."""
    import matplotlib.pyplot as plt

    path = Path(path)
    try:
        with writing(path), atomic_path(path) as tmp:
            _png_to(fig, tmp, dpi)
    finally:
        plt.close(fig)
    return path


class OutputBatch:
    """Several output files that appear together, or not at all.

    Every file is first written to a temporary name in the destination folder; only when all
    of them are complete are they renamed (:func:`os.replace`) to their final names. Use it
    through :func:`output_batch`, which removes the temporary files on any error, including
    ``KeyboardInterrupt``. Use it when a product is a set of files (NetCDF + JSON + PNG) so
    that a failure while making the last figure does not leave the first files behind.
    """

    def __init__(self, folder: str | os.PathLike[str]) -> None:
        self.folder = Path(folder)
        self._pending: list[tuple[Path, Path]] = []

    def path(self, name: str) -> Path:
        """Return a new temporary path that becomes ``folder/name`` on commit."""
        final = self.folder / name
        fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".tmp", dir=self.folder)
        os.close(fd)
        self._pending.append((Path(tmp), final))
        return Path(tmp)

    def netcdf(self, ds: xr.Dataset, name: str, dtype: str = "float64") -> Path:
        """Add a compressed NetCDF-4 file of an ``xarray.Dataset`` (``dtype``: see below).

        ``dtype="float32"`` stores the maps in single precision (:func:`netcdf_encoding`).
        """
        netcdf_encoding(ds, dtype)  # a bad dtype fails before the temporary file exists
        with writing(self.folder / name):
            _netcdf_to(ds, self.path(name), dtype)
        return self.folder / name

    def json(self, obj: Any, name: str) -> Path:
        """Add an indented UTF-8 JSON file."""
        text = _json_text(obj)
        with writing(self.folder / name):
            _text_to(text, self.path(name))
        return self.folder / name

    def text(self, text: str, name: str) -> Path:
        """Add a UTF-8 text file (CSV, tables)."""
        with writing(self.folder / name):
            _text_to(text, self.path(name))
        return self.folder / name

    def png(self, fig: Figure, name: str, dpi: int = PNG_DPI) -> Path:
        """Add a PNG of a matplotlib figure (the figure is closed)."""
        with writing(self.folder / name):
            _png_to(fig, self.path(name), dpi)
        return self.folder / name

    def commit(self) -> list[Path]:
        """Rename every temporary file to its final name; return the final paths."""
        umask = os.umask(0)
        os.umask(umask)
        done = []
        for tmp, final in self._pending:
            os.chmod(tmp, 0o666 & ~umask)
            os.replace(tmp, final)
            done.append(final)
        self._pending = []
        return done

    def abort(self) -> None:
        """Remove every temporary file not yet renamed."""
        for tmp, _ in self._pending:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        self._pending = []


@contextlib.contextmanager
def output_batch(folder: str | os.PathLike[str]) -> Iterator[OutputBatch]:
    """Yield an :class:`OutputBatch` for ``folder`` (created if missing); commit on success.

    On any error the temporary files, and the folders this call created, are removed.

    Examples
    --------
    >>> with output_batch("outputs") as out:  # doctest: +SKIP
    ...     out.netcdf(ds, "map.nc")
    ...     out.json(summary, "map.json")
    """
    created = _missing_folders(folder)
    batch = OutputBatch(prepare_out_dir(folder))
    try:
        yield batch
        batch.commit()
    except BaseException:
        batch.abort()
        for path in created:  # deepest first; only folders this call made and left empty
            with contextlib.suppress(OSError):
                path.rmdir()
        raise


def _missing_folders(folder: str | os.PathLike[str]) -> list[Path]:
    """Return the folders of ``folder`` that do not exist yet, deepest first."""
    path = Path(folder).expanduser().absolute()
    missing = []
    while not path.exists() and path != path.parent:
        missing.append(path)
        path = path.parent
    return missing
