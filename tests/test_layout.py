"""Rules of the layout that protect its ideas (no test here counts modules, lines or parameters).

- the top level's names resolve, and ``import fieldmap`` stays light;
- no import cycles: no two modules import each other, directly or in a ring;
- kernels apart from host code: ``kernels/`` (Warp code) never imports the host-side package;
- no private names across modules: no module takes a ``_name`` another module defines, and
  none re-exports names it does not define (a split that cuts one idea in two shows as either);
- tests read only what ships with them.
"""

import ast
import pathlib
import re
import subprocess
import sys

import fieldmap

PKG = pathlib.Path(fieldmap.__file__).parent


def test_all_names_resolve():
    for name in fieldmap.__all__:
        assert getattr(fieldmap, name) is not None, name
    assert set(fieldmap.__all__) <= set(dir(fieldmap))


def test_import_is_light():
    heavy = "('warp', 'xarray', 'matplotlib')"
    code = f"import fieldmap, sys; print(sorted(m for m in {heavy} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


ROOT = PKG.parent
#: kernels/ is installed as fieldmap.kernels (pyproject's package-dir)
KERNELS = ("fieldmap", "kernels")


def _package_modules(root: pathlib.Path) -> dict[str, pathlib.Path]:
    """Dotted name -> file of every module of ``fieldmap/`` and ``kernels/`` under ``root``.

    ``kernels/`` is installed as ``fieldmap.kernels`` (pyproject's package-dir) and named so.
    """
    out = {}
    for folder, prefix in ((root / "fieldmap", ("fieldmap",)), (root / "kernels", KERNELS)):
        for p in sorted(folder.rglob("*.py")):
            rel = p.relative_to(folder).with_suffix("").parts
            out[".".join(prefix + (rel[:-1] if rel[-1] == "__init__" else rel))] = p
    return out


def _imports(path: pathlib.Path, name: str):
    """Yield ``(line, module, imported name or None, bound name)`` for every import of a module.

    Every import counts, those inside functions included; a relative import (``from .x import
    y``, ``from . import x``, ``from .. import x``: the only kind ``kernels/`` uses) is resolved
    against the module's own dotted ``name`` (a package's ``__init__`` is the package itself).
    """
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            for a in node.names:
                yield node.lineno, module, a.name, a.asname or a.name
        elif isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name, None, a.asname or a.name.split(".")[0]


def _module_imports(path: pathlib.Path, name: str) -> set[str]:
    """All fieldmap modules (and ``module.name`` candidates) a module imports.

    A deferred import inside a function still ties the two modules together: a cycle through
    one (as ``grid._load`` imported by ``longitude`` once was) is a cycle of the design.
    """
    out = set()
    for _, module, item, _bound in _imports(path, name):
        if module == "fieldmap" or module.startswith("fieldmap."):
            out.add(module)
            if item is not None:
                out.add(f"{module}.{item}")
    return out


def test_no_import_cycles():
    """No two modules of fieldmap import each other, directly or in a ring.

    Every import counts, those inside functions included.
    """
    mods = _package_modules(ROOT)
    graph = {m: {d for d in _module_imports(p, m) if d in mods and d != m} for m, p in mods.items()}
    # packages' __init__ that only document are leaves; walk for rings
    state = {}

    def visit(m, stack):
        state[m] = 1
        for d in graph[m]:
            if state.get(d) == 1:
                raise AssertionError("import cycle: " + " -> ".join(stack + [m, d]))
            if d not in state:
                visit(d, stack + [m])
        state[m] = 2

    for m in graph:
        if m not in state:
            visit(m, [])


def _kernel_violations(root: pathlib.Path) -> list[str]:
    """List the imports of host-side fieldmap modules by ``kernels/`` (relative or absolute)."""
    bad = []
    for name, path in _package_modules(root).items():
        if name.split(".")[:2] != list(KERNELS):
            continue
        for line, module, item, _ in _imports(path, name):
            target = module if item is None else f"{module}.{item}"
            inside = target.split(".")[:2] == list(KERNELS)
            if (module == "fieldmap" or module.startswith("fieldmap.")) and not inside:
                bad.append(f"{path.name}:{line} imports {target}")
    return bad


