"""Sphinx configuration of the fieldmap documentation.

Build: ``make docs`` (or ``python -m sphinx -W --keep-going -b html docs docs/_build/html``).

The API reference is generated at build time from the package itself: the top-level
``fieldmap.__all__`` and every public subpackage and module found by :mod:`pkgutil`, so a new
module or public name appears without editing these files; the CLI reference from the argument
parser. Both are done by the local extension ``_ext/fieldmap_docs.py``.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import fieldmap

sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))  # fieldmap_docs

project = "fieldmap"
author = "the fieldmap developers"
copyright = "the fieldmap developers, BSD-3-Clause"
version = release = fieldmap.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
    "fieldmap_docs",  # _ext/: API lists, CLI parser, docstring escapes
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "api/_*.rst", "shared"]
templates_path = ["_templates"]

# -- API reference --------------------------------------------------------------------------
# fieldmap_docs.write_api_lists writes the lists of the API reference into api/_toplevel.rst and
# api/_modules.rst, included by api/index.rst; autosummary does not follow includes, so it is
# told to scan them, with every other page (the stubs it generates are scanned in turn).
_HERE = Path(__file__).resolve().parent
autosummary_generate = sorted(
    {"api/_toplevel.rst", "api/_modules.rst"}
    | {
        p.relative_to(_HERE).as_posix()
        for p in _HERE.rglob("*.rst")
        if not {"_build", "_templates", "generated"} & set(p.relative_to(_HERE).parts)
    }
)
autosummary_imported_members = False  # each object is documented once, in its defining module
autodoc_default_options = {"member-order": "bysource"}
autodoc_preserve_defaults = True  # signatures show defaults as written (WGS84, not its repr)
autodoc_typehints = "none"  # types are in the numpydoc Parameters sections
autodoc_mock_imports: list[str] = []  # Warp, xarray and matplotlib import fine here

# numpydoc renders the docstrings. Its validation is off: the docstrings are checked by ruff
# (pydocstyle, numpy convention); this build only fails on what breaks the pages.
numpydoc_show_class_members = False  # members come from autodoc (no duplicate descriptions)
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
numpydoc_xref_param_type = False
nitpicky = False

# -- Gallery (sphinx-gallery) ----------------------------------------------------------------
# Every script of examples/ (and of its sections flights/, maps/) runs in this build and is
# rendered with its figures in gallery/.
# The scripts save their figures as PNG files (fieldmap.products.io.write_png closes them), so
# the scraper of _ext/fieldmap_gallery.py collects the files written into FIELDMAP_EXAMPLE_OUT;
# the navigation examples run short (--small) with their outputs there too. Hooks are named by
# qualified name, which keeps this configuration picklable (no warning, so -W passes).
import fieldmap_gallery  # noqa: E402  (docs/_ext, on sys.path above)

os.environ.update(fieldmap_gallery.ENVIRONMENT)  # outputs, short flights, the sample logs
os.environ.setdefault("MPLBACKEND", "agg")
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "gallery",
    "filename_pattern": fieldmap_gallery.FILENAME_PATTERN,  # every example runs
    "ignore_pattern": fieldmap_gallery.IGNORE_PATTERN,  # _*.py: a helper, not an example
    "image_scrapers": ("fieldmap_gallery.png_scraper",),
    "reset_argv": "fieldmap_gallery.example_argv",
    "within_subsection_order": "FileNameSortKey",  # figures in the paper's order
    "download_all_examples": False,
    "remove_config_comments": True,
    "show_memory": False,
    "plot_gallery": "True",
    "abort_on_example_error": True,  # a failing example fails the build
    "write_computation_times": False,  # no sg_execution_times page outside the toctree
}

# -- Markdown (MyST) -------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# -- HTML ------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"fieldmap {version}"
html_static_path: list[str] = []  # README figures in _static/ are copied as images
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
    # the left navigation of ~230 API pages is most of the build time when expanded
    "collapse_navigation": True,
    "navigation_depth": 2,
}
html_sidebars = {"index": []}
html_show_sourcelink = False
