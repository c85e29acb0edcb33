"""Verified on-disk cache of parsed model coefficients, so that a new process loads a model fast.

Parsing a degree-2190 text model takes ~10 s; its coefficients as two ``.npy`` arrays load,
memory-mapped, in tens of milliseconds. Layout under :func:`cache_dir`
(``$FIELDMAP_MODEL_CACHE``, else ``$XDG_CACHE_HOME/fieldmap/models``, else
``~/.cache/fieldmap/models``)::

    entries/<content-hash>-<variant-hash>/{C.npy, S.npy, [SC.npy, SS.npy,] [CC.npy, CS.npy,]
                                           meta.json}
    paths/<hash of the real path>.json      # stat index: path, size, m/ctime_ns, inode -> hash

* **Key.** The SHA-256 of the model file's bytes (both files for GeographicLib's pair), plus a
  *variant*: the reader's name and version (:data:`fieldmap.models.icgem.READER_VERSION` etc.;
  bumped when a reader's output changes), the epoch of time-variable terms, the degree read
  (``all`` or a truncation) and, for NGA files, the GM and radius used. A changed file, reader or
  option is a different entry; nothing is ever looked up by path alone.
* **Fast check.** Hashing costs ~0.15 s per 200 MB from the page cache and seconds from a cold
  disk or a network file system, at every process start. So the content hash of a path is
  remembered in a stat index together with the file's size, modification and change times (ns)
  and inode; while all five are unchanged the remembered hash is used, and any change rehashes
  the file. The change time is what an edit in place whose modification time was set back
  (``touch -r``) still changes: no user process can set it.
* **Never trusted blindly.** ``meta.json`` stores the SHA-256 of every array's bytes, its shape
  and dtype; each load verifies them (~25 ms per 38 MB array) and an entry that fails — missing
  file, bad JSON, other shape, other checksum, other format version — is deleted and rebuilt
  from the model file.
* **Atomic.** An entry is written in a temporary folder and renamed into place; a process that
  loses the race keeps its own copy in memory and removes its temporary folder. A cache folder
  that cannot be written only costs the speed-up (the model still loads); one that is a file is
  refused (:func:`usable`).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import tempfile
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel

#: format of the entries themselves (bump when the layout changes)
CACHE_FORMAT = 2  # 2: sigma_c, sigma_s (SC.npy, SS.npy) stored when the model has them
_ARRAYS = ("C", "S")
_CORR = ("CC", "CS")


def usable(root: str) -> str:
    """Return ``root``, refused if it is no folder.

    :class:`InputError` if ``root``, or the nearest existing path above it, is not a folder (a
    missing folder is fine: the cache creates it). A cache folder that cannot be written only
    costs the speed-up, but a path that is a file, or lies under one (``FIELDMAP_MODEL_CACHE``
    set to a file by mistake), is a misconfiguration: every use of the cache reports it in one
    line, rather than ``fieldmap cache info`` listing "0 cached models" in it and every run
    parsing the model file again in silence.
    """
    probe = os.path.abspath(root)
    while not os.path.lexists(probe):
        parent = os.path.dirname(probe)
        if parent == probe:
            return root
        probe = parent
    if os.path.isdir(probe):
        return root
    same = probe == os.path.abspath(root)
    why = "is not a folder" if same else f"cannot be made ({probe} is not a folder)"
    raise InputError(
        f"model cache folder {root} {why}: set FIELDMAP_MODEL_CACHE to a folder (or read models "
        "without the cache, --no-cache)"
    )


def cache_dir() -> str:
    """Folder of the model cache (``FIELDMAP_MODEL_CACHE``, :mod:`fieldmap.config`); not created."""
    from fieldmap import config

    return config.get().model_cache


def downloads_dir(root: str | None = None) -> str:
    """Folder of the model files downloaded by name (:mod:`fieldmap.models.catalogue`).

    ``<cache>/downloads``; not created here. :func:`clear` leaves it alone (a download of a
    degree-2190 model takes minutes; its parsed entry a second to rebuild).
    """
    return os.path.join(_root(root), "downloads")


def _root(root: str | None) -> str:
    """``root``, else :func:`cache_dir`; an InputError if that is a file (:func:`usable`)."""
    return usable(root or cache_dir())


def _sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(8 << 20):
            h.update(chunk)
    return h.hexdigest()


def _sha256_array(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).reshape(-1).view(np.uint8).data).hexdigest()


def _regular(path: str) -> bool:
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


def content_hash(paths: list[str], root: str | None = None) -> str:
    """SHA-256 of the files' contents, through the stat index (module docstring)."""
    root = _root(root)
    parts = []
    for p in paths:
        real = os.path.realpath(p)
        st = os.stat(real)
        stamp = [st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino]
        idx = os.path.join(root, "paths", hashlib.sha256(real.encode()).hexdigest()[:32] + ".json")
        digest = None
        try:
            with open(idx, encoding="utf-8") as f:
                rec = json.load(f)
            if rec.get("path") == real and rec.get("stat") == stamp:
                digest = rec.get("sha256")
        except (OSError, ValueError):
            pass
        if not (isinstance(digest, str) and len(digest) == 64):
            digest = _sha256_file(real)
            _write_json(idx, {"path": real, "stat": stamp, "sha256": digest})
        parts.append(digest)
    if len(parts) == 1:
        return parts[0]
    return hashlib.sha256("".join(parts).encode()).hexdigest()


