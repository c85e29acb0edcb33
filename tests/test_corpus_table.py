"""benchmarks/corpus_table.py: the corpus by category, judged by the corpus test's checks."""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def corpus_table():
    sys.path.insert(0, str(BENCHMARKS))
    try:
        yield importlib.import_module("corpus_table")
    finally:
        sys.path.remove(str(BENCHMARKS))


def test_table_counts_a_meeting_and_a_refused_piece(corpus_table, tmp_path, capsys):
    """The munich piece meets the checks; the parked tanker is refused, in one line."""
    out = tmp_path / "rows.json"
    argv = ["--jobs", "1", "--name", "munich", "--name", "calfire_a5eca1_01", "--json", str(out)]
    assert corpus_table.main(argv) == 0
    text = capsys.readouterr().out
    assert "| calibration | 1 | 1 | 0 | 0 | 0 | 0 |" in text
    assert "| firefighting | 1 | 0 | 0 | 0 | 1 | 0 |" in text
    assert "| **all** | 2 | 1 | 0 | 0 | 1 | 0 |" in text
    assert "meet the checks: 1 of 2 (50.0 %)" in text
    rows = {r["name"]: r for r in json.loads(out.read_text())}
    assert rows["munich"]["verdict"] == "meets" and rows["munich"]["reasons"] == []
    assert rows["calfire_a5eca1_01"]["verdict"] == "refused"
    assert "\n" not in rows["calfire_a5eca1_01"]["reasons"][0]
    # against that run: every cell "before → now", no verdict changed
    # (and in worker processes: the same verdict)
    assert corpus_table.main(["--jobs", "2", "--name", "munich", "--before", str(out)]) == 0
    text = capsys.readouterr().out
    assert "| calibration | 1 | 1 → 1 | 0 → 0 | 0 → 0 | 0 → 0 | 0 → 0 |" in text
    assert "verdicts changed: none" in text


def test_positions_only_flies_the_piece_without_its_velocities(corpus_table, tmp_path, capsys):
    """``--positions-only``: the tanker flown from its positions, judged against its speeds."""
    piece = corpus_table.CORPUS / "firefighting" / "calfire_a53d70_12.csv.gz"
    from corpus_checks import VELOCITY_COLUMNS, positions_only

    header = positions_only(piece, tmp_path).read_text().splitlines()[0].split(",")
    assert not set(header) & set(VELOCITY_COLUMNS) and "altitude" in header
    out = tmp_path / "rows.json"
    argv = ["--jobs", "1", "--name", "calfire_a53d70_12", "--positions-only", "--json", str(out)]
    assert corpus_table.main(argv) == 0
    text = capsys.readouterr().out
    assert "| **all** | 1 | 1 | 0 | 0 | 0 | 0 |" in text and "known.json" not in text
    (row,) = json.loads(out.read_text())
    assert row["verdict"] == "meets" and row["speed_ratio"] <= 1.05


def test_bad_arguments_are_one_line_and_status_2(corpus_table, tmp_path, capsys):
    assert corpus_table.main(["--name", "no_such_piece"]) == 2
    assert corpus_table.main(["--name", "munich", "--json", str(tmp_path / "no" / "x")]) == 2
    (tmp_path / "bad.json").write_text("{")
    assert corpus_table.main(["--name", "munich", "--before", str(tmp_path / "bad.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(line.startswith("corpus_table: ") for line in err)
