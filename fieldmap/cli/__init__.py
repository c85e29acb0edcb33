"""Command-line entry point ``fieldmap``.

Each sub-command lives in its own module exposing ``register(subparsers)``; that function adds
the sub-parser and sets ``func`` (called with the parsed namespace, returns an exit status).
Every :class:`fieldmap.errors.FieldmapError` (and ``OSError`` on output) becomes one line on
stderr and exit status 2, never a traceback; so do bad option values found by argparse (no usage
block) and a missing optional dependency (the line names the module and the extra to install).
An option that does not apply in the context given (``navsim --block-s`` with ``--study``) is
refused the same way, never silently ignored: :func:`given` tells an option the user typed from
one left at its default.
Exit statuses: 0 success; 1 ``fieldmap point`` with bad input lines, or ``verify`` with a failed
check; 2 bad input; 3 an unexpected internal error (one line; set ``FIELDMAP_DEBUG=1`` for the
traceback); 130 interrupted (Ctrl-C); 143 terminated (SIGTERM). Interrupted or terminated runs
leave no partial output files (see :mod:`fieldmap.products.io`).

The one line of an error names the command's options where the library's message names its
keyword arguments, from one table (:data:`OPTIONS`). The library words its messages for a Python
caller and builds those that name a keyword from parts (the keyword references of
:mod:`fieldmap.errors`: ``Keyword``, ``Label``, ``Setting``, ``Advice``), and an
:class:`~fieldmap.errors.InputError` about one keyword carries its name as ``param``. The command
line gives its :class:`~fieldmap.errors.Wording` (:func:`wording_of`: the command's options of
:data:`OPTIONS`, the advice of its switches of :data:`ADVICE`) and the message words itself
(errors in :func:`main`, the notes of a conditioning report in :mod:`fieldmap.cli.nav`):
``(max_gap_s)`` becomes ``(--max-gap-s)``, ``pass airborne_only=False`` becomes ``leave out
--airborne-only``, ``frame='ned'`` becomes ``--frame ned``; an advice whose keyword the command
has no option for is left out. Nothing is found in the text of a message: the parts say what is
a keyword.

A command offers a subset of the options: ``fieldmap navsim`` all of them (:func:`options_of`),
``fieldmap table --corridor`` none (it reads the flight with the defaults).
``tests/test_params.py`` fails when a keyword that a message in :mod:`fieldmap.nav` is about
(``param=``, a keyword reference), or a keyword of the log functions or of
:class:`~fieldmap.nav.study.FlightStudy`, is missing from :data:`OPTIONS`.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import re
import signal
import sys
import warnings
from collections.abc import Callable, Sequence
from types import FrameType
from typing import Any, NoReturn

from fieldmap.errors import Wording

#: module name -> the sub-commands it registers (``main`` imports only the module of the command
#: run: a quick ``fieldmap point`` does not import the map, navigation and verify modules)
_COMMANDS = {
    "fieldmap.cli.point": ("point",),
    "fieldmap.cli.verify": ("verify",),
    "fieldmap.cli.cache": ("cache",),
    "fieldmap.cli.maps": ("map", "sweep", "truncation"),
    "fieldmap.cli.nav": ("navsim",),
    "fieldmap.cli.imu": ("imu",),
    "fieldmap.cli.table": ("table",),
}


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (no usage block), exit status 2.

    An option that takes a value may be given once only (a second ``--height-km`` would
    silently replace the first): :func:`build_parser` applies :func:`_once` to every option.
    Abbreviations are refused (``allow_abbrev=False``): ``--height`` is no ``--height-km``
    (10,000 km for a user who meant 10,000 m) but an unknown option. Sub-parsers are made of
    this class too (``add_subparsers`` takes the parent's class).
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs["allow_abbrev"] = False
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:  # noqa: D102 - argparse API
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


#: attribute of a namespace while it is parsed: the destinations already set by an option
_SEEN = "_options_seen"


def _once(action: argparse.Action) -> argparse.Action:
    """Make a value-taking option refuse a second occurrence on one command line.

    argparse keeps the last value of a repeated option and drops the others silently
    (``--trajectory a.csv --trajectory b.csv`` would fly ``b.csv`` only). Flags (no value),
    ``append`` and ``count`` options are left as they are.
    """
    if (
        not action.option_strings
        or action.nargs == 0
        or isinstance(action, (argparse._AppendAction, argparse._CountAction))
        or getattr(type(action), "_once", False)
    ):
        return action
    base = type(action)

    def __call__(
        self: argparse.Action,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: str | Sequence[Any] | None,
        option_string: str | None = None,
    ) -> None:
        seen = namespace.__dict__.setdefault(_SEEN, {})
        if self.dest in seen:
            first = seen[self.dest]
            again = "again" if first == option_string else f"after {first}"
            parser.error(
                f"{option_string} given {again}: give an option once (several values go "
                "after one option)"
            )
        seen[self.dest] = option_string
        base.__call__(self, parser, namespace, values, option_string)

    action.__class__ = type(f"Once{base.__name__}", (base,), {"__call__": __call__, "_once": True})
    return action


def _once_everywhere(parser: argparse.ArgumentParser) -> None:
    """Apply :func:`_once` to every option of ``parser`` and its sub-parsers (groups included)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in {id(p): p for p in action.choices.values()}.values():
                _once_everywhere(sub)
        else:
            _once(action)


