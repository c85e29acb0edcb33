"""Gravity models by name: a small catalogue of ICGEM files, downloaded once and verified.

``load_model("EGM2008")`` (``fieldmap map --model EGM2008``) finds the name here when it is
neither the bundled model, nor a file, nor an installed GeographicLib model: the ICGEM file is
downloaded once (with a progress bar, by :mod:`pooch`) into ``<model cache>/downloads``
(:func:`fieldmap.models.cache.downloads_dir`), verified against its SHA-256, and read as any
``.gfc`` file (its parsed coefficients then enter the model cache as usual).

Failures are one line each (:class:`~fieldmap.errors.InputError`, exit status 2): an unknown
name (the line lists the catalogue), no network or a blocked URL (the line names the URL and
the path where a copy fetched by hand is read from), a checksum mismatch (the file is removed,
never read).

Checksums. ICGEM publishes no checksums. The SHA-256 of each entry is the one pinned by
pyshtools 4.14.1 (``pyshtools/datasets/Earth/__init__.py``, ``known_hash`` of each model, the
same ICGEM URLs), which its users' downloads verify against
(``tests/test_catalogue.py::test_catalogue_pins_what_pyshtools_pins`` compares every URL and
SHA-256 with the ones the installed pyshtools pins); fieldmap has not downloaded the files itself
(its development machines have no network).
An entry without a checksum (``sha256=None``) must give the file's ``size``:
the first download is then checked by size and accepted with a warning naming its SHA-256
(to be recorded in the entry); one with neither is refused. The tide system and degree are
those of the files as pyshtools describes them, for the listing (``fieldmap cache models``);
the model read takes its tide system from the file's own header.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass

from fieldmap.errors import InputError

_ICGEM = "http://icgem.gfz-potsdam.de/getmodel/gfc"


@dataclass(frozen=True)
class CatalogueEntry:
    """One model of the catalogue.

    Attributes
    ----------
    name : str
        Name as the user types it (matched case-insensitively).
    url : str
        Where the ``.gfc`` file is downloaded from (ICGEM).
    filename : str
        Name of the file in the downloads folder.
    sha256 : str or None
        SHA-256 of the file (64 hex digits); None: unknown (then ``size`` is required).
    size : int or None
        Size of the file. Units: bytes. None: unknown.
    tide_system : str
        Permanent-tide system of the file (:mod:`fieldmap.models.tide`).
    degree : int
        Maximum degree of the file.
    licence : str
        Licence or terms of use, and the reference to cite.
    """

    name: str
    url: str
    filename: str
    sha256: str | None
    size: int | None
    tide_system: str
    degree: int
    licence: str

    def __post_init__(self) -> None:
        if self.sha256 is not None and (
            len(self.sha256) != 64 or set(self.sha256) - set("0123456789abcdef")
        ):
            raise ValueError(f"{self.name}: sha256 must be 64 lower-case hex digits")


#: the catalogue: lower-case name -> entry (URLs and SHA-256 as pinned by pyshtools 4.14.1)
CATALOGUE: dict[str, CatalogueEntry] = {
    e.name.lower(): e
    for e in (
        CatalogueEntry(
            "EGM2008",
            f"{_ICGEM}/c50128797a9cb62e936337c890e4425f03f0461d7329b09a8cc8561504465340/"
            "EGM2008.gfc",
            "EGM2008.gfc",
            "ab5b524da073e63b5bdceb7ca47a0de07a26dd44a1c5798f39fc98dc80af70fd",
            None,
            "tide_free",
            2190,
            "NGA, released for public use; cite Pavlis et al. (2012) JGR 117 B04406",
        ),
        CatalogueEntry(
            "EIGEN-6C4",
            f"{_ICGEM}/7fd8fe44aa1518cd79ca84300aef4b41ddb2364aef9e82b7cdaabdb60a9053f1/"
            "EIGEN-6C4.gfc",
            "EIGEN-6C4.gfc",
            "2ac274a66a25fb25bdddcec7074669867939345ad003bbc1ece3967450d48dc1",
            None,
            "tide_free",
            2190,
            "GFZ Data Services, doi:10.5880/icgem.2015.1 (Förste et al. 2014)",
        ),
        CatalogueEntry(
            "XGM2019e_2159",
            f"{_ICGEM}/eeb03971cf6e533e6eeb6b010336463286dcda0846684248d5530acf8e800055/"
            "XGM2019e_2159.gfc",
            "XGM2019e_2159.gfc",
            "ee24f7cf68f45b44cdbf3ccbf57e7382c7667869356061419f00f2ca951861e4",
            None,
            "zero_tide",
            2190,
            "ICGEM; cite Zingerle et al. (2020) J. Geod. 94, 66",
        ),
        CatalogueEntry(
            "GOCO06s",
            f"{_ICGEM}/32ec2884630a02670476f752d2a2bf1c395d8c8d6d768090ed95b4f04b0d5863/"
            "GOCO06s.gfc",
            "GOCO06s.gfc",
            "351d9d20b84cd2c0f52ce77146b1e3b774f408200b579ffaf98593cf3d271819",
            None,
            "zero_tide",
            300,
            "GFZ Data Services, doi:10.5880/ICGEM.2019.002 (Kvas et al. 2019)",
        ),
        CatalogueEntry(
            "GGM05C",
            f"{_ICGEM}/778a683780a5b0ad3163f4772b97b9075a0a13c389d2bd8ea3f891b64cfa383d/GGM05C.gfc",
            "GGM05C.gfc",
            "efb1781e748969dab2721f45365cd060b5963ffe4fd497006cc786f9e5241bf2",
            None,
            "zero_tide",
            360,
            "GFZ Data Services, doi:10.5880/icgem.2016.002 (Ries et al. 2016)",
        ),
    )
}


def names() -> list[str]:
    """Return the catalogue's model names, as spelt in it."""
    return [e.name for e in CATALOGUE.values()]


