"""Exceptions of fieldmap. The CLI turns every :class:`FieldmapError` into one line and exit 2."""


class FieldmapError(Exception):
    """Base class: a user-facing error with a clear one-line message."""


class ModelFileError(FieldmapError, ValueError):
    """A gravity-model file is missing, unreadable or malformed (message names file and line)."""


class InputError(FieldmapError, ValueError):
    """Invalid user input: coordinates, grid specification, degree, device, output folder."""
