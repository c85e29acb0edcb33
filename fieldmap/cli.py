"""Command-line entry point ``fieldmap``.

Each sub-command lives in its own module exposing ``register(subparsers)``; that function adds
the sub-parser and sets ``func`` (called with the parsed namespace, returns an exit status).
Every :class:`fieldmap.errors.FieldmapError` (and ``OSError`` on output) becomes one line on
stderr and exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys

# module name -> registers these sub-commands
_COMMAND_MODULES = (
    "fieldmap.cli_point",  # point, verify
    "fieldmap.cli_maps",  # map, sweep, truncation
    "fieldmap.cli_nav",  # navsim
)


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every available sub-command."""
    parser = argparse.ArgumentParser(
        prog="fieldmap",
        description=(
            "Gravity-field maps and strapdown navigation with Warp kernels. "
            "Default model: the bundled EIGEN-6S (degree 240)."
        ),
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"fieldmap {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _COMMAND_MODULES:
        try:
            mod = importlib.import_module(name)
        except ModuleNotFoundError as exc:  # a sub-command not written yet
            if exc.name == name:
                continue
            raise
        mod.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; return the exit status."""
    from .errors import FieldmapError

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except FieldmapError as exc:
        print(f"fieldmap {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
        print(f"fieldmap {args.command}: error:{where} {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"fieldmap {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
