"""The ``Examples`` sections of the main entry points run, and print what they show.

Every function of ``fieldmap.__all__`` (what a user calls) has one
(:func:`test_every_top_level_function_has_a_running_example`).

Each module's doctests run with :mod:`doctest` (as ``doctest.testmod`` would), plus those of
its entry points that a decorator wraps (``doctest`` skips a wrapper defined in another
module): they are found through ``__wrapped__``. Every entry
point listed must hold at least one example, so a lost section fails here. Warp is configured
by ``tests/conftest.py`` before this module is imported.
"""

from __future__ import annotations

import doctest
import importlib
import inspect

import pytest

#: module -> entry points (``Class.method`` for a method) whose docstrings hold examples
ENTRY_POINTS = {
    "fieldmap.field.gravity": ("gravity", "disturbance"),
    "fieldmap.field.normal": ("normal_gravity",),
    "fieldmap.field.geodesy": ("gravity_anomaly", "geoid_height"),
    "fieldmap.field.omission": ("Omission",),
    "fieldmap.models.registry": ("load_model",),
    "fieldmap.models.shmodel": ("SHModel.truncated",),
    "fieldmap.nav.study": ("FlightStudy", "run_flight"),
    "fieldmap.errors": ("Message",),
    "fieldmap.durations": ("seconds",),
}
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _doctests(name: str) -> list[doctest.DocTest]:
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder()
    tests = {t.name: t for t in finder.find(module)}
    for entry in ENTRY_POINTS[name]:
        obj = module
        for part in entry.split("."):
            obj = getattr(obj, part)
        obj = inspect.unwrap(obj)
        for t in finder.find(obj, f"{name}.{entry}", module=module, globs=vars(module)):
            tests.setdefault(t.name, t)
    return [t for t in tests.values() if t.examples]


@pytest.mark.parametrize("name", sorted(ENTRY_POINTS))
def test_docstring_examples_run(name):
    tests = _doctests(name)
    found = {t.name for t in tests}
    missing = [e for e in ENTRY_POINTS[name] if f"{name}.{e}" not in found]
    assert not missing, f"no Examples section in {', '.join(missing)}"
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.attempted >= len(ENTRY_POINTS[name])
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"


def _top_level_functions() -> list[str]:
    import fieldmap

    return sorted(n for n in fieldmap.__all__ if inspect.isfunction(getattr(fieldmap, n)))


@pytest.mark.parametrize("name", _top_level_functions())
def test_every_top_level_function_has_a_running_example(name):
    import fieldmap

    func = inspect.unwrap(getattr(fieldmap, name))
    module = inspect.getmodule(func)
    finder = doctest.DocTestFinder()
    tests = [
        t
        for t in finder.find(func, f"fieldmap.{name}", module=module, globs=vars(module))
        if t.examples
    ]
    assert tests, f"fieldmap.{name} has no Examples section"
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of {name} failed"
    skipped = [e.source for t in tests for e in t.examples if e.options.get(doctest.SKIP)]
    assert not skipped, f"fieldmap.{name}: examples marked +SKIP do not run: {skipped}"
