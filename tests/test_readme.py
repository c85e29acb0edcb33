"""The README and the documentation pages say what is true of the code they describe.

- the README's Python API block and the docs' "Flight study from Python" block run as written;
- every ``fieldmap.X`` / dotted path named in the README or a docs page is public and imports;
- the README's quick start is what the Makefile does, and the landing page of the docs includes
  the README's sections (by its "begin X" / "end X" markers) instead of a copy;
- the README's links point to files that exist.
"""

import importlib
import pathlib
import pkgutil
import re
import warnings

import pytest

import fieldmap

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
# the hand-written pages (docs/api/ is generated from the code, docs/_build and the gallery too)
PAGES = sorted(
    p
    for p in DOCS.rglob("*.md")
    if not {"_build", "api", "gallery", "generated"} & set(p.relative_to(DOCS).parts)
)
TEXTS = [README, *PAGES]


def _python_blocks(path: pathlib.Path) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), re.S)


def _docs_extension():
    """docs/_ext/fieldmap_docs.py, the local Sphinx extension (imported from its file)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "fieldmap_docs", DOCS / "_ext" / "fieldmap_docs.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_docs_build_runs_the_flight_guide(tmp_path):
    """The docs build runs every Python block of the guide and fails on the first that fails.

    The guide holds the marker; the extension's block finder sees the blocks this module's does;
    a marked page's blocks run, one without the marker is left alone, and a page whose code
    raises stops the build (``ExtensionError``). The guide's own run is
    ``test_flight_from_python`` (the build runs the same blocks).
    """
    from sphinx.errors import ExtensionError

    ext = _docs_extension()
    page = DOCS / "user_guide" / "flight_python.md"
    text = page.read_text(encoding="utf-8")
    assert ext.RUN_MARKER.search(text)
    assert ext.python_blocks(text) == _python_blocks(page)
    done = tmp_path / "ran"
    code = f"```python\nimport pathlib\npathlib.Path({str(done)!r}).write_text('ran')\n```\n"
    ext.run_page_code(None, "unmarked", [code])
    assert not done.exists()
    marker = "<!-- the docs build runs the Python blocks of this page in tests/ -->"
    ext.run_page_code(None, "marked", [f"{marker}\n{code}"])
    assert done.read_text() == "ran"
    bad = f"{marker}\n```python\nx = 1\n```\n```python\nx / 0\n```\n"
    with pytest.raises(ExtensionError, match="Python block 2 failed: ZeroDivisionError"):
        ext.run_page_code(None, "bad", [bad])


def test_python_api_block_runs():
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Python API") :]
    block = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    env: dict = {}
    exec(compile(block, "README.md", "exec"), env)
    assert env["dg"].shape == (1, 3)
    assert env["g"].shape == (1, 3)
    assert env["gam"].shape == (1, 3)
    assert env["N"].shape == (1,) and env["anom"].shape == env["eta"].shape == (1,)
    assert float(env["ds"]["modulus_mg"].max()) > 0


def test_flight_from_python(capsys, monkeypatch):
    """docs/user_guide/flight_python.md: the public flight-study calls, as the page writes them.

    The first block is the five lines of a user's own log (a log shipped in tests/data/flights,
    run in that folder, as the docs build runs it): it prints the recommendation and draws the
    figure. The second block's claims are checked too: J2 and J4 add more than
    the 10 % of the IMU-only error allowed; the full SH model (``sh`` → ``sh240``) adds exactly
    nothing against the truth, but the field above degree 240 and the commission do, more than
    10 %, so no model is recommended and the omission is named as the dominant term.
    """
    import matplotlib.pyplot as plt

    page = DOCS / "user_guide" / "flight_python.md"
    five, block = _python_blocks(page)
    assert len([line for line in five.splitlines() if line.strip()]) == 5, five
    folder = _docs_extension().RUN_MARKER.search(page.read_text(encoding="utf-8"))[1]
    assert folder == "tests/data/flights"
    monkeypatch.chdir(ROOT / folder)  # where the docs build runs the page
    plt.close("all")
    env: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # the page shows today's call
        exec(compile(five, str(page), "exec"), env)
    assert env["study"].conditioning is not None  # a log file, read and conditioned
    assert env["res"].summary["recommendation"] in capsys.readouterr().out
    assert len(plt.get_fignums()) == 1  # res.plot() drew the figure
    plt.close("all")
    env = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        exec(compile(block, str(page), "exec"), env)
    res, added, imu_only = env["res"], env["added_m"], env["imu_only_m"]
    budget = env["budget_m"]
    assert env["study"].imu_name == "navigation"
    assert 200 < env["study"].duration_s < 300  # "about four minutes"
    assert set(added) == set(budget) == {"j2", "j4", "sh240"}
    assert 10 < imu_only < 25  # "about 16 m"
    assert min(added["j2"], added["j4"]) > 0.1 * imu_only
    assert 6 < min(budget["j2"]["model_difference"], budget["j4"]["model_difference"]) < 11
    assert budget["sh240"]["model_difference"] == 0.0
    assert 3 < budget["sh240"]["omission"] < 8  # "about 5 m"
    assert 0.5 < budget["sh240"]["commission"] < 2  # "about 1 m"
    assert res.summary["recommended_model"] is None
    assert "field above degree 240 (omission) dominates" in res.summary["recommendation"]
    assert res.summary["recommendation"] in capsys.readouterr().out
    ds = env["ds"]
    assert {"run", "time", "axis"} <= set(ds.dims)
    assert ds["position_error"].shape == (ds.sizes["run"], ds.sizes["time"], 3)


@pytest.mark.parametrize("path", TEXTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_python_blocks_compile(path):
    """Every Python block of the README and the docs pages is valid Python."""
    for block in _python_blocks(path):
        compile(block, str(path), "exec")


def _api_names(text: str) -> set[str]:
    """Top-level names a page calls: ``fieldmap.X`` and those of the "From Python:" lists."""
    names = set(re.findall(r"\bfieldmap\.([A-Za-z_]\w*)", text))
    # "From Python: `disturbance_map(..., client=client)` (also `altitude_sweep`, ...)"
    for sentence in re.findall(r"From Python:(.*?)(?:\.\s|$)", text, re.S):
        names |= set(re.findall(r"`([A-Za-z_]\w*)[`(]", sentence))
    return names


def test_named_api_is_public():
    """Every name the README or a docs page uses from ``fieldmap.`` is public and imports.

    A top-level name is in ``fieldmap.__all__`` and is an attribute of the package; a module
    (``fieldmap.nav``, ``fieldmap.units``) imports. A dotted path such as
    ``fieldmap.nav.study.run_flight`` imports as its longest module, then its attributes.
    """
    modules = {m.name for m in pkgutil.iter_modules(fieldmap.__path__)} | {"kernels"}
    texts = {p: p.read_text(encoding="utf-8") for p in TEXTS}
    names = set().union(*(_api_names(t) for t in texts.values()))
    assert {"disturbance_map", "quantity_map", "run_flight", "FlightStudy"} <= names, sorted(names)
    for name in sorted(names):
        if name.startswith("__"):  # fieldmap.__all__
            continue
        if name in modules:
            importlib.import_module(f"fieldmap.{name}")
            continue
        assert name in fieldmap.__all__, f"the docs use fieldmap.{name}, not in fieldmap.__all__"
        obj = getattr(fieldmap, name)  # the lazy table resolves it (AttributeError if not)
        called = any(
            re.search(rf"(?<![\w.])(?:fieldmap\.)?{re.escape(name)}\(", t) for t in texts.values()
        )
        assert not called or callable(obj), f"the docs call fieldmap.{name}(), not callable"
    paths = set().union(
        *(re.findall(r"\bfieldmap(?:\.[A-Za-z_]\w*){2,}", t) for t in texts.values())
    )
    for path in sorted(paths):
        parts = path.split(".")
        for cut in range(len(parts), 0, -1):  # the longest importable module, then attributes
            try:
                obj = importlib.import_module(".".join(parts[:cut]))
                break
            except ModuleNotFoundError:
                continue
        for attr in parts[cut:]:
            assert hasattr(obj, attr), f"the docs name {path}: {obj.__name__} has no {attr}"
            obj = getattr(obj, attr)


def _section(text: str, name: str) -> str:
    begin, end = f"<!-- begin {name} -->", f"<!-- end {name} -->"
    assert text.count(begin) == 1 and text.count(end) == 1, name
    assert text.index(begin) < text.index(end), name
    return text[text.index(begin) + len(begin) : text.index(end)]


def test_quick_start_is_the_makefile():
    """The README's two quick-start commands exist, and ``make map`` runs what it says."""
    quick = _section(README.read_text(encoding="utf-8"), "quick start")
    lines = re.search(r"```bash\n(.*?)```", quick, re.S).group(1).splitlines()
    assert [line.split("#")[0].strip() for line in lines] == ["make map", "make test"]
    makefile = (ROOT / "Makefile").read_text(encoding="utf-8")
    said = re.search(r"`make map` runs `(fieldmap map [^`]*)`", quick).group(1)
    recipe = re.search(r"^map:.*\n\t\$\(BIN\)/(.*)$", makefile, re.M).group(1)
    assert recipe == said
    assert re.search(r"^test:.*\n\t\$\(BIN\)/python -m pytest -q$", makefile, re.M)


def test_docs_landing_page_includes_the_readme():
    """docs/index.md includes the README's sections by their markers, and opens on a figure."""
    index = (DOCS / "index.md").read_text(encoding="utf-8")
    readme = README.read_text(encoding="utf-8")
    includes = re.findall(
        r"```\{include\} \.\./README\.md\n:start-after: <!-- begin (.+?) -->\n"
        r":end-before: <!-- end \1 -->\n",
        index,
    )
    assert {"intro", "quick start", "example flight"} <= set(includes), includes
    for name in includes:
        _section(readme, name)  # the markers are there, once each, in order
    first = index.split("\n## ")[0]  # before the first section: the title and a figure
    image = re.search(r"```\{figure\} (\S+)", first).group(1)
    assert (DOCS / image).read_bytes()[:4] == b"\x89PNG"


def test_readme_links_exist():
    """Every relative link and image of the README points to a file of the repository."""
    text = README.read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [t for t in targets if not re.match(r"[a-z]+:", t)]
    assert any(t.startswith("docs/_static/") for t in local)  # the figures
    for target in local:
        assert (ROOT / target).exists(), target
