"""Block engine and Dask scale-out: same bits everywhere, faults, atomic outputs.

Small grids (degree <= 60, steps of 2-3 deg) so that each test takes seconds; the memory and
speed figures come from ``benchmarks/bench_dask.py``.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from fieldmap.errors import InputError
from fieldmap.products import variables as cf

distributed = pytest.importorskip("distributed")
pytest.importorskip("zarr")

from fieldmap import cluster  # noqa: E402
from fieldmap.products import engine, sinks  # noqa: E402
from fieldmap.products import statistics as blockstats  # noqa: E402
from fieldmap.products.maps import altitude_sweep, disturbance_map, truncation_map  # noqa: E402
from fieldmap.products.request import MapRequest  # noqa: E402
from fieldmap.products.statistics import map_statistics  # noqa: E402

KW = dict(lmax=40, step_deg=3.0)
ROWS = 8  # several blocks per height on these small grids
VARS = cf.DISTURBANCE_VARIABLES


def _blocks(**options):
    """Compute the product of the request of ``options`` on the engine."""
    return engine.compute(MapRequest.build(**options))


def _write(path, fmt, **options):
    """Stream the product of the request of ``options`` to ``path``."""
    return engine.write_product(MapRequest.build(**options), path, fmt)


@pytest.fixture(scope="module")
def client():
    with cluster.open_client(("local", 2)) as c:
        yield c


@pytest.fixture(scope="module")
def local_map():
    """Make the map here, blocks one after the other (the reference of the promises)."""
    return _blocks(heights_m=[20000.0], **KW, stacked=False, rows_per_block=ROWS)


def _same(a: xr.Dataset, b: xr.Dataset) -> None:
    for v in VARS:
        assert np.array_equal(a[v].values, b[v].values), v
    for k in a.attrs:
        if k != "history":
            assert np.array_equal(np.asarray(a.attrs[k]), np.asarray(b.attrs[k])), k


def test_plan_covers_every_row_once_with_its_mirror():
    grid = MapRequest.build(lmax=40, heights_m=[2e4, 5e4], step_deg=3.0, stacked=True).grid
    plan = engine.plan_blocks(grid, 40, ROWS)
    nlat = grid.lat.size
    for layer in range(2):
        rows = np.concatenate([b.rows for b in plan if b.layer == layer])
        assert np.array_equal(np.sort(rows), np.arange(nlat))
    for b in plan:
        assert b.rows.size <= ROWS
        lat = set(grid.lat[b.rows].tolist())
        assert all(-x in lat for x in lat)  # mirrored rows stay together (one recursion)
    assert [b.index for b in plan] == list(range(len(plan)))


def test_one_block_is_bitwise_the_in_memory_map():
    ref = disturbance_map(height_km=20, **KW)
    one = _blocks(heights_m=[20000.0], **KW, stacked=False, rows_per_block=10**6)
    for v in VARS:
        assert np.array_equal(ref[v].values, one[v].values), v


def test_block_statistics_match_map_statistics(local_map):
    """Partial sums combined: exact max, 1e-14 sums; percentiles within the histogram bin."""
    ref = map_statistics(local_map["modulus_mg"].values, local_map["latitude"].values)
    a = local_map.attrs
    assert a["max_mg"] == ref["max_mg"] and a["min_mg"] == ref["min_mg"]
    for k in ("mean_mg", "rms_mg"):
        assert a[k] == pytest.approx(ref[k], rel=1e-14, abs=0)
    for t, f in ref["area_fraction_above"].items():
        assert a[cf.fraction_attr(t)] == pytest.approx(f, rel=1e-14, abs=1e-16)
    for q in ("p50_mg", "p90_mg", "p99_mg"):
        assert abs(a[q] / ref[q] - 1) <= blockstats.PERCENTILE_RTOL
    assert blockstats.PERCENTILE_RTOL < 1.5e-4


def test_histogram_bins_from_the_float_bits():
    """Bins are monotone in the value, at most 2**-12 wide, and their centres within rtol."""
    rng = np.random.default_rng(3)
    lo, hi = blockstats.HIST_RANGE_MG
    x = np.concatenate(
        [
            10 ** rng.uniform(np.log10(lo), np.log10(hi), 100_000),
            2.0 ** np.arange(-40, 14),  # bin edges
            np.nextafter(2.0 ** np.arange(-39, 14), 0),  # just below them
        ]
    )
    x.sort()
    k = blockstats._hist_index(x)
    assert np.all(np.diff(k) >= 0) and k.min() >= 0 and k.max() < blockstats.HIST_BINS
    centres = np.array([blockstats._bin_centre(int(i)) for i in k])
    assert np.max(np.abs(centres / x - 1)) <= blockstats.PERCENTILE_RTOL
    # the edges: 0, below and above the range fall into the end bins
    assert list(blockstats._hist_index(np.array([0.0, lo / 3, hi * 3]))) == [
        0,
        0,
        blockstats.HIST_BINS - 1,
    ]


def test_workers_are_set_up_once(client):
    """Each worker: Warp threads from its share of the cores, glibc thresholds of a process."""

    def probe():
        cluster.worker_setup()
        return cluster._WORKER_READY, os.environ.get("FIELDMAP_THREADS")

    workers = list(client.scheduler_info(n_workers=-1)["workers"])
    out = [client.submit(probe, workers=[w], pure=False).result() for w in workers]
    assert len(out) == 2
    for ready, threads in out:
        assert ready and int(threads) >= 1
    cluster.worker_setup()  # not a worker: nothing changes here
    assert not cluster._WORKER_READY
    if "glibc" in (os.confstr("CS_GNU_LIBC_VERSION") or "").lower():
        assert cluster._glibc_thresholds(32 * 2**20)


def test_model_is_shipped_once_per_client(client):
    import dataclasses
    import gc

    from fieldmap.models.registry import load_model

    m1 = load_model("eigen-6s", lmax=20)
    m2 = dataclasses.replace(m1, name="copy")  # another object, alive only here
    f1 = cluster.scattered(client, m1)
    assert cluster.scattered(client, m1) is f1  # reused by the next product
    f2 = cluster.scattered(client, m2)
    assert f2.key != f1.key
    assert client.submit(lambda m: m.name, f2).result() == "copy"
    key = f2.key
    del m2, f2
    gc.collect()  # the model is gone: its copy on the cluster is released
    assert key not in {fut.key for _, fut in cluster._SCATTERED[client].values()}
    # the release is asynchronous: wait for it, bounded only so that a lost release cannot hang
    # the run (a guard, not a speed claim: any loaded machine releases well within it)
    deadline = time.monotonic() + 120
    while any(key in keys for keys in client.has_what().values()):
        assert time.monotonic() < deadline, "the model's copy stayed on the workers"
        time.sleep(0.1)
    assert any(f1.key in keys for keys in client.has_what().values())  # m1 is alive: kept


def test_local_cluster_is_bitwise_identical(client, local_map):
    dist = disturbance_map(height_km=20, **KW, client=client)  # default plan
    here = disturbance_map(height_km=20, **KW, scheduler="threads")
    _same(here, dist)
    on2 = _blocks(heights_m=[20000.0], **KW, stacked=False, rows_per_block=ROWS, client=client)
    _same(local_map, on2)


def test_in_memory_map_through_shared_memory_or_sockets(client, local_map, monkeypatch):
    """Workers of this host write the map into shared memory; elsewhere it comes back by Dask."""
    import glob

    shm = sinks.SHM_DIR
    before = set(glob.glob(os.path.join(shm, "fieldmap-blocks-*")))
    made = []
    create = sinks.SharedArrays.create.__func__

    def spy(cls, *a, **k):
        made.append(create(cls, *a, **k))
        return made[-1]

    monkeypatch.setattr(sinks.SharedArrays, "create", classmethod(spy))
    kw = dict(heights_m=[20000.0], **KW, stacked=False, rows_per_block=ROWS, client=client)
    shared = _blocks(**kw)
    _same(local_map, shared)
    assert os.path.isdir(shm) == (made[-1] is not None)  # shared memory used where there is one
    shared["east"].values[0, 0] = 1e9  # copy-on-write: the caller's own array
    monkeypatch.setattr(sinks, "SHM_DIR", "/nonexistent-shm")  # no shared memory: sockets
    sockets = _blocks(**kw)
    assert made[-1] is None
    _same(local_map, sockets)
    assert set(glob.glob(os.path.join(shm, "fieldmap-blocks-*"))) <= before  # nothing left


def test_shared_memory_probe(tmp_path):
    p = tmp_path / "probe"
    p.write_text("abc")
    assert sinks._probe_file(str(p), "abc")
    assert not sinks._probe_file(str(p), "abd")
    assert not sinks._probe_file(str(tmp_path / "missing"), "abc")


def test_stores_hold_the_same_bits(client, local_map, tmp_path):
    common = dict(heights_m=[20000.0], **KW, stacked=False, rows_per_block=ROWS)
    _write(tmp_path / "a.zarr", "zarr", **common, client=client)
    _write(tmp_path / "b.nc", "netcdf", **common, client=client)
    _write(tmp_path / "c.nc", "netcdf", **common)  # here, no cluster
    with (
        xr.open_zarr(tmp_path / "a.zarr") as z,
        xr.open_dataset(tmp_path / "b.nc") as n,
        xr.open_dataset(tmp_path / "c.nc") as c,
    ):
        for ds in (z, n, c):
            for v in VARS:
                assert np.array_equal(ds[v].values, local_map[v].values), v
            assert ds["modulus"].attrs["units"] == "mGal"
            assert float(ds["height"]) == 20000.0
            assert ds.attrs["max_mg"] == local_map.attrs["max_mg"]
            assert ds.attrs["p99_mg"] == local_map.attrs["p99_mg"]
        assert n["modulus"].encoding["zlib"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.zarr", "b.nc", "c.nc"]


def test_sweep_and_truncation_on_the_cluster(client):
    here = altitude_sweep(height_km=[20, 50], **KW, scheduler="threads")
    dist = altitude_sweep(height_km=[20, 50], **KW, client=client)
    for v in (*VARS, "max_mg", "mean_mg", "p99_mg", "area_fraction_above"):
        assert np.array_equal(here[v].values, dist[v].values), v
    ref = truncation_map(height_km=20, step_deg=3.0)
    tr = truncation_map(height_km=20, step_deg=3.0, client=client)
    for v in (*VARS, "max_mg"):
        assert np.array_equal(ref[v].values, tr[v].values), v


def test_streamed_sweep_file_header_is_the_in_memory_files(tmp_path):
    """The statistics variables of a streamed sweep carry the NaN fill xarray writes too."""
    import netCDF4

    from fieldmap.products.io import write_netcdf

    write_netcdf(altitude_sweep(height_km=[20, 50], **KW), tmp_path / "a.nc")
    _write(tmp_path / "b.nc", "netcdf", heights_m=[2e4, 5e4], **KW, stacked=True)
    with netCDF4.Dataset(tmp_path / "a.nc") as a, netCDF4.Dataset(tmp_path / "b.nc") as b:
        assert set(a.variables) == set(b.variables)
        for name in ("max_mg", "mean_mg", "p99_mg", "area_fraction_above", "modulus"):
            va, vb = a[name], b[name]
            assert va.ncattrs() and sorted(va.ncattrs()) == sorted(vb.ncattrs()), name
            assert np.isnan(va.getncattr("_FillValue")) and np.isnan(vb.getncattr("_FillValue"))


@pytest.mark.parametrize(("step", "rows"), [(2.5, 6), (3.0, 10), (7.0, 4), (1.5, 30)])
def test_zarr_shared_chunks_written_once_whole(tmp_path, step, rows, monkeypatch):
    """Odd grids and block sizes: chunks shared by two blocks, runs across two chunks."""
    monkeypatch.setattr(sinks, "CHUNK_BYTES", 8 * 360 * 3)  # small chunks: many shared
    kw = dict(lmax=10, step_deg=step)
    ref = _blocks(heights_m=[2e4], **kw, stacked=False, rows_per_block=rows)
    _write(tmp_path / "m.zarr", "zarr", heights_m=[2e4], **kw, stacked=False, rows_per_block=rows)
    with xr.open_zarr(tmp_path / "m.zarr") as z:
        for v in VARS:
            assert np.array_equal(z[v].values, ref[v].values), v


def test_lazy_dataset(client, local_map):
    lazy = disturbance_map(height_km=20, **KW, chunks=ROWS, client=client)
    assert lazy["modulus"].chunks is not None
    got = lazy.compute()
    for v in VARS:
        assert np.array_equal(got[v].values, local_map[v].values), v
    here = disturbance_map(height_km=20, **KW, chunks=ROWS)  # dask's own local scheduler
    assert np.array_equal(here["up"].values, local_map["up"].values)


def test_lazy_quantity_dataset(client):
    from fieldmap.products.maps import quantity_map

    ref = quantity_map("deflection", **KW, height_km=[20.0, 50.0])
    lazy = quantity_map("deflection", **KW, height_km=[20.0, 50.0], chunks=ROWS, client=client)
    assert lazy["xi"].chunks is not None and lazy["xi"].dims == ref["xi"].dims
    got = lazy.compute()
    for v in ("xi", "eta"):
        assert np.array_equal(got[v].values, ref[v].values), v
        assert got[v].attrs["units"] == "arcsec"
    geoid = quantity_map("geoid", **KW, chunks={"latitude": ROWS}).compute()
    assert np.array_equal(geoid["geoid"].values, quantity_map("geoid", **KW)["geoid"].values)


def test_worker_killed_mid_run_still_completes_identically(client):
    req = MapRequest.build(lmax=40, heights_m=[2e4], step_deg=3.0, rows_per_block=4, window=8)
    grid = req.grid
    with contextlib.nullcontext(client) as c:
        pids = list(c.run(os.getpid).values())
        mem = sinks.MemorySink(grid, False)
        killed = []

        def sink(block, data):
            if not killed:  # the other worker is busy with its block: kill it now
                os.kill(pids[-1], signal.SIGKILL)
                killed.append(pids[-1])
            mem.sink(block, data)

        stats = engine.run_blocks(req, client=c, sink=sink)
        assert killed
    ref = _blocks(heights_m=[20000.0], **KW, stacked=False, rows_per_block=4)
    for v in VARS:
        assert np.array_equal(mem.arrays[v], ref[v].values), v
    assert stats[0]["max_mg"] == ref.attrs["max_mg"]
    assert stats[0]["p50_mg"] == ref.attrs["p50_mg"]
    assert stats[0]["mean_mg"] == ref.attrs["mean_mg"]


def test_failed_run_leaves_nothing(tmp_path, monkeypatch):
    calls = []
    real = engine.compute_block

    def failing(job, model):
        calls.append(job.block.index)
        if len(calls) == 3:
            raise RuntimeError("disk on fire")
        return real(job, model)

    monkeypatch.setattr(engine, "compute_block", failing)
    for fmt, name in (("zarr", "m.zarr"), ("netcdf", "m.nc")):
        calls.clear()
        with pytest.raises(RuntimeError, match="disk on fire"):
            _write(tmp_path / name, fmt, heights_m=[2e4], **KW, stacked=False, rows_per_block=ROWS)
    assert list(tmp_path.iterdir()) == []


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize(
    ("quantity", "heights"),
    [("anomaly", 20.0), ("deflection", [20.0, 50.0]), ("geoid", 0.0), ("potential", 20.0)],
)
def test_quantity_maps_on_the_cluster(client, quantity, heights):
    """Values bitwise those of the in-memory map; statistics summed by blocks, same everywhere."""
    from fieldmap.products.maps import quantity_map

    ref = quantity_map(quantity, **KW, height_km=heights)
    dist = quantity_map(quantity, **KW, height_km=heights, client=client)
    hs = np.atleast_1d(heights) * 1e3
    here = _blocks(quantity=quantity, stacked=True, **KW, heights_m=hs, rows_per_block=ROWS)
    on2 = _blocks(
        quantity=quantity, stacked=True, **KW, heights_m=hs, rows_per_block=ROWS, client=client
    )
    assert set(dist.data_vars) == set(ref.data_vars) and set(dist.attrs) == set(ref.attrs)
    for v in ref.data_vars:
        assert np.array_equal(ref[v].values, here[v].values) or v.endswith(("_mean", "_rms")), v
        assert np.array_equal(here[v].values, on2[v].values), v  # statistics too
        assert np.array_equal(ref[v].values, dist[v].values) or v.endswith(("_mean", "_rms")), v
    for v in ref.data_vars:
        a, b = ref[v].attrs, on2[v].attrs
        assert a.keys() == b.keys(), v
        if "actual_range" in a:  # one height: the statistics are attributes
            assert np.array_equal(a["actual_range"], b["actual_range"])
            assert b["area_weighted_rms"] == pytest.approx(a["area_weighted_rms"], rel=1e-14)
            assert abs(b["area_weighted_mean"] - a["area_weighted_mean"]) <= (
                1e-14 * a["area_weighted_rms"]
            )
        if v.endswith(("_mean", "_rms")):
            rms = ref[v.rsplit("_", 1)[0] + "_rms"].values
            assert np.all(np.abs(on2[v].values - ref[v].values) <= 1e-14 * rms), v


def test_quantity_stores_hold_the_same_bits(client, tmp_path):
    from fieldmap.products.maps import quantity_map

    ref = quantity_map("deflection", **KW, height_km=[20.0, 50.0])
    common = dict(quantity="deflection", stacked=True, heights_m=[2e4, 5e4], rows_per_block=ROWS)
    _write(tmp_path / "a.zarr", "zarr", **KW, **common, client=client)
    _write(tmp_path / "b.nc", "netcdf", **KW, **common, client=client)
    with xr.open_zarr(tmp_path / "a.zarr") as z, xr.open_dataset(tmp_path / "b.nc") as n:
        for ds in (z, n):
            for v in ("xi", "eta", "xi_max", "eta_min"):
                assert np.array_equal(ds[v].values, ref[v].values), v
            assert ds["xi"].attrs["units"] == "arcsec"
            assert ds.attrs["quantity"] == "deflection"
            np.testing.assert_array_equal(z["xi_rms"].values, n["xi_rms"].values)
    with pytest.raises(InputError, match="quantity must be one of"):
        MapRequest.build(quantity="curvature", lmax=40, heights_m=[2e4])


def test_cli_truncation_on_local_cluster_equals_here(tmp_path):
    common = ["truncation", "--step-deg", "6", "--orders", "2,4", "--no-plots"]
    r1 = _fieldmap(*common, "--out", str(tmp_path / "here"))
    assert r1.returncode == 0, r1.stderr
    r2 = _fieldmap(*common, "--scheduler", "local:2", "--out", str(tmp_path / "l2"))
    assert r2.returncode == 0, r2.stderr
    table = [ln for ln in r1.stdout.splitlines() if not ln.startswith("written")]
    assert table == [ln for ln in r2.stdout.splitlines() if not ln.startswith("written")]
    (a,) = (tmp_path / "here").glob("*.nc")
    (b,) = (tmp_path / "l2").glob("*.nc")
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        for v in x.data_vars:
            assert np.array_equal(x[v].values, y[v].values), v
    out = tmp_path / "never"
    r3 = _fieldmap(*common, "--scheduler", f"tcp://127.0.0.1:{_free_port()}", "--out", str(out))
    assert r3.returncode == 2 and len(r3.stderr.strip().splitlines()) == 1, r3.stderr
    assert not out.exists()


def test_cli_block_engine_honours_the_model_file_options(tmp_path):
    """--gm/--radius (an NGA file) reach the block engine as they reach the in-memory path."""
    from fieldmap.models.nga import write_nga
    from fieldmap.models.registry import load_model

    path = tmp_path / "model_coefficients.txt"
    write_nga(path, load_model("eigen-6s", lmax=20))
    common = ["map", "--model", str(path), "--step-deg", "6", "--no-plots", "--no-cache"]
    opts = ["--gm", "3.986004418e14", "--radius", "6378137.0"]  # not the EGM2008 defaults
    r1 = _fieldmap(*common, *opts, "--out", str(tmp_path / "mem"))
    assert r1.returncode == 0, r1.stderr
    r2 = _fieldmap(*common, *opts, "--scheduler", "threads", "--out", str(tmp_path / "blk"))
    assert r2.returncode == 0, r2.stderr
    (a,) = (tmp_path / "mem").glob("*.nc")
    (b,) = (tmp_path / "blk").glob("*.nc")
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        assert x.attrs["model_radius"] == y.attrs["model_radius"] == 6378137.0
        assert x.attrs["model_gm"] == y.attrs["model_gm"] == 3.986004418e14
        # the block plan groups rows differently from the whole map: last-bit differences
        np.testing.assert_allclose(y["up"].values, x["up"].values, rtol=1e-13, atol=1e-12)


def test_cli_quantity_on_local_cluster_equals_in_memory(tmp_path):
    common = ["map", "--quantity", "anomaly", "--lmax", "30", "--step-deg", "4", "--no-plots"]
    r1 = _fieldmap(*common, "--out", str(tmp_path / "mem"))
    assert r1.returncode == 0, r1.stderr
    r2 = _fieldmap(*common, "--scheduler", "local:2", "--out", str(tmp_path / "l2"))
    assert r2.returncode == 0, r2.stderr
    assert "(block by block)" in r2.stdout
    (a,) = (tmp_path / "mem").glob("*.nc")
    (b,) = (tmp_path / "l2").glob("*.nc")
    assert a.name == b.name
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        assert np.array_equal(x["anomaly"].values, y["anomaly"].values)
        assert np.array_equal(
            x["anomaly"].attrs["actual_range"], y["anomaly"].attrs["actual_range"]
        )


def _fieldmap(*args, timeout=120):
    exe = Path(sys.executable).with_name("fieldmap")
    return subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=timeout)


def test_unreachable_scheduler_one_line_exit_2(tmp_path):
    out = tmp_path / "never"
    port = _free_port()
    r = _fieldmap(
        "map", "--lmax", "20", "--scheduler", f"tcp://127.0.0.1:{port}", "--out", str(out)
    )
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1
    assert "cannot reach the Dask scheduler" in r.stderr
    assert not out.exists()
    with pytest.raises(InputError, match="local:N"):
        cluster.parse_scheduler("local:0")


@pytest.mark.slow
def test_cli_cluster_started_from_the_shell_is_bitwise_identical(tmp_path):
    """``dask scheduler`` + two ``dask worker`` processes vs the blocks run here (CLI)."""
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "FIELDMAP_THREADS": "1"}
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "dask",
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--no-dashboard",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=env,
        )
    ]
    try:
        time.sleep(2)
        for _ in range(2):
            procs.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "dask",
                        "worker",
                        addr,
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--host",
                        "127.0.0.1",
                        "--no-dashboard",
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=env,
                )
            )
        with distributed.Client(addr, timeout=30) as c:
            c.wait_for_workers(2, timeout=60)
        common = [
            "map",
            "--lmax",
            "40",
            "--step-deg",
            "3",
            "--rows-per-block",
            str(ROWS),
            "--no-plots",
        ]
        r1 = _fieldmap(*common, "--scheduler", addr, "--out", str(tmp_path / "shell"))
        assert r1.returncode == 0, r1.stderr
        r2 = _fieldmap(*common, "--scheduler", "threads", "--out", str(tmp_path / "here"))
        assert r2.returncode == 0, r2.stderr
        r3 = _fieldmap(
            *common, "--scheduler", "local:2", "--format", "zarr", "--out", str(tmp_path / "local2")
        )
        assert r3.returncode == 0, r3.stderr
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
    (a,) = (tmp_path / "shell").glob("*.nc")
    (b,) = (tmp_path / "here").glob("*.nc")
    (z,) = (tmp_path / "local2").glob("*.zarr")
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y, xr.open_zarr(z) as w:
        for v in VARS:
            assert np.array_equal(x[v].values, y[v].values), v
            assert np.array_equal(w[v].values, y[v].values), v
        for k in ("max_mg", "mean_mg", "p50_mg", "p99_mg", "area_fraction_above_0p05_mg"):
            assert x.attrs[k] == y.attrs[k] == w.attrs[k], k


def test_propagator_groups_of_runs_on_the_cluster_equal_here(client):
    """The one propagator: runs in groups of two on Dask, two blocks, the local bits."""
    from fieldmap.nav import sensors
    from fieldmap.nav.mechanize import Baro, NavConfig
    from fieldmap.nav.propagator import Propagator
    from fieldmap.nav.sensors import load_imu

    _, spec = load_imu("tactical")
    n, ns, dt = 5, 40, 0.02
    kerr = sensors.draw(spec, n, seed=3).kernel_errors()
    rng = np.random.default_rng(0)
    dth = rng.normal(0.0, 1e-4, (1, 2 * ns, 3))
    dv = np.tile([0.0, 0.0, -9.8 * dt], (1, 2 * ns, 1)) + rng.normal(0.0, 1e-3, (1, 2 * ns, 3))
    start = {
        "llh": np.tile([0.8, 0.1, 1000.0], (n, 1)),
        "v": np.zeros((n, 3)),
        "q": np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
    }
    baro = Baro(None, 0.03, 3e-4, 1e-6, bias=rng.normal(0, 5, n), noise=0.5, gm_sigma=2.0,
                gm_tau=300.0)  # fmt: skip
    outs = []
    for c in (None, client):
        nav = NavConfig(["j2", "j4", "j4", "j6", "exact"], errors=kerr, baro=baro, output_every=10)
        p = Propagator("ned", start, dt, nav, device="cpu", client=c)
        p.runs_per_task = 2
        a = p.propagate(dth[:, :ns], dv[:, :ns], 0, np.full(ns, 1000.0))
        b = p.propagate(dth[:, ns:], dv[:, ns:], ns, np.full(ns, 1000.0))
        outs.append((a, b, p.get_state()))
    for x, y in zip(outs[0], outs[1]):
        for k in x:
            assert np.array_equal(x[k], y[k]), k


def test_navigation_monte_carlo_on_the_cluster(client):
    """Draws x models split into tasks: the single-launch result, bit for bit."""
    from fieldmap.nav import imu, paper, sensors, study

    sc = study.build_scenario(duration=20.0, sampling=imu.ImuSampling(100.0), truth_lmax=30)
    err = sensors.draw(sensors.TABLE4, 3, seed=7).repeat(2)
    grav = ["j4"] * 3 + ["sh18"] * 3
    ref = paper.propagate(sc, grav, errors=err)
    got = study.propagate(sc, grav, errors=err, client=client, runs_per_task=2)
    for k in ("t", "dP", "dV", "pos", "vel", "hor", "ver", "ned"):
        assert np.array_equal(ref[k], got[k]), k
    assert ref["diverged"] == got["diverged"]
    assert np.all(got["pos"][:, -1] > 0)


def test_navsim_study_on_the_cluster_equals_here(client):
    """``client=``: a Monte Carlo study's launches on Dask give the local numbers."""
    from fieldmap.nav import imu, paper, study

    sc = study.build_scenario(duration=20.0, sampling=imu.ImuSampling(100.0), truth_lmax=30)
    here = paper.table3(sc, draws=3, seed=5, nav="j4")
    there = paper.table3(sc, draws=3, seed=5, nav="j4", client=client)
    assert np.array_equal(here.pos, there.pos) and np.array_equal(here.vel, there.vel)
    assert here.rows == there.rows


