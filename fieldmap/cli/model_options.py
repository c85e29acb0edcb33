"""The model-file options shared by the sub-commands that load a gravity model.

``--model-dir``, ``--gm``, ``--radius`` and ``--no-cache`` (``fieldmap point``, ``map``,
``sweep``, ``truncation``); their values become keyword arguments of
:func:`fieldmap.models.registry.load_model` through
:func:`fieldmap.models.registry.model_options`, which also validates them.
"""

from __future__ import annotations

import argparse

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
}


def add_model_options(parser: argparse.ArgumentParser) -> None:
    """Add ``--model-dir``, ``--gm``, ``--radius`` and ``--no-cache`` to a CLI sub-parser."""
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