def _parse(parser: argparse.ArgumentParser, argv: list[str]) -> argparse.Namespace:
    """``parser.parse_args(argv)`` without the bookkeeping of :func:`_once`."""
    args = parser.parse_args(_joined_negative_values(parser, argv))
    args.__dict__.pop(_SEEN, None)
    return args


def _joined_negative_values(parser: argparse.ArgumentParser, argv: list[str]) -> list[str]:
    """Join an option and a value list that starts with a minus sign (``--route -33.9,151.2``).

    argparse reads a lone negative number as a value, but takes ``-33.9,151.2,1000;...`` or
    ``-5,10`` for an unknown option. Such a token after an option that takes a value becomes
    ``--option=-33.9,...``: a southern-hemisphere route or a height list starting below zero is
    given as written.
    """
    takes_value: set[str] = set()
    todo = [parser]
    while todo:
        p = todo.pop()
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                todo.extend(action.choices.values())
            elif action.option_strings and action.nargs != 0:
                takes_value.update(s for s in action.option_strings if s.startswith("--"))
    out: list[str] = []
    for i, arg in enumerate(argv):
        if arg == "--":  # the rest are positional arguments
            return out + argv[i:]
        if out and out[-1] in takes_value and _NEGATIVE_LIST.match(arg):
            out[-1] = f"{out[-1]}={arg}"
        else:
            out.append(arg)
    return out


#: a value list whose first item is a negative number: ``-5,10``, ``-33.9 151.2;...``
_NEGATIVE_LIST = re.compile(r"^-(\d|\.\d)[\d.eE+-]*[,;\s]")


class _Terminated(BaseException):
    """SIGTERM, raised as an exception so that temporary files are cleaned up."""