def test_navsim_scheduler_bad_input(tmp_path, capsys):
    """Navsim --scheduler: an unreachable scheduler is one line, exit 2, nothing written."""
    from fieldmap import cli

    out = tmp_path / "out"
    rc = cli.main(
        ["navsim", "--study", "table3", "--duration", "20", "--rate", "100",
         "--draws", "2", "--scheduler", "tcp://127.0.0.1:9",
         "--out", str(out)]
    )  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "scheduler" in err[0], err
    assert not out.exists()


@pytest.mark.parametrize(
    ("frame", "aiding"), [("ned", "baro"), ("lci", "none")], ids=["ned-baro", "lci"]
)
def test_flight_study_on_the_cluster_equals_here(client, frame, aiding):
    """A flight study's runs on Dask, time block by time block: the local result, bit for bit.

    Three time blocks (the states, Gauss-Markov and baro states carried by the client), IMU
    errors with white noise and bias instability, three models x three draws in groups of two.
    """
    from fieldmap.nav import study
    from fieldmap.nav.sensors import load_imu
    from fieldmap.nav.trajectory import FlightTrajectory, route_flight

    ft = FlightTrajectory(route_flight("45,7,9000;45.2,7.3,9500", 200.0))
    name, imu = load_imu("tactical")
    kw = dict(
        imu=imu, imu_name=name, models=["j2", "j4"], draws=3, seed=11, rate_hz=50.0,
        truth_lmax=30, output_dt=4.0, duration=60.0, block_s=24.0, frame=frame,
        altitude_aiding=aiding,
    )  # fmt: skip
    here = study.run_flight(study.FlightStudy(ft, **kw), device="cpu")
    there = study.run_flight(study.FlightStudy(ft, **kw), device="cpu", client=client)
    for res in (there,):
        for k in ("t", "dpos", "dvel", "datt", "track"):
            assert np.array_equal(getattr(here, k), getattr(res, k)), k
        for m in here.dg:
            assert np.array_equal(here.dg[m], res.dg[m]), m
        assert res.labels == here.labels and res.diverged == here.diverged
    assert here.dpos.shape[0] == 9 and np.all(np.isfinite(here.dpos))
    assert np.any(here.dpos[:, -1] != 0)


def test_cli_flight_study_with_scheduler(tmp_path):
    """``navsim --route ... --scheduler local:2``: the numbers of the same run here."""
    common = [
        "navsim", "--route", "45,7,9000;45.2,7.3,9500", "--speed-mps", "200", "--duration",
        "40", "--rate", "50", "--lmax", "30", "--models", "j4", "--draws", "2", "--imu", "tactical",
    ]  # fmt: skip
    r1 = _fieldmap(*common, "--out", str(tmp_path / "here"))
    assert r1.returncode == 0, r1.stderr
    r2 = _fieldmap(*common, "--scheduler", "local:2", "--out", str(tmp_path / "l2"))
    assert r2.returncode == 0, r2.stderr
    (a,) = (tmp_path / "here").glob("*.nc")
    (b,) = (tmp_path / "l2").glob("*.nc")
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        for v in x.data_vars:
            assert np.array_equal(x[v].values, y[v].values), v
