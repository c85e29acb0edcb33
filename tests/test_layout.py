"""The package layout: public names, 0.1 module paths kept as aliases, no import cycles."""

import ast
import pathlib
import subprocess
import sys
import warnings

import pytest

import fieldmap
from fieldmap import _compat

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


@pytest.mark.parametrize("old", sorted(fieldmap._MOVED))
def test_old_module_paths_still_import(old):
    """An old path warns, names its new home(s), and gives their public names."""
    targets = _compat.moved_targets(old)
    code = (
        "import warnings, importlib, sys\n"
        "warnings.simplefilter('error')\n"
        f"try:\n    importlib.import_module('fieldmap.{old}')\nexcept DeprecationWarning as e:\n"
        "    print('warned', e)\n"
        "warnings.simplefilter('ignore')\n"
        f"m = importlib.import_module('fieldmap.{old}')\n"
        f"targets = {targets!r}\n"
        "news = [importlib.import_module(t) for t in targets]\n"
        "if len(news) == 1:\n"
        "    print(m is news[0])\n"
        "else:\n"
        "    names = [n for t in news for n in dir(t) if not n.startswith('_')]\n"
        "    print(all(getattr(m, n) is not None for n in names) and bool(names))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    lines = out.stdout.splitlines()
    assert lines[0].startswith(f"warned fieldmap.{old} moved to {' and '.join(targets)}")
    assert lines[-1] == "True"


def test_old_gravity_path_keeps_public_function():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from fieldmap.gravity import disturbance  # noqa: F401  (0.1 path)
    assert callable(fieldmap.gravity) and fieldmap.gravity.__name__ == "gravity"
    from fieldmap.models import load_model

    assert load_model is fieldmap.load_model


def _module_imports(path: pathlib.Path) -> set[str]:
    """All fieldmap modules a module imports: at import time and inside functions (ast.walk).

    A deferred import inside a function still ties the two modules together: a cycle through
    one (as ``grid._load`` imported by ``longitude`` once was) is a cycle of the design.
    """
    tree = ast.parse(path.read_text())
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("fieldmap"):
            out.add(node.module)
            for a in node.names:
                out.add(f"{node.module}.{a.name}")
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("fieldmap"))
    return out


def test_no_import_cycles():
    """No two modules of fieldmap import each other, directly or in a ring.

    Every import counts, those inside functions included.
    """
    mods = {}
    for p in PKG.rglob("*.py"):
        rel = p.relative_to(PKG.parent).with_suffix("")
        name = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        mods[name] = p
    graph = {m: {d for d in _module_imports(p) if d in mods and d != m} for m, p in mods.items()}
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


def test_kernels_only_imported_by_fieldmap():
    """kernels/ holds Warp code only: it never imports the host-side package."""
    kdir = PKG.parent / "kernels"
    for p in kdir.glob("*.py"):
        for dep in _module_imports(p):
            assert dep.startswith("fieldmap.kernels"), f"{p.name} imports {dep}"