def test_kernels_apart_from_host_code():
    """kernels/ holds Warp code only: it never imports the host-side package."""
    assert _kernel_violations(ROOT) == []


# -- one idea per module: no sibling's private names, no re-exports ---------------------------
#
# What a line cap (once 450 lines a module) was meant to protect: a split that cuts one idea in
# two shows as a module importing a sibling's ``_private`` names, or as ``import X as X``
# re-exports. Both are refused here. The allow-lists hold the violations of the day these tests
# were written (the regrouping of nav/ and products/ removes them): they must only shrink, and a
# test fails when an entry no longer exists, so a fixed entry leaves the list.


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_imports(root: pathlib.Path) -> dict[str, set[str]]:
    """Map each module to the ``_names`` it takes from another fieldmap module.

    Counted: ``from M import _name`` (relative imports resolved) and ``alias._name`` where
    ``alias`` is bound to a fieldmap module by an import. Not counted: a private *module*
    (``from fieldmap import _warp``, ``fieldmap._version``,
    ``fieldmap.kernels._x``): an underscore module is a helper private to the fieldmap package
    as a whole, which any module of it may import; the rule is about ``_names`` defined inside
    another module (its own implementation details). Dunder names are not private.
    """
    mods = _package_modules(root)
    out: dict[str, set[str]] = {}
    for name, path in mods.items():
        bound = {}  # local name -> fieldmap module it stands for
        for _, module, item, local in _imports(path, name):
            if not (module == "fieldmap" or module.startswith("fieldmap.")):
                continue
            if item is None:  # import a.b.c binds a; import a.b.c as d binds a.b.c
                target = local if local == module.split(".")[0] else module
            else:
                target = f"{module}.{item}"
            if target in mods:
                bound[local] = target
            elif item is not None and _is_private(item):
                out.setdefault(name, set()).add(target)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.Attribute) and _is_private(node.attr)):
                continue
            chain, base = [], node.value  # alias.sub.mod._name: resolve alias.sub.mod
            while isinstance(base, ast.Attribute):
                chain.insert(0, base.attr)
                base = base.value
            if isinstance(base, ast.Name) and base.id in bound:
                owner = ".".join([bound[base.id], *chain])
                if owner in mods and f"{owner}.{node.attr}" not in mods:
                    out.setdefault(name, set()).add(f"{owner}.{node.attr}")
    return out


def _defined_names(tree: ast.Module) -> set[str]:
    """Return the names a module defines at its top level (imports are not definitions)."""
    names = set()
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                names.update(n.id for n in ast.walk(t) if isinstance(n, ast.Name))
        elif isinstance(node, (ast.If, ast.Try, ast.With)):  # conditional definitions
            todo += [*node.body, *getattr(node, "orelse", []), *getattr(node, "finalbody", [])]
            for h in getattr(node, "handlers", []):
                todo += h.body
    return names


def _all_names(tree: ast.Module) -> set[str]:
    """Return the strings written in a module's ``__all__`` (not its starred parts)."""
    names = set()
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                starred = {id(n) for s in ast.walk(node) if isinstance(s, ast.Starred)
                           for n in ast.walk(s)}  # fmt: skip
                names.update(
                    n.value
                    for n in ast.walk(node.value)
                    if isinstance(n, ast.Constant)
                    and isinstance(n.value, str)
                    and id(n) not in starred
                )
    return names


#: ``fieldmap/__init__.py`` is the top-level public face: the names below are imported there
#: with ``X as X`` (light, always-loaded names: the version, the errors, the ellipsoids), and
#: every other public name goes through its ``_LAZY`` table (name -> defining module, resolved by
#: its ``__getattr__``, PEP 562) and the ``*_LAZY`` part of its ``__all__``. Nothing else is
#: re-exported there, and no other module re-exports at all.
TOP_LEVEL_FACE = frozenset(
    {"__version__", "FieldmapError", "InputError", "ModelFileError", "Ellipsoid", "WGS84", "GRS80"}
)


