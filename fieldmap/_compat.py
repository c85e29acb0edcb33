"""Deprecated spellings of the public API kept working for one release (fieldmap 0.2).

fieldmap 0.1 took the options of its point functions positionally, in orders that differed
between functions, and named the same thing differently (``unit=``/``units=``, ``kind=``,
``lat``/``lat_deg``). :func:`keyword_api` keeps such calls working, with a
``DeprecationWarning`` that names the spelling to use; they go in fieldmap 0.3.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import importlib.abc
import importlib.machinery
import inspect
import sys
import types
import warnings
from collections.abc import Callable
from typing import Any, TypeVar, cast

F = TypeVar("F", bound=Callable[..., Any])


def warn(message: str, stacklevel: int = 3) -> None:
    """Issue the ``DeprecationWarning`` of a 0.1 spelling (removed in fieldmap 0.3)."""
    warnings.warn(
        f"{message} (deprecated in fieldmap 0.2, removed in 0.3)",
        DeprecationWarning,
        stacklevel=stacklevel,
    )


def keyword_api(
    ncoords: int, old_order: tuple[str, ...] = (), renamed: dict[str, str] | None = None
) -> Callable[[F], F]:
    """Accept the 0.1 calls of a function whose options are now keyword-only.

    Parameters
    ----------
    ncoords : int
        Number of positional coordinates (3 for latitude, longitude, height).
    old_order : tuple of str
        The 0.1 names of the arguments that followed the coordinates, in their 0.1 order:
        extra positional arguments are bound to them.
    renamed : dict, optional
        0.1 keyword name -> current name (e.g. ``{"unit": "units"}``).
    """
    renamed = renamed or {}

    def decorate(func: F) -> F:
        name = func.__name__

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            notes = []
            if len(args) > ncoords:
                extra = args[ncoords:]
                if len(extra) > len(old_order):
                    raise TypeError(
                        f"{name}() takes {ncoords} positional arguments but {len(args)} were given"
                    )
                names = old_order[: len(extra)]
                notes.append(f"pass {', '.join(names)} by keyword")
                for key, value in zip(names, extra):
                    if key in kwargs:
                        raise TypeError(f"{name}() got multiple values for argument {key!r}")
                    kwargs[key] = value
                args = args[:ncoords]
            for old, new in renamed.items():
                if old in kwargs:
                    if new in kwargs:
                        raise TypeError(f"{name}() got both {old!r} (0.1 name) and {new!r}")
                    notes.append(f"{old}= is now {new}=")
                    kwargs[new] = kwargs.pop(old)
            if notes:
                warn(f"{name}(): {'; '.join(notes)}", stacklevel=3)
            return func(*args, **kwargs)

        return cast(F, wrapper)

    return decorate


def options_api(param: str, options_type: type, first_field: str | None = None) -> Callable[[F], F]:
    """Accept the 0.1 keyword calls of a function whose options now travel as one object.

    Keywords that name fields of ``options_type`` (a frozen dataclass) are folded into the
    function's ``param`` argument (``dataclasses.replace`` of the one given, or of the
    ``options_type(**keywords)``), with a ``DeprecationWarning``.

    Parameters
    ----------
    param : str
        Name of the function's options argument.
    options_type : type
        The frozen dataclass of the options.
    first_field : str, optional
        A value in the place of ``param`` that is no ``options_type`` is the 0.1 value of this
        field (``synthesize(traj, 100.0, ...)``: the rate where the sampling is now).
    """
    names = {f.name for f in dataclasses.fields(options_type)}

    def decorate(func: F) -> F:
        name = func.__name__
        sig = inspect.signature(func)

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            old = {k: kwargs.pop(k) for k in list(kwargs) if k in names and k not in sig.parameters}
            bound = sig.bind_partial(*args, **kwargs)
            given = bound.arguments.get(param)
            if given is not None and not isinstance(given, options_type):
                if first_field is None or first_field in old:
                    raise TypeError(f"{name}() takes {param}={options_type.__name__}(...)")
                old[first_field] = given
                given = None
            if old:
                bound.arguments[param] = (
                    options_type(**old)
                    if given is None
                    else dataclasses.replace(cast(Any, given), **old)
                )
                keys = ", ".join(f"{k}=" for k in old)
                warn(f"{name}(): pass {keys} in {param}={options_type.__name__}(...)")
            return func(*bound.args, **bound.kwargs)

        return cast(F, wrapper)

    return decorate


def folded(
    names: tuple[str, ...], fold: Callable[[dict[str, Any], dict[str, Any]], Any]
) -> Callable[[F], F]:
    """Accept keywords a function no longer takes, folded into those it takes now.

    ``fold(old, kwargs)`` receives the retired keywords of the call (``old``, those given) and
    its other keywords (``kwargs``, to rewrite in place) and returns the advice of the
    ``DeprecationWarning``, or ``(advice, target)``: a callable run with the call's positional
    arguments and the rewritten keywords in place of the function (for an old option the new
    signature has no room for).

    Parameters
    ----------
    names : tuple of str
        The retired keyword names.
    fold : callable
        ``fold(old, kwargs) -> str | tuple[str, callable]``.
    """

    def decorate(func: F) -> F:
        name = func.__name__

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            old = {k: kwargs.pop(k) for k in names if k in kwargs}
            if not old:
                return func(*args, **kwargs)
            advice = fold(old, kwargs)
            target = func
            if isinstance(advice, tuple):
                advice, target = advice
            warn(f"{name}(): {advice}", stacklevel=3)
            return target(*args, **kwargs)

        return cast(F, wrapper)

    return decorate


def grouped_api(old_order: tuple[str, ...], groups: dict[str, tuple[str, ...]]) -> Callable[[F], F]:
    """Accept the 0.2 calls of a function whose arguments now travel in groups (tuples).

    A call that passes something else than a tuple where a group goes, more positional
    arguments than the function takes, or a member of a group by keyword, is bound to the 0.2
    names ``old_order``; each group's members become its tuple, with a ``DeprecationWarning``.

    Parameters
    ----------
    old_order : tuple of str
        The 0.2 positional parameters, in order.
    groups : dict
        New parameter -> the 0.2 parameters it holds, in order
        (``{"increments": ("dtheta", "dv", "dt")}``).
    """
    members = {m for ms in groups.values() for m in ms}

    def decorate(func: F) -> F:
        name = func.__name__
        positional = [
            p.name
            for p in inspect.signature(func).parameters.values()
            if p.kind is inspect.Parameter.POSITIONAL_OR_KEYWORD
        ]
        at = [positional.index(g) for g in groups]

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            grouped = all(isinstance(args[i], tuple) for i in at if i < len(args))
            if grouped and len(args) <= len(positional) and not members.intersection(kwargs):
                return func(*args, **kwargs)
            if len(args) > len(old_order):
                raise TypeError(f"{name}() takes at most {len(old_order)} positional arguments")
            bound = dict(zip(old_order, args))
            for key, value in kwargs.items():
                if key in bound:
                    raise TypeError(f"{name}() got multiple values for argument {key!r}")
                bound[key] = value
            for new, group in groups.items():
                missing = [m for m in group if m not in bound]
                if missing:
                    raise TypeError(f"{name}() missing 0.2 argument(s) {', '.join(missing)}")
                bound[new] = tuple(bound.pop(m) for m in group)
            notes = ", ".join(f"{new}=({', '.join(g)})" for new, g in groups.items())
            warn(f"{name}(): pass {notes}", stacklevel=3)
            return func(**bound)

        return cast(F, wrapper)

    return decorate


#: the advice of a 0.2 ``lmax=``/``epoch=`` (:func:`model_api`)
MODEL_OPTIONS_ADVICE = (
    "belong to the model: pass model=load_model(name, lmax=..., epoch=...) or model.truncated(lmax)"
)


def model_api(apply: Callable[..., Any]) -> Callable[[F], F]:
    """Accept the 0.2 ``lmax=``/``epoch=`` of a point function: model options, on the model.

    They are folded into its ``model=`` by ``apply(model, lmax=, epoch=)``
    (:func:`fieldmap.field.gravity.apply_model_options`: the same bits, the kernels read
    degrees 0..lmax only), with a ``DeprecationWarning`` naming
    ``model=load_model(name, lmax=, epoch=)`` or ``model.truncated(lmax)``.
    """

    def decorate(func: F) -> F:
        default = inspect.signature(func).parameters["model"].default

        def fold(old: dict[str, Any], kwargs: dict[str, Any]) -> str:
            kwargs["model"] = apply(kwargs.get("model", default), **old)
            return " and ".join(f"{k}=" for k in old) + " " + MODEL_OPTIONS_ADVICE

        return folded(("lmax", "epoch"), fold)(func)

    return decorate


#: Old module paths (relative to ``fieldmap``) -> the module(s) that hold their public names
#: now. A tuple lists several new homes of one old module (it was split or merged); its names are
#: looked up in them in order. Importing an old path warns and yields the new module (or, for a
#: tuple, a module that forwards attribute lookups); the old paths go in fieldmap 0.3.
MOVED: dict[str, str | tuple[str, ...]] = {
    # fieldmap 0.1: a flat package
    "icgem": "models.icgem",
    "_gfc_scan": "models.icgem",
    "model": "models.shmodel",
    "geographiclib": "models.geographiclib",
    "ellipsoid": "field.ellipsoid",
    "normal": "field.normal",
    "sh": "field.sh",
    "gravity": "field.gravity",
    "frames": "field.frames",
    "gridspec": "grids.spec",
    "grid": "grids.synthesis",
    "longitude": "grids.longitude",
    "maps": "products.maps",
    "stats": "products.statistics",
    "cf": "products.variables",
    "io": "products.io",
    "plots": "products.plots",
    "coastline": "products.coastline",
    "launch_frames": "nav.frames",
    "strapdown": "nav.mechanize",
    "strapdown_ned": "nav.mechanize",
    "imu": "nav.imu",
    "imu_errors": "nav.sensors",
    "trajectory": "nav.trajectory",
    "navsim": ("nav.paper", "nav.study"),
    "navplots": "nav.plots",
    "forcened": "nav.frames",
    "cli_maps": "cli.maps",
    "cli_nav": "cli.nav",
    "cli_point": "cli.point",
    "verify": "cli.verify",
    # fieldmap 0.2: the flight logs, one module per step (fieldmap.nav.logs)
    "nav.readers": "nav.logs.read",
    "nav.readers_parsed": "nav.logs.read",
    "nav.readers_tables": "nav.logs.read",
    "nav.readers_gnss": "nav.logs.read",
    "nav.readers_formats": "nav.logs.read",
    "nav.readers_heights": "nav.logs.read",
    "nav.conditioning": ("nav.logs.condition", "nav.logs.report"),
    "nav.conditioning_fit": "nav.logs.fit",
    "nav.conditioning_stages": "nav.logs.condition",
    "nav.conditioning_steps": "nav.logs.condition",
    "nav.conditioning_report": "nav.logs.report",
    "nav.flightlog": "nav.logs",
    # fieldmap 0.2: the composition of the steps is the package's own (issue 25)
    "nav.logs.load": "nav.logs",
    # fieldmap 0.2: every format a log comes in is read, into its records, in one module (issue 25)
    "nav.logs.gnss": "nav.logs.read",
    "nav.logs.track": "nav.logs.read",
    # fieldmap 0.2: every trajectory a study flies, closed-form or sampled, in one module (issue 25)
    "nav.flight": "nav.trajectory",
    # fieldmap 0.2: nav/ regrouped by concept (issue 25)
    "nav.launch_frames": "nav.frames",
    "nav.forcened": "nav.frames",
    "nav.flightsamples": "nav.trajectory",
    "nav.imu_errors": "nav.sensors",
    "nav.imu_specs": "nav.sensors",
    "nav.allan": "nav.sensors",
    "nav.navgravity": "nav.gravity",
    "nav.tablegravity": "nav.gravity",
    "nav.trackgravity": "nav.gravity",
    "nav.batch": "nav.mechanize",
    "nav.strapdown": ("nav.mechanize", "nav.gravity"),
    "nav.strapdown_ned": "nav.mechanize",
    "nav.scenario": "nav.study",
    "nav.flightblocks": "nav.study",
    "nav.flighterrors": "nav.study",
    "nav.flightsim": ("nav.study", "nav.propagator"),
    "nav.datasets": "nav.study",
    "nav.studies": ("nav.paper", "nav.study", "nav.propagator"),
    "nav.plotparts": "nav.plots",
    "nav.plots_montecarlo": "nav.plots",
    "nav.flightplots": "nav.plots",
    # fieldmap 0.2: products/ regrouped by concept
    "products.stats": "products.statistics",
    "products.blockstats": "products.statistics",
    "products.cf": "products.variables",
    "products.quantity_product": "products.variables",
    "products.blockmeta": "products.variables",
    "products.summary": "products.variables",
    "products.quantity_maps": ("products.maps", "products.variables", "products.plots"),
    "products.blocks": ("products.engine", "products.variables"),
    "products.cluster": "cluster",
    "products.lazy": "products.engine",
    "products.distributed": ("products.engine", "products.sinks", "products.request"),
    "products.blockio": ("products.sinks", "products.variables"),
    "products.blockstore": "products.sinks",
    "products.mapaxes": "products.plots",
    "products.studyplots": "products.plots",
    "products.table": "products.tables.build",
    "products.table_io": "products.tables.files",
    "products.table_model": "products.tables.model",
    # fieldmap 0.2: the SH device code in one module (the struct, both ranges, the kernels)
    "kernels.sh_model": "kernels.sh",
    "kernels.sh_xrange": "kernels.sh",
    "kernels.navtable": "kernels.navgravity",
    "kernels.sensor_errors": "kernels.strapdown",
    "kernels.launch_frames": "kernels.frames",
    # fieldmap 0.2: one module per sub-command
    "cli.navflight": "cli.nav",
    "cli.navoptions": "cli.nav",
    # fieldmap 0.2: the table that words library errors for the command line is main()'s (issue 25)
    "cli.params": "cli",
}


def moved_targets(old: str) -> tuple[str, ...]:
    """Full module names that now hold the names of ``fieldmap.<old>``."""
    new = MOVED[old]
    return tuple("fieldmap." + n for n in ((new,) if isinstance(new, str) else new))


class _Forward(types.ModuleType):
    """An old module split into several: attribute lookups go to each new home in order."""

    def __init__(self, name: str, targets: tuple[str, ...]):
        super().__init__(name)
        self.__targets = targets

    def __getattr__(self, attr: str) -> Any:
        for target in self.__targets:
            module = importlib.import_module(target)
            if hasattr(module, attr):
                return getattr(module, attr)
        raise AttributeError(f"module {self.__name__!r} has no attribute {attr!r}")

    def __dir__(self) -> list[str]:
        names: set[str] = set()
        for target in self.__targets:
            names.update(dir(importlib.import_module(target)))
        return sorted(names)


class _AliasLoader(importlib.abc.Loader):
    def __init__(self, fullname: str, targets: tuple[str, ...]):
        self.fullname = fullname
        self.targets = targets

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        if len(self.targets) == 1:
            return importlib.import_module(self.targets[0])
        return _Forward(self.fullname, self.targets)

    def exec_module(self, module: types.ModuleType) -> None:
        pass


class _MovedFinder(importlib.abc.MetaPathFinder):
    """Import an old ``fieldmap.<old>`` path as the module(s) that replaced it."""

    def find_spec(
        self, fullname: str, path: Any = None, target: Any = None
    ) -> importlib.machinery.ModuleSpec | None:
        head, _, old = fullname.partition(".")
        if head != "fieldmap" or old not in MOVED:
            return None
        targets = moved_targets(old)
        warnings.warn(
            f"{fullname} moved to {' and '.join(targets)} in fieldmap 0.2; "
            "the old path goes in 0.3",
            DeprecationWarning,
            stacklevel=3,
        )
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(fullname, targets))


def install_moved_finder() -> None:
    """Put the finder of old module paths on ``sys.meta_path`` (once; after the path finder)."""
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        sys.meta_path.append(_MovedFinder())


#: Names of a package that moved into one of its modules: package (relative to ``fieldmap``) ->
#: (module now holding them, the names). ``fieldmap.models`` was, in 0.1, the module now called
#: ``fieldmap.models.registry``.
MOVED_NAMES: dict[str, tuple[str, tuple[str, ...]]] = {
    # the "table:FILE" model name is parsed where model names are (issue 25)
    "products.tables.model": ("models.registry", ("table_path", "PREFIX=TABLE_PREFIX")),
    "models": (
        "models.registry",
        ("load_model", "kaula_model", "clear_cache", "BUNDLED", "DEFAULT_MODEL"),
    ),
    # the central-difference tensor is the reference of the synthesis (issue 28)
    "field.gradient": ("reference.gradient", ("STEP",)),
    # the Legendre rows are the basis of the commission σ too, production code (issue 25)
    "reference.sh": ("field.legendre", ("legendre_rows",)),
}


def moved_names(package: str) -> Callable[[str], Any]:
    """Return the module ``__getattr__`` (PEP 562) of ``fieldmap.<package>``'s moved names.

    Each lookup of a moved name warns (``DeprecationWarning``) and gives the name from its home.
    """
    home, names = MOVED_NAMES[package]
    # "OLD=NEW": a name renamed in its new home
    renamed: dict[str, str] = {n.split("=")[0]: n.split("=")[-1] for n in names}

    def __getattr__(name: str) -> Any:
        if name not in renamed:
            raise AttributeError(f"module 'fieldmap.{package}' has no attribute {name!r}")
        new = renamed[name]
        warn(f"fieldmap.{package}.{name} is fieldmap.{home}.{new}", stacklevel=3)
        return getattr(importlib.import_module(f"fieldmap.{home}"), new)

    return __getattr__
