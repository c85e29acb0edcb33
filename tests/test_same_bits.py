"""Same numbers: every product gives the numbers recorded before the regrouping (issue 25).

``tests/data/same_bits/reference.npz`` holds every data variable and coordinate of the NetCDF
files that the commands of ``tests/same_bits_cases.py`` wrote on the commit named in
``reference.json``. Each case is compared twice with them:

**Within the float64 error bound, on any CPU kind.** Another CPU kind (another vector width or
FMA use, another NumPy loop or libm) rounds single operations differently, so the same code
gives other last bits. Each kind's result lies within the float64 error bound ``E`` of the
computation from the exact value, so two kinds differ by at most ``2E``, and that is the
tolerance (:func:`bound`), written with ``eps = 2u`` (``u = 2**-53``, the unit roundoff of
float64; Higham 2002, *Accuracy and Stability of Numerical Algorithms*, §2.2):

* A map value is a spherical-harmonic sum to degree ``L``: the sum over degrees has error at
  most ``γ_(L+1) Σ|t|`` (Higham eq. 4.4, the partial sums hold every term once) and the
  Legendre recursion over degree adds ``~(n+1) u`` to each term of degree ``n ≥ 1``
  (``P̄_00 = 1`` is exact). With ``B = Σ_n |t_n|`` over all degrees and ``B₁`` over ``n ≥ 1``:
  ``|Δ| ≤ eps ((L + 1 + FIXED_OPS) B + (L + 1) B₁)``. ``B`` is bounded from the model's
  coefficients by the addition theorem (:func:`series_bound`), ``FIXED_OPS`` counts the
  operations outside the sums. A sum of positive terms (the commission σ) is bounded relative
  to itself.
* A flight integrates ``N = duration × IMU rate`` steps, each rounding the state ``x`` by at
  most ``u |x|``: ``|Δx| ≤ N eps S`` with ``S`` the state's magnitude, and the first-order INS
  error model (Groves 2013 §14.2: δv̇ = −f × δψ) carries the attitude's rounding into the
  velocity (``f T``) and the position (``f T²/2``): ``S = 1 rad`` (attitude),
  ``V + f T`` (velocity), ``R + V T + f T²/2`` (position). The true path, built in
  ``path_steps`` steps, is within ``path_steps eps R``, and a degree-``L`` field evaluated on
  it within ``(L + 2)/r`` of its size times that, plus its synthesis' bound
  (:func:`flight_bound`).

These bounds are worst cases: on an Intel family 6 model 207 against the recorded AMD numbers
the largest difference is 0.06 of its bound (the attitude error of "flight"); a change of 1e-9
of GM, or of the map values themselves, is outside them (issue 35's closing note shows both).

**Bitwise, on a CPU kind whose numbers are recorded.** ``reference_kind_*.npz``
(``tests/data/same_bits/record_kind.py``: the same old commit run on that kind), matched by
:func:`same_bits_cases.machine` (CPU model, family and model numbers, vector instruction sets,
Warp, NumPy). There the code of today must give the old code's bits.
"""

from __future__ import annotations

import functools
import json
import math
import pathlib
from dataclasses import dataclass

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

#: Two correctly rounded results of one operation differ by at most one ulp of 1 (2u).
EPS = float(np.finfo(np.float64).eps)
#: Operations of a map value outside its sums over degree: the longitude sum (an FFT of
#: log2(n) ≤ 10 passes here), the normal field subtracted, the frame rotation, the unit.
FIXED_OPS = 16
#: Earth's rotation rate times its equatorial radius: what an inertial frame adds to a speed.
#: Units: m/s.
EARTH_ROTATION_SPEED = 7.292115e-5 * 6_378_137.0
#: Earth's polar radius (WGS84 b), the smallest radius of a map node at height 0. Units: m.
POLAR_RADIUS = 6_356_752.314
#: Normal gravity at the equator, the smallest γ a geoid height is divided by. Units: m/s².
GAMMA_EQUATOR = 9.7803253359


