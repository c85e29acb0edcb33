"""The longitude FFTs of the grid synthesis: public APIs only, and the same bits however split.

:func:`fieldmap.grids.longitude._irfft` runs ``numpy.fft.irfft(..., out=)`` (NumPy >= 2.0) or
``scipy.fft.irfft`` and a copy; both are pocketfft's C++ code, as SciPy's private binding that
fieldmap once imported (``scipy.fft._pocketfft.pypocketfft``, which a SciPy release may
remove). ``benchmarks/bench_fft.py`` times them against it and against ducc0.
"""

from __future__ import annotations

import pathlib
import re

import fieldmap.kernels
import numpy as np
import pytest
import scipy.fft

import fieldmap
from fieldmap import _warp
from fieldmap.grids import longitude as L
from fieldmap.grids import synthesis as G
from fieldmap.models.registry import kaula_model


def test_no_private_scipy_module_is_imported():
    """No module of fieldmap imports a private SciPy module (``scipy.x._y``)."""
    root = pathlib.Path(fieldmap.__file__).parent
    kernels = pathlib.Path(fieldmap.kernels.__file__).parent
    private = re.compile(r"\bscipy(\.\w+)*\._\w+")
    found = [
        f"{path.name}:{n}"
        for path in [*root.rglob("*.py"), *kernels.rglob("*.py")]
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if private.search(line)
    ]
    assert found == []


@pytest.mark.parametrize("nper", [2, 7, 360, 720, 1001, 3600])
@pytest.mark.parametrize("public", [True, False])
def test_irfft_gives_scipy_bits_row_by_row(monkeypatch, nper, public):
    """Both paths give scipy.fft.irfft's bits, and each row the bits it has alone."""
    monkeypatch.setattr(L, "IRFFT_OUT", public and L.IRFFT_OUT)
    rng = np.random.default_rng(nper)
    nh = nper // 2 + 1
    H = rng.standard_normal((13, nh)) + 1j * rng.standard_normal((13, nh))
    want = scipy.fft.irfft(H, n=nper, axis=-1, norm="forward")
    got = np.empty((13, nper))
    L._irfft(H, nper, got)
    np.testing.assert_array_equal(got, want)
    one = np.empty((13, nper))
    for r in range(13):
        L._irfft(H[r : r + 1], nper, one[r : r + 1])
    np.testing.assert_array_equal(one, got)
    strided = np.ascontiguousarray(H.T).T  # the ready layout's series are strided
    L._irfft(strided, nper, one)
    np.testing.assert_array_equal(one, got)


@pytest.mark.parametrize("lon0", [0.0, -180.0, 2.5])  # ready layout, ready half turn, phased
def test_same_bits_with_any_threads_and_chunks(monkeypatch, lon0):
    """The grid's bits do not depend on the thread count nor on the FFT chunks."""
    model = kaula_model(40, seed=6)
    grid = G.make_grid(5.0, region=(lon0, lon0 + 355.0, -60.0, 60.0), heights_m=[0.0, 5e3])
    with _warp.threads(1):
        ref = G.synthesize(model, grid, device="cpu")
    with _warp.threads(2):
        two = G.synthesize(model, grid, device="cpu")
    monkeypatch.setattr(L, "CHUNK_MIN", 3)
    monkeypatch.setattr(L, "CHUNK_BYTES", 1)
    with _warp.threads(2):
        small = G.synthesize(model, grid, device="cpu")
    np.testing.assert_array_equal(two, ref)
    np.testing.assert_array_equal(small, ref)
