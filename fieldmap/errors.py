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


class UnitWarning(UserWarning):
    """A value that is accepted but looks like a unit typed wrong (the result is computed).

    Parameters
    ----------
    param : str
        The keyword the value was given to (``"height_km"``); the command line names its
        option instead (``--height-km``).
    value : str
        The value as given (``"20000"``, ``"20, 50"``).
    detail : str
        What was seen and the likely slip, one line.
    """

    def __init__(self, param: str, value: str, detail: str) -> None:
        super().__init__(f"{param}={value}: {detail}")
        self.param, self.value, self.detail = param, value, detail
