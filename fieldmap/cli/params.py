"""Keyword arguments of the library named as the command line spells them: one table.

The flight-log readers and the conditioning (:mod:`fieldmap.nav.logs`), the flight study
(:class:`fieldmap.nav.study.FlightStudy`) and the mechanization checks of the propagator
(:mod:`fieldmap.nav.propagator`) word their messages for a Python caller: they name keyword
arguments ("no stretch ... without a gap over 60 s (max_gap_s)", "pass airborne_only=False to
keep ground movement", "draws must be within 1..10000", "baro altitude aiding needs
frame='ned'"), and an :class:`~fieldmap.errors.InputError` about one carries its name as
``param``. A user of the command line can only change options, so the CLI rewords such text
with :data:`OPTIONS` and :data:`ADVICE` before it shows it (:func:`reword`; errors in
:func:`fieldmap.cli.main`, the notes of a conditioning report in :mod:`fieldmap.cli.nav`).

How a message names a keyword ``name`` (a key of :data:`OPTIONS`), and what the command line
makes of it:

- ``(name)`` after the value it sets: ``(--option)``, or left out where no option sets it;
- an *advice*, a clause that starts with ``pass``, ``give`` or ``raise`` after ``; ``, ``: ``,
  ``? `` or ``, or `` and runs to the next ``; `` or ``, or ``, an unmatched ``)`` or the end
  (``pass name=value ...``, ``give ... name ...``): ``pass name=value`` becomes the whole advice
  of :data:`ADVICE` for that setting, else ``give --option value``; a bare ``name`` becomes
  ``--option``; where the command has no option for a keyword it names, the clause is left out;
- ``name=value`` anywhere else (``needs frame='ned'``): ``--option value``; without an option
  the Python setting stays;
- ``name`` anywhere else (e.g. ``max_gap_s must be a positive number``): ``--option``; without
  one the Python name stays.

Outside ``name=value`` a keyword is found only where it cannot be a plain word: a name with an
underscore, or the error's own ``param`` (``columns``, ``draws``); never inside a path
(``/data/models/x``, ``table:models.bin``).

A command offers a subset of the options: ``fieldmap navsim`` all of them (:func:`options_of`),
``fieldmap table --corridor`` none (it reads the flight with the defaults).
``tests/test_params.py`` fails when a keyword that a message in :mod:`fieldmap.nav` is about
(``param=``), or a keyword of the log functions or of :class:`~fieldmap.nav.study.FlightStudy`,
is missing from :data:`OPTIONS`.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

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
    "airborne_only": None,  # --keep-ground sets airborne_only=False: see ADVICE
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
    "truth": "--model",
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
    "airborne_only=False": "give --keep-ground",
    "smooth=True": "leave out --no-smooth",
}

#: separators before an advice clause ("? " keeps its question mark)
_SEP = re.compile(r"; |: |(?<=\?) |, or ")
_VALUE = r"'[^']*'|\"[^\"]*\"|[\w.+-]+"
#: around a keyword: no word, option or path characters (``--frame``, ``/data/models/x``,
#: ``table:models.bin``, ``frame=``); a sentence may end after it (``... columns.``)
_BEFORE = r"(?<![-\w/\\.:])"
_AFTER = r"(?![\w=/\\]|\.\w)"


def options_of(command: str) -> dict[str, str | None]:
    """Return the options of ``command`` that set keywords of :mod:`fieldmap.nav`.

    ``navsim`` has them all (:data:`OPTIONS`); any other command none: its flight logs are
    read with the defaults, and advice to change a keyword is left out.
    """
    return dict(OPTIONS) if command == "navsim" else {}


def _names(param: str | None = None, *, all_names: bool = False) -> str:
    """Regex of the keywords to find: all (``pass name=value``), else those no plain word.

    A keyword with an underscore cannot be a plain word; one without (``columns``, ``smooth``)
    is found bare only as the error's own ``param``.
    """
    names = [n for n in OPTIONS if all_names or "_" in n or n == param]
    return "|".join(sorted(map(re.escape, names), key=len, reverse=True)) or "(?!)"


def _bare(name: str) -> re.Pattern[str]:
    return re.compile(rf"{_BEFORE}{re.escape(name)}{_AFTER}")


def _clause_end(text: str, start: int) -> int:
    """End of the clause starting at ``start``: the next separator, unmatched ``)`` or the end."""
    depth, i = 0, start
    while i < len(text):
        c = text[i]
        if c == "(":
            depth += 1
        elif c == ")":
            if depth == 0:
                return i
            depth -= 1
        elif depth == 0 and (text.startswith("; ", i) or text.startswith(", or ", i)):
            return i
        i += 1
    return i


def _advice(
    clause: str, param: str | None, options: Mapping[str, str | None], advice: Mapping[str, str]
) -> str | None:
    """Return the clause with its keywords as options; None where one has no option."""

    def setting(m: re.Match[str]) -> str:
        name, value = m.group(1), m.group(2)
        whole = advice.get(f"{name}={value}")
        if whole is not None:
            return whole
        option = options.get(name)
        if option is None:
            raise LookupError(name)
        return f"give {option} {value.strip(chr(39) + chr(34))}"

    def bare(m: re.Match[str]) -> str:
        option = options.get(m.group(0))
        if option is None:
            raise LookupError(m.group(0))
        return option

    try:
        clause = re.sub(rf"\bpass ({_names(all_names=True)})=({_VALUE})", setting, clause)
        return re.sub(rf"{_BEFORE}(?:{_names(param)}){_AFTER}", bare, clause)
    except LookupError:
        return None


def reword(
    text: str,
    param: str | None = None,
    options: Mapping[str, str | None] = OPTIONS,
    advice: Mapping[str, str] = ADVICE,
) -> str:
    """Return a message of :mod:`fieldmap.nav` as the command line spells it.

    Parameters
    ----------
    text : str
        The message (or a note) in the Python wording (see the module docstring).
    param : str, optional
        The keyword the message is about (:attr:`fieldmap.errors.InputError.param`): its bare
        name is reworded even where it could be a plain word (``columns``).
    options : mapping
        Keyword -> option of the command (default :data:`OPTIONS`; :func:`options_of`).
    advice : mapping
        ``"name=value"`` -> whole advice (default :data:`ADVICE`); empty where the command has
        none of those switches.
    """
    if not options:
        advice = {}
    # advices: rewritten, or left out with the separator before them
    out, pos = [], 0
    verbs = re.compile(rf"(?:{_SEP.pattern})(?=(?:pass|give|raise) )")
    for m in verbs.finditer(text):
        if m.start() < pos:
            continue
        end = _clause_end(text, m.end())
        new = _advice(text[m.end() : end], param, options, advice)
        out.append(text[pos : m.start()])
        if new is not None:
            out.append(text[m.start() : m.end()] + new)
        pos = end
    text = "".join(out) + text[pos:]

    # settings "name=value" outside an advice (``needs frame='ned'``)
    def setting(m: re.Match[str]) -> str:
        option = options.get(m.group(1))
        return f"{option} {m.group(2).strip(chr(39) + chr(34))}" if option else m.group(0)

    text = re.sub(rf"{_BEFORE}({_names(all_names=True)})=({_VALUE})", setting, text)

    # labels "(name)"
    def label(m: re.Match[str]) -> str:
        option = options.get(m.group(1))
        return f" ({option})" if option else ""

    text = re.sub(rf" \(({_names(param)})\)", label, text)
    # bare names elsewhere: those that cannot be plain words, and the error's own keyword
    for name in OPTIONS:
        option = options.get(name)
        if option and ("_" in name or name == param):
            text = _bare(name).sub(option, text)
    return text
