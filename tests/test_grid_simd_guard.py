"""The CPU SIMD snippets of the grid kernels never return zeros on a wrong build.

``column8_simd`` (:mod:`fieldmap.kernels.grid_simd`) and ``column8x_simd``
(:mod:`fieldmap.kernels.grid_xrange`) are clang vector code. A kernel that calls them is also
built for CUDA (the choice is the run-time ``simd`` argument), so their text holds a branch for
other compilers; that branch once returned a zero matrix, so a wrong flag or a non-clang
build gave zero gravity without a word. Now:

- the preprocessor branches of each snippet are evaluated here for NVRTC (CUDA), clang (the
  CPU) and another host compiler: CUDA reaches a trap (with a message) before any return, a
  non-clang host compiler an ``#error``, clang the SIMD code; no branch returns zeros;
- the host passes ``simd = 1`` on the CPU only (:func:`fieldmap.grids.synthesis.simd_flag`);
- the plain Warp recursion (``simd = 0``, what CUDA runs) matches the NumPy reference and
  the SIMD path, for both kernels;
- on a CUDA device (where present), a launch with ``simd = 1`` fails loudly.

(The CUDA builds themselves are compiled by ``test_cuda_build.py``.)
"""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
import warp as wp
from fieldmap.kernels import grid_simd, grid_xrange

from fieldmap.field import frames
from fieldmap.grids import synthesis as G
from fieldmap.models.registry import kaula_model

SNIPPETS = {
    "column8_simd": grid_simd._COLUMN8_SIMD,
    "column8x_simd": grid_xrange._COLUMN8X_SIMD,
}
ZERO_RETURN = "return wp::mat_t<16, 8, wp::float64>();"

#: Predefined macros of the compilers that may see the snippets.
COMPILERS = {
    "nvrtc": {"__CUDACC__", "__CUDA_ARCH__", "__CUDACC_RTC__"},
    "clang-cuda": {"__CUDACC__", "__CUDA_ARCH__", "__clang__"},
    "clang": {"__clang__"},  # Warp's CPU compiler
    "gcc": {"__GNUC__"},
    "msvc": {"_MSC_VER"},
}


def _active_lines(text: str, defined: set[str]) -> list[str]:
    """Return the lines a C preprocessor keeps (``#if/#elif/#else/#endif`` on ``defined``).

    Directives other than conditionals (``#error``, ``#pragma``, ``#define``) are kept as lines
    when their branch is active.
    """

    def value(expr: str) -> bool:
        py = re.sub(r"defined\s*\(\s*(\w+)\s*\)", lambda m: str(m.group(1) in defined), expr)
        py = py.replace("||", " or ").replace("&&", " and ").replace("!", " not ")
        assert re.fullmatch(r"[\sA-Za-z()]*", py), expr  # only defined(), !, ||, && here
        return bool(eval(py))  # noqa: S307 - a boolean expression of True/False built above

    out: list[str] = []
    stack: list[list[bool]] = []  # [this branch active, some branch taken]
    for line in text.splitlines():
        s = line.strip()
        live = all(active for active, _ in stack)
        if s.startswith("#if"):
            v = value(s[3:])
            stack.append([v, v])
        elif s.startswith("#elif"):
            top = stack[-1]
            v = not top[1] and value(s[5:])
            top[0], top[1] = v, top[1] or v
        elif s.startswith("#else"):
            top = stack[-1]
            top[0], top[1] = not top[1], True
        elif s.startswith("#endif"):
            stack.pop()
        elif live:
            out.append(s)
    assert not stack, "unbalanced #if/#endif"
    return out


def _first(lines: list[str], pattern: str) -> int:
    return next((i for i, ln in enumerate(lines) if re.search(pattern, ln)), len(lines))