def _write_json(path: str, obj: Any) -> None:
    """Write ``obj`` atomically; silently give up where the cache folder is not writable."""
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=os.path.dirname(path), suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(obj, f)
        os.replace(tmp, path)
    except OSError:
        pass


def _entry(root: str, digest: str, variant: str) -> str:
    vhash = hashlib.sha256(variant.encode()).hexdigest()[:16]
    return os.path.join(root, "entries", f"{digest[:40]}-{vhash}")


def _meta_of(model: SHModel) -> dict:
    header = {k: v for k, v in model.header.items() if k != "correction"}
    return {
        "name": model.name,
        "gm": model.gm,
        "radius": model.radius,
        "max_degree": model.nominal_degree,
        "tide_system": model.tide_system,
        "epoch": model.epoch,
        "source": model.source,
        "header": header,
    }


def load(paths: list[str], variant: str, *, root: str | None = None) -> SHModel | None:
    """Return the cached model for these files and variant, or None (absent or invalid).

    An entry that fails verification is deleted.
    """
    root = _root(root)
    try:
        digest = content_hash(paths, root)
    except OSError:
        return None
    folder = _entry(root, digest, variant)
    if not os.path.isdir(folder):
        return None
    try:
        with open(os.path.join(folder, "meta.json"), encoding="utf-8") as f:
            meta = json.load(f)
        if meta.get("format") != CACHE_FORMAT or meta.get("variant") != variant:
            raise ValueError("other format or variant")
        arrays = {}
        for name, rec in meta["arrays"].items():
            a = np.load(os.path.join(folder, f"{name}.npy"), mmap_mode="r", allow_pickle=False)
            if list(a.shape) != rec["shape"] or a.dtype != np.float64:
                raise ValueError(f"{name}: shape or dtype")
            if _sha256_array(a) != rec["sha256"]:
                raise ValueError(f"{name}: checksum")
            arrays[name] = a
        m = meta["model"]
        header = dict(m["header"])
        if "CC" in arrays:
            header["correction"] = SHModel(
                f"{m['name']} correction",
                1.0,
                1.0,
                arrays["CC"],
                arrays["CS"],
                arrays["CC"].shape[0] - 1,
                source=m["source"],
            )
        return SHModel(
            name=m["name"],
            gm=float(m["gm"]),
            radius=float(m["radius"]),
            C=arrays["C"],
            S=arrays["S"],
            nominal_degree=int(m["max_degree"]),
            tide_system=m["tide_system"],
            epoch=m["epoch"],
            source=m["source"],
            header=header,
            sigma_c=arrays.get("SC"),
            sigma_s=arrays.get("SS"),
        )
    except (OSError, ValueError, KeyError, TypeError):
        shutil.rmtree(folder, ignore_errors=True)
        return None


def store(paths: list[str], variant: str, model: SHModel, *, root: str | None = None) -> bool:
    """Write ``model`` as the entry of these files and variant; True if written.

    Never raises for an unwritable cache (the caller keeps the model it has in memory).
    """
    root = _root(root)
    try:
        digest = content_hash(paths, root)
        folder = _entry(root, digest, variant)
        os.makedirs(os.path.dirname(folder), exist_ok=True)
        tmp = tempfile.mkdtemp(dir=os.path.dirname(folder), prefix=".tmp-")
    except OSError:
        return False
    try:
        arrays = {"C": model.C, "S": model.S}
        corr = model.header.get("correction")
        if isinstance(corr, SHModel):
            arrays.update({"CC": corr.C, "CS": corr.S})
        if model.sigma_c is not None and model.sigma_s is not None:
            arrays.update({"SC": model.sigma_c, "SS": model.sigma_s})
        rec = {}
        for name, a in arrays.items():
            a = np.ascontiguousarray(a, dtype=np.float64)
            np.save(os.path.join(tmp, f"{name}.npy"), a, allow_pickle=False)
            rec[name] = {"shape": list(a.shape), "sha256": _sha256_array(a)}
        meta = {
            "format": CACHE_FORMAT,
            "variant": variant,
            "files": [os.path.realpath(p) for p in paths],
            "arrays": rec,
            "model": _meta_of(model),
        }
        with open(os.path.join(tmp, "meta.json"), "w", encoding="utf-8") as f:
            json.dump(meta, f)
        try:
            os.rename(tmp, folder)
        except OSError:  # another process was first, or a stale entry sits there
            shutil.rmtree(folder, ignore_errors=True)
            os.rename(tmp, folder)
        return True
    except (OSError, TypeError, ValueError):
        shutil.rmtree(tmp, ignore_errors=True)
        return False