def _on_sigterm(signum: int, frame: FrameType | None) -> NoReturn:
    raise _Terminated()


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """Return the top-level parser with every available sub-command (or only ``command``'s).

    ``command``: a sub-command name; its module alone is imported and registered (the parser
    then knows that sub-command only). Unknown or None: every sub-command.
    """
    parser = _Parser(
        prog="fieldmap",
        description=(
            "Gravity-field maps and strapdown navigation with Warp kernels. "
            "Default model: the bundled EIGEN-6S (degree 240)."
        ),
    )
    from fieldmap import __version__

    parser.add_argument("--version", action="version", version=f"fieldmap {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    only = [m for m, cmds in _COMMANDS.items() if command in cmds]
    for name in only or _COMMANDS:
        try:
            mod = importlib.import_module(name)
        except ModuleNotFoundError as exc:  # a sub-command not written yet
            if exc.name == name:
                continue
            raise
        if command is not None and only and len(_COMMANDS[name]) > 1:  # that sub-command alone
            mod.register(sub, commands=(command,))
        else:
            mod.register(sub)
    _once_everywhere(parser)
    return parser


#: attribute of the parsed namespace: the destinations the command line set (:func:`given`)
_GIVEN = "_given_options"


def _command_of(argv: list[str]) -> str | None:
    """Return the sub-command named on a command line (its first argument not starting with -)."""
    for arg in argv:
        if not arg.startswith("-"):
            return arg
    return None


def given_options(argv: list[str]) -> frozenset[str]:
    """Return the destinations (``bias_mode``, ``lat_max``...) that ``argv`` itself sets.

    The command line is parsed a second time by a parser whose every default is removed
    (``argparse.SUPPRESS``), so the namespace holds only what was typed: an option given with
    its default value (``--bias-mode gauss``) counts as given, an option left out does not.
    """
    parser = build_parser(_command_of(argv))

    def strip(p: argparse.ArgumentParser) -> None:
        p._defaults.clear()  # set_defaults(func=...)
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in {id(s): s for s in action.choices.values()}.values():
                    strip(sub)
            else:
                action.default = argparse.SUPPRESS

    strip(parser)
    return frozenset(vars(_parse(parser, argv)))


def given(args: argparse.Namespace, dest: str) -> bool:
    """Tell whether the user gave the option of ``dest`` (not its default) on the command line.

    False for a namespace not made by :func:`main` (a script calling a sub-command's function):
    nothing is refused then for being given.
    """
    return dest in getattr(args, _GIVEN, ())


#: The optional dependencies, as in pyproject.toml's ``[project.optional-dependencies]``: extra ->
#: requirement -> the modules it provides. Only the extras fieldmap itself imports from (not
#: ``test``, ``dev``, ``docs``); ``tests/test_bad_input_cli.py`` checks the table against
#: pyproject.toml.
OPTIONAL_DEPENDENCIES = {
    "distributed": {"dask[distributed]": ("dask", "distributed"), "zarr": ("zarr",)},
}
_EXTRA_OF_MODULE = {
    module: extra
    for extra, requirements in OPTIONAL_DEPENDENCIES.items()
    for modules in requirements.values()
    for module in modules
}


def missing_optional(exc: BaseException) -> str | None:
    """Return the one-line message for a missing optional dependency, or None for other errors.

    A ``ModuleNotFoundError`` for a module of an extra (``zarr``, ``dask``, ``distributed``) is
    no internal error: the install lacks an optional part, and the message names the module and
    the extra that brings it.
    """
    if not isinstance(exc, ModuleNotFoundError) or not exc.name:
        return None
    module = exc.name.partition(".")[0]
    extra = _EXTRA_OF_MODULE.get(module)
    if extra is None:
        return None
    return f"{module} is not installed: pip install 'fieldmap[{extra}]'"


# -- library messages in the command line's words: one table ---------------------------------

#: keyword argument of :mod:`fieldmap.nav` -> the ``navsim`` option that sets it (None: the
#: command line has no option for it; its advice is left out, or taken from ADVICE)
OPTIONS: dict[str, str | None] = {
    # read_track
    "columns": "--columns",
    "alt_units": "--alt-units",
    "height_ref": "--height-ref",
    "time_format": "--time-format",
    # condition, load_flight
    "position_noise_m": "--position-noise-m",
    "max_gap_s": "--max-gap-s",
    "airborne_only": None,  # --airborne-only sets airborne_only=True: see ADVICE
    "smooth": None,  # --no-smooth sets smooth=False: see ADVICE
    "reorder": None,
    "on_long_gap": None,
    "min_speed_mps": None,
    "max_speed_mps": None,
    "max_climb_mps": None,
    "max_accel_g": None,
    "max_jerk": None,
    "threshold": None,
    "dt_out": None,
    "vehicle": "--vehicle",
    # FlightResult.plot / CovarianceStudyResult.plot (Python only)
    "kind": None,
    "log_velocities": None,  # --ignore-log-velocities sets log_velocities=False: see ADVICE
    "model": None,  # the truth model's geoid makes MSL heights ellipsoidal
    "ellipsoid": None,
    # FlightStudy (fieldmap.nav.study)
    "flight": None,  # --trajectory FILE or --route
    "imu": "--imu",
    "models": "--models",
    "draws": "--draws",
    "seed": "--seed",
    "rate_hz": "--rate",
    "frame": "--frame",
    "altitude_aiding": "--altitude-aiding",
    "baro": None,
    "truth": "--truth-model",
    "truth_lmax": "--lmax",
    "truth_evaluation": "--truth-evaluation",
    "gravity_rate_hz": "--gravity-rate-hz",
    "n_gauss": "--gauss",
    "duration": "--duration",
    "output_dt": "--output-dt",
    "block_s": "--block-s",
    "fraction": "--fraction",
    "omission_model": "--omission-model",
    "commission": "--commission",
    "method": "--method",
    "speed_mps": "--speed-mps",
    "imu_name": None,
    "gnss": None,
    # GnssSpec (fieldmap.nav.aiding), a FlightStudy's gnss
    "gnss.rate_hz": "--gnss-rate",
    "gnss.sigma_m": "--gnss-sigma",
    "gnss.velocity_sigma_mps": "--gnss-velocity-sigma",
    "gnss.outages": "--gnss-outage",
    "gnss.bias_m": "--gnss-bias",
    "gnss.bias_tau_s": "--gnss-bias",
    # Propagator (fieldmap.nav.propagator)
    "launch": None,
    "nav": None,  # its NavConfig (not navsim's --nav, the normal model of table3)
    "state": None,
    "h_ref": None,
}
#: ``"name=value"`` (the value as ``repr`` writes it) -> the whole advice on the command line,
#: for settings made by a switch rather than by an option with a value
ADVICE: dict[str, str] = {
    "airborne_only=False": "leave out --airborne-only",
    "smooth=True": "leave out --no-smooth",
    "log_velocities=False": "give --ignore-log-velocities",
}


def options_of(command: str) -> dict[str, str | None]:
    """Return the options of ``command`` that set keywords of :mod:`fieldmap.nav`.

    ``navsim`` has them all (:data:`OPTIONS`); any other command none: its flight logs are
    read with the defaults, and advice to change a keyword is left out.
    """
    return dict(OPTIONS) if command == "navsim" else {}


def wording_of(command: str) -> Wording:
    """Return how ``command`` names the keywords of library messages (:mod:`fieldmap.errors`).

    ``navsim``: its options (:data:`OPTIONS`) and the advice of its switches (:data:`ADVICE`);
    any other command: no option for any keyword (advice to change one is left out, a keyword
    named in a sentence keeps its Python name).
    """
    options = options_of(command)
    return Wording(options, ADVICE if options else {})


def _worded(exc: BaseException, command: str) -> str:
    """Return the message of ``exc``, naming the command's options where it names a keyword."""
    from fieldmap.errors import InputError

    if isinstance(exc, InputError):
        return exc.worded(wording_of(command))
    return str(exc)


def _warning_line(prefix: str, show: Callable[..., None]) -> Callable[..., None]:
    """``warnings.showwarning`` printing a :class:`fieldmap.errors.UnitWarning` as one line.

    The line names the command's option (``--height-km 20000: ...``: the map commands' options
    are their keywords spelt with dashes); any other warning is shown by ``show``.
    """
    from fieldmap.errors import UnitWarning

    def showwarning(message: Any, category: type, *args: Any, **kwargs: Any) -> None:
        if isinstance(message, UnitWarning):
            option = "--" + message.param.replace("_", "-")
            text = f"{option} {message.value.replace(',', '')}: {message.detail}"
            print(f"{prefix}: warning: {_one_line(text)}", file=sys.stderr)
        else:
            show(message, category, *args, **kwargs)

    return showwarning


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; return the exit status."""
    from fieldmap import config
    from fieldmap.errors import FieldmapError, UnitWarning

    program = argv is None  # this process's own command line (the ``fieldmap`` program)
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(_command_of(argv))
    args = _parse(parser, argv)
    if not getattr(args, "func", None):
        commands = ", ".join(c for cmds in _COMMANDS.values() for c in cmds)
        parser.error(f"a command is needed: one of {commands}")
    if sys.stdout is None:  # started with stdout closed (``fieldmap point >&-``)
        print(f"fieldmap {args.command}: error: standard output is closed", file=sys.stderr)
        return 2
    setattr(args, _GIVEN, given_options(argv))
    # Warp's notice about stale cache folders of another Warp version says nothing about the run
    warnings.filterwarnings("ignore", message="Kernel cache artifacts from a previous Warp")
    prefix = f"fieldmap {args.command}"
    one_shot = program and args.command == "point"
    if one_shot:  # a short process: no garbage collection (see _spare_final_collections)
        gc.disable()
    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # pragma: no cover - not the main thread
        pass
    try:
        config.get()  # the FIELDMAP_* variables, read once: a bad value is bad input (exit 2)
        with warnings.catch_warnings():
            warnings.simplefilter("always", UnitWarning)  # every run says it, not the first
            warnings.showwarning = _warning_line(prefix, warnings.showwarning)
            return int(args.func(args) or 0)
    except FieldmapError as exc:
        print(f"{prefix}: error: {_one_line(_worded(exc, args.command))}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. ``fieldmap point < pts | head``: stop quietly
        _silence_stdout()
        return 1
    except OSError as exc:
        where = f" {exc.filename!r}:" if getattr(exc, "filename", None) else ""
        print(f"{prefix}: error:{where} {_one_line(exc.strerror or exc)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prefix}: interrupted", file=sys.stderr)
        return 130
    except _Terminated:
        print(f"{prefix}: terminated", file=sys.stderr)
        return 143
    except MemoryError:
        print(
            f"{prefix}: error: out of memory; use a coarser grid or fewer points", file=sys.stderr
        )
        return 2
    except Exception as exc:  # noqa: BLE001 - the CLI never shows a traceback
        missing = missing_optional(exc)
        if missing is not None:
            print(f"{prefix}: error: {missing}", file=sys.stderr)
            return 2
        if config.get().debug:
            raise
        print(
            f"{prefix}: internal error: {type(exc).__name__}: {_one_line(exc)} "
            "(set FIELDMAP_DEBUG=1 for the traceback)",
            file=sys.stderr,
        )
        return 3
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        if one_shot:
            _spare_final_collections()


def _spare_final_collections() -> None:
    """Keep the interpreter's exit from traversing every live object again (``gc.freeze``).

    ``fieldmap point`` as a program runs with the cyclic garbage collector off and calls this
    when it has written its output and the process is about to exit. Warp's ~3,400 registered
    builtins and their closures make each full collection cost tens of milliseconds: while
    Warp is imported (~30 ms of collections triggered by its allocations), and in the
    collections that interpreter shutdown runs whether or not the collector is on (0.2-0.3 s
    of a one-point run in all). The command makes no reference cycles of note (parsed lines,
    NumPy arrays and output strings are freed by reference counting), and objects alive at
    its end live until the exit anyway; frozen, the shutdown's collections skip them. Results
    and output are not touched: exit still flushes stdout and runs the atexit hooks.
    """
    gc.freeze()


def _silence_stdout() -> None:
    """After a broken pipe, point stdout at /dev/null so that the exit flush does not fail."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # pragma: no cover
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
