"""Navigation gravity model names: ``j2``/``j4``/``j6``/``exact``/``sh``/``shN``/``table:FILE``.

Parse a navigation gravity name to the kernel kind and SH degree of
:mod:`fieldmap.kernels.navgravity` (:func:`parse_gravity`), replace the deprecated 0.1 aliases
(:func:`gravity_names`) and rank the models by cost (:func:`gravity_cost`). Shared by the LCI
and NED mechanizations and the studies built on them.
"""

from __future__ import annotations

import re

from fieldmap import _compat
from fieldmap.errors import InputError
from fieldmap.models.shmodel import SHModel


def _kernel_kinds() -> dict:
    from fieldmap.kernels import navgravity as kng

    return {
        "exact": int(kng.NAV_NORMAL_EXACT),
        "sh": int(kng.NAV_SH),
        "table": int(kng.NAV_TABLE),
        "j2": int(kng.NAV_J2),
        "j4": int(kng.NAV_J4),
        "j6": int(kng.NAV_J6),
    }


#: navigation gravity names -> kernel kind (the integer codes of kernels/navgravity.py);
#: "shN" = SH to degree N; "exact" is the closed-form level-ellipsoid field (the ``normal="exact"``
#: of :func:`fieldmap.field.normal.normal_model`: one name on the map and the navigation side)
GRAVITY_KINDS = _kernel_kinds()
_SH_NAME = re.compile(r"^sh(\d+)?$")
#: normal navigation models from the simplest to the most complete
NORMAL_MODELS = ("j2", "j4", "j6", "exact")
#: deprecated navigation gravity names (fieldmap 0.1) -> current name; removed in 0.3
GRAVITY_ALIASES = {"normal": "exact"}


def gravity_names(names, stacklevel: int = 4) -> list:
    """``names`` with the deprecated aliases (``"normal"``) replaced by their current name.

    Other names are returned as given (validation is :func:`parse_gravity`'s). One
    ``DeprecationWarning`` per call when any alias was used (``stacklevel`` as in
    :func:`fieldmap._compat.warn`, counted from the caller of this function).
    """
    out, used = [], []
    for name in names:
        key = str(name).strip().lower() if isinstance(name, str) else None
        if key in GRAVITY_ALIASES:
            used.append(key)
            out.append(GRAVITY_ALIASES[key])
        else:
            out.append(name)
    for key in dict.fromkeys(used):
        _compat.warn(
            f'navigation gravity model "{key}" is now "{GRAVITY_ALIASES[key]}"', stacklevel
        )
    return out


#: SH degrees ``auto`` tries (those up to the model's degree, and the model's own)
AUTO_DEGREES = (12, 24, 36, 72, 120, 180, 360, 720, 1080, 2190)


def auto_models(sh_model: SHModel) -> list[str]:
    """Return what ``auto`` stands for: every normal model, then SH degrees to the model's.

    ``j2 j4 j6 exact`` and ``shN`` for N in :data:`AUTO_DEGREES` below the model's degree,
    then the full model; tables are the user's (``auto,table:FILE``).
    """
    degrees = [d for d in AUTO_DEGREES if d < sh_model.lmax] + [sh_model.lmax]
    return [*NORMAL_MODELS, *(f"sh{d}" for d in degrees)]


def sh_degree(name: str) -> int | None:
    """SH degree N of a navigation name ``shN`` (None for ``sh`` or a normal model).

    The one parser of the ``shN`` spelling; :func:`parse_gravity` validates against a model.
    """
    m = _SH_NAME.match(str(name).strip().lower())
    return None if m is None or m.group(1) is None else int(m.group(1))


def table_file(name) -> str | None:
    """Return the file of a navigation name ``table:FILE`` (as given, case kept), else None."""
    from fieldmap.products.tables.model import table_path

    return table_path(name) if isinstance(name, str) else None


def gravity_cost(name: str, sh_model: SHModel | None = None) -> float:
    """Relative cost of one evaluation: (N + 1)² for SH degree N, 1 normal models, 64 a table."""
    if table_file(name) is not None:
        return 64.0  # a 4 x 4 x 4 stencil
    key = str(name).strip().lower()
    key = GRAVITY_ALIASES.get(key, key)
    if key in GRAVITY_KINDS and key != "sh":
        return 1.0
    deg = sh_degree(key)
    if deg is None:
        deg = sh_model.lmax if sh_model is not None else 0
    return float((deg + 1) ** 2)


def parse_gravity(name: str, sh_model: SHModel | None) -> tuple[int, int]:
    """Navigation gravity name (j2, j4, j6, exact, sh, shN, table:FILE) -> (kernel kind, degree).

    The deprecated ``"normal"`` is ``"exact"`` (with a ``DeprecationWarning``). A table name is
    checked by loading the table (:func:`fieldmap.products.table_model.load_table`).
    """
    path = table_file(name)
    if path is not None:
        from fieldmap.products.tables.model import load_table

        load_table(path)
        return GRAVITY_KINDS["table"], 0
    key = str(gravity_names([name])[0]).strip().lower()
    if key in NORMAL_MODELS:
        return GRAVITY_KINDS[key], 0
    m = _SH_NAME.match(key)
    if not m:
        raise InputError(
            f"unknown navigation gravity model {name!r} (j2, j4, j6, exact, sh, shN, table:FILE)"
        )
    if sh_model is None:
        raise InputError(f"navigation gravity {name!r} needs an SH model (sh_model=...)")
    deg = sh_model.lmax if m.group(1) is None else int(m.group(1))
    if deg < 2 or deg > sh_model.lmax:
        raise InputError(
            f"SH degree {deg} of {name!r} is outside 2..{sh_model.lmax} of {sh_model.name}"
        )
    return GRAVITY_KINDS["sh"], deg
