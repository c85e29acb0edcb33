"""The model-file options shared by the sub-commands that load a gravity model.

``--model-dir``, ``--gm``, ``--radius``, ``--no-cache`` and ``--tide-system`` (``fieldmap point``,
``map``, ``sweep``, ``table``; ``truncation --degrees`` and ``navsim`` add ``--tide-system``
alone with :func:`add_tide_option`); their values become keyword arguments of
:func:`fieldmap.models.registry.load_model` through
:func:`fieldmap.models.registry.model_options`, which also validates them.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from fieldmap.models.shmodel import SHModel

#: every option that chooses or reads the spherical-harmonic model: dest -> option (refused by
#: the quantities no model enters: ``point --quantity normal``, ``map --quantity gradient-normal``)
MODEL_OPTIONS = {
    "model": "--model",
    "lmax": "--lmax",
    "epoch": "--epoch",
    "model_dir": "--model-dir",
    "gm": "--gm",
    "radius": "--radius",
    "no_cache": "--no-cache",
    "tide_system": "--tide-system",
}

#: the names of :data:`fieldmap.models.tide.TIDE_SYSTEMS`, spelt out (start-up time)
TIDE_CHOICES = ("tide_free", "zero_tide", "mean_tide")


def add_tide_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--tide-system`` (the model converted after loading, :mod:`fieldmap.models.tide`)."""
    parser.add_argument(
        "--tide-system",
        choices=TIDE_CHOICES,
        default=None,
        help="convert the model to this permanent-tide system after loading (C̄20, IERS "
        "Conventions 2010 §6.2.2); recorded in the products (default: the model file's own; "
        "refused for a model whose tide system is unknown)",
    )


def add_model_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--model-dir``, ``--gm``, ``--radius``, ``--no-cache``, ``--tide-system``."""
    parser.add_argument(
        "--model-dir",
        default=None,
        help="folder of GeographicLib models: --model NAME reads DIR/NAME.egm (as Gravity -d), "
        "or DIR/NAME; refused with the bundled model or a file path outside DIR",
    )
    parser.add_argument(
        "--gm",
        type=float,
        default=None,
        help="GM of an NGA coefficient file, m³/s² (default: EGM96/EGM2008 values by file name)",
    )
    parser.add_argument(
        "--radius",
        type=float,
        default=None,
        help="reference radius of an NGA coefficient file, m (default as --gm)",
    )
    parser.add_argument(
        "--no-cache",
        action="store_true",
        help="parse the model file, neither reading nor writing the on-disk model cache",
    )
    add_tide_option(parser)


def in_tables_system(model: SHModel, names: Iterable[str], asked: str | None) -> SHModel:
    """Return the truth ``model`` in the tide system of the compensation tables in ``names``.

    A navigation table (``table:FILE``) holds δg of the model it was built from, in that model's
    tide system (recorded in the table's NetCDF file as ``model_tide_system``; a binary table
    records none). The truth is converted to that system so that truth and table are compared
    in one, which :func:`fieldmap.models.registry.announce` then says in one line. Refused in one
    line:
    tables in two systems, or ``--tide-system`` (``asked``) naming another system than theirs.
    A truth or table of unknown system is left as it is.
    """
    from fieldmap.errors import InputError
    from fieldmap.models.registry import table_path
    from fieldmap.models.tide import TIDE_SYSTEMS, convert_tide_system
    from fieldmap.products.tables.model import load_table

    systems: dict[str, str] = {}
    for name in names:
        path = table_path(name)
        if path is not None:
            system = str(load_table(path).meta.get("tide_system", "unknown"))
            if system in TIDE_SYSTEMS:
                systems.setdefault(system, name)
    if not systems:
        return model
    if len(systems) > 1:
        raise InputError(
            "--models: compensation tables in several tide systems ("
            + ", ".join(f"{n}: {s}" for s, n in systems.items())
            + "): compare the truth with tables of one system"
        )
    ((system, name),) = systems.items()
    if asked is not None and asked != system:
        raise InputError(
            f"--tide-system {asked}, but --models {name} was built in {system}: the truth and "
            f"the tables are compared in one system (give --tide-system {system}, or leave it out)"
        )
    if model.tide_system not in TIDE_SYSTEMS:
        return model
    return convert_tide_system(model, system)
