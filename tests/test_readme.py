"""The README's Python API block runs as written (its names, keywords and shapes are current)."""

import pathlib
import re

README = pathlib.Path(__file__).resolve().parents[1] / "README.md"


def test_python_api_block_runs():
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Python API") :]
    block = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    env: dict = {}
    exec(compile(block, "README.md", "exec"), env)
    assert env["dg"].shape == (1, 3)
    assert env["g"].shape == (1, 3)
    assert env["gam"].shape == (1, 3)
    assert env["N"].shape == (1,) and env["dga"].shape == (1, 3)
    assert float(env["ds"]["modulus_mg"].max()) > 0
