r"""Fully normalised associated Legendre functions by degree rows, in X-numbers (NumPy).

:func:`legendre_rows` yields P̄nm(t) for all orders of one degree n at once, vectorised over
points and orders, degree after degree: the basis of the NumPy σ sums of the commission error
(:mod:`fieldmap.field.commission`, :mod:`fieldmap.field.commission_grid`) and of the independent
references (:mod:`fieldmap.reference.sh`, :mod:`fieldmap.reference.gradient`). It shares no code
with the Warp kernels (:mod:`fieldmap.kernels.sh`), which build the functions column by column;
differences on purpose:

* the Legendre functions are built **row by row** (all orders of degree n at once, vectorised
  over points and orders) instead of column by column;
* the range problem near the poles is handled with **X-numbers** (Fukushima 2012, J. Geodesy
  86:271-285): every value is a float mantissa times 2^(400·k) with an integer k per point and
  order, and the powers u^m are carried the same way; nothing is scaled by a fixed 1e-280 and no
  Horner scheme in u is used. Along a column ``P̄nm/u^m`` does not decay (it grows, by at
  most ~sqrt(2n) per row, or oscillates), so one rescaling per row keeps it in range at any
  degree (checked against mpmath and the kernels up to degree 10,800, equator to poles); the
  cost is O(N·lmax²) NumPy work, ~6 s per point at degree 10,800.

The functions are fully normalised without the Condon-Shortley phase; t = sin ψ and u = cos ψ
of the geocentric latitude ψ. The recursion runs on Q = P̄nm/u^m (row-wise, over all m < n at
once),

.. math::
    Q_{nm} = a_{nm}\,t\,Q_{n-1,m} - b_{nm}\,Q_{n-2,m},\qquad
    a_{nm} = \sqrt{\frac{(2n-1)(2n+1)}{(n-m)(n+m)}},\quad
    b_{nm} = \sqrt{\frac{(2n+1)(n+m-1)(n-m-1)}{(n-m)(n+m)(2n-3)}},

with the sectoral start :math:`Q_{nn} = \sqrt{3}\prod_{k=2}^{n}\sqrt{(2k+1)/(2k)}`
(Q_00 = 1); P̄nm = Q u^m and P̄nm/u = Q u^(m−1) stay finite at u = 0.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

_STEP = 400  # X-number exponent step: values are mantissa * 2**(400 k)
_BIG = 2.0**_STEP


def _powers_x(u: np.ndarray, kmax: int) -> tuple[np.ndarray, np.ndarray]:
    """u^k for k = 0..kmax as X-numbers: ``(mant, exp2)`` arrays of shape (N, kmax+1)."""
    fu, eu = np.frexp(u)  # u = fu * 2**eu, fu in [0.5, 1) (or 0)
    mant = np.empty((u.size, kmax + 1))
    ex = np.empty((u.size, kmax + 1), dtype=np.int64)
    cur = np.ones_like(u)
    cur_e = np.zeros(u.size, dtype=np.int64)
    for k in range(kmax + 1):
        mant[:, k] = cur
        ex[:, k] = cur_e + k * eu
        cur = cur * fu
        small = (cur != 0.0) & (np.abs(cur) < 1.0 / _BIG)
        cur = np.where(small, cur * _BIG, cur)
        cur_e = cur_e - np.where(small, _STEP, 0)
    return mant, ex


def legendre_rows(
    t: np.ndarray, u: np.ndarray, lmax: int
) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Yield ``(n, P, PU)`` for n = 0..lmax.

    ``P[:, m]`` = P̄nm(t) and ``PU[:, m]`` = P̄nm(t)/u (m ≥ 1; column 0 set to 0), shapes
    (N, n+1), fully normalised without Condon-Shortley phase. ``PU`` stays finite at u = 0.

    Recursion (row-wise, over all m < n at once):
    ``Q_nm = a_nm t Q_{n-1,m} − b_nm Q_{n-2,m}`` with Q = P̄/u^m and the sectoral start
    ``Q_nn = sqrt(3) prod_{k=2}^{n} sqrt((2k+1)/(2k))`` (Q_00 = 1).
    """
    N = t.size
    umant, uex = _powers_x(u, lmax + 1)
    q1 = np.zeros((N, lmax + 1))  # row n-1 mantissas, per column exponent k
    q2 = np.zeros((N, lmax + 1))  # row n-2
    kx = np.zeros((N, lmax + 1), dtype=np.int64)
    sect = 1.0
    for n in range(lmax + 1):
        qn = np.zeros((N, lmax + 1))
        if n >= 1:
            m = np.arange(n, dtype=np.float64)
            a = np.sqrt((2 * n - 1) * (2 * n + 1) / ((n - m) * (n + m)))
            with np.errstate(invalid="ignore", divide="ignore"):
                b = np.sqrt(
                    (2 * n + 1) * (n + m - 1) * (n - m - 1) / ((n - m) * (n + m) * (2 * n - 3))
                )
            b = np.where(n - m >= 2, b, 0.0)
            qn[:, :n] = a * t[:, None] * q1[:, :n] - b * q2[:, :n]
            sect = np.sqrt(3.0) if n == 1 else sect * np.sqrt((2 * n + 1) / (2.0 * n))
        qn[:, n] = sect
        kx[:, n] = 0
        # keep mantissas in range: rescale a whole column (rows n and n-1 together)
        big = np.maximum(np.abs(qn), np.abs(q1)) > _BIG
        qn = np.where(big, qn / _BIG, qn)
        q1 = np.where(big, q1 / _BIG, q1)
        kx = kx + big
        cols = slice(0, n + 1)
        P = np.ldexp(qn[:, cols] * umant[:, cols], _STEP * kx[:, cols] + uex[:, cols])
        PU = np.zeros_like(P)
        if n >= 1:
            c1 = slice(1, n + 1)
            c0 = slice(0, n)
            PU[:, c1] = np.ldexp(qn[:, c1] * umant[:, c0], _STEP * kx[:, c1] + uex[:, c0])
        yield n, P, PU
        q2, q1 = q1, qn