@pytest.mark.parametrize("name", sorted(SNIPPETS))
@pytest.mark.parametrize("compiler", sorted(COMPILERS))
def test_no_branch_returns_zeros(name, compiler):
    lines = _active_lines(SNIPPETS[name], COMPILERS[compiler])
    trap, ret = _first(lines, r"\b__trap\(\)"), _first(lines, r"\breturn\b")
    error = _first(lines, r"^#error\b")
    if "__CUDA_ARCH__" in COMPILERS[compiler]:
        # a CUDA build compiles: a message, then the trap, before any return
        printf = _first(lines, r"\bprintf\(")
        assert printf < trap < ret < len(lines), lines
        assert name in lines[printf] and "simd = 0" in lines[printf]
    elif "__clang__" in COMPILERS[compiler]:
        assert error == trap == len(lines)  # the SIMD code itself
        assert any("ext_vector_type(8)" in ln for ln in lines)
        assert ZERO_RETURN not in lines
    else:
        assert error < len(lines) and error < ret, lines  # the build stops, with a message
        assert name in lines[error] and "clang" in lines[error]


def test_preprocessor_model_reads_directives():
    """The little preprocessor above keeps the right branch (so the test above can fail)."""
    text = "#if defined(A) || !defined(B)\na\n#elif defined(C)\nc\n#else\nz\n#endif\n"
    assert _active_lines(text, {"A"}) == ["a"]
    assert _active_lines(text, {"B", "C"}) == ["c"]
    assert _active_lines(text, {"B"}) == ["z"]


def test_host_asks_for_simd_on_the_cpu_only():
    assert G.simd_flag("cpu") == 1
    for device in ("cuda", "cuda:0", "cuda:1"):
        assert G.simd_flag(device) == 0


@pytest.mark.parametrize("legendre", ["scaled", "xrange"])
def test_plain_warp_path_matches_numpy_reference(monkeypatch, legendre):
    """``simd = 0`` (the path CUDA runs) against the NumPy SH reference and the SIMD path."""
    from fieldmap.reference import sh as ref

    model = kaula_model(60, seed=4)
    grid = G.make_grid(6.0, 84.0, heights_m=[10e3])
    la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    x, y, z = frames.geodetic_to_ecef(la, lo, 10e3)
    g = ref.gravitation_ecef(model, x.ravel(), y.ravel(), z.ravel()).reshape(*la.shape, 3)
    want = np.einsum("...ij,...j->...i", frames.C_e_to_enu(la, lo), g)
    simd = G.synthesize(model, grid, quantity="gravitation", device="cpu", legendre=legendre)[0]
    monkeypatch.setattr(G, "simd_flag", lambda device: 0)
    plain = G.synthesize(model, grid, quantity="gravitation", device="cpu", legendre=legendre)[0]
    scale = np.max(np.linalg.norm(want, axis=-1))
    assert np.max(np.abs(plain - want)) <= 1e-13 * scale
    assert np.max(np.abs(plain - simd)) <= 1e-14 * scale
    assert np.max(np.abs(plain)) > 0.9 * scale  # not zeros


_CUDA_TRAP = r"""
import numpy as np, warp as wp
from fieldmap import _warp
_warp.init()
from fieldmap.grids import synthesis as G
from fieldmap.models.registry import kaula_model
G.simd_flag = lambda device: 1  # the wrong flag for a CUDA device
grid = G.make_grid(30.0, 60.0, heights_m=[0.0])
try:
    out = G.synthesize(kaula_model(8, seed=1), grid, device="cuda:0")
    wp.synchronize()
except Exception as exc:
    print("RAISED", type(exc).__name__, exc)
else:
    print("RETURNED", float(np.max(np.abs(out))))
"""


@pytest.mark.skipif(not wp.is_cuda_available(), reason="no CUDA device")
def test_cuda_launch_with_simd_fails_loudly():
    """On a GPU, a kernel told to use the CPU snippet stops (message), never returns zeros."""
    proc = subprocess.run(
        [sys.executable, "-c", _CUDA_TRAP], capture_output=True, text=True, timeout=600
    )
    text = proc.stdout + proc.stderr
    assert "column8_simd (CPU SIMD) called on a CUDA device" in text, text
    assert "RETURNED" not in proc.stdout, text
