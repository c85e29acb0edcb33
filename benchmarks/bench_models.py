"""Model loading and one-point answers at degree 2190: fieldmap vs GeographicLib's ``Gravity``.

Run: ``python benchmarks/bench_models.py [--lmax 2190] [--repeats 5] [--folder DIR]``

A synthetic Kaula-rule model of degree ``--lmax`` (the size of EGM2008/EIGEN-6C4) is written as
an ICGEM ``.gfc`` file and as GeographicLib's ``.egm``/``.egm.cof`` pair (kept in ``--folder``
between runs, so the write is paid once). Each measurement is a fresh process, as a user runs it
(medians of ``--repeats``; wall time and the CPU time of the child, which a busy shared machine
inflates less):

* fieldmap ``load_model`` of the ``.gfc`` with ``--no-cache`` (the text parser), then the first
  cached load (parse + write the cache), then later processes (verified memory-mapped cache);
* the same for the ``.egm`` pair;
* ``fieldmap point`` for one point (disturbance) with warm caches, on both files;
* GeographicLib ``Gravity -D`` for the same point on the same ``.egm`` model (it reads its binary
  ``.cof`` whole at every start: its load and its one-point answer are the same run).

Ratios fieldmap / Gravity are printed from the medians of this run.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

from fieldmap.models.geographiclib import gravity_tool, write_egm
from fieldmap.models.icgem import write_icgem
from fieldmap.models.registry import kaula_model

POINT = "30 105 20000\n"


def _run(cmd, env, stdin=""):
    """Wall and child-CPU seconds of one command."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, input=stdin, capture_output=True, text=True, env=env, timeout=900)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{cmd[:4]} failed: {proc.stderr.strip()[-300:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _median(cmd, env, repeats, stdin=""):
    runs = [_run(cmd, env, stdin) for _ in range(repeats)]
    return statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)


def _load_cmd(path, no_cache=False):
    code = (
        "import sys, time; t0 = time.perf_counter(); "
        "from fieldmap.models.registry import load_model; "
        f"m = load_model({path!r}, cache={not no_cache}); "
        "print(m.lmax, time.perf_counter() - t0)"
    )
    return [sys.executable, "-c", code]


def main(argv=None) -> int:
    """Run the benchmark and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lmax", type=int, default=2190)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--folder", default=os.path.join(tempfile.gettempdir(), "fieldmap-bench-2190"))
    args = ap.parse_args(argv)
    folder = args.folder
    os.makedirs(folder, exist_ok=True)
    gfc = os.path.join(folder, f"k{args.lmax}.gfc")
    name = f"k{args.lmax}"
    egm = os.path.join(folder, f"{name}.egm")
    if not (os.path.exists(gfc) and os.path.exists(egm + ".cof")):
        print(f"writing a Kaula model of degree {args.lmax} to {folder} ...", flush=True)
        model = kaula_model(args.lmax, seed=7)
        write_icgem(gfc, model)
        write_egm(model, folder, name=name)
    cache = tempfile.mkdtemp(prefix="fieldmap-bench-cache-")
    env = {**os.environ, "FIELDMAP_MODEL_CACHE": cache}
    rows = []

    def row(label, wall, cpu, peer=None):
        rows.append((label, wall, cpu, peer))
        print(f"  {label:<48s} {wall:8.3f} s wall {cpu:8.3f} s CPU", flush=True)

    print(f"degree {args.lmax}, {args.repeats} repeats, cache {cache}", flush=True)
    row(".gfc load, parser (--no-cache)", *_run(_load_cmd(gfc, no_cache=True), env))
    row(".gfc load, first cached (parse + store)", *_run(_load_cmd(gfc), env))
    gfc_load = _median(_load_cmd(gfc), env, args.repeats)
    row(".gfc load, later process (verified cache)", *gfc_load)
    row(".egm load, reader (--no-cache)", *_run(_load_cmd(egm, no_cache=True), env))
    _run(_load_cmd(egm), env)
    egm_load = _median(_load_cmd(egm), env, args.repeats)
    row(".egm load, later process (verified cache)", *egm_load)
    point = [sys.executable, "-m", "fieldmap", "point"]
    _run(point + ["--model", gfc], env, POINT)  # warm the kernel and table caches
    gfc_point = _median(point + ["--model", gfc], env, args.repeats, POINT)
    row("fieldmap point, 1 point, .gfc, warm caches", *gfc_point)
    egm_point = _median(point + ["--model", name, "--model-dir", folder], env, args.repeats, POINT)
    row("fieldmap point, 1 point, .egm, warm caches", *egm_point)
    exe = gravity_tool()
    if exe is None:
        print("GeographicLib's Gravity is not installed: no ratios")
        return 0
    grav = _median([exe, "-n", name, "-d", folder, "-D"], env, args.repeats, POINT)
    row("Gravity -D, 1 point (load + answer)", *grav)
    print("\nratios (fieldmap / Gravity, medians of this run):")
    for label, (w, c) in (
        ("model load (.gfc, cached) / Gravity one point", gfc_load),
        ("model load (.egm, cached) / Gravity one point", egm_load),
        ("fieldmap point (.gfc) / Gravity one point", gfc_point),
        ("fieldmap point (.egm) / Gravity one point", egm_point),
    ):
        print(f"  {label:<48s} {w / grav[0]:7.1f} x wall  {c / grav[1]:7.1f} x CPU")
    print(f"\nload average while measuring: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
