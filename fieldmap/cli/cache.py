"""Sub-command ``fieldmap cache {info,clear,models,fetch}``: the on-disk model cache.

The cache itself is :mod:`fieldmap.models.cache`; this module only adds its sub-parser and prints
what it holds or removes; ``models`` lists the catalogue of models by name
(:mod:`fieldmap.models.catalogue`) and ``fetch NAME`` downloads one of them ahead of use.
"""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``fieldmap cache {info,clear,models,fetch}`` (the on-disk cache of models)."""
    c = subparsers.add_parser(
        "cache",
        help="show or clear the on-disk cache of parsed model files",
        description="The cache holds parsed coefficients of model files (verified by checksums, "
        "keyed by file content and reader version) under $FIELDMAP_MODEL_CACHE (default "
        "$XDG_CACHE_HOME/fieldmap/models, i.e. ~/.cache/fieldmap/models); 'info' prints it. "
        "Models of the catalogue ('models' lists them) are downloaded into its downloads/ "
        "folder when first named (--model EGM2008) or by 'fetch NAME'; 'clear' keeps them.",
    )
    c.add_argument(
        "action",
        choices=("info", "clear", "models", "fetch"),
        help="list the entries, delete them, list the catalogue, or download a catalogue model",
    )
    c.add_argument("name", nargs="?", default=None, help="catalogue model of 'fetch'")
    c.set_defaults(func=run_cache)


def run_cache(args: argparse.Namespace) -> int:
    """Run ``fieldmap cache``: entries (``info``, ``clear``), catalogue (``models``, ``fetch``)."""
    from fieldmap.errors import InputError
    from fieldmap.models import cache as disk_cache

    if (args.name is not None) != (args.action == "fetch"):
        raise InputError(
            "fieldmap cache fetch takes a catalogue model name"
            if args.name is None
            else f"a model name applies to 'fetch', not to '{args.action}'"
        )
    if args.action in ("models", "fetch"):
        from fieldmap.models import catalogue

        if args.action == "fetch":
            print(catalogue.fetch(catalogue.entry(args.name)))
            return 0
        for e in catalogue.CATALOGUE.values():
            print(catalogue.describe(e))
        print(f"downloads in {disk_cache.downloads_dir()}")
        return 0
    if args.action == "clear":
        count, size = disk_cache.clear()
        where = disk_cache.cache_dir()
        print(f"removed {count} cached models ({size / 2**20:.1f} MiB) from {where}")
        return 0
    rows = disk_cache.info()
    for r in rows:
        print(f"{r['bytes'] / 2**20:9.1f} MiB  {r['variant']}  {' '.join(r['files'] or [])}")
    total = sum(r["bytes"] for r in rows)
    print(f"{len(rows)} cached models, {total / 2**20:.1f} MiB in {disk_cache.cache_dir()}")
    return 0
