"""Record the numbers of the code before the regrouping on this machine's CPU kind.

``reference.npz`` was recorded on one CPU kind; another kind (another vector width, FMA, NumPy
loop) may round the last bit of the same code differently, so the bitwise comparison there needs
that kind's own numbers of the *same old code*. Usage, from the repository root::

    git worktree add --detach /tmp/before 50b20a48d78ae8f23f49b8e0af933d60a2607cd4
    python tests/data/same_bits/record_kind.py /tmp/before

The old checkout's ``fieldmap/`` (and ``kernels/`` as ``fieldmap.kernels``) is copied into a
temporary folder and put first on ``PYTHONPATH``; the cases of ``tests/same_bits_cases.py`` run
on it in a fresh interpreter (the options the old command line spelled differently are given
its spelling, :data:`OLD_SPELLING`). Written: ``reference_kind_<cpu kind>.npz`` with the arrays
that differ from ``reference.npz`` (the others are equal on this kind too), and a ``.json`` with
the machine, the old commit and the cases that differ.
"""

import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import numpy as np

HERE = pathlib.Path(__file__).parent
TESTS = HERE.parents[1]
#: option spellings of the command line on the recorded commit
OLD_SPELLING = {"--height-km": "--heights-km"}

_RUN = """
import pathlib, sys, tempfile
import numpy as np
sys.path.insert(0, {tests!r})
import fieldmap
import same_bits_cases as sbc
assert fieldmap.__file__.startswith({tree!r}), fieldmap.__file__
sbc.CASES["table"] = [{spelling!r}.get(a, a) for a in sbc.CASES["table"]]
arrays = {{}}
with tempfile.TemporaryDirectory() as tmp:
    for name in sbc.CASES:
        for key, values in sbc.run_case(name, pathlib.Path(tmp) / name).items():
            arrays[f"{{name}}/{{key}}"] = values
np.savez_compressed({out!r}, **arrays)
"""


def main(before: pathlib.Path) -> None:
    sys.path.insert(0, str(TESTS))
    from same_bits_cases import machine

    commit = subprocess.run(
        ["git", "-C", str(before), "rev-parse", "HEAD"], capture_output=True, text=True, check=True
    ).stdout.strip()
    with tempfile.TemporaryDirectory() as tmp:
        tree = pathlib.Path(tmp) / "tree"
        shutil.copytree(before / "fieldmap", tree / "fieldmap")
        shutil.copytree(before / "kernels", tree / "fieldmap" / "kernels")
        out = pathlib.Path(tmp) / "numbers.npz"
        code = _RUN.format(tests=str(TESTS), tree=str(tree), spelling=OLD_SPELLING, out=str(out))
        env = {**os.environ, "PYTHONPATH": str(tree)}
        subprocess.run([sys.executable, "-c", code], cwd=tmp, env=env, check=True)
        with np.load(out) as z:
            numbers = {k: z[k] for k in z.files}
    with np.load(HERE / "reference.npz") as z:
        primary = {k: z[k] for k in z.files}
    differ = {
        k: v
        for k, v in numbers.items()
        if k in primary and not np.array_equal(v, primary[k], equal_nan=True)
    }
    kind = machine()
    tag = "".join(c if c.isalnum() else "-" for c in kind["cpu_kind"]).strip("-")
    np.savez_compressed(HERE / f"reference_kind_{tag}.npz", **differ)
    meta = {
        "commit": commit,
        "machine": kind,
        "cases_that_differ": sorted({k.split("/", 1)[0] for k in differ}),
        "arrays": len(differ),
    }
    (HERE / f"reference_kind_{tag}.json").write_text(json.dumps(meta, indent=1) + "\n")
    print(f"reference_kind_{tag}: {len(differ)} arrays differ in {meta['cases_that_differ']}")


if __name__ == "__main__":
    main(pathlib.Path(sys.argv[1]).resolve())
