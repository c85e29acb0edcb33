"""sphinx-gallery hooks of the fieldmap documentation: the example scripts' PNG files.

The example scripts in ``examples/`` save their figures as PNG files with
:func:`fieldmap.products.io.write_png` (which closes each figure), so sphinx-gallery's matplotlib
scraper finds no open figure. The scraper here collects the PNG files an example wrote into
:data:`OUT` instead (the folder of ``FIELDMAP_EXAMPLE_OUT``, and of ``--out`` of the navigation
examples), as in sphinx-gallery's "image files on disk" recipe. ``docs/conf.py`` names these hooks
by their qualified names (``fieldmap_gallery.png_scraper``, ``fieldmap_gallery.example_argv``),
which keeps the Sphinx configuration picklable.
"""

from __future__ import annotations

import shutil
from pathlib import Path

#: Where the examples write their figures during the docs build (inside the build folder).
OUT = Path(__file__).resolve().parents[1] / "_build" / "gallery_outputs"

#: sphinx-gallery's ``filename_pattern``: every script of examples/ runs in the docs build ...
FILENAME_PATTERN = r"/(fig|section|table)\w*\.py$"
#: ... except the helpers (``_settings.py``), which are no examples (``ignore_pattern``).
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
