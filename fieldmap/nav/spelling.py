"""How the messages of the flight-log readers and the conditioning name an option.

A message that says what to change must name something the reader can change. From Python that
is a keyword argument ("pass airborne_only=False to keep ground movement"); from the command
line it is an option ("give --keep-ground to keep ground movement"), and a keyword that the
command line does not expose is not named at all. The readers (:mod:`fieldmap.nav.readers`),
the conditioning (:mod:`fieldmap.nav.conditioning`) and :func:`fieldmap.nav.flightlog.load_flight`
spell options with :func:`keyword` and :func:`advice`; the CLI runs them within
:func:`spelled` with its table (:data:`fieldmap.cli.navflight.SPELLING`). Outside
:func:`spelled` the Python spelling is used. A caller that sets a keyword of the function it
calls has its own keyword advised instead (:func:`set_by`). Both live in
:class:`contextvars.ContextVar` objects: other threads keep the Python spelling.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = ["advice", "keyword", "set_by", "spelled"]

#: None: the Python spelling; else keyword -> option, ``"keyword=value"`` -> the whole advice
_TABLE: ContextVar[Mapping[str, str] | None] = ContextVar("fieldmap_option_spelling", default=None)
#: ``"keyword=value"`` -> (keyword, value) of the caller that sets it (:func:`set_by`)
_BY: ContextVar[Mapping[str, tuple]] = ContextVar("fieldmap_option_set_by", default={})


@contextmanager
def spelled(table: Mapping[str, str]) -> Iterator[None]:
    """Spell options with ``table`` within the block.

    ``table`` maps a keyword to the option that sets it (``"max_gap_s": "--max-gap-s"``) and a
    setting ``"keyword=value"`` (the value as ``repr`` writes it) to the whole advice
    (``"airborne_only=False": "give --keep-ground"``). A keyword not in the table has no
    option: :func:`keyword` and :func:`advice` return None for it, and messages leave it out.
    """
    token = _TABLE.set(dict(table))
    try:
        yield
    finally:
        _TABLE.reset(token)


@contextmanager
def set_by(settings: Mapping[str, tuple]) -> Iterator[None]:
    """Within the block, advise the caller's own keyword for a setting it makes.

    ``{"reorder=True": ("smooth", True)}``: :func:`fieldmap.nav.flightlog.load_flight` passes
    ``reorder=smooth`` to the conditioning, so its reader is told to pass ``smooth=True``
    (on the command line: what the table says of ``smooth=True``).
    """
    token = _BY.set({**_BY.get(), **settings})
    try:
        yield
    finally:
        _BY.reset(token)


def keyword(name: str) -> str | None:
    """Return the option ``name`` as the reader writes it (``max_gap_s``, ``--max-gap-s``).

    None where the command line has no such option.
    """
    table = _TABLE.get()
    return name if table is None else table.get(name)


def advice(name: str, value) -> str | None:
    """Return how to set ``name`` to ``value``.

    ``pass height_ref='msl'`` from Python, ``give --height-ref msl`` from the command line;
    None where the command line cannot set it.
    """
    name, value = _BY.get().get(f"{name}={value!r}", (name, value))
    table = _TABLE.get()
    if table is None:
        return f"pass {name}={value!r}"
    whole = table.get(f"{name}={value!r}")
    if whole is not None:
        return whole
    option = table.get(name)
    return None if option is None else f"give {option} {value}"