@dataclass(frozen=True)
class Series:
    """A map case: a spherical-harmonic sum of EIGEN-6S to degree ``lmax``.

    ``part``: ``"full"`` the model with its degree 0 (gravitation minus the normal field, the
    difference of two sums of size g), ``"disturbing"`` the model minus the normal potential
    (:func:`fieldmap.field.geodesy.disturbing_model`: the anomaly and the geoid), ``"sigma"``
    a sum of positive variances (the commission σ).
    """

    lmax: int
    part: str


@dataclass(frozen=True)
class Flight:
    """A navigation case: ``duration_s × rate_hz`` strapdown steps (checked against the file).

    ``speed_mps`` bounds the speed of the state (the ground speed flown plus
    :data:`EARTH_ROTATION_SPEED` for an inertial frame), ``force_mps2`` the specific force;
    ``lmax`` is the truth model's degree; ``path_steps`` the steps that built the true path
    (``route_flight``'s geodesic steps of 1 s; 0 for a closed-form path), where the gravity
    errors are evaluated.
    """

    duration_s: float
    rate_hz: float
    speed_mps: float
    force_mps2: float
    lmax: int
    path_steps: int


#: How each case computes its numbers. The boost-glide path of table1/table3 glides at 2.2 km/s
#: at most (``BoostGlideProfile.v_glide``) and boosts at up to 59.4 m/s² in its first 100 s
#: (``BoostGlide(duration=100).kinematics``), plus gravity; the route of "flight" flies 469 s at
#: 200 m/s (its ``--speed-mps``) with turns and climbs of 2 m/s² at most (``route_flight``).
COMPUTATION: dict[str, Series | Flight] = {
    "map": Series(240, "full"),
    "map_region": Series(240, "full"),
    "sweep": Series(240, "full"),
    # the J2n normal series against the exact normal field: within the full model's bound
    "truncation_orders": Series(240, "full"),
    "truncation_degrees": Series(240, "full"),
    "geoid": Series(240, "disturbing"),
    "anomaly": Series(240, "disturbing"),
    "gradient": Series(240, "full"),
    "geoid_sigma": Series(240, "sigma"),
    "table": Series(60, "full"),
    "table1": Flight(100.0, 200.0, 2200.0 + EARTH_ROTATION_SPEED, 59.4 + 9.9, 240, 0),
    "table3": Flight(100.0, 200.0, 2200.0 + EARTH_ROTATION_SPEED, 59.4 + 9.9, 240, 0),
    "flight": Flight(469.0, 200.0, 200.0 + EARTH_ROTATION_SPEED, 9.9 + 2.0, 60, 469),
}

#: Map variables: SI unit size of their values (m/s² per unit, or m, or s⁻² per unit), the
#: derivative order of the series (0 potential, 1 gravitation, 2 gradient) and whether the
#: value is the modulus of a vector (|Δ|v|| ≤ |Δv| ≤ √3 of a component's bound).
_MGAL, _MG, _EOTVOS = 1e-5, 9.80665e-3, 1e-9
_ACCEL = {"east", "north", "up", "dd", "de", "dn"}
_MODULUS_MGAL = {"modulus", "max_mgal", "mean_mgal", "rms_mgal", "p99_mgal"}
_MODULUS_MG = {"modulus_mg", "max_mg", "mean_mg", "rms_mg", "p50_mg", "p99_mg"}
_MEANS = {"mean_mg", "rms_mg", "mean_mgal", "rms_mgal"}
_GRADIENT = {"T_ee", "T_en", "T_eu", "T_nn", "T_nu", "T_uu"}
#: Inputs written back as coordinates: bitwise on any kind.
_INPUTS = {"latitude", "longitude", "height", "threshold_mg", "time", "order", "degree"}


