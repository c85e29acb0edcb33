"""Local Sphinx extension of the fieldmap documentation (loaded by ``conf.py``).

- :func:`write_api_lists` writes the autosummary lists of the API reference at build time, from
  ``fieldmap.__all__`` and the public subpackages and modules found by :mod:`pkgutil`, so a new
  module or public name appears without editing the documentation;
- :func:`escape_magnitudes` keeps plain-text magnitudes such as ``|δp|`` in docstrings from being
  read as reStructuredText substitutions;
- :func:`cli_parser` is the ``fieldmap`` argument parser with its help texts made inert for
  sphinx-argparse (which parses them as reStructuredText; they are written for a terminal);
- :func:`run_page_code` runs the Python blocks of the pages marked with :data:`RUN_MARKER` (the
  guide "Flight study from Python") as the build reads them, so a guide whose code no longer
  runs fails the build.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import pkgutil
import re
import shutil
import sys
from pathlib import Path

import fieldmap

DOCS = Path(__file__).resolve().parent.parent

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
    "errors": "Errors",
    "units": "Units",
    "limits": "Accepted ranges",
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


def _first_sentence(module) -> str:
    """Return the first sentence of a module docstring as a short plain title, or ''."""
    doc = " ".join((inspect.getdoc(module) or "").split("\n\n")[0].split())
    doc = re.sub(r":\w+:`~?([^`]*)`", r"\1", doc).replace("``", "")
    first = re.split(r"(?<=[.:;])\s", doc, maxsplit=1)[0].rstrip(".:;")
    return first if 0 < len(first) <= 60 and "`" not in first and "*" not in first else ""


def _canonical(name: str) -> str | None:
    """Return the documented path of a top-level name (where it is defined), if it has one.

    Functions and classes: their module and qualified name. Constants and instances: the public
    module holding the same object with a ``#:`` doc comment (autosummary documents those).
    """
    obj = getattr(fieldmap, name)
    if inspect.isclass(obj) or inspect.isfunction(obj):
        module = getattr(obj, "__module__", "")
        qualname = getattr(obj, "__qualname__", name)
        if _public(module) and getattr(importlib.import_module(module), qualname, None) is obj:
            return f"{module}.{qualname}"
        return None
    from sphinx.errors import PycodeError
    from sphinx.pycode import ModuleAnalyzer

    lazy = getattr(fieldmap, "_LAZY", {}).get(name)  # where fieldmap.__init__ takes it from
    first = [lazy if isinstance(lazy, str) else ""]
    for module in first + sorted(m for m in list(sys.modules) if _public(m)):
        if module not in sys.modules:
            continue
        if getattr(sys.modules[module], "__dict__", {}).get(name) is not obj:
            continue
        try:
            if ("", name) in ModuleAnalyzer.for_module(module).find_attr_docs():
                return f"{module}.{name}"
        except PycodeError:
            continue
    return None


def _public(module: str) -> bool:
    """Whether a module is documented by the recursive pages (public, not excluded)."""
    parts = module.split(".")
    return (
        len(parts) > 1
        and parts[0] == "fieldmap"
        and parts[1] not in EXCLUDE
        and not any(p.startswith("_") for p in parts[1:])
    )


def write_api_lists(app=None, config=None) -> None:
    """Write the autosummary lists of the API reference (``api/_toplevel.rst``, ``_modules.rst``).

    Called before autosummary reads the sources, so the stubs it generates always follow the
    package: ``fieldmap.__all__`` for the top level, :mod:`pkgutil` for subpackages and modules.
    Stale stubs of a previous build are removed first.
    """
    out = DOCS / "api"
    shutil.rmtree(out / "generated", ignore_errors=True)

    public = [name for name in fieldmap.__all__ if not name.startswith("_")]
    for name in public:  # import every lazily exported name first, so _canonical sees them
        getattr(fieldmap, name)
    linked, own = [], []
    for name in public:
        target = _canonical(name)
        if target is None or target.rsplit(".", 1)[1] != name:  # a constant or instance
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
            "Other exports (constants, instances, functions exported under another name):",
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
        title = TITLES.get(name) or _first_sentence(importlib.import_module(f"fieldmap.{name}"))
        title = f"{title}: ``fieldmap.{name}``" if title else f"``fieldmap.{name}``"
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


# -- the CLI parser for sphinx-argparse ------------------------------------------------------
_RST_SPECIAL = re.compile(r"([^\w\s.,;()'\"])")


def _inert(text: str | None) -> str | None:
    """Return plain text as reStructuredText that renders as written (one paragraph)."""
    if not text:
        return text
    return _RST_SPECIAL.sub(r"\\\1", " ".join(text.split()))


def cli_parser() -> argparse.ArgumentParser:
    """Return :func:`fieldmap.cli.build_parser` with every help text escaped for the docs.

    argparse re-wraps help texts as one paragraph, so do the docs; ``%(default)s`` and the like
    are expanded first (sphinx-argparse formats the help again, hence the doubled ``%``).
    """
    from fieldmap.cli import build_parser

    parser = build_parser()
    todo = [parser]
    while todo:
        p = todo.pop()
        p.description = _inert(p.description)
        p.epilog = _inert(p.epilog)
        formatter = p._get_formatter()
        for group in p._action_groups:
            group.description = _inert(group.description)
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                for choice in action._choices_actions:
                    choice.help = _inert(choice.help)
                todo.extend(action.choices.values())
                continue
            if action.help and action.help is not argparse.SUPPRESS:
                action.help = _inert(formatter._expand_help(action)).replace("%", "%%")
            if action.choices is not None:
                action.choices = [_inert(str(c)) for c in action.choices]
    return parser


# -- one-line summaries ------------------------------------------------------------------------
#: Abbreviations that do not end the first sentence of a docstring (autosummary's tables show that
#: sentence): the docstrings cite "Chen et al. 2022 Fig. 7", "eq. (13)", "Groves (2013) eq. 3.7.7".
ABBREVIATIONS = tuple(
    f"{lead}{word}."
    for word in ("Fig", "Figs", "fig", "figs", "Eq", "Eqs", "eq", "eqs", "cf", "No", "approx")
    for lead in (" ", "(")
)


def _extend_abbreviations() -> None:
    from sphinx.ext import autosummary

    known = getattr(autosummary, "WELL_KNOWN_ABBREVIATIONS", None)
    if isinstance(known, tuple):
        autosummary.WELL_KNOWN_ABBREVIATIONS = known + ABBREVIATIONS


def drop_object_base(app, name, obj, options, bases: list) -> None:
    """Leave ``object`` out of "Bases:" (every class has it; it says nothing)."""
    bases[:] = [b for b in bases if b is not object]


# -- pages whose code the build runs -----------------------------------------------------------
#: A page holding this comment has its Python blocks run by the build, in order, in one
#: namespace, in the folder it names (relative to the repository's root, where the paths the
#: code names are relative to): ``<!-- the docs build runs the Python blocks of this page in
#: tests/data/flights/ -->``.
RUN_MARKER = re.compile(r"<!-- the docs build runs the Python blocks of this page in (\S*?)/? -->")
ROOT = DOCS.parent


def python_blocks(text: str) -> list[str]:
    """Return the fenced Python blocks of a Markdown page, in order."""
    return re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)


def run_page_code(app, docname: str, source: list[str]) -> None:
    """Run the Python blocks of a page holding :data:`RUN_MARKER`; fail the build if one fails.

    Sphinx's ``source-read`` event, so each build that reads the page runs it (``make docs``
    reads every page: ``-E``). The figures the code draws are closed after it.
    """
    marker = RUN_MARKER.search(source[0])
    if marker is None:
        return
    import contextlib
    import io
    import os
    import time

    import matplotlib
    from sphinx.errors import ExtensionError
    from sphinx.util import logging

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    blocks = python_blocks(source[0])
    if not blocks:
        raise ExtensionError(f"{docname}: marked to run, but holds no Python block")
    namespace: dict = {"__name__": "__main__"}
    here, start = os.getcwd(), time.perf_counter()
    os.chdir(ROOT / marker[1])
    try:
        for k, block in enumerate(blocks, 1):
            try:
                with contextlib.redirect_stdout(io.StringIO()):
                    exec(compile(block, f"{docname} (Python block {k})", "exec"), namespace)
            except Exception as exc:
                raise ExtensionError(
                    f"{docname}: Python block {k} failed: {type(exc).__name__}: {exc}"
                ) from exc
    finally:
        os.chdir(here)
        plt.close("all")
    logging.getLogger(__name__).info(
        f"{docname}: ran its {len(blocks)} Python blocks in {time.perf_counter() - start:.0f} s"
    )


def setup(app):
    """Generate the API lists before autosummary (builder-inited) runs; escape docstrings."""
    app.connect("config-inited", write_api_lists)
    app.connect("source-read", run_page_code)
    app.connect("autodoc-process-docstring", escape_magnitudes, priority=400)
    app.connect("autodoc-process-bases", drop_object_base)
    _extend_abbreviations()
    return {"parallel_read_safe": True, "parallel_write_safe": True}