def _reexports(root: pathlib.Path) -> dict[str, set[str]]:
    """Map each module to the names it re-exports without defining them.

    Counted: ``from M import y as y`` and ``import x as x`` (the explicit re-export idiom of
    PEP 484), a string in ``__all__`` that the module does not define, and a module-level
    ``__getattr__`` (PEP 562 forwarding). Exception: in ``fieldmap/__init__.py`` the
    :data:`TOP_LEVEL_FACE` imports and its ``__getattr__`` (the ``_LAZY`` table).
    """
    out: dict[str, set[str]] = {}
    for name, path in _package_modules(root).items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        top = name == "fieldmap"
        found = set()
        for _, module, item, local in _imports(path, name):
            plain = item if item is not None else module
            if (
                local == plain
                and local != "*"
                and any(
                    isinstance(n, (ast.Import, ast.ImportFrom))
                    and any(a.asname == local for a in n.names)
                    for n in tree.body
                )
            ):
                found.add(local)
        found |= _all_names(tree) - _defined_names(tree)
        if any(isinstance(n, ast.FunctionDef) and n.name == "__getattr__" for n in tree.body):
            found.add("__getattr__")
        for n in tree.body:  # __getattr__ = f(...) forwards as well
            if isinstance(n, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "__getattr__" for t in n.targets
            ):
                found.add("__getattr__")
        if top:
            found -= TOP_LEVEL_FACE | {"__getattr__"}
        if found:
            out[name] = found
    return out


#: Today's imports of a sibling's private names (module -> "defining module._name"). Must only
#: shrink: remove an entry when the regrouping fixes it; never add one.
PRIVATE_IMPORTS_BEING_FIXED: dict[str, frozenset[str]] = {}
#: Today's re-exports (module -> names). Must only shrink, as above.
REEXPORTS_BEING_FIXED: dict[str, frozenset[str]] = {}


def _against(found: dict[str, set[str]], allowed: dict[str, frozenset[str]]) -> tuple[list, list]:
    """Return (violations not allowed, allowed entries no longer found)."""
    new = sorted(f"{m}: {n}" for m, ns in found.items() for n in ns - allowed.get(m, frozenset()))
    gone = sorted(f"{m}: {n}" for m, ns in allowed.items() for n in ns - found.get(m, set()))
    return new, gone


def test_no_private_names_imported_across_modules():
    """No module of fieldmap/ or kernels/ takes a ``_name`` defined in another module."""
    new, gone = _against(_private_imports(ROOT), PRIVATE_IMPORTS_BEING_FIXED)
    assert not new, "imports of another module's private names:\n" + "\n".join(new)
    assert not gone, "fixed: remove from PRIVATE_IMPORTS_BEING_FIXED:\n" + "\n".join(gone)


def test_no_reexports():
    """No module re-exports names it does not define (the top level's lazy table aside)."""
    new, gone = _against(_reexports(ROOT), REEXPORTS_BEING_FIXED)
    assert not new, "re-exported names (define them, or import from their home):\n" + "\n".join(new)
    assert not gone, "fixed: remove from REEXPORTS_BEING_FIXED:\n" + "\n".join(gone)


def _plant(root: pathlib.Path, files: dict[str, str]) -> pathlib.Path:
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return root


