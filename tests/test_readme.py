"""The README's Python API block runs as written (its names, keywords and shapes are current)."""

import importlib
import pathlib
import pkgutil
import re

import fieldmap

README = pathlib.Path(__file__).resolve().parents[1] / "README.md"


def test_python_api_block_runs():
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Python API") :]
    block = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    env: dict = {}
    exec(compile(block, "README.md", "exec"), env)
    assert env["dg"].shape == (1, 3)
    assert env["g"].shape == (1, 3)
    assert env["gam"].shape == (1, 3)
    assert env["N"].shape == (1,) and env["anom"].shape == env["eta"].shape == (1,)
    assert float(env["ds"]["modulus_mg"].max()) > 0


def _readme_api_names() -> set[str]:
    """Top-level names the README calls: ``fieldmap.X`` and those of the "From Python:" lists."""
    text = README.read_text(encoding="utf-8")
    names = set(re.findall(r"\bfieldmap\.([A-Za-z_]\w*)", text))
    # "From Python: `disturbance_map(..., client=client)` (also `altitude_sweep`, ...)"
    for sentence in re.findall(r"From Python:(.*?)(?:\.\s|$)", text, re.S):
        names |= set(re.findall(r"`([A-Za-z_]\w*)[`(]", sentence))
    return names


def test_readme_names_are_public():
    """Every name the README uses from ``fieldmap.`` is in ``fieldmap.__all__`` and importable.

    Module paths (``fieldmap.nav``, ``fieldmap.units``) and the 0.1 module paths the README names
    as deprecated are modules, not names; dotted paths such as
    ``fieldmap.nav.distributed.on_cluster`` must import.
    """
    modules = {m.name for m in pkgutil.iter_modules(fieldmap.__path__)} | {"kernels"}
    names = _readme_api_names()
    text = README.read_text(encoding="utf-8")
    assert {"disturbance_map", "quantity_map"} <= names, sorted(names)
    for name in sorted(names):
        if name.startswith("__"):  # fieldmap.__all__
            continue
        if name in fieldmap._MOVED and name not in fieldmap.__all__:  # an 0.1 module path
            continue
        if name in modules:
            importlib.import_module(f"fieldmap.{name}")
            continue
        assert name in fieldmap.__all__, f"README uses fieldmap.{name}, not in fieldmap.__all__"
        obj = getattr(fieldmap, name)  # the lazy table resolves it (AttributeError if not)
        called = re.search(rf"(?<![\w.])(?:fieldmap\.)?{re.escape(name)}\(", text)
        assert not called or callable(obj), f"README calls fieldmap.{name}(), not callable"
    for path in sorted(set(re.findall(r"\bfieldmap(?:\.[A-Za-z_]\w*){2,}", text))):
        parts = path.split(".")
        for cut in range(len(parts), 0, -1):  # the longest importable module, then attributes
            try:
                obj = importlib.import_module(".".join(parts[:cut]))
                break
            except ModuleNotFoundError:
                continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr)
        assert obj is not None, path
