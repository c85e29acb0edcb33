"""Every map example script (Chen et al. 2022 §4) runs small and writes its figures.

Like warp's test_examples.py, at a small grid and low degree. Full-size runs reproduce the paper's
figures (see the README).
"""

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
