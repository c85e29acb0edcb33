"""Exceptions of fieldmap, and messages that name the caller's keywords in the caller's words.

The CLI turns every :class:`FieldmapError` into one line and exit status 2.

A message about a keyword argument names it as its reader spells it: a Python caller reads
``max_gap_s``, a user of ``fieldmap navsim`` reads ``--max-gap-s``. Such a message is built from
parts, so that nothing has to be found in its text afterwards: plain text, and the keyword
references of this module,

- :class:`Keyword` ``max_gap_s``: a keyword named in a sentence;
- :class:`Label` `` (max_gap_s)``: after the value it sets ("60 s (max_gap_s)"), left out where
  the reader has no name for it;
- :class:`Setting` ``frame='ned'``: a keyword and its value ("needs frame='ned'");
- :class:`Advice`: a clause that advises a change ("; raise max_gap_s", "; pass
  airborne_only=False to fly the ground movement", with :class:`Pass` for the "pass
  name=value"), left out whole where the reader cannot make that change.

A :class:`Message` holds the parts; as a ``str`` it is the Python wording, and
:meth:`Message.worded` gives it in the words of a :class:`Wording`: keyword -> the reader's name
of it (``"max_gap_s" -> "--max-gap-s"``, None where it has none) and the whole advice of settings
that a switch makes (``"airborne_only=False" -> "leave out --airborne-only"``).
:class:`InputError` takes the parts of its message and the keyword it is about (``param``);
:mod:`fieldmap.cli` words it with the command's option table.

Examples
--------
>>> e = InputError(
...     "no stretch without a gap over 60 s", Label("max_gap_s"),
...     Advice(": raise ", Keyword("max_gap_s")), param="max_gap_s",
... )
>>> str(e)
'no stretch without a gap over 60 s (max_gap_s): raise max_gap_s'
>>> e.worded(Wording({"max_gap_s": "--max-gap-s"}))
'no stretch without a gap over 60 s (--max-gap-s): raise --max-gap-s'
>>> e.worded(Wording({}))
'no stretch without a gap over 60 s'
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Union, cast


class FieldmapError(Exception):
    """Base class: a user-facing error with a clear one-line message."""


class ModelFileError(FieldmapError, ValueError):
    """A gravity-model file is missing, unreadable or malformed (message names file and line)."""


# -- the parts of a message ---------------------------------------------------------------------
@dataclass(frozen=True)
class Keyword:
    """A keyword argument named in a message: ``name``, or the reader's name of it.

    Where the reader has no name for it (a command without that option), the Python name
    stays; inside an :class:`Advice` the clause is left out instead.
    """

    name: str


@dataclass(frozen=True)
class Label:
    """`` (name)`` after the value a keyword sets ("60 s (max_gap_s)"); nothing without a name."""

    name: str


@dataclass(frozen=True)
class Setting:
    """A keyword and its value: ``name='value'`` in Python, ``--option value`` on a command line.

    Where the reader has no name for the keyword, the Python setting stays.
    """

    name: str
    value: Any


@dataclass(frozen=True)
class Pass:
    """Advice to set a keyword: ``pass name=value``; ``give --option value`` on a command line.

    A setting made by a switch has its own advice (:attr:`Wording.switches`: ``leave out
    --airborne-only``). Only inside an :class:`Advice`, which is left out where neither exists.
    """

    name: str
    value: Any


class Metavar(str):
    """A placeholder value in advice (``Pass("vehicle", Metavar("CLASS"))``): no quotes."""

    def __repr__(self) -> str:
        return str(self)


#: what a message is made of
Part = Union[str, Keyword, Label, Setting, Pass, "Advice", "Message"]


@dataclass(frozen=True, init=False)
class Advice:
    """A clause advising a change, separator included (``"; raise ", Keyword("max_gap_s")``).

    It is left out whole where the reader has no name for a keyword it names: a command
    without the option cannot follow it.
    """

    parts: tuple[Part, ...]

    def __init__(self, *parts: Part) -> None:
        object.__setattr__(self, "parts", tuple(parts))


@dataclass(frozen=True)
class Wording:
    """How a reader names keywords.

    Parameters
    ----------
    names : mapping or None
        Keyword -> the reader's name of it (``"max_gap_s" -> "--max-gap-s"``; None or absent:
        the reader has none). None: the Python wording (every keyword by its own name, settings
        as ``name=value``).
    switches : mapping
        ``"name=value"`` (the value as ``repr`` writes it) -> the whole advice for a setting
        that a switch makes rather than an option with a value (``"airborne_only=False" ->
        "leave out --airborne-only"``).
    """

    names: Mapping[str, str | None] | None = None
    switches: Mapping[str, str] = field(default_factory=dict)

    @property
    def python(self) -> bool:
        """True for the Python wording."""
        return self.names is None

    def name(self, keyword: str) -> str | None:
        """Return the reader's name of ``keyword`` (None: it has none)."""
        return keyword if self.names is None else self.names.get(keyword)


#: the wording of a Python caller: keywords by their own names
PYTHON = Wording()


