"""Where a product's blocks go: memory (shared or sent back), NetCDF-4, zarr; atomic stores.

- **zarr** (:class:`ZarrTarget`): chunked along latitude (``chunk_rows`` rows of all longitudes,
  Blosc/zstd), written by the workers in parallel. A block holds two runs of rows (south rows
  and their mirrors), so a chunk may be shared by two blocks; each worker writes the chunks its
  block covers whole and returns the rows of shared chunks (fewer than ``chunk_rows`` per run
  end); the client gathers them and writes each shared chunk once, whole, when all its rows
  are in. No chunk ever has two writers, without any lock, and nothing is read back.
- **NetCDF-4** (:class:`NetCDFWriter`): zlib + shuffle at :data:`fieldmap.products.io.COMPLEVEL`
  (as the in-memory products), chunks of ``chunk_rows`` rows; HDF5 has no parallel writer
  without MPI, so the client is the one writer and the workers send it their blocks (at most
  ``window`` in flight, which bounds the memory).
- **memory** (:func:`memory_target`): a product returned whole is written by workers of the
  client's machine into shared memory, else sent back to the client.
- :func:`atomic_store` gives the writers a hidden temporary name next to the final one, renamed
  only when the whole product, statistics included, is complete: a failed or interrupted run
  leaves no partial product under the final name. :func:`decimated` reads a stored product
  back at a resolution fit for figures.

:func:`fieldmap.products.engine.write_product` streams a product's blocks to these targets.
"""

from __future__ import annotations

import contextlib
import math
import os
import shutil
import tempfile
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import xarray as xr

from fieldmap.products.variables import DISTURBANCE_VARIABLES, Template

if TYPE_CHECKING:
    from fieldmap.grids.spec import GridSpec


class _Block(Protocol):
    """What a sink reads of a :class:`fieldmap.products.engine.Block` (the engine imports us)."""

    @property
    def layer(self) -> int: ...
    @property
    def rows(self) -> np.ndarray: ...
    def runs(self) -> list[tuple[int, int]]: ...