def test_layout_checks_catch_planted_violations(tmp_path):
    """The checks above fail on a planted violation of each kind (they can fail)."""
    root = _plant(
        tmp_path,
        {
            "fieldmap/__init__.py": (
                "from fieldmap.e import InputError as InputError\nfrom fieldmap.a import g as g\n"
            ),
            "fieldmap/_warp.py": "def init():\n    pass\n",
            "fieldmap/sub/__init__.py": "",
            "fieldmap/sub/a.py": "def _p():\n    pass\n\n\ndef f():\n    pass\n",
            "fieldmap/sub/b.py": (
                "from fieldmap import _warp\nfrom fieldmap.sub.a import _p\nfrom . import a\n"
                "from .a import f as f\n__all__ = ['f', 'h']\n\n\ndef h():\n    a._p()\n"
            ),
            "fieldmap/sub/c.py": (
                "from ..sub import a as mod\nimport fieldmap.sub.a\nimport fieldmap\n"
                "x = mod._q\ny = fieldmap.sub.a._r\nz = fieldmap._LAZY\n"
            ),
            "fieldmap/d.py": "def __getattr__(name):\n    return name\n",
            "kernels/k.py": "from .j import _ok\nfrom .. import sub\n",
            "kernels/j.py": "from ..sub.a import f\nimport fieldmap.kernels.k\n",
        },
    )
    assert _kernel_violations(root) == [
        "j.py:1 imports fieldmap.sub.a.f",
        "k.py:2 imports fieldmap.sub",
    ]
    assert _private_imports(root) == {
        "fieldmap.sub.b": {"fieldmap.sub.a._p"},
        "fieldmap.sub.c": {"fieldmap.sub.a._q", "fieldmap.sub.a._r", "fieldmap._LAZY"},
        "fieldmap.kernels.k": {"fieldmap.kernels.j._ok"},
    }
    assert _reexports(root) == {
        "fieldmap": {"g"},
        "fieldmap.sub.b": {"f"},
        "fieldmap.d": {"__getattr__"},
    }
    new, gone = _against({"m": {"x", "y"}}, {"m": frozenset({"x", "z"}), "n": frozenset({"w"})})
    assert new == ["m: y"] and gone == ["m: z", "n: w"]


#: A string that names a place outside the repository (a test must read only what ships with it)
FIXED_PATH = re.compile(r"^(?:/(?:tmp|home|root|work|mnt|opt|srv|data|scratch|var)/|[A-Za-z]:\\)")


def _fixed_paths(folder: pathlib.Path) -> list[str]:
    """List the string literals of the test files that are absolute paths outside the repository.

    Docstrings are prose, not reads: they are not counted.
    """
    out = []
    for p in sorted(folder.rglob("*.py")):
        tree = ast.parse(p.read_text(encoding="utf-8"))
        docs = {
            id(n.value)
            for n in ast.walk(tree)
            if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)
        }
        for n in ast.walk(tree):
            if (
                isinstance(n, ast.Constant)
                and isinstance(n.value, str)
                and id(n) not in docs
                and FIXED_PATH.match(n.value)
            ):
                out.append(f"{p.relative_to(folder).as_posix()}:{n.lineno}: {n.value!r}")
    return out


def test_no_fixed_paths_outside_the_repository(tmp_path):
    """No test reads a fixed path such as /tmp/...: its data ship under tests/data/."""
    assert _fixed_paths(ROOT / "tests") == []
    (tmp_path / "test_x.py").write_text(
        '"""Docs may say /tmp/notes.md."""\nfrom pathlib import Path\n\n'
        'DATA = Path("/tmp/traffic/samples")\n'
    )
    assert _fixed_paths(tmp_path) == ["test_x.py:4: '/tmp/traffic/samples'"]


def test_strict_typing_list_names_existing_modules():
    """Every module pyproject holds to ``disallow_untyped_defs`` exists (moved: rename it there).

    mypy only notes an override naming a module that is gone, so strictness would lapse unseen
    when a module moves; this list must follow the module, and never shrink.
    """
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    strict = [
        m
        for o in config["tool"]["mypy"]["overrides"]
        if o.get("disallow_untyped_defs")
        for m in ([o["module"]] if isinstance(o["module"], str) else o["module"])
    ]
    assert len(strict) >= 17, strict
    mods = _package_modules(ROOT)
    assert [m for m in strict if m not in mods] == []
