"""The coefficient tables of an ICGEM ``.gfc`` file's data lines (used by :mod:`.icgem`).

:class:`StaticTable` fills C, S (and σC, σS, :func:`sigma_columns`) from the ``gfc``/``gfct``
lines, chunk by chunk, and checks duplicates and gaps; :func:`time_variable` adds the trend and
periodic terms (``trnd``/``dot``, ``acos``, ``asin``) at an epoch, by the rule of the ICGEM format
quoted in :mod:`fieldmap.models.icgem`; :func:`times` converts the lines' time stamps to decimal
years. Errors name the file and the line (:func:`fail`).
"""

from __future__ import annotations

import math

import numpy as np

from fieldmap.errors import InputError, ModelFileError
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


def epochs(path, nhead, v2, t, cols):
    """Return the time-variable lines' epochs t0; in icgem2.0, only the lines valid at ``t``.

    ``cols``: line, kind, n, m, c, s, σc, σs, has σ, and the last three values of each line.
    Returns the first nine (icgem2.0: the lines valid at ``t`` only), t0 and the period.
    """
    lines, kind, n, m, c, s, sc, ss, has_sig, last, prev, third = cols
    period = np.where(kind >= 3, last, 1.0)
    t0 = np.zeros(kind.size)
    if v2:  # gfct/trnd: ... t0 t1; acos/asin: ... t0 t1 period
        t0 = times(path, np.where(kind >= 3, third, prev), lines, nhead)
        t1 = times(path, np.where(kind >= 3, prev, last), lines, nhead)
        active = (t0 <= t) & (t < t1)
        gct = kind == 1
        has_gfct = np.unique(n[gct] * (n[gct] + 1) // 2 + m[gct])
        act_gfct = np.unique(n[gct & active] * (n[gct & active] + 1) // 2 + m[gct & active])
        if has_gfct.size != act_gfct.size:
            lo, hi = t0[gct].min(), t1[gct].max()
            raise InputError(
                f"epoch {t:.4f} is outside the validity intervals of {path}"
                f" ({lo:.4f} to {hi:.4f}) for some coefficients"
            )
        lines, kind, n, m, c, s, sc, ss, has_sig, t0, period = (
            a[active] for a in (lines, kind, n, m, c, s, sc, ss, has_sig, t0, period)
        )
    elif (kind == 1).any():  # icgem1.0: t0 on the gfct line
        g = kind == 1
        t0[g] = times(path, last[g], lines[g], nhead)
    return lines, kind, n, m, c, s, sc, ss, has_sig, t0, period


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


class StaticTable:
    """C, S (and σC, σS) of the static lines, filled chunk by chunk (:meth:`add`, :meth:`finish`).

    Besides the (lmax+1)² tables it keeps, per coefficient (packed index n(n+1)/2 + m), the data
    line of its first static line: the duplicate and gap checks name the same lines as a check
    of the whole file at once would. Chunks come in line order.
    """

    def __init__(self, lmax, nbytes, sigma=True):
        self.C = np.zeros((lmax + 1, lmax + 1))
        self.S = np.zeros((lmax + 1, lmax + 1))
        self.SC = self.SS = None
        self.sigma = sigma  # False: header "errors no", σ columns ignored
        dtype = np.uint32 if nbytes < 2**32 - 1 else np.int64  # a line index < its byte offset
        self.none = np.iinfo(dtype).max
        self.line = np.full((lmax + 1) * (lmax + 2) // 2, self.none, dtype)
        self.repeat = None  # (line, key) of the first static line repeating a coefficient

    def _sigmas(self, n, m, sc, ss, has):
        if self.sigma and has.any():
            if self.SC is None:
                self.SC, self.SS = np.zeros_like(self.C), np.zeros_like(self.C)
            self.SC[n[has], m[has]], self.SS[n[has], m[has]] = sc[has], ss[has]

    def add(self, lines, n, m, c, s, sc, ss, has):
        """Enter static lines (data line indices ``lines``, increasing, after earlier chunks')."""
        idx = n * (n + 1) // 2 + m
        self.C[n, m], self.S[n, m] = c, s
        self._sigmas(n, m, sc, ss, has)
        seen = self.line[idx] != self.none  # given by an earlier chunk
        if not seen.any():
            self.line[idx] = lines
            if (self.line[idx] == lines).all():
                return
        order = np.argsort(idx, kind="stable")  # a coefficient given twice: first lines kept
        first = np.ones(idx.size, bool)
        first[1:] = idx[order][1:] != idx[order][:-1]
        is_first = np.zeros(idx.size, bool)
        is_first[order[first]] = True
        new = is_first & ~seen
        self.line[idx[new]] = lines[new]
        rep = seen | ~is_first
        if rep.any() and self.repeat is None:
            k = int(np.flatnonzero(rep)[0])
            self.repeat = (int(lines[k]), int(idx[k]))

    def finish(self, path, nhead, lines, n, m, c, s, sc, ss, has):
        """Enter the gfct lines (kept, active), check duplicates and gaps; return C, S, σ."""
        idx = n * (n + 1) // 2 + m
        rep = [self.repeat] if self.repeat is not None else []
        if idx.size:  # a gfct line after or before gfc lines of its coefficient, or twice
            given = np.unique(idx[self.line[idx] != self.none])
            keys = np.concatenate([given, idx])
            at = np.concatenate([self.line[given].astype(np.int64), lines])
            order = np.lexsort((at, keys))
            later = np.flatnonzero(keys[order][1:] == keys[order][:-1]) + 1
            if later.size:
                k = order[later[np.argmin(at[order[later]])]]
                rep.append((int(at[k]), int(keys[k])))
        if rep:
            line, key = min(rep)
            given = [int(self.line[key])] if self.line[key] != self.none else []
            first = min(given + [int(v) for v in lines[idx == key]])
            raise fail(
                path,
                nhead + line + 1,
                f"duplicate coefficient (first given on line {nhead + first + 1})",
            )
        self.C[n, m], self.S[n, m] = c, s
        self.line[idx] = lines
        self._sigmas(n, m, sc, ss, has)
        if self.line[0] == self.none:
            self.C[0, 0] = 1.0
        present = self.line != self.none
        miss = present.size
        if present.size > 3:  # degrees 0 and 1 may be omitted (C00 = 1, origin at the centre)
            miss = 3 + int(np.argmin(present[3:])) if not present[3:].all() else miss
        if miss < present.size:
            miss_n = (math.isqrt(8 * miss + 1) - 1) // 2
            miss_m = miss - miss_n * (miss_n + 1) // 2
            if not present[:miss].any():
                raise ModelFileError(f"{path}: no line for n={miss_n} m={miss_m}")
            last = int(np.max(self.line[:miss][present[:miss]]))
            top = present.size - 1 - int(np.argmax(present[::-1]))
            why = "file truncated?" if miss > top else "degree gap"
            raise fail(
                path,
                nhead + last + 1,
                f"no line for n={miss_n} m={miss_m} after this one ({why})",
            )
        sig = None
        if self.SC is not None and (self.SC.any() or self.SS.any()):
            sig = (self.SC, self.SS)
        return self.C, self.S, sig

    def first_line(self, n, m):
        """Return the data line of the static line of (n, m), or None."""
        v = self.line[n * (n + 1) // 2 + m]
        return None if v == self.none else int(v)


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
    return sc, ss, has


def negative_sigma(vals, off, nf, kind, v2):
    """Tell, per data line, whether one of its σ columns (up to four) is negative.

    A standard deviation is never negative: such a file is malformed (NGA's reader refuses it
    too), and taking its absolute value would only hide the error.
    """
    nsig = nf - 2 - _EXTRA[int(bool(v2))][kind]
    bad = np.zeros(off.size, bool)
    for j in range(int(nsig.max(initial=0))):
        sel = nsig > j
        bad[sel] |= vals[off[sel] + 2 + j] < 0.0
    return bad
