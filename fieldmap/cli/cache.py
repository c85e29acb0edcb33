"""Sub-command ``fieldmap cache {info,clear}``: the on-disk cache of parsed model files.

The cache itself is :mod:`fieldmap.models.cache`; this module only adds its sub-parser and prints
what it holds or removes.
"""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``fieldmap cache {info,clear}`` (the on-disk cache of parsed models)."""
    c = subparsers.add_parser(
        "cache",
        help="show or clear the on-disk cache of parsed model files",
        description="The cache holds parsed coefficients of model files (verified by checksums, "
        "keyed by file content and reader version) under $FIELDMAP_MODEL_CACHE (default "
        "$XDG_CACHE_HOME/fieldmap/models, i.e. ~/.cache/fieldmap/models); 'info' prints it.",
    )
    c.add_argument("action", choices=("info", "clear"), help="list the entries, or delete them")
    c.set_defaults(func=run_cache)


def run_cache(args: argparse.Namespace) -> int:
    """Run ``fieldmap cache``: print the entries (``info``) or delete them (``clear``)."""
    from fieldmap.models import cache as disk_cache

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
