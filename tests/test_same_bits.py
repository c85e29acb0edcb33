"""Same bits: every product gives the numbers recorded before the regrouping (issue 25).

``tests/data/same_bits/reference.npz`` holds every data variable and coordinate of the NetCDF
files that the commands of ``tests/same_bits_cases.py`` wrote on the commit named in
``reference.json``. The same code on another CPU kind (another vector width or FMA use, another
NumPy loop) may round the last bit differently, so the numbers are bitwise equal only on a
machine of a kind whose numbers of that same old code are recorded: ``reference_kind_*.npz``
(``tests/data/same_bits/record_kind.py``), matched by :func:`same_bits_cases.machine` (CPU
model, family and model numbers, vector instruction sets, Warp, NumPy). On any other kind they
must agree to 1e-12 relative, and a navigation error or a height, a difference of float64
states, to 1e-12 of the state it is the difference of (:data:`STATE_SCALE`): a last-bit
difference of a position of 6,400 km is 1e-9 m of position error.
"""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest
from same_bits_cases import CASES, machine, run_case

REF = pathlib.Path(__file__).parent / "data" / "same_bits"
#: Variables renamed since the reference was recorded: old "file:variable" -> new.
RENAMED: dict[str, str] = {}
#: Numbers a later issue changed on purpose, recorded again (same machine kind) and read over
#: those of reference.npz: issue 28's gradient maps by synthesis instead of central
#: differences (they moved by at most 1.5e-5 E, the differences' error; tests/test_gradient*.py)
RERECORDED = ("reference_issue28.npz",)


#: For the variables that are differences of float64 states, the scale of the state: Earth's
#: radius for positions and heights (m), 1 km/s for velocities, 1 rad for angles, 10 m/s² for
#: gravity; last-bit differences of the states are 1e-12 of it at most after a flight.
STATE_SCALE = {
    "position_error": 6.4e6,
    "predicted_position_error": 6.4e6,
    "height": 6.4e6,
    "velocity_error": 1.0e3,
    "attitude_error": 1.0,
    "gravity_error": 10.0,
}


def _atol(key: str) -> float:
    """Absolute tolerance of ``file:variable`` on another CPU kind (:data:`STATE_SCALE`)."""
    return 1e-12 * STATE_SCALE.get(key.rsplit(":", 1)[-1], 0.0)


def _kind_references() -> list[tuple[dict, pathlib.Path]]:
    return [
        (json.loads(meta.read_text()), meta.with_suffix(".npz"))
        for meta in sorted(REF.glob("reference_kind_*.json"))
    ]


@pytest.fixture(scope="module")
def reference():
    meta = json.loads((REF / "reference.json").read_text())
    with np.load(REF / "reference.npz") as z:
        arrays = {k: z[k] for k in z.files}
    for name in RERECORDED:
        with np.load(REF / name) as z:
            arrays.update({k: z[k] for k in z.files if k in arrays})
    exact = False
    for kind, numbers in _kind_references():
        if kind["machine"] == machine():
            exact = True
            with np.load(numbers) as z:
                arrays.update({k: z[k] for k in z.files if k in arrays})
    return {**meta, "exact": exact}, arrays


@pytest.mark.parametrize("name", sorted(CASES))
def test_same_numbers_as_before(name, reference, tmp_path):
    meta, arrays = reference
    exact = meta["exact"]
    got = run_case(name, tmp_path / name)
    expected = {k.split("/", 1)[1]: v for k, v in arrays.items() if k.split("/", 1)[0] == name}
    assert expected, f"no reference numbers for {name}"
    for key, want in expected.items():
        key = RENAMED.get(key, key)
        assert key in got, f"{name}: {key} no longer written (have {sorted(got)})"
        have = got[key]
        assert have.shape == want.shape and have.dtype == want.dtype, key
        if exact or want.dtype.kind != "f":
            assert np.array_equal(have, want, equal_nan=True), f"{name}: {key} changed"
        else:
            np.testing.assert_allclose(have, want, rtol=1e-12, atol=_atol(key), err_msg=key)


def test_reference_records_every_case(reference):
    _, arrays = reference
    assert {k.split("/", 1)[0] for k in arrays} == set(CASES)


def test_kind_references_are_of_the_recorded_commit(reference):
    """Each CPU kind's numbers are of the reference's commit, and differ only in the last bits."""
    meta, arrays = reference
    primary = json.loads((REF / "reference.json").read_text())
    with np.load(REF / "reference.npz") as z:
        first = {k: z[k] for k in z.files}
    for kind, numbers in _kind_references():
        assert kind["commit"] == primary["commit"]
        with np.load(numbers) as z:
            assert set(z.files) <= set(first) and z.files
            for key in z.files:
                want, have = first[key], z[key]
                np.testing.assert_allclose(have, want, rtol=1e-12, atol=_atol(key), err_msg=key)
