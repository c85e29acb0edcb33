"""Every example script runs small and writes its figures; the gallery runs every one.

Like warp's test_examples.py, at a small grid and low degree (the map examples: the paper's
Chen et al. 2022 §4 and the gallery's ``maps/``) or a short flight (``flights/``). Full-size runs
reproduce the paper's figures (see the README).
"""

import pathlib
import re
import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
FIGURES = {
    "fig02_03_components.py": ["fig02_model_gravity_20km.png", "fig03_normal_gravity_20km.png"],
    "fig04_06_disturbance_20km.py": [
        "fig04_isolines_20km.png",
        "fig05_above_0.06mg_20km.png",
        "fig06_above_0.10mg_20km.png",
    ],
    "fig07_altitudes.py": [
        "fig07_isolines_50km.png",
        "fig07_isolines_100km.png",
        "fig07_isolines_50_100km.png",
        "fig07_sweep.png",
    ],
    "fig08_truncation.py": ["fig08_truncation_20km.png"],
    "fig10_region.py": ["fig10_region_20km.png"],
    "section41_statistics.py": ["section41_area_fractions.png"],
    "maps/map1_geoid.py": ["map1_geoid.png"],
    "maps/map2_gradient_tensor.py": ["map2_gradient_tensor.png"],
    "maps/map3_tide_systems.py": ["map3_tide_difference.png", "map3_tide_profile.png"],
    "maps/map4_degree_sweep.py": ["map4_omission_by_degree.png", "map4_omission_maps.png"],
}
SCRIPTS = sorted(FIGURES)  # the map examples; the navigation studies (table*) have their own tests
#: the flight examples, each run short (FIELDMAP_EXAMPLE_SMALL) on a sample log of tests/data
FLIGHTS = {
    "flights/flight1_log.py": ["flight1_conditioning.png", "flight1_errors.png"],
    "flights/flight2_covariance_budget.py": ["flight2_budget.png", "flight2_sigma.png"],
    "flights/flight3_gnss_outage.py": ["flight3_errors.png", "flight3_budget.png"],
}
LOGS = EXAMPLES.parent / "tests" / "data" / "flights"


@pytest.mark.parametrize("script", SCRIPTS)
def test_example_runs(script, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("FIELDMAP_EXAMPLE_STEP", "10")
    monkeypatch.setenv("FIELDMAP_EXAMPLE_LMAX", "30")
    monkeypatch.setenv("FIELDMAP_EXAMPLE_OUT", str(tmp_path))
    monkeypatch.setattr(sys, "argv", [script])
    runpy.run_path(str(EXAMPLES / script), run_name="__main__")
    out = capsys.readouterr().out
    assert out.strip()
    assert sorted(p.name for p in tmp_path.glob("*.png")) == sorted(FIGURES[script])
    for name in FIGURES[script]:
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG", name
    if script == "maps/map2_gradient_tensor.py":  # Laplace: the disturbance's tensor is traceless
        trace = float(re.search(r"largest \|trace\| \(Laplace: 0\): (\S+)", out)[1])
        assert trace < 1e-9
    if script == "maps/map3_tide_systems.py":  # zonal, +3 cm at the equator, -6 cm at the poles
        low, high = map(float, re.search(r"N_zero − N_free: (\S+) \.\. (\S+) cm", out).groups())
        assert -6.1 < low < -5.5 and 2.9 < high < 3.1, (low, high)
        assert float(re.search(r"closed form: (\S+) m", out)[1]) < 1e-3
    if script == "section41_statistics.py":
        assert "16.67 %" in out and "EIGEN-6S degree 30" in out
        _check_section41_numbers(out)


@pytest.mark.parametrize("script", sorted(FLIGHTS))
def test_flight_example_runs(script, tmp_path, monkeypatch, capsys):
    """Each flight example flies its short version on a sample log and writes its figures."""
    monkeypatch.setenv("FIELDMAP_EXAMPLE_SMALL", "1")
    monkeypatch.setenv("FIELDMAP_EXAMPLE_LOGS", str(LOGS))
    monkeypatch.setenv("FIELDMAP_EXAMPLE_OUT", str(tmp_path))
    monkeypatch.chdir(tmp_path)  # the logs are found through FIELDMAP_EXAMPLE_LOGS alone
    monkeypatch.setattr(sys, "argv", [script])
    runpy.run_path(str(EXAMPLES / script), run_name="__main__")
    out = capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.glob("*.png")) == sorted(FLIGHTS[script])
    for name in FLIGHTS[script]:
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG", name
    assert "IMU" in out and "10%" in out  # the recommendation, printed
    if script == "flights/flight3_gnss_outage.py":  # the one outage of the short flight
        assert re.search(r"^\s+20–25\s+\d", out, re.M), out


