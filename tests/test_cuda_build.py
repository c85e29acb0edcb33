"""Every Warp kernel of ``fieldmap.kernels`` builds for CUDA, on any machine.

Warp's wheel ships NVRTC, so CUDA code can be generated and compiled ahead of time without a GPU
or a CUDA driver (``wp.compile_aot_module(module, arch=...)``). Each kernel module is compiled
once to a CUBIN for ``ARCH`` (sm_90: the H100/H200 this project runs on); a CUBIN goes through
ptxas, so register allocation and stack frames are checked as well as the C++ front end.

Device functions reach a CUDA build only through a kernel that calls them. Modules that hold
functions only (``frames``, ``navgravity``) are covered by the kernels that use
them, plus the small wrapper kernels below for functions no fieldmap kernel calls; a coverage test
fails on any ``@wp.func`` that none of these builds compiled.

The builds run once per session in a child interpreter that calls ``fieldmap._warp.init()`` before
importing any kernel module, so they use the options fieldmap runs with (no backward kernels: a
Warp module fixes its options when it is first imported). The CUBINs' ``.nv.info`` records give
registers and stack frame per kernel (printed with ``-s``); a last test shows that a kernel which
builds and runs on the CPU but not in CUDA fails here with NVRTC's message.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import pkgutil
import re
import shutil
import struct
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import NamedTuple

import pytest
import warp as wp

from fieldmap import _warp

# Before any kernel module is imported: a Warp module takes its options (here: no backward pass)
# from wp.config when its first kernel or function is defined.
_warp.init()

import fieldmap.kernels  # noqa: E402
from fieldmap.kernels import frames as klf  # noqa: E402
from fieldmap.kernels import navgravity as knav  # noqa: E402
from fieldmap.kernels import normal as knormal  # noqa: E402
from fieldmap.kernels import sh as ksh  # noqa: E402

#: CUDA compute capability the kernels are compiled for (H100 / H200).
ARCH = 90
#: Registers per thread block on every compute capability >= 5.0 (CUDA C++ Programming Guide,
#: "Technical Specifications per Compute Capability": 64 K 32-bit registers per block), and the
#: per-warp allocation unit (256 registers, same table / CUDA occupancy calculator).
REGS_PER_BLOCK = 65536
REG_ALLOC_UNIT = 256

KERNEL_MODULE_NAMES = sorted(m.name for m in pkgutil.iter_modules(fieldmap.kernels.__path__))


def _module(name: str):
    return importlib.import_module(f"fieldmap.kernels.{name}")


def _kernels_of(module) -> list:
    return [
        v
        for v in vars(module).values()
        if isinstance(v, wp.Kernel) and v.module.name == module.__name__
    ]


def _functions_of(module) -> list:
    return [
        v
        for v in vars(module).values()
        if isinstance(v, wp.Function) and v.module.name == module.__name__
    ]


# -------------------------------------------------------------------- wrapper kernels
# Functions that no fieldmap kernel calls (used from tests on the CPU, or kept for callers to
# come). Each result is stored so that ptxas sees the code, not only the front end.


@wp.kernel
def _launch_frames_wrapper(
    lp: klf.LaunchParams,
    t: wp.array(dtype=wp.float64),
    v: wp.array(dtype=wp.vec3d),
    m_out: wp.array(dtype=wp.mat33d),
    v_out: wp.array(dtype=wp.vec3d),
):
    i = wp.tid()
    m_out[4 * i + 0] = klf.C_t_to_a(t[i], t[i], t[i])
    m_out[4 * i + 1] = klf.C_l_to_t(t[i], t[i], t[i], lp.omega)
    m_out[4 * i + 2] = klf.C_e_to_a(lp, t[i])
    m_out[4 * i + 3] = klf.C_e_to_t(t[i], lp.omega)
    v_out[3 * i + 0] = klf.a_to_ecef(lp, v[i], t[i])
    v_out[3 * i + 1] = klf.ecef_to_a(lp, v[i], t[i])
    v_out[3 * i + 2] = klf.vector_e_to_a(lp, v[i], t[i])


@wp.kernel
def _navgravity_wrapper(
    kind: wp.array(dtype=int),
    p: wp.array(dtype=wp.vec3d),
    ell: knormal.NormalParams,
    model: ksh.SHKernelModel,
    tab: knav.TableKernel,
    g_out: wp.array(dtype=wp.vec3d),
):
    i = wp.tid()
    g_out[i] = knav.nav_gravity_ecef(kind[i], p[i], ell, model, tab)


# -------------------------------------------------------------------- building


class CudaBuild(NamedTuple):
    """Outcome of one ahead-of-time CUDA build of a Warp module."""

    name: str
    error: str | None  # exception text, None on success
    log: str  # what the compiler wrote (NVRTC writes its diagnostics to fd 2)
    source: str  # generated CUDA C++ (empty if code generation failed)
    binary: str | None  # path of the CUBIN

    def failure(self) -> str:
        """One message with the exception and the compiler log."""
        return f"{self.name} does not build for CUDA sm_{ARCH}: {self.error}\n{self.log.strip()}"


def build_cuda(module, out_dir: Path, arch: int = ARCH) -> CudaBuild:
    """Compile ``module`` to a CUBIN for ``arch`` in ``out_dir``, capturing compiler output."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    error, binary = None, None
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            binary = str(
                wp.compile_aot_module(module, arch=arch, module_dir=out_dir, use_ptx=False)[0]
            )
        except Exception as exc:  # report every kind of build failure with its message
            error = f"{type(exc).__name__}: {exc}"
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
        tmp.seek(0)
        log = tmp.read().decode("utf-8", "replace")
    # on failure Warp leaves its sources in a sibling build folder "<out_dir>_p<pid>_t<tid>"
    sources = sorted(out_dir.parent.glob(f"{out_dir.name}*/*.cu"))
    source = "\n".join(p.read_text() for p in sources)
    return CudaBuild(getattr(module, "__name__", str(module)), error, log, source, binary)