def lookup(name: object) -> CatalogueEntry | None:
    """Return the entry of ``name`` (case-insensitive), or None."""
    if not isinstance(name, str):
        return None
    return CATALOGUE.get(name.strip().lower())


def entry(name: str) -> CatalogueEntry:
    """Return the entry of ``name``; an unknown name is one line listing the catalogue."""
    found = lookup(name)
    if found is None:
        raise InputError(f"unknown catalogue model {name!r}: one of {', '.join(names())}")
    return found


def local_path(e: CatalogueEntry, folder: str | None = None) -> str:
    """Where the file of ``e`` is kept (and read from, when put there by hand)."""
    from fieldmap.models.cache import downloads_dir

    return os.path.join(folder or downloads_dir(), e.filename)


def fetch(e: CatalogueEntry, folder: str | None = None, progress: bool | None = None) -> str:
    """Return the path of the verified file of ``e``, downloading it first if absent.

    Parameters
    ----------
    e : CatalogueEntry
        The model.
    folder : str, optional
        Downloads folder (default :func:`fieldmap.models.cache.downloads_dir`).
    progress : bool, optional
        Progress bar on stderr (default: when stderr is a terminal).

    Raises
    ------
    InputError
        Download failed (the line names the URL and the path to put the file at), checksum
        or size mismatch (the file is removed), an entry with neither checksum nor size.
    """
    path = local_path(e, folder)
    if os.path.exists(path):
        _verify_present(e, path)
        return path
    if e.sha256 is None and e.size is None:
        raise InputError(
            f"{e.name}: the catalogue has neither a checksum nor a size for {e.url}, so a "
            f"download cannot be verified: fetch it yourself and give its path (--model FILE)"
        )
    os.makedirs(os.path.dirname(path), exist_ok=True)
    _download(e, path, sys.stderr.isatty() if progress is None else progress)
    if e.sha256 is None:  # verified by size only: say so, with the hash to record
        _check_size(e, path)
        from fieldmap.models.cache import content_hash

        print(
            f"fieldmap: warning: {e.name}: no checksum in the catalogue; {path} accepted by its "
            f"size ({e.size} bytes), SHA-256 {content_hash([path])}",
            file=sys.stderr,
        )
    return path


def _download(e: CatalogueEntry, path: str, progress: bool) -> None:
    """Download ``e.url`` to ``path`` with pooch (verified against ``e.sha256`` when known)."""
    import logging

    import pooch  # type: ignore[import-untyped]  # no py.typed marker (pooch 1.9)

    if progress:  # with the bar; a failure is then one line of its own
        print(f"fieldmap: downloading {e.name} from {e.url} to {path}", file=sys.stderr)
    logger = pooch.get_logger()
    level = logger.level
    logger.setLevel(logging.WARNING)  # our line above says it; pooch's would be a second one
    try:
        pooch.retrieve(
            e.url,
            known_hash=None if e.sha256 is None else f"sha256:{e.sha256}",
            fname=os.path.basename(path),
            path=os.path.dirname(path),
            downloader=pooch.HTTPDownloader(progressbar=progress, timeout=60),
        )
    except ValueError as exc:  # pooch: the hash of the download differs (nothing kept)
        _remove(path)
        if "hash" in str(exc).lower():
            raise InputError(
                f"{e.name}: the file downloaded from {e.url} does not have the catalogue's "
                f"SHA-256 {e.sha256}: removed, not used"
            ) from None
        raise _unreachable(e, path, exc) from None
    except Exception as exc:  # noqa: BLE001 - no network, refused, HTTP error: one line
        _remove(path)
        raise _unreachable(e, path, exc) from None
    finally:
        logger.setLevel(level)


def _unreachable(e: CatalogueEntry, path: str, exc: BaseException) -> InputError:
    """One line: the URL, why (the exception's kind, an HTTP status), where to put the file."""
    why = type(exc).__name__
    status = getattr(getattr(exc, "response", None), "status_code", None)
    if status is not None:
        why += f", HTTP {status}"
    return InputError(
        f"cannot download {e.name} from {e.url} ({why}): download it by hand to {path}"
    )


def _verify_present(e: CatalogueEntry, path: str) -> None:
    """Check a file already in the downloads folder (through the stat index of the cache)."""
    if e.sha256 is None:
        _check_size(e, path)
        return
    from fieldmap.models.cache import content_hash

    digest = content_hash([path])
    if digest != e.sha256:
        _remove(path)
        raise InputError(
            f"{e.name}: {path} has SHA-256 {digest}, not the catalogue's {e.sha256}: removed, "
            f"not used (download it again, or by hand from {e.url})"
        )


def _check_size(e: CatalogueEntry, path: str) -> None:
    size = os.path.getsize(path)
    if e.size is not None and size != e.size:
        _remove(path)
        raise InputError(
            f"{e.name}: {path} has {size} bytes, not the catalogue's {e.size}: removed, not used"
        )


def _remove(path: str) -> None:
    try:
        os.remove(path)
    except OSError:
        pass


def describe(e: CatalogueEntry, folder: str | None = None) -> str:
    """One line of ``fieldmap models``: name, degree, tide system, state, licence."""
    path = local_path(e, folder)
    state = "downloaded" if os.path.exists(path) else "not downloaded"
    size = "size ?" if e.size is None else f"{e.size / 2**20:.0f} MiB"
    checksum = "sha256 " + (e.sha256[:12] + "…" if e.sha256 else "unknown")
    return (
        f"{e.name:<14} degree {e.degree:<5d} {e.tide_system:<10} {size:<9} {checksum:<20} "
        f"{state}; {e.licence}"
    )
