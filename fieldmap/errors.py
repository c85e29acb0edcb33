"""Exceptions of fieldmap. The CLI turns every :class:`FieldmapError` into one line and exit 2."""

from __future__ import annotations


class FieldmapError(Exception):
    """Base class: a user-facing error with a clear one-line message."""


class ModelFileError(FieldmapError, ValueError):
    """A gravity-model file is missing, unreadable or malformed (message names file and line)."""


class InputError(FieldmapError, ValueError):
    """Invalid user input: coordinates, grid specification, degree, device, output folder.

    Parameters
    ----------
    *args
        The message (one line), as for any exception.
    param : str, optional
        The keyword argument of the function called that the error is about
        (``"max_gap_s"``). The message names it as Python spells it ("60 s (max_gap_s)",
        "pass airborne_only=False"); the command line rewords such messages with its own
        options (:mod:`fieldmap.cli`). None: the error is about no single keyword.
    """

    def __init__(self, *args: object, param: str | None = None) -> None:
        super().__init__(*args)
        self.param = param
