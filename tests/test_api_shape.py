"""The public API's shape: no public function or method takes more than 8 parameters.

Walked: every name of ``fieldmap.__all__`` and every public module of ``fieldmap/`` (a module
whose dotted path has no ``_``-prefixed part; ``fieldmap.kernels`` is not walked: Warp kernels
take their launch arrays, they are not the Python API). In each module, the functions it defines
with a public name, and the public methods (instance, class and static) of the classes it
defines with a public name.

Counting: every parameter but ``self``/``cls``; ``*args`` and ``**kwargs`` count one each (a
pass-through hides options, it does not remove them). A class's constructor is not counted: an
options object (a frozen request dataclass) is where many options belong.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import fieldmap

MAX_PARAMETERS = 8

#: Public functions allowed over MAX_PARAMETERS ("module.qualname": parameters): none since the
#: last twelve (the point functions, synthesize, build_table, evaluate_points, the NumPy strapdown
#: references) became ≤ 8 (issue 25). None may be added; the check below stays for the record.
OVER_THE_LIMIT_BEING_FIXED: dict[str, int] = {}


def public_modules() -> list[str]:
    """Return the dotted names of the public modules of fieldmap (kernels excluded)."""
    names = ["fieldmap"]
    for info in pkgutil.walk_packages(fieldmap.__path__, "fieldmap."):
        parts = info.name.split(".")
        if any(p.startswith("_") for p in parts) or parts[1] == "kernels":
            continue
        names.append(info.name)
    return sorted(names)


def _count(fn) -> int | None:
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):  # a builtin without a signature
        return None
    params = list(sig.parameters)
    if params and params[0] in ("self", "cls"):
        params = params[1:]
    return len(params)


def _functions_of(obj, qualname: str):
    """Yield (qualified name, callable) for a public function, or a class's public methods."""
    if inspect.isclass(obj):
        for name, member in vars(obj).items():
            if name.startswith("_"):
                continue
            if isinstance(member, (staticmethod, classmethod)):
                member = member.__func__
            if inspect.isfunction(member):
                yield f"{qualname}.{name}", member
    elif inspect.isfunction(obj):
        yield qualname, obj


def parameter_counts() -> dict[str, int]:
    """Return ``{"module.qualname": parameters}`` for every public function and method walked."""
    seen: dict[str, int] = {}
    candidates = []
    for modname in public_modules():
        module = importlib.import_module(modname)
        for name, obj in vars(module).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != modname:
                continue  # imported from elsewhere: counted where it is defined
            candidates.append(obj)
    candidates += [getattr(fieldmap, name) for name in fieldmap.__all__]
    for obj in candidates:
        if not (inspect.isclass(obj) or inspect.isfunction(obj)):
            continue
        for qualname, fn in _functions_of(obj, f"{obj.__module__}.{obj.__qualname__}"):
            n = _count(fn)
            if n is not None:
                seen[qualname] = n
    return seen


def test_no_public_function_over_eight_parameters():
    counts = parameter_counts()
    over = {q: n for q, n in counts.items() if n > MAX_PARAMETERS}
    print(f"{len(counts)} public functions and methods; over {MAX_PARAMETERS} parameters:")
    for q, n in sorted(over.items(), key=lambda kv: -kv[1]):
        print(f"  {n:3d}  {q}")
    new = sorted(
        f"{q} ({n})"
        for q, n in over.items()
        if n > OVER_THE_LIMIT_BEING_FIXED.get(q, MAX_PARAMETERS)
    )
    assert not new, f"over {MAX_PARAMETERS} parameters (or more than listed): " + ", ".join(new)
    fixed = sorted(q for q in OVER_THE_LIMIT_BEING_FIXED if q not in over)
    assert not fixed, "fixed or gone: remove from OVER_THE_LIMIT_BEING_FIXED: " + ", ".join(fixed)


def test_the_walk_can_fail():
    """The walk sees a module's functions and methods and counts as documented."""

    def f(a, b, *args, c=1, **kw):
        pass

    class K:
        def m(self, a, b, c, d, e, f, g, h, i):
            pass

        @staticmethod
        def s(a):
            pass

        def _private(self, a, b, c, d, e, f, g, h, i):
            pass

    assert _count(f) == 5
    got = dict(_functions_of(K, "K"))
    assert sorted(got) == ["K.m", "K.s"] and _count(got["K.m"]) == 9 and _count(got["K.s"]) == 1
    counts = parameter_counts()
    assert "fieldmap.products.maps.disturbance_map" in counts and len(counts) > 300
