"""CI's skip policy (tests/conftest.py, ``FIELDMAP_STRICT_SKIPS=1``): only a missing GPU skips."""

import os
import subprocess
import sys
import textwrap

from conftest import unexpected_skips


def test_skip_reasons_of_the_suite():
    """The suite's own skip reasons, sorted into allowed (no GPU) and not allowed."""
    allowed = [
        "this Warp build has no NVRTC (wp.get_cuda_supported_archs() is empty): CUDA code cannot",
        "this Warp's NVRTC cannot target sm_90 (it offers [])",
        "needs a CUDA device",
        "no GPU",
    ]
    refused = [
        "GeographicLib's Gravity (geographiclib-tools) missing",
        "GeographicLib's Gravity tool is not installed",
        "no C compiler",
        "could not import 'navtk.inertial': No module named 'navtk'",
        "cfchecker is in the test extra: pip install .[test]",
        "could not import 'fieldmap.field.normal': No module named 'fieldmap.field.normal'",
        "option --x silently ignored today (gap)",
    ]
    skips = [(f"t::{i}", r) for i, r in enumerate(allowed + refused)]
    assert [r for _, r in unexpected_skips(skips)] == refused


def test_strict_session_fails_on_a_skip(tmp_path):
    """Skips not allowed (a test, a file) fail a run under FIELDMAP_STRICT_SKIPS=1, not without."""
    (tmp_path / "test_one.py").write_text(
        textwrap.dedent(
            """
            import pytest

            def test_gpu():
                pytest.skip("needs a CUDA device")

            def test_tool():
                pytest.skip("GeographicLib's Gravity tool is not installed")
            """
        )
    )
    (tmp_path / "test_two.py").write_text(
        'import pytest\n\npytest.importorskip("no_such_peer_xyz")\n\n\ndef test_x():\n    pass\n'
    )
    conftest = os.path.join(os.path.dirname(__file__), "conftest.py")
    (tmp_path / "conftest.py").write_text(open(conftest, encoding="utf-8").read())
    codes = {}
    for strict in ("0", "1"):
        env = dict(os.environ, FIELDMAP_STRICT_SKIPS=strict)
        run = subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-p", "no:cacheprovider",
             str(tmp_path / "test_one.py"), str(tmp_path / "test_two.py")],
            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        codes[strict] = run.returncode
        assert "tests/conftest.py" not in run.stderr
        assert "test_one.py::test_tool: GeographicLib" in run.stdout, run.stdout
        assert "test_two.py: could not import 'no_such_peer_xyz'" in run.stdout, run.stdout
    assert codes == {"0": 0, "1": 1}
    assert run.stdout.count("NOT ALLOWED") == 2 and "test_gpu: needs a CUDA device" in run.stdout