def _modules_with_kernels() -> list[str]:
    return [n for n in KERNEL_MODULE_NAMES if _kernels_of(_module(n))]


def _build_all(out_dir: Path) -> dict:
    """Build every kernel module and the wrappers here; record which device functions they hold.

    Runs in a fresh interpreter (see ``__main__`` below), where :func:`fieldmap._warp.init` comes
    before the first kernel import, as in the ``fieldmap`` CLI; function identifiers in the
    generated code are per process, so the coverage is worked out here too.
    """
    builds = {}
    for name in [*_modules_with_kernels(), "wrappers"]:
        module = sys.modules[__name__] if name == "wrappers" else _module(name)
        build = build_cuda(module, out_dir / name)
        builds[name] = build._asdict() | {
            "kernels": [k.key for k in _kernels_of(module)],
            "block_dim": wp.get_module(module.__name__).options["block_dim"],
        }
    source = "\n".join(b["source"] for b in builds.values())
    covered = {
        f"{name}.{f.key}": bool(re.search(rf"\b{re.escape(f.native_func)}\(", source))
        for name in KERNEL_MODULE_NAMES
        for f in _functions_of(_module(name))
    }
    return {"builds": builds, "functions": covered}


@pytest.fixture(scope="session")
def cuda_builds(tmp_path_factory):
    """All CUDA builds, made once per session in a child interpreter."""
    archs = wp.get_cuda_supported_archs()
    if not archs:
        pytest.skip(
            "this Warp build has no NVRTC (wp.get_cuda_supported_archs() is empty): "
            "CUDA code cannot be compiled on this machine"
        )
    if ARCH not in archs:
        pytest.skip(f"this Warp's NVRTC cannot target sm_{ARCH} (it offers {archs})")
    out = tmp_path_factory.mktemp("cuda_build")
    proc = subprocess.run(
        [sys.executable, __file__, str(out)], capture_output=True, text=True, timeout=600
    )
    assert proc.returncode == 0, f"CUDA build driver failed:\n{proc.stdout}\n{proc.stderr}"
    return json.loads((out / "builds.json").read_text())


# -------------------------------------------------------------------- cubin metadata


def cubin_resources(path: Path) -> dict[str, dict[str, int]]:
    """Per-kernel registers and stack use read from a CUBIN's ``.nv.info`` section.

    ``.nv.info`` holds records ``<format u8><attribute u8><u16>``; for format 4 (EIFMT_SVAL) the
    u16 is a payload size and the payload is ``<symbol index u32><value u32>``. Attributes read:
    0x2f EIATTR_REGCOUNT, 0x11 EIATTR_FRAME_SIZE, 0x12 EIATTR_MIN_STACK_SIZE (bytes).
    """
    data = path.read_bytes()
    assert data[:4] == b"\x7fELF" and data[4] == 2, f"{path} is not a 64-bit ELF"
    shoff = struct.unpack_from("<Q", data, 0x28)[0]
    shentsize, shnum, shstrndx = struct.unpack_from("<HHH", data, 0x3A)
    sections = [
        struct.unpack_from("<IIQQQQIIQQ", data, shoff + k * shentsize) for k in range(shnum)
    ]

    def body(sec):
        return data[sec[4] : sec[4] + sec[5]]

    def cstr(blob, off):
        return blob[off : blob.index(b"\0", off)].decode()

    shstr = body(sections[shstrndx])
    by_name = {cstr(shstr, s[0]): s for s in sections}
    symtab, strtab = by_name[".symtab"], body(sections[by_name[".symtab"][6]])
    syms = body(symtab)
    names = [cstr(strtab, struct.unpack_from("<I", syms, k)[0]) for k in range(0, len(syms), 24)]
    info = body(by_name[".nv.info"])
    keys = {0x2F: "registers", 0x11: "frame_bytes", 0x12: "stack_bytes"}
    out: dict[str, dict[str, int]] = {}
    pos = 0
    while pos + 4 <= len(info):
        fmt, attr, size = struct.unpack_from("<BBH", info, pos)
        pos += 4
        if fmt != 4:
            continue  # the u16 was the value itself
        if attr in keys:
            sym, value = struct.unpack_from("<II", info, pos)
            if names[sym].endswith("_cuda_kernel_forward"):
                out.setdefault(names[sym], {})[keys[attr]] = value
        pos += size
    return out


