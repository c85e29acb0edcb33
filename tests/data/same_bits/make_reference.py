"""Record the numbers of tests/same_bits_cases.py (run once, on the commit before a regrouping).

Usage: ``python tests/data/same_bits/make_reference.py`` from the repository root. Writes
``reference.npz`` (every array) and ``reference.json`` (commit, machine, versions).
"""

import json
import pathlib
import platform
import subprocess
import sys
import tempfile

import numpy as np

HERE = pathlib.Path(__file__).parent
sys.path.insert(0, str(HERE.parents[1]))

from same_bits_cases import CASES, machine, run_case  # noqa: E402

arrays = {}
with tempfile.TemporaryDirectory() as tmp:
    for name in CASES:
        for key, values in run_case(name, pathlib.Path(tmp) / name).items():
            arrays[f"{name}/{key}"] = values
        print(name, "done", flush=True)
np.savez_compressed(HERE / "reference.npz", **arrays)
commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True).stdout
(HERE / "reference.json").write_text(
    json.dumps(
        {"commit": commit.strip(), "machine": machine(), "python": platform.python_version()},
        indent=1,
    )
    + "\n"
)
print(len(arrays), "arrays")