@functools.cache
def _degree_norms(lmax: int, part: str) -> tuple[np.ndarray, float, float]:
    """Per-degree norms ``√Σ_m (C̄²+S̄²)`` of EIGEN-6S (or its disturbing model), GM, radius."""
    from fieldmap.field.geodesy import disturbing_model
    from fieldmap.models.registry import load_model

    model = load_model("eigen-6s", lmax=lmax)
    if part == "disturbing":
        model = disturbing_model(model).truncated(lmax)
    norms = np.sqrt(np.sum(model.C**2 + model.S**2, axis=1))
    return norms, float(model.gm), float(model.radius)


def series_bound(lmax: int, part: str, r: float, kind: str) -> tuple[float, float]:
    r"""Bounds ``(B, B₁)`` of ``Σ|t_n|`` (all degrees, and ``n ≥ 1``) at radius ``r`` (SI).

    By the addition theorem ``Σ_m Ȳ_nm(x)² = 2n + 1`` at any point, so by Cauchy-Schwarz the
    degree-``n`` term of ``GM/r Σ (R/r)^n C̄_nm Ȳ_nm`` is at most
    ``GM/r (R/r)^n √(Σ_m C̄² + S̄²) √(2n+1)`` times ``f_n / r^k``: ``f_n = 1`` for the
    ``"potential"``; ``n + 1`` for a ``"gravitation"`` component (radial ``n + 1``, horizontal
    ``√(n(n+1)/2)`` as ``Σ_m (∂Ȳ_nm)² = (2n+1) P_n'(1)``); ``n + 3`` for the ``"anomaly"``
    ``−∂T/∂r − 2T/r``; ``2(n+1)(n+2)`` for a ``"gradient"`` component (``(n+1)(n+2)`` bounds
    ``T_rr`` and the horizontal second derivatives, ``√(3P_n''(1) + P_n'(1)) < 0.62 (n+1)²``,
    the factor 2 the frame's first-derivative terms).
    """
    norms, gm, radius = _degree_norms(lmax, part)
    n = np.arange(norms.size, dtype=np.float64)
    k, f = {
        "potential": (0, np.ones_like(n)),
        "gravitation": (1, n + 1.0),
        "anomaly": (1, n + 3.0),
        "gradient": (2, 2.0 * (n + 1.0) * (n + 2.0)),
    }[kind]
    terms = gm / r ** (1 + k) * f * (radius / r) ** n * norms * np.sqrt(2.0 * n + 1.0)
    return float(terms.sum()), float(terms[1:].sum())


def _map_bound(case: str, var: str, arrays: dict[str, np.ndarray], file: str) -> float | None:
    """Absolute bound of ``var`` of a map case (None: a relative or discrete rule applies)."""
    spec = COMPUTATION[case]
    assert isinstance(spec, Series)
    heights = arrays.get(f"{file}:height", np.zeros(1))
    r = POLAR_RADIUS + float(np.min(heights))
    L = spec.lmax
    if var in _GRADIENT:
        kind, unit, vector = "gradient", _EOTVOS, False
    elif var == "geoid":
        kind, unit, vector = "potential", GAMMA_EQUATOR, False
    elif var == "anomaly":
        kind, unit, vector = "anomaly", _MGAL, False
    elif var in _ACCEL:
        kind, unit, vector = "gravitation", _MGAL, False
    elif var in _MODULUS_MGAL:
        kind, unit, vector = "gravitation", _MGAL, True
    elif var in _MODULUS_MG:
        kind, unit, vector = "gravitation", _MG, True
    else:
        return None
    b, b1 = series_bound(L, spec.part, r, kind)
    bound = EPS * ((L + 1 + FIXED_OPS) * b + (L + 1) * b1) / unit
    if vector:
        bound *= math.sqrt(3.0)
    if var in _MEANS:  # a weighted sum over the map's cells: n eps of its largest value
        modulus = arrays[f"{file}:{'modulus_mg' if var.endswith('_mg') else 'modulus'}"]
        cells = modulus.shape[-2] * modulus.shape[-1]
        bound += cells * EPS * float(np.max(np.abs(modulus)))
    return bound


