"""``fieldmap verify`` can fail: a broken install fails, a skipped check is not a pass."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from fieldmap import cli
from fieldmap.cli import verify
from fieldmap.errors import InputError

ARGS = ["verify", "--device", "cpu", "--lmax", "4", "--points", "5"]


def _passing(device, opts):
    yield verify._compare("identity", device, lambda: np.ones(3), lambda: np.ones(3), "")


def _skipping(device, opts):
    raise verify.SkipCheck("needs a CUDA device")
    yield  # pragma: no cover - a generator, as the real checks


def _missing_reference(device, opts):
    raise ModuleNotFoundError("No module named 'fieldmap.reference.sh'")
    yield  # pragma: no cover


def _run(monkeypatch, capsys, checks):
    monkeypatch.setattr(verify, "CHECKS", checks)
    rc = cli.main(ARGS)
    return rc, capsys.readouterr().out


def test_missing_fieldmap_module_fails(monkeypatch, capsys):
    """A part of fieldmap that cannot be imported is a failure (it was a "skipped" pass, exit 0)."""
    monkeypatch.setitem(sys.modules, "fieldmap.nav.mechanize", None)  # its import now fails
    checks = (("fieldmap.field.sh", _passing), ("fieldmap.nav.mechanize", _passing))
    rc, out = _run(monkeypatch, capsys, checks)
    assert rc == 1
    rows = verify.run_checks(["cpu"], lmax=4, points=5)
    assert [r.status for r in rows] == ["ok", "FAIL"]
    assert not rows[1].ok and "broken install: ModuleNotFoundError" in rows[1].note
    assert "FAIL: broken install" in out and "1 of 2 checks within 1e-12 relative; 1 FAILED" in out


def test_import_error_inside_a_check_fails(monkeypatch, capsys):
    rc, out = _run(monkeypatch, capsys, (("fieldmap.field.sh", _missing_reference),))
    assert rc == 1
    assert "broken install: ModuleNotFoundError: No module named 'fieldmap.reference.sh'" in out


def test_skipped_is_reported_not_passed(monkeypatch, capsys):
    checks = (("fieldmap.field.sh", _passing), ("fieldmap.field.normal", _skipping))
    rc, out = _run(monkeypatch, capsys, checks)
    assert rc == 0  # nothing failed
    rows = verify.run_checks(["cpu"], lmax=4, points=5)
    assert [r.status for r in rows] == ["ok", "skipped"] and not rows[1].ok
    assert "skipped: needs a CUDA device" in out
    assert "1 of 2 checks within 1e-12 relative; 1 skipped" in out


def test_nothing_verified_fails(monkeypatch, capsys):
    rc, out = _run(monkeypatch, capsys, (("fieldmap.field.sh", _skipping),))
    assert rc == 1 and "0 of 1 checks" in out


@pytest.mark.parametrize("lmax", [None, -1, 241])
def test_bad_degree(lmax):
    """None was a TypeError (``0 <= None``) instead of bad input."""
    with pytest.raises(InputError, match="lmax"):
        verify.run_checks(["cpu"], lmax=lmax)
