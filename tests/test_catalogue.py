"""Models by name (fieldmap.models.catalogue), against a local HTTP server: no network used."""

from __future__ import annotations

import hashlib
import http.server
import os
import threading

import numpy as np
import pytest

from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.models import catalogue
from fieldmap.models.catalogue import CATALOGUE, CatalogueEntry
from fieldmap.models.icgem import write_icgem
from fieldmap.models.registry import clear_cache, load_model


class _Server:
    """An http.server in a thread serving one folder; counts the GET requests."""

    def __init__(self, folder):
        counter = self
        self.gets = 0

        class Handler(http.server.SimpleHTTPRequestHandler):
            def __init__(self, *args, **kwargs):
                super().__init__(*args, directory=str(folder), **kwargs)

            def do_GET(self):  # noqa: N802 - http.server's name
                counter.gets += 1
                super().do_GET()

            def log_message(self, *args):  # quiet
                pass

        self.httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def close(self):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.fixture
def served(tmp_path, monkeypatch):
    """Serve a small .gfc (the bundled EIGEN-6S to degree 12) locally; a downloads folder."""
    for var in ("NO_PROXY", "no_proxy"):
        monkeypatch.setenv(var, "127.0.0.1,localhost")
    www = tmp_path / "www"
    www.mkdir()
    small = load_model("eigen-6s", lmax=12)
    write_icgem(www / "small.gfc", small)
    data = (www / "small.gfc").read_bytes()
    downloads = tmp_path / "downloads"
    from fieldmap.models import cache

    monkeypatch.setattr(cache, "downloads_dir", lambda root=None: str(downloads))
    server = _Server(www)
    clear_cache()
    yield {
        "server": server,
        "sha256": hashlib.sha256(data).hexdigest(),  # of the bytes served, independently
        "size": len(data),
        "model": small,
        "downloads": downloads,
        "monkeypatch": monkeypatch,
    }
    server.close()
    clear_cache()


def _entry(served, **changes):
    fields = {
        "name": "Test-Small",
        "url": served["server"].url + "/small.gfc",
        "filename": "Test-Small.gfc",
        "sha256": served["sha256"],
        "size": None,
        "tide_system": "tide_free",
        "degree": 12,
        "licence": "test",
    }
    e = CatalogueEntry(**{**fields, **changes})
    served["monkeypatch"].setitem(CATALOGUE, e.name.lower(), e)
    return e


def test_download_once_verify_and_read(served):
    _entry(served)
    m = load_model("TEST-SMALL")  # case-insensitive
    path = served["downloads"] / "Test-Small.gfc"
    assert path.is_file() and served["server"].gets == 1
    np.testing.assert_array_equal(m.C, served["model"].C)
    np.testing.assert_array_equal(m.S, served["model"].S)
    assert m.source == str(path) and m.tide_system == "tide_free"
    clear_cache()
    load_model("test-small", lmax=4)  # in the downloads folder now: no second request
    assert served["server"].gets == 1
    assert not [p for p in os.listdir(served["downloads"]) if p != "Test-Small.gfc"]


def test_checksum_mismatch_removes_the_file(served):
    _entry(served, sha256="0" * 64)
    with pytest.raises(InputError, match="does not have the catalogue's SHA-256") as exc:
        load_model("test-small")
    assert "\n" not in str(exc.value) and "removed, not used" in str(exc.value)
    assert not os.listdir(served["downloads"])  # nothing kept, nothing read


def test_damaged_file_in_the_folder_is_removed(served):
    e = _entry(served)
    path = catalogue.fetch(e)
    with open(path, "ab") as f:
        f.write(b"gfc 13 0 1.0 0.0\n")
    with pytest.raises(InputError, match="not the catalogue's"):
        catalogue.fetch(e)
    assert not os.path.exists(path)


def test_offline_is_one_line_naming_url_and_path(served):
    with_closed_port = "http://127.0.0.1:9/small.gfc"  # discard port: nothing listens
    e = _entry(served, url=with_closed_port)
    with pytest.raises(InputError) as exc:
        catalogue.fetch(e)
    msg = str(exc.value)
    assert "\n" not in msg and with_closed_port in msg
    assert str(served["downloads"] / "Test-Small.gfc") in msg and "by hand" in msg
    assert not os.path.exists(served["downloads"] / "Test-Small.gfc")


