"""sphinx-gallery hooks of the fieldmap documentation: the example scripts' settings and PNG files.

The example scripts in ``examples/`` (the paper's, and the sections ``flights/`` and ``maps/``)
save their figures as PNG files with
:func:`fieldmap.products.io.write_png` (which closes each figure), so sphinx-gallery's matplotlib
scraper finds no open figure. The scraper here collects the PNG files an example wrote into
:data:`OUT` instead (the folder of ``FIELDMAP_EXAMPLE_OUT``, and of ``--out`` of the navigation
examples), as in sphinx-gallery's "image files on disk" recipe. :data:`ENVIRONMENT` is what the
build sets for them: the output folder, the short flights, the folder of the sample logs.
``docs/conf.py`` names these hooks by their qualified names (``fieldmap_gallery.png_scraper``,
``fieldmap_gallery.example_argv``), which keeps the Sphinx configuration picklable.
"""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: Where the examples write their figures during the docs build (inside the build folder).
OUT = ROOT / "docs" / "_build" / "gallery_outputs"

#: The environment of the examples in the docs build (sphinx-gallery runs each in the folder of
#: its script): figures into :data:`OUT`; the flight examples fly their short version (the
#: first minutes, few draws, a low IMU rate) and read the sample logs by their absolute path.
#: The map examples run at full size (they read ``FIELDMAP_EXAMPLE_STEP``/``_LMAX``, not set).
ENVIRONMENT = {
    "FIELDMAP_EXAMPLE_OUT": str(OUT),
    "FIELDMAP_EXAMPLE_SMALL": "1",
    "FIELDMAP_EXAMPLE_LOGS": str(ROOT / "tests" / "data" / "flights"),
}

#: sphinx-gallery's ``filename_pattern``: every script of examples/ and its sections runs in
#: the docs build ...
FILENAME_PATTERN = r"/[a-z]\w*\.py$"
#: ... but a file whose name starts with ``_`` would be a helper, no example (``ignore_pattern``;
#: there is none: each example reads its settings itself, from public API only).
IGNORE_PATTERN = r"(^|/)_\w*\.py$"

#: Command-line arguments of the navigation examples in the gallery: the short run of the
#: tests (60 s at 100 Hz instead of 800 s at 200 Hz), outputs into :data:`OUT`.
NAV_ARGV = ["--small", "--out", str(OUT)]


def example_argv(gallery_conf, script_vars) -> list[str]:
    """Return the arguments an example runs with (``reset_argv`` of sphinx-gallery)."""
    name = Path(script_vars["src_file"]).name
    return list(NAV_ARGV) if name.startswith("table") else []


def png_scraper(block, block_vars, gallery_conf) -> str:
    """Move the PNG files written into :data:`OUT` by the last code block into the gallery.

    Files are taken in name order and moved (not copied), so each file is shown once, under
    the example that wrote it. Returns the reST of the images (``figure_rst``).
    """
    from sphinx_gallery.scrapers import figure_rst

    if not OUT.is_dir():
        return ""
    names = []
    paths = block_vars["image_path_iterator"]
    for png in sorted(OUT.glob("*.png")):
        target = paths.next()
        shutil.move(str(png), target)
        names.append(target)
    return figure_rst(names, gallery_conf["src_dir"])