@contextlib.contextmanager
def atomic_store(final: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a hidden temporary path next to ``final``; on success rename it to ``final``.

    Works for a file or a folder (zarr). An existing product of the same name is replaced
    only once the new one is complete; on any error the temporary path is removed.
    """
    final = Path(final)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
    tmp.rmdir()  # the writer creates it (a file or a folder)
    try:
        yield tmp
        if final.is_dir() and not final.is_symlink():
            old = final.with_name(f".{final.name}.old-{os.getpid()}")
            os.replace(final, old)
            os.replace(tmp, final)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, final)
    except BaseException:
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                tmp.unlink()
        raise


def decimated(path: str | os.PathLike[str], fmt: str, max_nodes: int = 2_000_000) -> xr.Dataset:
    """Return a view of a stored product with at most about ``max_nodes`` nodes per map, in memory.

    Every ``s``-th row and column (``s = ceil(sqrt(nodes / max_nodes))``), read lazily from
    the store, so that figures of huge grids never hold the full-resolution arrays. ``s`` > 1
    is kept in ``attrs["figure_decimation"]`` (:func:`fieldmap.products.plots.node_step`);
    the other attributes are the product's.
    """
    opener = (
        (lambda p: xr.open_zarr(p, consolidated=True))
        if fmt == "zarr"
        else (lambda p: xr.open_dataset(p, engine="netcdf4"))
    )
    with opener(path) as ds:
        n = ds.sizes["latitude"] * ds.sizes["longitude"]
        s = max(1, math.ceil(math.sqrt(n / max_nodes)))
        view = ds.isel(latitude=slice(None, None, s), longitude=slice(None, None, s)).load()
    view.attrs = {k: v.item() if isinstance(v, np.generic) else v for k, v in view.attrs.items()}
    if s > 1:  # the product's attributes stay as stored (grid_step_deg: the product's step)
        view.attrs["figure_decimation"] = s
    return view


#: Bytes of one chunk of one variable (uncompressed), for the default ``chunk_rows``.
CHUNK_BYTES = 2**20


def chunk_rows(nlon: int) -> int:
    """Rows per chunk: about ``CHUNK_BYTES`` of float64 per chunk, 1..256 rows."""
    return int(min(256, max(1, CHUNK_BYTES // (8 * nlon))))


def _slabs(block: _Block, nrows_total: int, rows: int) -> list[tuple[int, int, bool]]:
    """Split each run of a block into chunk-aligned parts: (r0, r1, whole_chunks)."""
    out = []
    for r0, r1 in block.runs():
        a = -(-r0 // rows) * rows
        b = r1 if r1 == nrows_total else (r1 // rows) * rows
        if a >= b:
            out.append((r0, r1, False))
            continue
        if r0 < a:
            out.append((r0, a, False))
        out.append((a, b, True))
        if b < r1:
            out.append((b, r1, False))
    return out


def _put(arr: Any, layer: int, stacked: bool, r0: int, r1: int, values: np.ndarray) -> None:
    if stacked:
        arr[layer, r0:r1, :] = values
    else:
        arr[r0:r1, :] = values


def _put_block(arr: Any, block: _Block, stacked: bool, values: np.ndarray) -> None:
    """Write a block's rows (``values`` in the order of ``block.rows``), one slice per run."""
    pos = 0
    for r0, r1 in block.runs():
        _put(arr, block.layer, stacked, r0, r1, values[pos : pos + r1 - r0])
        pos += r1 - r0


class ZarrTarget:
    """A zarr store being filled block by block (picklable: workers open it by path).

    Workers write the chunks their block covers whole; the client (:meth:`sink`) gathers the
    rows of the chunks shared by two blocks and writes each such chunk once, whole, when all
    its rows have arrived (no read-modify-write, no chunk with two writers).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        nlat: int,
        rows: int,
        stacked: bool,
        names: Iterable[str] = DISTURBANCE_VARIABLES,
    ) -> None:
        self.path = str(path)
        self.nlat = nlat
        self.rows = rows
        self.stacked = stacked
        self.names = tuple(names)
        self._open: dict | None = None  # client side: arrays opened once
        self._pending: dict = {}  # client side: (layer, chunk) -> [rows filled, {name: rows}]

    def __getstate__(self) -> dict[str, Any]:
        # the workers get the path and the layout, never the client's buffers
        return {**self.__dict__, "_open": None, "_pending": {}}

    def _arrays(self) -> dict[str, Any]:
        import zarr

        # a cancelled task still running after a failed run must not recreate the removed store
        if not os.path.isfile(os.path.join(self.path, "zarr.json")):
            raise FileNotFoundError(f"zarr store {self.path} is gone (run aborted)")
        return {name: zarr.open_array(f"{self.path}/{name}", mode="r+") for name in self.names}

    def write_block(self, block: _Block, data: dict[str, Any]) -> dict[str, Any]:
        """Write the whole chunks of ``block``; return the rows of shared chunks."""
        arrays = self._arrays()
        pos = {int(r): k for k, r in enumerate(block.rows)}
        edges = []
        for r0, r1, whole in _slabs(block, self.nlat, self.rows):
            k0, k1 = pos[r0], pos[r1 - 1] + 1
            if whole:
                for name in self.names:
                    _put(arrays[name], block.layer, self.stacked, r0, r1, data[name][k0:k1])
            else:
                edges.append((r0, r1, {name: data[name][k0:k1] for name in self.names}))
        return {"edges": edges}

    def sink(self, block: _Block, data: dict[str, Any]) -> None:
        """Client side: collect the shared-chunk rows a worker returned; write full chunks."""
        if self._open is None:
            self._open = self._arrays()
        for r0, r1, values in data["edges"]:
            for c in range(r0 // self.rows, (r1 - 1) // self.rows + 1):
                c0, c1 = c * self.rows, min((c + 1) * self.rows, self.nlat)
                a, b = max(r0, c0), min(r1, c1)
                key = (block.layer, c)
                entry = self._pending.get(key)
                if entry is None:
                    nlon = values[self.names[0]].shape[1]
                    bufs = {name: np.empty((c1 - c0, nlon)) for name in self.names}
                    entry = self._pending[key] = [0, bufs]
                for name in self.names:
                    entry[1][name][a - c0 : b - c0] = values[name][a - r0 : b - r0]
                entry[0] += b - a
                if entry[0] == c1 - c0:  # every row of the chunk is here: one whole write
                    for name in self.names:
                        _put(self._open[name], block.layer, self.stacked, c0, c1, entry[1][name])
                    del self._pending[key]

    def check_complete(self) -> None:
        """Raise if a shared chunk is still waiting for rows (a bug, never silent)."""
        if self._pending:
            raise RuntimeError(f"zarr chunks left incomplete: {sorted(self._pending)[:4]}")


def create_zarr(
    path: str | os.PathLike[str], tmpl: Template, grid: GridSpec, block_rows: int | None = None
) -> ZarrTarget:
    """Create the zarr store (coordinates, attributes, empty chunked variables) at ``path``.

    ``block_rows``: the largest block of the plan. Chunks are then at most an eighth of it (a
    quarter of a run of rows), so that the workers write nearly every chunk themselves and the
    client only the few rows of chunks shared by two blocks.
    """
    import dask.array as da
    import zarr

    nh, nlat, nlon = grid.shape
    stacked = tmpl.stacked
    rows = chunk_rows(nlon)
    if block_rows is not None:  # ... but no chunk under 128 KiB: tiny files cost more
        rows = min(rows, max(block_rows // 8, -(-(2**17) // (8 * nlon)), 1))
    shape = (nh, nlat, nlon) if stacked else (nlat, nlon)
    chunks = (1, rows, nlon) if stacked else (rows, nlon)
    ds = tmpl.skeleton()
    var_attrs, dims = tmpl.variables, tmpl.dims
    for name in var_attrs:
        ds[name] = (dims, da.zeros(shape, chunks=chunks), var_attrs[name])
    encoding = {name: {"chunks": chunks} for name in var_attrs}
    ds.to_zarr(path, mode="w", compute=False, encoding=encoding, consolidated=False)
    del zarr
    return ZarrTarget(path, nlat, rows, stacked, tuple(var_attrs))


def finish_zarr(
    path: str | os.PathLike[str],
    attrs: dict[str, Any],
    extra_vars: dict[str, Any] | None = None,
    var_attrs: dict[str, Any] | None = None,
) -> None:
    """Add the statistics (attributes and small variables) and consolidate the metadata.

    ``var_attrs``: {variable: attributes} added to the variables (a quantity's statistics).
    """
    import zarr

    kept = dict(zarr.open_group(path, mode="r").attrs)  # appending variables resets them
    if extra_vars:
        xr.Dataset(extra_vars).to_zarr(path, mode="a", consolidated=False)
    g = zarr.open_group(path, mode="r+")
    g.attrs.update({**kept, **{k: _jsonable(v) for k, v in attrs.items()}})
    for name, va in (var_attrs or {}).items():
        if va:
            arr = zarr.open_array(f"{path}/{name}", mode="r+")
            arr.attrs.update({k: _jsonable(v) for k, v in va.items()})
    with warnings.catch_warnings():  # "not part of the Zarr 3 specification": xarray reads it
        warnings.simplefilter("ignore")
        zarr.consolidate_metadata(path)


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


class NetCDFWriter:
    """A NetCDF-4 file written block by block by one writer (the client)."""

    def __init__(self, path: str | os.PathLike[str], tmpl: Template, grid: GridSpec) -> None:
        import netCDF4

        nh, nlat, nlon = grid.shape
        ds = tmpl.skeleton()
        var_attrs, dims = tmpl.variables, tmpl.dims
        self.stacked = tmpl.stacked
        from fieldmap.products.io import COMPLEVEL, netcdf_encoding

        # the same encoding as the in-memory products: no _FillValue on coordinates (CF 1.8 §5)
        ds.to_netcdf(path, engine="netcdf4", mode="w", encoding=netcdf_encoding(ds))
        # the coordinates that are no dimension (height, height_km), as xarray names them in
        # the "coordinates" attribute of each variable they apply to (a subset of its dims)
        self.aux = {str(k): set(c.dims) for k, c in ds.coords.items() if k not in ds.dims}
        self.nc = netCDF4.Dataset(path, "a")
        rows = chunk_rows(nlon)
        chunks = (1, min(rows, nlat), nlon) if self.stacked else (min(rows, nlat), nlon)
        self.vars = {}
        for name in var_attrs:
            # netCDF4's stubs type complevel as a Literal[0..9] (COMPLEVEL is 1)
            v = self.nc.createVariable(  # type: ignore[call-overload]
                name,
                "f8",
                dims,
                zlib=True,
                shuffle=True,
                complevel=COMPLEVEL,
                chunksizes=chunks,
                fill_value=np.nan,
            )
            v.setncatts(var_attrs[name])
            self._coordinates(v, dims)
            self.vars[name] = v

    def sink(self, block: _Block, data: dict[str, Any]) -> None:
        """Write one block's variables at its rows."""
        for name, var in self.vars.items():
            _put_block(var, block, self.stacked, data[name])

    def finish(
        self, attrs: dict, extra_vars: dict | None = None, var_attrs: dict | None = None
    ) -> None:
        """Write the statistics (global, extra variables, per-variable attributes) and close."""
        for name, va in (var_attrs or {}).items():
            if va:
                self.vars[name].setncatts(va)
        for name, (dims, values, vattrs) in (extra_vars or {}).items():
            from fieldmap.products.io import COMPLEVEL

            dims = (dims,) if isinstance(dims, str) else dims
            packed = (
                {"zlib": True, "shuffle": True, "complevel": COMPLEVEL} if len(dims) > 1 else {}
            )
            # netCDF4's stubs type complevel as a Literal[0..9]: COMPLEVEL is 1. NaN fill, as
            # xarray writes float variables (the in-memory products' files)
            v = self.nc.createVariable(  # type: ignore[call-overload]
                name, "f8", dims, fill_value=np.nan, **packed
            )
            v[...] = values
            v.setncatts(vattrs)
            self._coordinates(v, dims)
        self.nc.setncatts(attrs)
        self.close()

    def _coordinates(self, var: Any, dims: Iterable[str]) -> None:
        """Set the ``coordinates`` attribute of ``var`` as xarray writes it (names sorted)."""
        names = sorted(k for k, d in self.aux.items() if d <= set(dims))
        if names:
            var.setncattr("coordinates", " ".join(names))

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self.nc is not None and self.nc.isopen():
            self.nc.close()


#: Folder of the shared-memory filesystem (Linux); absent elsewhere.
SHM_DIR = "/dev/shm"


def _probe_file(path: str, token: str) -> bool:
    try:
        with open(path) as f:
            return f.read() == token
    except OSError:
        return False


class SharedArrays:
    """The variables of an in-memory product in shared memory, written by workers of this host.

    When the workers run on the client's machine (a LocalCluster, or workers started on
    127.0.0.1), a map returned in memory need not travel back through the sockets: each
    variable is a ``.npy`` file in the shared-memory filesystem, every worker maps it and writes
    its block's rows in place (a block re-run after a worker died writes the same bits), and
    the client maps the files when the last block is in. Measured on the 0.1° map of
    ``benchmarks/bench_dask.py``: the transfer and the copy into place cost the client more than
    the blocks' computation. Used only when :meth:`create` finds room and every worker sees the
    folder (:meth:`visible_from`); otherwise the blocks come back through Dask.
    """

    def __init__(
        self, folder: str, names: Iterable[str], shape: tuple[int, ...], stacked: bool
    ) -> None:
        self.folder = folder
        self.names = tuple(names)
        self.shape = shape
        self.stacked = stacked

    @classmethod
    def create(
        cls, names: Iterable[str], grid: GridSpec, stacked: bool, shm_dir: str | None = None
    ) -> SharedArrays | None:
        """Create the files; None without a shared-memory folder or room for twice the product."""
        nh, nlat, nlon = grid.shape
        shape = (nh, nlat, nlon) if stacked else (nlat, nlon)
        nbytes = len(tuple(names)) * math.prod(shape) * 8
        shm_dir = shm_dir or SHM_DIR
        try:
            st = os.statvfs(shm_dir)
        except (OSError, AttributeError):
            return None
        if st.f_bavail * st.f_frsize < 2 * nbytes:
            return None
        folder = tempfile.mkdtemp(prefix="fieldmap-blocks-", dir=shm_dir)
        try:
            for name in names:
                np.lib.format.open_memmap(
                    os.path.join(folder, f"{name}.npy"), mode="w+", dtype=np.float64, shape=shape
                ).flush()
        except OSError:
            shutil.rmtree(folder, ignore_errors=True)
            return None
        return cls(folder, names, shape, stacked)

    def visible_from(self, client: Any) -> bool:
        """Tell whether every worker of ``client`` reads this folder (the same machine)."""
        token = os.urandom(8).hex()
        probe = os.path.join(self.folder, "probe")
        with open(probe, "w") as f:
            f.write(token)
        try:
            seen = client.run(_probe_file, probe, token)
        except Exception:  # a worker that cannot answer: use the sockets
            return False
        finally:
            os.unlink(probe)
        return bool(seen) and all(seen.values())

    def write_block(self, block: _Block, data: dict[str, Any]) -> dict[str, Any]:
        """Worker side: write the block's rows into the shared files; nothing travels back."""
        for name in self.names:
            mm = np.load(os.path.join(self.folder, f"{name}.npy"), mmap_mode="r+")
            _put_block(mm, block, self.stacked, data[name])
            del mm
        return {}

    def sink(self, block: _Block, data: dict[str, Any]) -> None:
        """Client side: nothing to do, the workers wrote the rows."""

    def arrays(self) -> dict:
        """Map the variables copy-on-write (writable, private; the files may then be removed)."""
        return {
            name: np.asarray(np.load(os.path.join(self.folder, f"{name}.npy"), mmap_mode="c"))
            for name in self.names
        }

    def remove(self) -> None:
        """Remove the files (mapped arrays stay valid)."""
        shutil.rmtree(self.folder, ignore_errors=True)


@contextlib.contextmanager
def memory_target(
    grid: GridSpec, stacked: bool, names: Iterable[str], client: Any
) -> Iterator[
    tuple[
        Callable[[_Block, dict[str, Any]], None],
        SharedArrays | None,
        Callable[[], dict[str, np.ndarray]],
    ]
]:
    """Yield ``(sink, store, arrays)`` for a product returned in memory.

    ``arrays()`` gives the variables once every block is in. Shared memory
    (:class:`SharedArrays`) when the workers of ``client`` are on this machine, else the
    blocks come back to :class:`MemorySink`. The shared files are removed in any case.
    """
    shared = SharedArrays.create(names, grid, stacked) if client is not None else None
    if shared is not None and not shared.visible_from(client):
        shared.remove()
        shared = None
    if shared is None:
        mem = MemorySink(grid, stacked, names)
        yield mem.sink, None, (lambda: mem.arrays)
        return
    try:
        yield shared.sink, shared, shared.arrays
    finally:
        shared.remove()


class MemorySink:
    """Assemble the blocks into in-memory arrays (the Python API's eager mode)."""

    def __init__(
        self, grid: GridSpec, stacked: bool, names: Iterable[str] = DISTURBANCE_VARIABLES
    ) -> None:
        nh, nlat, nlon = grid.shape
        self.shape = (nh, nlat, nlon) if stacked else (nlat, nlon)
        self.stacked = stacked
        self.names = tuple(names)
        self.arrays: dict = {}

    def sink(self, block: _Block, data: dict[str, Any]) -> None:
        """Copy one block's variables into place (a slice copy per run of rows).

        A block holding every row of a single-height product is taken as it is (its arrays
        become the product's, no copy): a small map is one block (``run_blocks``).
        """
        if not self.stacked and not self.arrays and block.rows.size == self.shape[0]:
            self.arrays = {name: data[name] for name in self.names}
            return
        for name in self.names:
            if name not in self.arrays:
                self.arrays[name] = np.empty(self.shape)
            _put_block(self.arrays[name], block, self.stacked, data[name])
