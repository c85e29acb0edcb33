"""Sphinx configuration of the fieldmap documentation.

Build: ``make docs`` (or ``python -m sphinx -W --keep-going -b html docs docs/_build/html``).

The API reference is generated at build time from the package itself: the top-level
``fieldmap.__all__`` and every public subpackage and module found by :mod:`pkgutil`, so a new
module or public name appears without editing these files (see :func:`write_api_lists`).
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import shutil
from pathlib import Path

import fieldmap

HERE = Path(__file__).resolve().parent

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
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "api/_*.rst"]
templates_path = ["_templates"]

# -- API reference --------------------------------------------------------------------------
# The lists of the API reference are written by write_api_lists into api/_toplevel.rst and
# api/_modules.rst, included by api/index.rst; autosummary does not follow includes, so it is
# told to scan them (stubs it generates are scanned in turn, recursively).
autosummary_generate = ["api/index.rst", "api/_toplevel.rst", "api/_modules.rst"]
autosummary_imported_members = False  # each object is documented once, in its defining module
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # types are in the numpydoc Parameters sections
autodoc_mock_imports: list[str] = []  # Warp, xarray and matplotlib import fine here

# numpydoc renders the docstrings. Its validation is off: the docstrings are checked by ruff
# (pydocstyle, numpy convention); this build only fails on what breaks the pages.
numpydoc_show_class_members = False  # members come from autodoc (no duplicate descriptions)
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
numpydoc_xref_param_type = False
nitpicky = False

# -- Markdown (MyST) -------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# -- HTML ------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"fieldmap {version}"
html_static_path: list[str] = []
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_sidebars = {"index": []}
html_show_sourcelink = False

# -- generated API lists ----------------------------------------------------------------------
#: Subpackages shown first, in the order the data flows; any other public subpackage follows.
ORDER = ["models", "field", "grids", "products", "nav", "reference"]
#: Not part of the Python API reference: the CLI has its own page, data holds files only, and
#: the Warp kernels (``fieldmap.kernels``) are documented through their host functions.
EXCLUDE = {"cli", "data", "kernels"}
TITLES = {
    "models": "Gravity-field models",
    "field": "The field at points",
    "grids": "Grids",
    "products": "Maps and products",
    "nav": "Navigation",
    "reference": "NumPy references",
}


def _public_modules() -> tuple[list[str], list[str]]:
    """Return the public subpackages and top-level modules of fieldmap, by name."""
    packages, modules = [], []
    for info in pkgutil.iter_modules(fieldmap.__path__):
        if info.name.startswith("_") or info.name in EXCLUDE:
            continue
        (packages if info.ispkg else modules).append(info.name)
    rank = {name: i for i, name in enumerate(ORDER)}
    packages.sort(key=lambda n: (rank.get(n, len(ORDER)), n))
    return packages, sorted(modules)


def _canonical(name: str) -> str | None:
    """Return the documented path of a top-level name (its defining module), if it has one."""
    obj = getattr(fieldmap, name)
    if inspect.isclass(obj) or inspect.isfunction(obj):
        module = getattr(obj, "__module__", "")
        qualname = getattr(obj, "__qualname__", name)
        if module.startswith("fieldmap.") and not module.split(".")[1].startswith("_"):
            if getattr(importlib.import_module(module), qualname, None) is obj:
                return f"{module}.{qualname}"
    return None


def write_api_lists(app=None, config=None) -> None:
    """Write the autosummary lists of the API reference into ``api/_toplevel.rst`` and ``api/_modules.rst``.

    Called before autosummary reads the sources, so the stubs it generates always follow the
    package: ``fieldmap.__all__`` for the top level, :mod:`pkgutil` for subpackages and modules.
    Stale stubs of a previous build are removed first.
    """
    out = HERE / "api"
    shutil.rmtree(out / "generated", ignore_errors=True)

    linked, own = [], []
    for name in fieldmap.__all__:
        if name.startswith("_"):
            continue
        target = _canonical(name)
        if target is None:
            own.append(f"fieldmap.{name}")
        else:
            linked.append(f"~{target}")
    top = [
        ".. autosummary::",
        "",
        *(f"   {t}" for t in linked),
        "",
    ]
    if own:
        top += [
            "Constants and instances:",
            "",
            ".. autosummary::",
            "   :toctree: generated",
            "",
            *(f"   {t}" for t in own),
            "",
        ]
    (out / "_toplevel.rst").write_text("\n".join(top))

    packages, modules = _public_modules()
    body = []
    for name in packages + modules:
        mod = importlib.import_module(f"fieldmap.{name}")
        doc = (inspect.getdoc(mod) or "").strip().splitlines()
        title = TITLES.get(name) or (doc[0].rstrip(".") if doc else name)
        title = f"{title}: ``fieldmap.{name}``"
        body += [
            title,
            "-" * len(title),
            "",
            ".. autosummary::",
            "   :toctree: generated",
            "   :recursive:",
            "",
            f"   fieldmap.{name}",
            "",
        ]
    (out / "_modules.rst").write_text("\n".join(body))


# -- |x| in docstrings ------------------------------------------------------------------------
# The docstrings are written as plain text, where |δp| is a magnitude; reStructuredText reads it
# as a substitution reference and fails on it ("Undefined substitution referenced"). Outside
# inline literals, roles, math and literal blocks, such bars are escaped before numpydoc parses
# the docstring.
_BARS = re.compile(r"(?<![\\\w|])\|(?=[^\s|])([^|`\n]*?[^\s|\\])\|(?![\w|])")
_INLINE = re.compile(r"(``.+?``|:[\w:+-]+:`[^`]*`|`[^`]*`_{0,2})")


def _escape_bars(line: str) -> str:
    parts = _INLINE.split(line)
    for i in range(0, len(parts), 2):  # even parts are outside inline markup
        parts[i] = _BARS.sub(r"\\|\1\\|", parts[i])
    return "".join(parts)


def escape_magnitudes(app, what, name, obj, options, lines: list[str]) -> None:
    """Escape ``|x|`` (a magnitude in plain text) in a docstring, in place."""
    block_indent = None  # indentation of the directive or paragraph opening a literal block
    for i, line in enumerate(lines):
        stripped = line.lstrip()
        indent = len(line) - len(stripped)
        if block_indent is not None:
            if not stripped or indent > block_indent:
                continue  # inside a literal, math or code block: leave it as written
            block_indent = None
        if re.match(r"\.\. (math|code-block|code|highlight|literalinclude)::", stripped):
            block_indent = indent
            continue
        if stripped.endswith("::") and not stripped.startswith(".."):
            block_indent = indent
        if stripped.startswith(("| ", "+-", "+=")) or stripped == "|":
            continue  # a line block or a grid table
        lines[i] = _escape_bars(line)


def setup(app):
    """Generate the API lists before autosummary (builder-inited, priority 500) runs."""
    app.connect("config-inited", write_api_lists)
    app.connect("autodoc-process-docstring", escape_magnitudes, priority=400)
    return {"parallel_read_safe": True}
