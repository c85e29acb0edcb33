"""Benchmark: the longitude FFTs of the grid synthesis, four backends.

``fieldmap.grids.longitude._irfft`` turns each row's half spectrum into the longitude sums
(an inverse real FFT of length L, ``norm="forward"``, written into a given array). Four ways:

- ``pocketfft``: SciPy's private binding ``scipy.fft._pocketfft.pypocketfft.c2r`` with ``out=``
  (what fieldmap used up to 0.2; a SciPy release may remove it);
- ``scipy``: the public ``scipy.fft.irfft`` (the same pocketfft code, same bits; no ``out=``:
  a fresh array and a copy);
- ``numpy``: the public ``numpy.fft.irfft(..., out=)`` of NumPy >= 2.0 (pocketfft's C++ code as
  SciPy's: the same bits, written into ``out``);
- ``ducc0``: ``ducc0.fft.c2r(..., out=)`` (the maintained successor of pocketfft, public,
  ``out=``; other code paths, so other last bits).

A row's bits must not depend on the other rows of the call (the threads and the chunks of
:func:`fieldmap.grids.longitude.longitude_sums` split the rows by the thread count): case 1
also says whether each backend gives the same bits for the rows transformed together and one
by one.

Prints, from one run: (1) the transforms alone at the sizes of 1°, 0.5° and 0.1° grids
(median CPU time of ``--repeat`` rounds, the backends in turn in each round), whether each backend
gives pocketfft's bits and its largest difference; (2) the whole ``synthesize`` of EIGEN-6S
degree 240 on the 0.5° grid 80S-80N at 20 km (321 x 720, disturbance), the longitude part
(``last_timings["longitude"]``) and the total, each backend in turn, with ratios to
pocketfft and whether the grid keeps pocketfft's bits.

Usage: ``python benchmarks/bench_fft.py [--repeat 9] [--threads 2]``.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from fieldmap import _warp
from fieldmap.grids import longitude
from fieldmap.grids import synthesis as G
from fieldmap.models.registry import load_model


def _pocketfft(H, n, out):
    from scipy.fft._pocketfft import pypocketfft

    pypocketfft.c2r(H, (H.ndim - 1,), n, False, 0, out, 1)


def _scipy(H, n, out):
    import scipy.fft

    out[...] = scipy.fft.irfft(H, n=n, axis=-1, norm="forward", workers=1)


def _numpy(H, n, out):
    np.fft.irfft(H, n=n, axis=-1, norm="forward", out=out)


def _ducc0(H, n, out):
    import ducc0

    ducc0.fft.c2r(H, axes=(H.ndim - 1,), lastsize=n, forward=False, inorm=0, out=out, nthreads=1)


def _available():
    backends = {"pocketfft": _pocketfft, "scipy": _scipy, "numpy": _numpy, "ducc0": _ducc0}
    out = {}
    for name, fn in backends.items():
        try:
            fn(np.zeros((1, 3), complex), 4, np.empty((1, 4)))
            out[name] = fn
        except (ImportError, AttributeError, TypeError) as exc:
            print(f"  {name}: not available ({type(exc).__name__}: {exc})")
    return out


def _rounds(fns: dict, repeat: int, inner: int = 1) -> dict[str, float]:
    """Median CPU seconds per call of each ``fns[name]()``, the functions in turn in each round.

    CPU time of this process (one thread here): what the other work of a shared machine
    changes least.
    """
    times: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(repeat):
        for name, fn in fns.items():
            t0 = time.process_time()
            for _ in range(inner):
                fn()
            times[name].append((time.process_time() - t0) / inner)
    return {k: statistics.median(v) for k, v in times.items()}


def transforms(backends: dict, repeat: int) -> None:
    """Case 1: the transforms alone, rows of the sizes the grids use."""
    rng = np.random.default_rng(0)
    print("\n1. Inverse real FFTs alone (one thread), median CPU time per call of a chunk of rows")
    print(
        f"{'L':>6} {'rows':>5} "
        + " ".join(f"{k:>16}" for k in backends)
        + "  bits vs pocketfft; rows one by one = together"
    )
    # the chunks of longitude._fft_rows (CHUNK_BYTES of half spectra), odd counts of rows
    for nper, rows in [(360, 181), (720, 91), (3600, 19)]:
        nh = nper // 2 + 1
        H = rng.standard_normal((rows, nh)) + 1j * rng.standard_normal((rows, nh))
        outs = {k: np.empty((rows, nper)) for k in backends}
        fns = {k: (lambda f=f, o=outs[k]: f(H, nper, o)) for k, f in backends.items()}
        med = _rounds(fns, repeat, inner=20)
        ref = outs.get("pocketfft")
        base = med.get("pocketfft")
        cells = [
            f"{med[k] * 1e6:8.1f} us" + (f" {med[k] / base:4.2f}x" if base else "")
            for k in backends
        ]
        same = []
        if ref is not None:
            for k in backends:
                diff = np.max(np.abs(outs[k] - ref)) / np.max(np.abs(ref))
                same.append(f"{k}: {'same' if np.array_equal(outs[k], ref) else f'{diff:.1e}'}")
        alone = {}
        for k, f in backends.items():
            one = np.empty((rows, nper))
            for r in range(rows):
                f(H[r : r + 1], nper, one[r : r + 1])
            alone[k] = "yes" if np.array_equal(one, outs[k]) else "NO"
        print(
            f"{nper:6d} {rows:5d} "
            + " ".join(cells)
            + "  "
            + ", ".join(same)
            + "; "
            + ", ".join(f"{k}: {v}" for k, v in alone.items())
        )


def synthesis(backends: dict, repeat: int) -> None:
    """Case 2: the whole grid synthesis with each backend."""
    model = load_model("eigen-6s")
    grid = G.make_grid(0.5, 80.0, heights_m=[20e3])
    print(
        f"\n2. synthesize(EIGEN-6S 240, 0.5 deg grid {grid.lat.size} x {grid.lon.size}, "
        f"20 km, disturbance), {_warp.cpu_workers()} threads; median of {repeat} rounds"
    )
    saved = longitude._irfft
    results, lon_t, tot_t = {}, {k: [] for k in backends}, {k: [] for k in backends}
    try:
        G.synthesize(model, grid, quantity="disturbance", device="cpu")  # compile, warm up
        for _ in range(repeat):
            for name, fn in backends.items():
                longitude._irfft = fn
                t0 = time.perf_counter()
                results[name] = G.synthesize(model, grid, quantity="disturbance", device="cpu")
                tot_t[name].append(time.perf_counter() - t0)
                lon_t[name].append(G.last_timings["longitude"])
    finally:
        longitude._irfft = saved
    ref = results.get("pocketfft")
    lon0 = statistics.median(lon_t["pocketfft"]) if ref is not None else None
    tot0 = statistics.median(tot_t["pocketfft"]) if ref is not None else None
    for name in backends:
        lon, tot = statistics.median(lon_t[name]), statistics.median(tot_t[name])
        line = f"  {name:10s} longitude {lon * 1e3:7.1f} ms   total {tot * 1e3:7.1f} ms"
        if lon0:
            line += f"   ratios {lon / lon0:4.2f}x, {tot / tot0:4.2f}x"
            same = np.array_equal(results[name], ref)
            diff = np.max(np.abs(results[name] - ref))
            line += "   bits: " + ("same" if same else f"differ (max {diff:.1e} m/s2)")
        print(line)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    _warp.init()
    backends = _available()
    transforms(backends, args.repeat)
    with _warp.threads(args.threads):
        synthesis(backends, args.repeat)


if __name__ == "__main__":
    main()
