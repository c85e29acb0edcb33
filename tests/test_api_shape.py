"""The public API shows its options: what a user calls names them in its signature.

``help()``, ``inspect.signature`` and an IDE read a function's signature; options hidden in
``**options`` or ``*args`` are options none of them shows. Walked: every function and class of
``fieldmap.__all__`` (a class: its constructor and public methods) and the request builder
:meth:`fieldmap.products.request.MapRequest.build`. A frozen request's ``replace``-style copy
(``MapRequest.replace``, ``executing``) takes the changed fields by name, as
``dataclasses.replace`` does, and an exception its message as ``*args``: neither is walked.
"""

from __future__ import annotations

import inspect
import pydoc

import pytest

import fieldmap
from fieldmap.products.request import MapRequest

#: Methods that copy a frozen object with changed fields (``dataclasses.replace``'s shape).
COPIES = {"MapRequest.replace", "MapRequest.executing"}


def hidden_options(fn) -> list[str]:
    """Return the ``*args``/``**kwargs`` parameters of ``fn`` (options no signature shows)."""
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):  # a builtin without a signature
        return []
    kinds = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    return [p.name for p in params if p.kind in kinds]


def public_callables() -> dict[str, object]:
    """Return ``{"name": callable}`` for the top level's functions, constructors and methods."""
    out: dict[str, object] = {"MapRequest.build": MapRequest.build}
    for name in fieldmap.__all__:
        obj = getattr(fieldmap, name)
        if inspect.isfunction(obj):
            out[name] = obj
        elif (
            inspect.isclass(obj)
            and obj.__module__.startswith("fieldmap.")
            and not issubclass(obj, BaseException)  # an exception's message is its *args
        ):
            out[f"{name}.__init__"] = obj
            for attr, member in vars(obj).items():
                if isinstance(member, (staticmethod, classmethod)):
                    member = member.__func__
                if not attr.startswith("_") and inspect.isfunction(member):
                    out[f"{name}.{attr}"] = member
    return out


def test_public_functions_name_their_options():
    hidden = {
        name: found
        for name, fn in public_callables().items()
        if name not in COPIES and (found := hidden_options(fn))
    }
    assert not hidden, f"options hidden in *args/**kwargs: {hidden}"


def test_the_walk_sees_what_it_must_and_can_fail():
    def f(a, *, b=1, **options):
        pass

    def g(a, *args):
        pass

    assert hidden_options(f) == ["options"] and hidden_options(g) == ["args"]
    walked = public_callables()
    assert {"disturbance_map", "run_flight", "FlightStudy.__init__", "MapRequest.build"} <= set(
        walked
    )


MAPS = ["disturbance_map", "altitude_sweep", "truncation_map", "component_maps", "quantity_map"]


@pytest.mark.parametrize("name", MAPS)
def test_map_signatures_show_typed_keyword_options(name):
    """``inspect.signature(fieldmap.disturbance_map)`` and ``help()`` show every option."""
    func = getattr(fieldmap, name)
    params = inspect.signature(func).parameters
    expected = {"height_km", "step_deg", "lat_max", "region", "ellipsoid", "device", "client"}
    assert expected <= set(params), sorted(params)
    for p in params.values():
        assert p.annotation is not p.empty, f"{name}: {p.name} has no type"
        if p.name not in ("model", "quantity"):
            assert p.kind is p.KEYWORD_ONLY, f"{name}: {p.name} is not keyword-only"
    text = pydoc.render_doc(func, renderer=pydoc.plaintext)
    assert "height_km" in text and "step_deg" in text


def test_disturbance_map_options_are_the_requests():
    """Every option of the map façades is an option of the request that validates them."""
    build = set(inspect.signature(MapRequest.build).parameters)
    for name in ("disturbance_map", "altitude_sweep", "truncation_map", "component_maps"):
        assert set(inspect.signature(getattr(fieldmap, name)).parameters) <= build, name
    quantity = set(inspect.signature(fieldmap.quantity_map).parameters) - {"quantity"}
    assert quantity <= build