def test_http_error_is_named(served):
    e = _entry(served, url=served["server"].url + "/missing.gfc")
    with pytest.raises(InputError, match="HTTP 404"):
        catalogue.fetch(e)


def test_no_checksum_size_then_warning(served, capsys):
    e = _entry(served, sha256=None, size=served["size"])
    path = catalogue.fetch(e)
    err = capsys.readouterr().err
    assert "no checksum" in err and served["sha256"] in err  # the hash to record
    assert os.path.getsize(path) == served["size"]
    os.remove(path)
    wrong = _entry(served, sha256=None, size=served["size"] + 1)
    with pytest.raises(InputError, match="bytes, not the catalogue's"):
        catalogue.fetch(wrong)
    assert not os.path.exists(path)
    neither = _entry(served, sha256=None, size=None)
    with pytest.raises(InputError, match="neither a checksum nor a size"):
        catalogue.fetch(neither)
    assert served["server"].gets == 2


def test_cli_model_by_name(served, tmp_path, capsys):
    _entry(served)
    points = tmp_path / "p.txt"
    args = ["point", "--quantity", "geoid", "--lmax", "6", "--input", str(points)]
    points.write_text("45 10 0\n")
    assert main([*args, "--model", "Test-Small"]) == 0
    by_name = capsys.readouterr().out
    assert main([*args, "--model", "eigen-6s"]) == 0  # the same coefficients, bundled
    assert capsys.readouterr().out == by_name
    assert served["server"].gets == 1


def test_unknown_name_lists_the_catalogue(capsys):
    with pytest.raises(InputError) as exc:
        load_model("EGM2009")
    for name in ("EGM2008", "EIGEN-6C4", "XGM2019e_2159", "GOCO06s", "GGM05C"):
        assert name in str(exc.value)
    assert main(["cache", "fetch", "EGM2009"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "EGM2008" in err[0] and "GGM05C" in err[0]


def test_catalogue_entries_well_formed(capsys):
    from fieldmap.models.tide import TIDE_SYSTEMS

    assert len(CATALOGUE) == 5
    for key, e in CATALOGUE.items():
        assert key == e.name.lower()
        assert e.url.startswith("http://icgem.gfz-potsdam.de/getmodel/gfc/")
        assert e.url.endswith("/" + e.filename) and e.tide_system in TIDE_SYSTEMS
        assert e.sha256 is not None and len(e.sha256) == 64  # pinned (pyshtools 4.14.1)
    assert main(["cache", "models"]) == 0
    out = capsys.readouterr().out
    assert all(e.name in out for e in CATALOGUE.values())
    with pytest.raises(ValueError, match="64 lower-case hex"):
        CatalogueEntry("x", "u", "f", "ABC", None, "tide_free", 2, "")


def test_catalogue_pins_what_pyshtools_pins(monkeypatch):
    """Each entry's URL and SHA-256 equal those pyshtools' own downloader pins for the model.

    An independent check of the catalogue's pins (ICGEM publishes no checksums): pyshtools'
    ``datasets.Earth`` functions are called with its ``pooch.retrieve`` replaced by a recorder,
    so nothing is downloaded; a pyshtools release that re-pins a file makes this fail.
    """
    Earth = pytest.importorskip("pyshtools.datasets.Earth")
    pinned: dict[str, str] = {}

    class Recorded(Exception):
        pass

    def record(url, known_hash, *args, **kwargs):
        pinned[url] = known_hash
        raise Recorded

    monkeypatch.setattr(Earth, "_retrieve", record)
    for fetch in (Earth.EGM2008, Earth.EIGEN_6C4, Earth.XGM2019E, Earth.GOCO06S, Earth.GGM05C):
        with pytest.raises(Recorded):
            fetch()
    assert len(pinned) == len(CATALOGUE) == 5
    for e in CATALOGUE.values():
        assert pinned.get(e.url) == f"sha256:{e.sha256}", e.name