# -------------------------------------------------------------------- tests

BUILD_NAMES = [*_modules_with_kernels(), "wrappers"]


def _build(cuda_builds, name) -> tuple[CudaBuild, dict]:
    rec = cuda_builds["builds"][name]
    build = CudaBuild(**{k: rec[k] for k in CudaBuild._fields})
    assert build.error is None, build.failure()
    return build, rec


@pytest.mark.parametrize("name", BUILD_NAMES)
def test_module_builds_for_cuda(cuda_builds, name):
    """Each kernel module (and the wrapper kernels here) compiles to an sm_90 CUBIN."""
    build, rec = _build(cuda_builds, name)
    binary = Path(build.binary)
    assert binary.suffix == ".cubin" and binary.stat().st_size > 0
    assert rec["kernels"]
    for key in rec["kernels"]:
        assert re.search(rf"\b{re.escape(key)}_[0-9a-f]+_cuda_kernel_forward\(", build.source), (
            f"kernel {key} missing from the CUDA build of {name}"
        )


def test_every_device_function_reaches_a_cuda_build(cuda_builds):
    """Every ``@wp.func`` in fieldmap.kernels is compiled by one of the CUDA builds."""
    for name in BUILD_NAMES:
        _build(cuda_builds, name)
    functions = cuda_builds["functions"]
    assert len(functions) >= 20  # all modules were scanned
    missing = [f for f, ok in functions.items() if not ok]
    assert not missing, (
        f"device functions that no kernel compiles for CUDA (call them from a wrapper kernel in "
        f"{Path(__file__).name}): {', '.join(missing)}"
    )


def test_kernels_fit_a_default_block(cuda_builds):
    """Registers per thread x the module's block size stay within one block's register file.

    Warp launches 256-thread blocks unless a module sets ``block_dim``; a kernel that needs more
    registers than a block holds fails at launch ("too many resources requested for launch").
    Registers and stack frames are printed for the record (run with ``-s``).
    """
    rows = []
    for name in BUILD_NAMES:
        build, rec = _build(cuda_builds, name)
        block = rec["block_dim"]
        resources = cubin_resources(Path(build.binary))
        assert len(resources) == len(rec["kernels"]), (name, sorted(resources))
        for kernel, res in sorted(resources.items()):
            regs = res["registers"]
            warp_regs = -(-regs * 32 // REG_ALLOC_UNIT) * REG_ALLOC_UNIT
            rows.append(
                f"{name:10s} {kernel.split('_cuda_kernel')[0]:40s} regs {regs:3d}  "
                f"stack frame {res.get('frame_bytes', 0):4d} B"
            )
            assert 0 < regs <= 255
            assert warp_regs * (block // 32) <= REGS_PER_BLOCK, (
                f"{kernel}: {regs} registers x {block} threads exceed {REGS_PER_BLOCK} per block"
            )
    print(f"\nCUDA sm_{ARCH} resources per thread:\n" + "\n".join(rows))


_BROKEN_SOURCE = '''
import warp as wp


@wp.func_native("""
#if defined(__CUDA_ARCH__)
    return fieldmap_undeclared_on_cuda(x);
#else
    return x;
#endif
""")
def cpu_only(x: wp.float64) -> wp.float64: ...


@wp.kernel
def cpu_only_kernel(a: wp.array(dtype=wp.float64)):
    i = wp.tid()
    a[i] = cpu_only(a[i]) + wp.float64(1.0)
'''


def test_cuda_only_error_is_reported(cuda_builds, tmp_path):
    """A kernel that builds and runs on the CPU but not in CUDA is caught, with NVRTC's message.

    Shows that the harness can fail: the message names the offending identifier.
    """
    path = tmp_path / "fieldmap_cuda_build_selftest.py"
    path.write_text(_BROKEN_SOURCE)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module
    try:
        spec.loader.exec_module(module)
        a = wp.array([2.0], dtype=wp.float64, device="cpu")
        wp.launch(module.cpu_only_kernel, dim=1, inputs=[a], device="cpu")
        assert a.numpy()[0] == 3.0
        build = build_cuda(module, tmp_path / "out")
    finally:
        del sys.modules[path.stem]
        # leave no build of this throw-away module in the user's kernel cache
        for leftover in Path(wp.config.kernel_cache_dir).rglob(f"*{path.stem}*"):
            shutil.rmtree(leftover, ignore_errors=True) if leftover.is_dir() else leftover.unlink()
    assert build.error is not None
    assert "fieldmap_undeclared_on_cuda" in build.log and "error" in build.log, build.log


if __name__ == "__main__":  # the child interpreter of the ``cuda_builds`` fixture
    target = Path(sys.argv[1])
    (target / "builds.json").write_text(json.dumps(_build_all(target)))