def flight_bound(case: str, var: str, want: np.ndarray) -> np.ndarray | float:
    """Absolute bound of ``var`` of a navigation case (module docstring; SI units)."""
    spec = COMPUTATION[case]
    assert isinstance(spec, Flight)
    steps = spec.duration_s * spec.rate_hz
    T, V, f = spec.duration_s, spec.speed_mps, spec.force_mps2
    R = 6_378_137.0
    position = steps * EPS * (R + V * T + 0.5 * f * T * T)
    path = max(spec.path_steps, 1) * EPS * R
    # a degree-L field moves by (L + 2)/r of its size when its point moves (its radial
    # derivative), on top of its synthesis' own bound
    b, b1 = series_bound(spec.lmax, "full", POLAR_RADIUS, "gravitation")
    field = (spec.lmax + 2) / POLAR_RADIUS * path * b
    field += EPS * ((spec.lmax + 1 + FIXED_OPS) * b + (spec.lmax + 1) * b1)
    field *= 2.0  # gravity_error is the difference of two such fields (model minus truth)
    bounds = {
        "attitude_error": steps * EPS * 1.0,
        "velocity_error": steps * EPS * (V + f * T),
        "position_error": position,
        "height": path,
        "latitude": math.degrees(path / POLAR_RADIUS),
        "longitude": math.degrees(path / POLAR_RADIUS),
        "gravity_error": field,
        # the double time integral of gravity_error, summed at the steps
        "predicted_position_error": 0.5 * T * T * field + steps * EPS * float(np.max(np.abs(want))),
    }
    return bounds[var]


def bound(case: str, key: str, want: np.ndarray, arrays: dict[str, np.ndarray]) -> np.ndarray:
    """Return the largest difference of ``file:variable`` of ``case`` between two CPU kinds."""
    file, var = key.rsplit(":", 1)
    spec = COMPUTATION[case]
    if var == "time" or (var in _INPUTS and not isinstance(spec, Flight)):
        return np.zeros_like(want)
    if var in ("geoid_sigma", "truth_gravity_sigma"):  # positive terms: relative to itself
        L = spec.lmax
        rel = EPS * ((L + 1) ** 2 + 2 * (L + 1) + FIXED_OPS)
        if isinstance(spec, Flight):  # and the path's rounding, as the gravitation's
            rel += (L + 2) / POLAR_RADIUS * flight_bound(case, "height", want)
        return rel * np.abs(want)
    if isinstance(spec, Flight):
        return np.broadcast_to(flight_bound(case, var, want), want.shape)
    absolute = _map_bound(case, var, arrays, file)
    if absolute is None:
        raise AssertionError(f"{case}: no error bound for {key}: add it to test_same_bits.py")
    return np.broadcast_to(absolute, want.shape)


def _area_fraction_bound(key: str, arrays: dict[str, np.ndarray], case: str) -> np.ndarray:
    """Bound an area fraction above a threshold: the area of the cells within their bound of it."""
    from fieldmap.products.statistics import area_weights

    file = key.rsplit(":", 1)[0]
    v = arrays[f"{file}:modulus_mg"].reshape((-1, *arrays[f"{file}:modulus_mg"].shape[-2:]))
    thresholds = arrays[f"{file}:threshold_mg"]
    b = _map_bound(case, "modulus_mg", arrays, file)
    w = area_weights(arrays[f"{file}:latitude"])
    w = w / (w.sum() * v.shape[-1])
    near = np.abs(v[..., None] - thresholds) <= b  # (height, lat, lon, threshold)
    return np.einsum("hijt,i->ht", near, w).reshape(arrays[key].shape)


def _kind_references() -> list[tuple[dict, pathlib.Path]]:
    return [
        (json.loads(meta.read_text()), meta.with_suffix(".npz"))
        for meta in sorted(REF.glob("reference_kind_*.json"))
    ]


def _by_case(arrays: dict[str, np.ndarray], name: str) -> dict[str, np.ndarray]:
    return {k.split("/", 1)[1]: v for k, v in arrays.items() if k.split("/", 1)[0] == name}


