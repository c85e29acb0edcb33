"""An unknown device is a :class:`fieldmap._warp.DeviceError` wherever it is named.

``DeviceError`` is an :class:`~fieldmap.errors.InputError`: the API raises it as it is (no
re-wrapping into a plain ``InputError`` that hides which error it was), and the CLI prints it as
one line with exit status 2.
"""

from __future__ import annotations

import numpy as np
import pytest

from fieldmap import _warp, cli
from fieldmap.errors import InputError
from fieldmap.grids import synthesis

BAD = "cuda:97"


def test_device_error_is_an_input_error():
    assert issubclass(_warp.DeviceError, InputError)


def test_api_raises_device_error():
    from fieldmap.cli.point import evaluate_points
    from fieldmap.cli.verify import run_checks

    calls = [
        lambda: synthesis.resolve_device(BAD),
        lambda: run_checks([BAD], lmax=2, points=5),
        lambda: evaluate_points(
            np.array([0.0]), np.array([0.0]), np.array([0.0]), model_options={"lmax": 2}, device=BAD
        ),
    ]
    for call in calls:
        with pytest.raises(_warp.DeviceError, match="not present"):
            call()


@pytest.mark.parametrize(
    "argv",
    [
        ["point", "--device", BAD],
        ["verify", "--device", BAD],
        ["navsim", "--device", BAD, "--study", "table1"],
        ["map", "--device", BAD, "--step-deg", "30"],
    ],
)
def test_cli_prints_one_line(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr("sys.stdin", __import__("io").StringIO("0 0 0\n"))
    rc = cli.main(argv)
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and "not present" in err and BAD in err, err
    assert list(tmp_path.iterdir()) == []