def cached_read(
    paths: list[str],
    variant: str,
    lmax: int | None,
    reader: Callable[[int | None], SHModel],
    *,
    enabled: bool = True,
) -> SHModel:
    """Return the model of ``paths`` read to degree ``lmax``, through the cache.

    Parameters
    ----------
    paths : list of str
        The model file(s) (their contents key the entry).
    variant : str
        Reader name and version, epoch, options (see the module docstring).
    lmax : int or None
        Degree needed (None: all). A cached full read serves every lmax (a slice of the
        memory map); otherwise a read to exactly this degree is looked up, then made and stored.
    reader : callable
        ``reader(lmax) -> SHModel``, the parser.
    enabled : bool
        False: parse and neither read nor write the cache.
    """
    if not enabled or _disabled or not all(_regular(p) for p in paths):
        # a device, pipe or missing file: the reader names the problem (and /dev/zero must
        # not be hashed forever)
        return reader(lmax)
    full = load(paths, variant + "|all")
    if full is not None:
        if lmax is None or lmax == full.lmax:
            return full
        if lmax < full.lmax:
            return full.truncated(lmax)
    if lmax is not None:
        part = load(paths, variant + f"|L{lmax}")
        if part is not None:
            return part
    model = reader(lmax)
    store(paths, variant + ("|all" if lmax is None else f"|L{lmax}"), model)
    return model


def clear(root: str | None = None) -> tuple[int, int]:
    """Delete every cached model; return (entries removed, bytes freed)."""
    root = _root(root)
    count = size = 0
    for sub in ("entries", "paths", "tables"):
        folder = os.path.join(root, sub)
        if not os.path.isdir(folder):
            continue
        for name in os.listdir(folder):
            path = os.path.join(folder, name)
            if sub != "paths" and not name.startswith(".tmp-"):
                count += 1
            for dirpath, _, files in os.walk(path):
                for fn in files:
                    try:
                        size += os.path.getsize(os.path.join(dirpath, fn))
                    except OSError:
                        pass
            if os.path.isdir(path):
                shutil.rmtree(path, ignore_errors=True)
            else:
                try:
                    os.remove(path)
                except OSError:
                    pass
    return count, size


def info(root: str | None = None) -> list[dict]:
    """List the cached models: folder, files, variant, size in bytes."""
    root = _root(root)
    out: list[dict] = []
    folder = os.path.join(root, "entries")
    if not os.path.isdir(folder):
        return out
    for name in sorted(os.listdir(folder)):
        path = os.path.join(folder, name)
        try:
            with open(os.path.join(path, "meta.json"), encoding="utf-8") as f:
                meta = json.load(f)
            size = sum(os.path.getsize(os.path.join(path, f)) for f in os.listdir(path))
        except (OSError, ValueError):
            continue
        files, variant = meta.get("files"), meta.get("variant")
        out.append({"entry": path, "files": files, "variant": variant, "bytes": size})
    return out


_disabled = False


def disable() -> None:
    """Stop reading and writing any cache in this process (``--no-cache``)."""
    global _disabled
    _disabled = True


#: smallest degree whose Legendre recursion tables are worth caching on disk (below it they
#: take milliseconds to compute)
TABLES_MIN_DEGREE = 1000