class _Unnamed(Exception):
    """A keyword the reader has no name for, inside an advice (the advice is left out)."""


def _render(parts: tuple[Part, ...], wording: Wording, advice: bool = False) -> Iterator[str]:
    for part in parts:
        if isinstance(part, Message):
            yield from _render(part.parts, wording, advice)
        elif isinstance(part, str):
            yield part
        elif isinstance(part, Keyword):
            name = wording.name(part.name)
            if name is None and advice:
                raise _Unnamed(part.name)
            yield part.name if name is None else name
        elif isinstance(part, Label):
            name = wording.name(part.name)
            if name is None and advice:
                raise _Unnamed(part.name)
            yield "" if name is None else f" ({name})"
        elif isinstance(part, Setting):
            name = wording.name(part.name)
            if wording.python or name is None:
                if advice and name is None:
                    raise _Unnamed(part.name)
                yield f"{part.name}={part.value!r}"
            else:
                yield f"{name} {part.value}"
        elif isinstance(part, Pass):
            if wording.python:
                yield f"pass {part.name}={part.value!r}"
                continue
            whole = wording.switches.get(f"{part.name}={part.value!r}")
            name = wording.name(part.name)
            if whole is None and name is None:
                raise _Unnamed(part.name)
            yield whole if whole is not None else f"give {name} {part.value}"
        elif isinstance(part, Advice):
            try:
                yield "".join(_render(part.parts, wording, advice=True))
            except _Unnamed:
                if advice:  # an advice inside an advice goes with it
                    raise
        else:
            raise TypeError(f"a message part must be text or a keyword reference, got {part!r}")


class Message(str):
    """A message made of text and keyword references; as a ``str``, its Python wording.

    ``Message("the samples are 100 s apart: raise ", Keyword("max_gap_s"))``: see the module
    docstring. Joined to other text (``f"{msg}"``, ``msg + "..."``) it is plain text in the
    Python wording; give it to :class:`InputError` (or to another ``Message``) as a part to
    keep its keywords.

    Examples
    --------
    >>> note = Message("vehicle: glider (guessed", Advice("; ", Pass("vehicle", Metavar("CLASS")),
    ...                " to choose"), ")")
    >>> note
    'vehicle: glider (guessed; pass vehicle=CLASS to choose)'
    >>> note.worded(Wording({"vehicle": "--vehicle"}))
    'vehicle: glider (guessed; give --vehicle CLASS to choose)'
    >>> note.worded(Wording({}))
    'vehicle: glider (guessed)'
    """

    parts: tuple[Part, ...]

    def __new__(cls, *parts: Part) -> Message:  # noqa: D102 - documented on the class
        self = super().__new__(cls, "".join(_render(tuple(parts), PYTHON)))
        self.parts = tuple(parts)
        return self

    def worded(self, wording: Wording) -> str:
        """Return the message in the words of ``wording`` (plain text)."""
        return "".join(_render(self.parts, wording))

    def substitute(self, old: Part, new: Part) -> Message:
        """Return the message with the part ``old`` replaced by ``new`` (in advice too).

        A caller that sets a keyword itself replaces advice about it with advice about its own
        keyword (``Pass("reorder", True)`` -> ``Pass("smooth", True)``).
        """

        def swap(parts: tuple[Part, ...]) -> tuple[Part, ...]:
            out: list[Part] = []
            for part in parts:
                if isinstance(part, (Message, Advice)):
                    part = type(part)(*swap(part.parts))
                out.append(new if part == old else part)
            return tuple(out)

        return Message(*swap(self.parts))

    def __reduce__(self) -> tuple[Any, ...]:  # pickled with its parts (Dask workers)
        return (Message, self.parts)


#: the parts that make a message a :class:`Message` (besides text)
_REFERENCES = (Keyword, Label, Setting, Pass, Advice, Message)


def worded(text: str, wording: Wording) -> str:
    """Return ``text`` in the words of ``wording``: a :class:`Message` reworded, text as it is."""
    return text.worded(wording) if isinstance(text, Message) else str(text)


class InputError(FieldmapError, ValueError):
    """Invalid user input: coordinates, grid specification, degree, device, output folder.

    Parameters
    ----------
    *parts
        The message (one line): a text, or text and keyword references (:class:`Keyword`,
        :class:`Label`, :class:`Setting`, :class:`Advice`), joined as a :class:`Message`
        (without a keyword reference, the arguments of any exception).
    param : str, optional
        The keyword argument of the function called that the error is about
        (``"max_gap_s"``). None: the error is about no single keyword.

    ``str(error)`` is the message in Python's words; :meth:`worded` gives it in the words of a
    command line (:mod:`fieldmap.cli` uses the option table of the command).
    """

    def __init__(self, *parts: object, param: str | None = None) -> None:
        if any(isinstance(p, _REFERENCES) for p in parts):
            parts = (Message(*cast("tuple[Part, ...]", parts)),)
        super().__init__(*parts)
        self.param = param

    def worded(self, wording: Wording) -> str:
        """Return the message in the words of ``wording`` (a command's options)."""
        return worded(self.args[0], wording) if self.args else ""


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
