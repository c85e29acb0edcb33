"""A command line refused as bad input: the check the bad-input tests share."""

from __future__ import annotations

from fieldmap.cli import main


def refused(argv, tmp_path, capsys, *words, absent=()) -> str:
    """Run ``fieldmap ARGV --out``; assert one line on stderr with ``words``; return it.

    Exit status 2, no traceback, nothing on stdout, no output folder; none of ``absent`` in
    the line.
    """
    out = tmp_path / "out"
    try:
        rc = main([*argv, "--out", str(out)])
    except SystemExit as exc:  # argparse
        rc = exc.code
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert rc == 2, cap.err
    assert len(lines) == 1, cap.err
    assert "Traceback" not in cap.err and "internal error" not in cap.err
    for w in words:
        assert w in lines[0], (w, lines[0])
    for w in absent:
        assert w not in lines[0], (w, lines[0])
    assert cap.out == "", cap.out
    assert not out.exists()
    return lines[0]