def cached_tables(
    lmax: int, compute: Callable[[int], dict[str, np.ndarray]], *, root: str | None = None
) -> dict[str, np.ndarray]:
    """Recursion tables of the spherical-harmonic engine, kept on disk for high degrees.

    ``compute(lmax) -> dict`` of float64 arrays (:func:`fieldmap.field.sh.recursion_tables`,
    0.4 s at degree 2190). The key is the degree and the SHA-256 of the source code of
    ``compute``, so a change of the formulas is a new entry; the arrays are verified by their
    checksums as the model entries are (a bad entry is recomputed and rewritten).
    """
    if _disabled or lmax < TABLES_MIN_DEGREE:
        return compute(lmax)
    try:
        folder = _tables_folder(lmax, compute, root)
    except InputError:  # the cache path is a file: only the speed-up is lost (the model loads
        return compute(lmax)  # with the cache on report it; load_model(cache=False) must run)
    if folder is None:
        return compute(lmax)
    with _tables_lock:  # a prefetch under way (another thread): wait for it, take its result
        tab = _prefetched.pop(folder, None)
        _prefetched.clear()  # one of another entry (older formulas) is not kept either
        return tab if tab is not None else _load_tables(folder, lmax, compute)


_tables_lock = threading.Lock()
_prefetched: dict = {}  # folder -> tables verified by prefetch_tables, for the next call only


def prefetch_tables(lmax: int, *, root: str | None = None) -> None:
    """Verify the cached tables of degree ``lmax`` now, for the next :func:`cached_tables` call.

    For ``fieldmap point``, which verifies them while Warp is imported, before the code that
    keys the entry (the source of ``compute``) is importable: the one entry of degree ``lmax``
    present is verified, and the next :func:`cached_tables` call takes it if it is the entry of
    its ``compute`` (once; later calls load and verify as usual; a call made meanwhile waits).
    Nothing happens if there is no such entry, or several (older formulas), or it is damaged
    (then :func:`cached_tables` rebuilds it as usual).
    """
    if _disabled or lmax < TABLES_MIN_DEGREE:
        return
    try:
        parent = os.path.join(_root(root), "tables")
        names = [n for n in os.listdir(parent) if n.startswith(f"L{int(lmax)}-")]
    except (OSError, InputError):  # InputError: the cache path is a file (see cached_tables)
        return
    if len(names) != 1:
        return
    folder = os.path.join(parent, names[0])
    with _tables_lock:
        try:
            tab = _verified_tables(folder)
        except (OSError, ValueError, KeyError, TypeError):
            return
        _prefetched.clear()
        _prefetched[folder] = tab


def _tables_folder(
    lmax: int, compute: Callable[[int], dict[str, np.ndarray]], root: str | None
) -> str | None:
    """Entry of the tables of ``lmax`` made by ``compute`` (keyed by its source), or None."""
    import inspect

    root = _root(root)
    try:
        code = inspect.getsource(compute)
    except (OSError, TypeError):
        return None
    key = hashlib.sha256(code.encode()).hexdigest()[:16]
    return os.path.join(root, "tables", f"L{int(lmax)}-{key}")


def _verified_tables(folder: str) -> dict:
    """Memory maps of the tables in ``folder``, checked against their shapes and SHA-256."""
    with open(os.path.join(folder, "meta.json"), encoding="utf-8") as f:
        meta = json.load(f)
    out = {}
    for name, rec in meta["arrays"].items():
        a = np.load(os.path.join(folder, f"{name}.npy"), mmap_mode="r", allow_pickle=False)
        if list(a.shape) != rec["shape"] or a.dtype != np.float64:
            raise ValueError(name)
        if _sha256_array(a) != rec["sha256"]:
            raise ValueError(name)
        out[name] = a
    return out


def _load_tables(
    folder: str, lmax: int, compute: Callable[[int], dict[str, np.ndarray]]
) -> dict[str, np.ndarray]:
    """Return the verified tables of ``folder``; compute and store them if absent or damaged."""
    try:
        return _verified_tables(folder)
    except (OSError, ValueError, KeyError, TypeError):
        shutil.rmtree(folder, ignore_errors=True)
    tab = compute(lmax)
    try:
        os.makedirs(os.path.dirname(folder), exist_ok=True)
        tmp = tempfile.mkdtemp(dir=os.path.dirname(folder), prefix=".tmp-")
        rec = {}
        for name, a in tab.items():
            a = np.ascontiguousarray(a, dtype=np.float64)
            np.save(os.path.join(tmp, f"{name}.npy"), a, allow_pickle=False)
            rec[name] = {"shape": list(a.shape), "sha256": _sha256_array(a)}
        with open(os.path.join(tmp, "meta.json"), "w", encoding="utf-8") as f:
            json.dump({"format": CACHE_FORMAT, "lmax": int(lmax), "arrays": rec}, f)
        try:
            os.rename(tmp, folder)
        except OSError:
            shutil.rmtree(tmp, ignore_errors=True)
    except OSError:
        pass
    return tab
