"""The coefficient tables of an ICGEM ``.gfc`` file's data lines (used by :mod:`.icgem`).

:func:`static_coefficients` fills C, S from the ``gfc``/``gfct`` lines and checks duplicates and
gaps; :func:`time_variable` adds the trend and periodic terms (``trnd``/``dot``, ``acos``,
``asin``) at an epoch, by the rule of the ICGEM format quoted in :mod:`fieldmap.models.icgem`;
:func:`static_sigmas` keeps the σ columns of the static lines (:func:`sigma_columns`);
:func:`times` converts the lines' time stamps to decimal years. Errors name the file and the
line (:func:`fail`).
"""

from __future__ import annotations

import numpy as np

from fieldmap.errors import ModelFileError
from fieldmap.models._gfc_scan import yyyymmdd

#: keyword of each kind of data line (the kinds of ``fieldmap.models.icgem``'s keywords)
KIND_NAME = ("gfc", "gfct", "trnd", "acos", "asin")


def fail(path, line, msg):
    """Return the :class:`ModelFileError` of ``msg`` at ``line`` of ``path`` (no line: the file)."""
    where = f"{path}, line {line}" if line else f"{path}"
    return ModelFileError(f"{where}: {msg}")


def times(path, values, lines, nhead):
    """Decimal years of ICGEM time stamps ``yyyymmdd[.hhmm]`` (one per data line)."""
    uniq, inv = np.unique(values, return_inverse=True)
    out = np.empty(uniq.size)
    for k, v in enumerate(uniq):
        try:
            out[k] = yyyymmdd(float(v))
        except (ValueError, OverflowError):
            line = nhead + int(lines[np.flatnonzero(inv == k)[0]]) + 1
            raise fail(path, line, f"bad time stamp {v!r} (expected yyyymmdd[.hhmm])") from None
    return out[inv]


def duplicates(path, keys, lines, nhead, what):
    order = np.argsort(keys, kind="stable")
    dup = np.flatnonzero(keys[order][1:] == keys[order][:-1])
    if dup.size:
        later = order[dup + 1]
        k = later[np.argmin(lines[later])]
        first = lines[order[dup[np.argmin(lines[later])]]]
        raise fail(
            path,
            nhead + int(lines[k]) + 1,
            f"duplicate {what} (first given on line {nhead + int(first) + 1})",
        )


def static_coefficients(path, lines, kind, n, m, idx, c, s, lmax, nhead):
    """Fill C, S from gfc/gfct lines; check duplicates and gaps."""
    st = kind <= 1
    if st.any():
        duplicates(path, idx[st], lines[st], nhead, "coefficient")
    C = np.zeros((lmax + 1, lmax + 1))
    S = np.zeros((lmax + 1, lmax + 1))
    C[n[st], m[st]], S[n[st], m[st]] = c[st], s[st]
    have = np.zeros((lmax + 1, lmax + 1), bool)
    have[n[st], m[st]] = True
    if not have[0, 0]:
        C[0, 0] = 1.0
    have[:2] = True  # degrees 0 and 1 may be omitted (C00 = 1, origin at the centre of mass)
    have[np.triu_indices(lmax + 1, 1)] = True
    if not have.all():
        miss_n, miss_m = (int(v[0]) for v in np.nonzero(~have))
        midx = miss_n * (miss_n + 1) // 2 + miss_m
        before = idx[st] < midx
        if not before.any():
            raise ModelFileError(f"{path}: no line for n={miss_n} m={miss_m}")
        last = np.max(lines[st][before])
        why = "file truncated?" if midx > idx[st].max() else "degree gap"
        raise fail(
            path, nhead + int(last) + 1, f"no line for n={miss_n} m={miss_m} after this one ({why})"
        )
    return C, S


def time_variable(path, lines, kind, n, m, idx, c, s, t0, period, t, v2, C, S, nhead):
    """Add trend and periodic terms at epoch ``t`` (None: each coefficient's t0)."""
    tv = kind >= 2
    ref = np.full(int(idx.max(initial=0)) + 1, np.nan)
    g = kind == 1
    ref[idx[g]] = t0[g]
    tref = t0 if v2 else ref[idx]
    orphan = tv & np.isnan(tref)
    if orphan.any():
        k = np.flatnonzero(orphan)[0]
        raise fail(
            path,
            nhead + int(lines[k]) + 1,
            f"'{KIND_NAME[kind[k]]}' for n={n[k]} m={m[k]} without a 'gfct' line",
        )
    for kd, what in ((2, "trend"), (3, "acos term"), (4, "asin term")):
        sel = kind == kd
        if sel.any():
            keys = idx[sel] * 4096.0 + (period[sel] if kd >= 3 else 0.0)
            duplicates(path, keys, lines[sel], nhead, what)
    dt = (t - tref) if t is not None else np.zeros(idx.size)
    factor = np.select(
        [kind == 2, kind == 3, kind == 4],
        [dt, np.cos(2 * np.pi * dt / period), np.sin(2 * np.pi * dt / period)],
        0.0,
    )
    np.add.at(C, (n[tv], m[tv]), factor[tv] * c[tv])
    np.add.at(S, (n[tv], m[tv]), factor[tv] * s[tv])
    if t is not None:
        return t
    epochs = np.unique(t0[g])
    return float(epochs[0]) if epochs.size == 1 else None


# number of fields after "C S [sigmas]" per kind (gfc, gfct, trnd, acos, asin): icgem1.0, icgem2.0
_EXTRA = (np.array([0, 1, 0, 1, 1]), np.array([0, 2, 2, 3, 3]))


def sigma_columns(vals, off, nf, kind, v2):
    """Return σC, σS of each data line and whether the line has them.

    The first pair of σ columns is taken: the calibrated one of ``calibrated_and_formal`` files.
    """
    nsig = nf - 2 - _EXTRA[int(bool(v2))][kind]
    has = nsig >= 2
    sc = np.where(has, vals[np.minimum(off + 2, vals.size - 1)], 0.0)
    ss = np.where(has, vals[np.minimum(off + 3, vals.size - 1)], 0.0)
    return np.abs(sc), np.abs(ss), has


def static_sigmas(kind, n, m, sc, ss, has, lmax, errors=""):
    """σ tables of the static (gfc/gfct) lines, or None when the file gives none.

    None when the header says ``errors no``, when no static line has σ columns or all are 0.
    Lines without σ (degrees 0 and 1 left out of the file, for one) get σ = 0.
    Time-variable models: σ of the static part only (the ``gfct`` line's σ; trend and periodic
    terms' σ are not propagated).
    """
    st = (kind <= 1) & has
    if (errors.split() or [""])[0].lower() == "no" or not st.any():
        return None
    SC = np.zeros((lmax + 1, lmax + 1))
    SS = np.zeros((lmax + 1, lmax + 1))
    SC[n[st], m[st]], SS[n[st], m[st]] = sc[st], ss[st]
    if not (SC.any() or SS.any()):
        return None
    return SC, SS
