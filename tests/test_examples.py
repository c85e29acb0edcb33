"""Every map example script (Chen et al. 2022 §4) runs small and writes its figures.

Like warp's test_examples.py, at a small grid and low degree. Full-size runs reproduce the paper's
figures (see the README).
"""

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
        "fig07_sweep.png",
    ],
    "fig08_truncation.py": ["fig08_truncation_20km.png"],
    "fig10_region.py": ["fig10_region_20km.png"],
    "section41_statistics.py": [],
}
SCRIPTS = sorted(FIGURES)  # the map examples (figures 2-8, 10); other examples have their own tests


@pytest.mark.parametrize("script", SCRIPTS)
def test_example_runs(script, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("FIELDMAP_EXAMPLE_STEP", "10")
    monkeypatch.setenv("FIELDMAP_EXAMPLE_LMAX", "30")
    monkeypatch.setenv("FIELDMAP_EXAMPLE_OUT", str(tmp_path))
    monkeypatch.syspath_prepend(str(EXAMPLES))
    monkeypatch.setattr(sys, "argv", [script])
    runpy.run_path(str(EXAMPLES / script), run_name="__main__")
    out = capsys.readouterr().out
    assert out.strip()
    for name in FIGURES[script]:
        assert (tmp_path / name).read_bytes()[:4] == b"\x89PNG", name
    if script == "section41_statistics.py":
        assert "16.67 %" in out and "EIGEN-6S degree 30" in out
        _check_section41_numbers(out)


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
    """The docs build runs every example, not the helpers, and each has a gallery title.

    sphinx-gallery needs a docstring opening with a title line underlined by ``=``; it runs
    the files matching ``filename_pattern`` and skips those matching ``ignore_pattern``.
    """
    import ast

    hooks = _gallery_hooks()
    scripts = sorted(EXAMPLES.glob("*.py"))
    helpers = [p for p in scripts if p.name.startswith("_")]
    examples = [p for p in scripts if p not in helpers]
    assert set(SCRIPTS) < {p.name for p in examples}  # the map examples, and the others
    assert [p.name for p in helpers] == ["_settings.py"]
    for path in helpers:
        assert re.search(hooks.IGNORE_PATTERN, str(path)), path.name
    for path in examples:
        assert re.search(hooks.FILENAME_PATTERN, str(path)), path.name
        assert not re.search(hooks.IGNORE_PATTERN, str(path)), path.name
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")), clean=False)
        title, underline, blank = doc.splitlines()[:3]
        assert title.strip() and set(underline) == {"="} and len(underline) >= len(title)
        assert not blank.strip(), path.name
    assert (
        hooks.example_argv({}, {"src_file": str(EXAMPLES / "table1_gravity_models.py")})[0]
        == "--small"
    )  # the navigation studies run short in the docs build
    assert hooks.example_argv({}, {"src_file": str(EXAMPLES / "fig08_truncation.py")}) == []