def _check_section41_numbers(out):
    """Check the printed "ours" column against the point API (no grid synthesis, no FFT).

    Node maxima of |δg| at 20/50/100 km and the 20 km area fraction above 0.05 mg, recomputed
    from ``fieldmap.field.gravity.disturbance``
    at the nodes of the same 10° grid (±80°); the printed
    values are rounded to 3 decimals (mg) and 2 decimals (%).
    """
    import numpy as np

    from fieldmap.field.gravity import disturbance
    from fieldmap.grids.spec import make_grid
    from fieldmap.models.registry import load_model
    from fieldmap.products.statistics import weights_2d

    rows = (re.match(r"(.+?)\s{2,}([-+.\de]+) ", line) for line in out.splitlines())
    ours = {m[1]: float(m[2]) for m in rows if m}
    grid = make_grid(10.0, 80.0, heights_m=[20e3])
    la, lo = np.meshgrid(grid.lat, grid.lon, indexing="ij")
    m30 = load_model("eigen-6s", lmax=30)
    for km in (20, 50, 100):
        dg = disturbance(la, lo, km * 1e3, model=m30, units="mg", device="cpu")
        mod = np.linalg.norm(dg, axis=-1)
        assert abs(ours[f"max |dg| at {km} km"] - mod.max()) <= 5e-4 + 1e-9, km
        if km == 20:
            w = weights_2d(grid.lat, grid.lon.size)
            frac = 100 * w[mod > 0.05].sum() / w.sum()
            assert abs(ours["area > 0.05 mg at 20 km"] - frac) <= 5e-3 + 1e-9
            assert 0 < frac < 100  # a real threshold split


def _gallery_hooks():
    """docs/_ext/fieldmap_gallery.py: the patterns docs/conf.py gives sphinx-gallery."""
    import importlib.util

    path = EXAMPLES.parent / "docs" / "_ext" / "fieldmap_gallery.py"
    spec = importlib.util.spec_from_file_location("fieldmap_gallery", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_example_is_in_the_gallery():
    """The docs build runs every example, each has a gallery title and its own thumbnail.

    sphinx-gallery needs a docstring opening with a title line underlined by ``=``, and a
    ``GALLERY_HEADER.rst`` in each section's folder; it runs the files matching
    ``filename_pattern`` (none matches ``ignore_pattern``: there are no helper scripts). An
    example imports no private name (no ``_settings``, no ``fieldmap._x``), and each one writes
    figures (the tests above check the files) with its thumbnail among them: sphinx-gallery's
    placeholder is for an example that draws nothing.
    """
    import ast

    hooks = _gallery_hooks()
    scripts = sorted(EXAMPLES.rglob("*.py"))
    names = {p.relative_to(EXAMPLES).as_posix() for p in scripts}
    assert names == set(FIGURES) | set(FLIGHTS) | {
        "table1_gravity_models.py",
        "table3_accel_errors.py",
    }  # every example is run by a test (table1/3: tests/test_navsim.py)
    for folder in {p.parent for p in scripts}:
        assert (folder / "GALLERY_HEADER.rst").is_file(), folder
    for path in scripts:
        name = path.relative_to(EXAMPLES).as_posix()
        assert re.search(hooks.FILENAME_PATTERN, str(path)), name
        assert not re.search(hooks.IGNORE_PATTERN, str(path)), name
        text = path.read_text(encoding="utf-8")
        tree = ast.parse(text)
        doc = ast.get_docstring(tree, clean=False)
        title, underline, blank = doc.splitlines()[:3]
        assert title.strip() and set(underline) == {"="} and len(underline) >= len(title)
        assert not blank.strip(), name
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                modules = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                modules = [node.module or ""] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for module in modules:
                parts = module.split(".")
                private = [p for p in parts if p.startswith("_") and parts[0] != "__future__"]
                assert not private, f"{name} imports {module}"
        thumbnail = re.search(r"^# sphinx_gallery_thumbnail_number = (\d+)$", text, re.M)
        figures = FIGURES.get(name) or FLIGHTS.get(name) or ["table's figure"]
        assert 1 <= (int(thumbnail[1]) if thumbnail else 1) <= len(figures), name
    assert (
        hooks.example_argv({}, {"src_file": str(EXAMPLES / "table1_gravity_models.py")})[0]
        == "--small"
    )  # the navigation studies run short in the docs build
    assert hooks.example_argv({}, {"src_file": str(EXAMPLES / "fig08_truncation.py")}) == []
    env = hooks.ENVIRONMENT  # the flight examples run short there, on the sample logs
    assert env["FIELDMAP_EXAMPLE_SMALL"] == "1"
    assert pathlib.Path(env["FIELDMAP_EXAMPLE_LOGS"]) == LOGS
    for name in FLIGHTS:
        logs = re.findall(r'logs / "([^"]+)"', (EXAMPLES / name).read_text(encoding="utf-8"))
        assert logs and all((LOGS / log).is_file() for log in logs), name