@pytest.fixture(scope="module")
def reference():
    """Return the recorded numbers, and this CPU kind's own numbers where they are recorded."""
    with np.load(REF / "reference.npz") as z:
        arrays = {k: z[k] for k in z.files}
    for name in RERECORDED:
        with np.load(REF / name) as z:
            arrays.update({k: z[k] for k in z.files if k in arrays})
    this_kind = None
    for kind, numbers in _kind_references():
        if kind["machine"] == machine():
            this_kind = dict(arrays)
            with np.load(numbers) as z:
                this_kind.update({k: z[k] for k in z.files if k in arrays})
    return arrays, this_kind


def _check_within_bound(name: str, expected: dict, got: dict, what: str) -> None:
    for key, want in expected.items():
        have = got[RENAMED.get(key, key)]
        assert have.shape == want.shape and have.dtype == want.dtype, key
        if want.dtype.kind != "f":
            assert np.array_equal(have, want), f"{name}: {key} changed"
            continue
        if key.endswith(":area_fraction_above"):
            tol = _area_fraction_bound(key, expected, name)
        else:
            tol = bound(name, key, want, expected)
        excess = np.abs(have - want) - tol
        worst = np.unravel_index(np.argmax(excess), want.shape) if want.size else ()
        assert not np.any(excess > 0) and np.array_equal(np.isnan(have), np.isnan(want)), (
            f"{name}: {key} differs from {what} beyond the float64 error bound: at {worst} "
            f"{have[worst]!r} vs {want[worst]!r}, |Δ| {abs(have[worst] - want[worst]):.3g} "
            f"> {tol[worst]:.3g}"
        )


@pytest.mark.parametrize("name", sorted(CASES))
def test_same_numbers_as_before(name, reference, tmp_path):
    """Within the float64 error bound of the recorded numbers; bitwise on a recorded kind."""
    arrays, this_kind = reference
    got = run_case(name, tmp_path / name)
    expected = _by_case(arrays, name)
    assert expected, f"no reference numbers for {name}"
    for key in expected:
        assert RENAMED.get(key, key) in got, f"{name}: {key} no longer written ({sorted(got)})"
    spec = COMPUTATION[name]
    if isinstance(spec, Flight):
        import xarray as xr

        for path in (tmp_path / name).rglob("*.nc"):
            with xr.open_dataset(path, decode_times=False) as ds:
                meta = json.loads(ds.attrs["meta"])
            assert (meta["duration_s"], meta["imu_rate_hz"]) == (spec.duration_s, spec.rate_hz)
    _check_within_bound(name, expected, got, "the recorded numbers")
    if this_kind is not None:
        for key, want in _by_case(this_kind, name).items():
            have = got[RENAMED.get(key, key)]
            assert np.array_equal(have, want, equal_nan=True), (
                f"{name}: {key} is not bitwise the recorded numbers of this CPU kind "
                f"(largest |Δ| {np.nanmax(np.abs(have - want)) if want.size else 0:.3g})"
            )


def test_reference_records_every_case(reference):
    arrays, _ = reference
    assert {k.split("/", 1)[0] for k in arrays} == set(CASES) == set(COMPUTATION)


def test_kind_references_are_of_the_recorded_commit(reference):
    """Each CPU kind's numbers are of the reference's commit, within the error bound of them."""
    arrays, _ = reference
    primary = json.loads((REF / "reference.json").read_text())
    with np.load(REF / "reference.npz") as z:
        first = {k: z[k] for k in z.files}
    kinds = _kind_references()
    assert kinds
    for kind, numbers in kinds:
        assert kind["commit"] == primary["commit"]
        with np.load(numbers) as z:
            assert set(z.files) <= set(first) and z.files
            theirs = {k: z[k] for k in z.files}
        for name in {k.split("/", 1)[0] for k in theirs}:
            recorded = _by_case(first, name)
            have = {**recorded, **_by_case(theirs, name)}
            _check_within_bound(name, recorded, have, f"the numbers of {numbers.name}")
