r"""Numerical parts of flight-log conditioning: robust trends, noise, the penalised spline.

Used by :mod:`fieldmap.nav.logs.condition`; times ``t`` (s, strictly increasing) and values ``y``
of shape ``(n, d)`` (m) of one segment.

Robust local trend (:func:`robust_trend`). The step velocities ``Δy/Δt`` are smoothed by a
running median (Tukey 1977); a running median of a sequence monotone over the window returns
its middle value, so a velocity changing steadily (an acceleration, a turn entry) passes without
bias. The positions minus the integrated robust velocity form a nearly flat series whose running
median is the reference. A wild sample, or a burst of fewer than ``half`` samples, moves neither
median (breakdown point 1/2; Hampel 1974). The ``half`` values at either end come from a
Theil–Sen line (Theil 1950, Sen 1968) through the end window.

Noise (:func:`loo_noise`, :func:`noise_sigma`). Each sample is predicted by the cubic through its
two neighbours on either side (Lagrange); the error divided by ``sqrt(1 + Σ w_j²)`` has the
standard deviation of white noise on ``y`` for any sample spacing.

Penalised spline (:class:`Whittaker`, :func:`fit_path`). Grid values ``g`` minimising
``Σ w_i |y_i − (B g)_i|² + λ Σ |Δ² g / dt²|² dt`` (``B``: cubic Lagrange interpolation to the
sample times): the discrete cubic smoothing spline (Whittaker 1923; Reinsch 1967; Eilers 2003),
one banded Cholesky solve per λ. λ from the discrepancy principle (Reinsch 1967; Morozov 1966)
corrected for the fit's degrees of freedom (Buja, Hastie & Tibshirani 1989), estimated with
Hutchinson's (1989) randomised trace; outliers by iteratively reweighted least squares with
Tukey's bisquare (Beaton & Tukey 1974; Garcia 2010).

The log's own velocities (:class:`Observed`, :func:`observations`, :func:`check`,
:func:`residuals`). ADS-B messages carry the aircraft's velocity (ground speed, track, vertical
rate, from the
airborne velocity message: DO-260B §2.2.3.2.6), NMEA RMC sentences the speed and course over
the ground, GPX files a speed: a measurement of the velocity at the fix, independent of the
positions, whose noise it does not share. They enter the smoothing fit of
:mod:`fieldmap.nav.logs.fit` as rows of the path's time derivative (:class:`~.fit.Rates`):

- **Horizontal**: east and north components ``v_E = s sin χ``, ``v_N = s cos χ`` (ground speed
  s, track χ) carried to the rate of the surface point the horizontal fit follows (its ECEF
  position on the ellipsoid): east × ``N / (N + h)``, north × ``M / (M + h)`` (N, M the prime
  vertical and meridian radii of curvature; Heiskanen & Moritz 1967 eqs. 2-81, 5-58).
- **Vertical**: the vertical rate, up positive.
- **σ** (:func:`observations`): the larger of the quantisation (a rounding error of step q has
  σ = q/√12: 1 kt and 1° horizontally, the track's error scaled by the speed, 64 ft/min
  vertically) and the noise of the velocity series itself, from the same leave-one-out cubic
  predictions as the positions' (:func:`~fieldmap.nav.logs.fit.loo_noise`): the velocities
  change smoothly, their noise does not. A run of L equal values (steady flight: the same
  rounded speed and track for minutes) carries one rounding error, not L: each of its values
  has the weight 1/(L σ²), so that the rounding does not integrate into a drift along the
  track.
- **Outliers**: a horizontal velocity further than ``OUTLIER_K`` robust σ (and over
  ``OUTLIER_FLOOR``) from the positions-only fit's, or not within the contradiction bound of
  it (stale, or another source), is left out; a vertical rate further than ``OUTLIER_K``
  robust σ from the cubic through its neighbours (barometric heights, not the rates, are what
  goes wrong for minutes).
- **Contradiction** (:func:`check`): where the log's ground speeds or tracks disagree with its
  positions by more than ``CONTRADICTION`` of the speed (and ``CONTRADICTION_MIN`` m/s) for
  the median sample, one of the two is wrong for the whole log (a unit, a column, a
  convention): an :class:`~fieldmap.errors.InputError` in one line, nothing flown.

The report (:func:`residuals`) gives the flown path's ground speed, track and vertical rate
against the log's: RMS, largest, and the σ the fit gave them.

References: Hampel, F. R. (1974) J. Amer. Statist. Assoc. 69, 383-393. Tukey, J. W. (1977)
Exploratory Data Analysis. Theil, H. (1950) Proc. KNAW 53; Sen, P. K. (1968) J. Amer. Statist.
Assoc. 63, 1379-1389. Whittaker, E. T. (1923) Proc. Edinburgh Math. Soc. 41, 63-75. Reinsch,
C. H. (1967) Numer. Math. 10, 177-183. Eilers, P. H. C. (2003) Anal. Chem. 75, 3631-3636.
Buja, A., Hastie, T. & Tibshirani, R. (1989) Ann. Statist. 17, 453-510. Hutchinson, M. F.
(1989) Commun. Statist. Simul. 18, 1059-1076. Beaton, A. E. & Tukey, J. W. (1974)
Technometrics 16, 147-185. Garcia, D. (2010) Comput. Statist. Data Anal. 54, 1167-1178.
Silverman, B. W. (1984) Ann. Statist. 12, 898-916. Wahba, G. (1983) J. R. Statist. Soc. B 45,
133-150.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from fieldmap.errors import Advice, InputError, Keyword, Pass

#: normal consistency factor of the MAD (1 / Φ⁻¹(3/4))
MAD_SCALE = 1.482602218505602
#: heights closer than this (m) are equal (a level hold, geoid heights added along the track)
HEIGHT_EQ = 0.05
#: order of the differences the smoother penalises (2: acceleration, the cubic spline)
ORDER = 2
#: Rademacher probes of the trace estimate
PROBES = 24
#: robust fit: reweighting passes, bisquare constant (95 % efficiency, Beaton & Tukey 1974)
IRLS_ITER, BISQUARE_C = 4, 4.685


def _theil_sen_end(x: np.ndarray, m: int) -> np.ndarray:
    """Theil–Sen line through ``x[:m]`` (index as abscissa), evaluated at 0..m-1; (m, d)."""
    i, j = np.triu_indices(m, 1)
    slope = np.median((x[j] - x[i]) / (j - i)[:, None], axis=0)
    icpt = np.median(x[:m] - slope * np.arange(m)[:, None], axis=0)
    return icpt + slope * np.arange(m)[:, None]


def running_median(x: np.ndarray, half: int) -> np.ndarray:
    """Centred running median over ``2 half + 1`` samples along axis 0 of ``x`` (n, d).

    The ``half`` samples at either end get a Theil–Sen line through the first (last)
    ``2 half + 1`` samples instead of a truncated window: a trend passes the ends unbiased and
    a wild end sample does not pull it.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.shape[0]
    half = min(int(half), (n - 1) // 2)
    if half < 1:
        return x.copy()
    w = 2 * half + 1
    out = np.empty_like(x)
    win = np.lib.stride_tricks.sliding_window_view(x, w, axis=0)  # (n - w + 1, d, w)
    out[half : n - half] = np.median(win, axis=-1)
    out[:half] = _theil_sen_end(x, w)[:half]
    out[n - half :] = _theil_sen_end(x[::-1], w)[:half][::-1]
    return out


def local_scale(off: np.ndarray, dim: int, half: int) -> np.ndarray:
    """Robust local standard deviation per component from offset magnitudes ``off`` (n,).

    Over ``± half`` samples (ends reflected): the larger of the median and the 90th percentile
    of the magnitudes, each divided by its value under unit normal noise in ``dim`` (1 or 2)
    components (0.6745, 1.6449; Rayleigh 1.1774, 2.1460). The two agree for Gaussian noise;
    the percentile widens the bound for the heavy-tailed noise of real logs (timing jitter of
    resampled ADS-B positions) while outliers, a few per window, move neither.
    """
    off = np.asarray(off, dtype=np.float64)
    n = off.size
    c50, c90 = (0.6745, 1.6449) if dim == 1 else (1.1774, 2.1460)
    half = min(int(half), n - 1)
    if half < 1:
        return np.full(n, max(np.median(off) / c50, np.percentile(off, 90) / c90))
    win = np.lib.stride_tricks.sliding_window_view(np.pad(off, half, mode="reflect"), 2 * half + 1)
    q = np.percentile(win, [50, 90], axis=-1)
    return np.maximum(q[0] / c50, q[1] / c90)


def robust_trend(t: np.ndarray, y: np.ndarray, half: int) -> np.ndarray:
    """Robust local trend of ``y`` (n, d) at the times ``t`` (see the module docstring).

    Returns the trend at the samples, (n, d). Fewer than 3 samples: ``y`` itself.
    """
    n = t.size
    if n < 3:
        return y.copy()
    dt = np.diff(t)[:, None]
    dy = np.diff(y, axis=0)
    v = running_median(dy / dt, half)
    D = np.concatenate([np.zeros((1, y.shape[1])), np.cumsum(dy - v * dt, axis=0)])
    return y - D + running_median(D, half)


def interpolate_trend(t_ref: np.ndarray, ref: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Carry the trend known at ``t_ref`` to ``t``: cubic inside, linear beyond the ends."""
    from scipy.interpolate import CubicSpline

    if t_ref.size < 2:
        return np.broadcast_to(ref[:1], (t.size, ref.shape[1])).copy()
    if t_ref.size < 4:
        return np.stack([np.interp(t, t_ref, ref[:, k]) for k in range(ref.shape[1])], -1)
    cs = CubicSpline(t_ref, ref, bc_type="natural")
    out = cs(np.clip(t, t_ref[0], t_ref[-1]))
    lo, hi = t < t_ref[0], t > t_ref[-1]
    if lo.any():
        out[lo] += (t[lo] - t_ref[0])[:, None] * cs(t_ref[0], 1)
    if hi.any():
        out[hi] += (t[hi] - t_ref[-1])[:, None] * cs(t_ref[-1], 1)
    return out


def loo_noise(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Normalised leave-one-out cubic prediction errors of samples 2..n-3, shape (n - 4, d).

    Each has the standard deviation of white noise on ``y`` whatever the sample spacing.
    """
    n = t.size
    if n < 5:
        return np.zeros((0, y.shape[1]))
    idx = np.arange(2, n - 2)
    nb = idx[:, None] + np.array([-2, -1, 1, 2])
    tt = t[nb] - t[idx][:, None]
    w = np.ones_like(tt)
    for j in range(4):
        for k in range(4):
            if k != j:
                w[:, j] *= -tt[:, k] / (tt[:, j] - tt[:, k])
    pred = np.einsum("mj,mjd->md", w, y[nb])
    return (y[idx] - pred) / np.sqrt(1.0 + np.sum(w * w, axis=1))[:, None]


def mad_sigma(x: np.ndarray) -> float:
    """1.4826 × the median absolute value of ``x`` (all entries pooled; 0 when empty)."""
    x = np.abs(np.asarray(x)).ravel()
    return float(MAD_SCALE * np.median(x)) if x.size else 0.0


def noise_sigma(
    z: np.ndarray,
    k: float = 5.0,
    floor: float = 0.0,
    half: int = 25,
    frac: float = 0.3,
) -> tuple[float, np.ndarray]:
    """Noise σ (m) from normalised prediction errors ``z`` ((n - 4, d), :func:`loo_noise`).

    Errors beyond ``max(k MAD-σ, floor)`` are outliers, left out. Returns the RMS over the
    segment and a local RMS per sample (padded to (n,)) over ``±half`` samples, at least
    ``frac`` times the segment's: the noise of ADS-B positions grows with speed (timing
    jitter). The RMS, not the MAD, is what the residual sum of a fit meets.
    """
    z = np.asarray(z, dtype=np.float64)
    m = z.shape[0]
    if z.size == 0:
        return 0.0, np.zeros(0)
    z = z.reshape(m, -1)
    ok = np.all(np.abs(z) <= max(k * mad_sigma(z), floor), axis=1)
    z2 = np.where(ok, np.mean(z * z, axis=1), 0.0)
    cs = np.concatenate([[0.0], np.cumsum(z2)])
    cc = np.concatenate([[0.0], np.cumsum(ok)])
    glob = float(np.sqrt(cs[-1] / max(cc[-1], 1.0)))
    i = np.arange(m)
    lo, hi = np.clip(i - half, 0, m), np.clip(i + half + 1, 0, m)
    loc = np.sqrt((cs[hi] - cs[lo]) / np.maximum(cc[hi] - cc[lo], 1.0))
    loc = np.maximum(loc, frac * glob)
    return glob, np.concatenate([np.full(2, loc[0]), loc, np.full(2, loc[-1])])


def level_runs(t: np.ndarray, h: np.ndarray, min_s: float) -> np.ndarray:
    """Mark the samples in runs of one height (within :data:`HEIGHT_EQ`) ``min_s`` long (n,)."""
    d = np.diff(np.concatenate([[0], (np.abs(np.diff(h)) <= HEIGHT_EQ).astype(np.int8), [0]]))
    out = np.zeros(t.size, bool)
    for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
        if t[b] - t[a] >= min_s:
            out[a : b + 1] = True
    return out


def height_quantum(h: np.ndarray) -> float:
    """Step of quantised heights (m), e.g. 7.62 for 25 ft, or 0 when not quantised.

    Quantised: every height change over :data:`HEIGHT_EQ` is (to 1 %) a whole multiple of the
    smallest; or, for quantised pressure altitudes converted to heights (steps that vary with
    altitude, geoid heights added), at least a fifth of the changes are within ``HEIGHT_EQ``
    of zero: then the 10th percentile of the others.
    """
    dh = np.abs(np.diff(np.asarray(h, dtype=np.float64)))
    nz = dh[dh > HEIGHT_EQ]
    if nz.size < 10:
        return 0.0
    q = float(nz.min())
    r = nz / q
    if np.mean(np.abs(r - np.round(r)) < 0.01) > 0.98:
        return q
    return float(np.percentile(nz, 10)) if np.mean(dh <= HEIGHT_EQ) >= 0.2 else 0.0


def lagrange_rows(t0: float, dt: float, ng: int, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Lagrange interpolation from the grid ``t0 + dt k`` (k < ng) to the times ``t``.

    Returns the first of the four nodes used for each time, (m,), and their weights, (m, 4).
    """
    x = (np.asarray(t, dtype=np.float64) - t0) / dt
    k = np.clip(np.floor(x).astype(np.int64), 1, ng - 3)
    u = x - k
    L = np.stack(
        [
            -u * (u - 1.0) * (u - 2.0) / 6.0,
            (u + 1.0) * (u - 1.0) * (u - 2.0) / 2.0,
            -(u + 1.0) * u * (u - 2.0) / 2.0,
            (u + 1.0) * u * (u - 1.0) / 6.0,
        ],
        -1,
    )
    return k - 1, L


def lagrange_rate_rows(
    t0: float, dt: float, ng: int, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Time derivative of the cubic Lagrange interpolation of :func:`lagrange_rows` at ``t``.

    Returns the first node of each time, (m,), and the weights of the rate, (m, 4) (1/s).
    """
    x = (np.asarray(t, dtype=np.float64) - t0) / dt
    k = np.clip(np.floor(x).astype(np.int64), 1, ng - 3)
    u = x - k
    dL = np.stack(
        [
            -(3.0 * u * u - 6.0 * u + 2.0) / 6.0,
            (3.0 * u * u - 4.0 * u - 1.0) / 2.0,
            -(3.0 * u * u - 2.0 * u - 2.0) / 2.0,
            (3.0 * u * u - 1.0) / 6.0,
        ],
        -1,
    )
    return k - 1, dL / dt


def on_grid(g: np.ndarray, rows: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Values at the times of ``rows`` (from :func:`lagrange_rows`) of grid values ``g``."""
    k0, L = rows
    return np.einsum("mj,mjd->md", L, g[k0[:, None] + np.arange(4)])


@dataclass(frozen=True)
class Rates:
    """Observed rates of a fitted component: times ``t`` (m,), values ``v`` (m, d), weights.

    Units: s; m/s (the component's units per second); ``w`` = 1/σ² in (s/m)².
    """

    t: np.ndarray
    v: np.ndarray
    w: np.ndarray


class Whittaker:
    """Penalised least-squares path on a regular grid (Whittaker 1923; Eilers 2003).

    Minimises ``Σ_i w_i |y_i − (B g)_i|² + lam Σ_k |Δᵐ g_k / dtᵐ|² dt`` over the grid values
    ``g`` (ng, d): ``B`` interpolates the grid to the sample times ``t`` (cubic Lagrange), ``Δᵐ``
    the m-th difference (m = :data:`ORDER`; 2: the discrete cubic smoothing spline of Reinsch
    1967). One banded Cholesky solve per λ; the data part is assembled once. With ``probes``
    > 0 :meth:`solve` also returns ``tr(B A⁻¹ Bᵀ W)``, the equivalent degrees of freedom of the
    fit, by Hutchinson's (1989) estimator with fixed Rademacher probes (deterministic).
    """

    def __init__(
        self,
        grid: tuple[float, float, int],
        t: np.ndarray,
        y: np.ndarray,
        w: np.ndarray,
        probes: int = 0,
        rates: Rates | None = None,
    ) -> None:
        t0, self.dt, self.ng = grid
        ng = self.ng
        self.rows = k0, L = lagrange_rows(t0, self.dt, ng, t)
        self.u = u = max(3, ORDER)
        self.ab = np.zeros((u + 1, ng))
        d = y.shape[1]
        self.probes = probes
        if probes:
            self.z = np.random.default_rng(20240601).choice([-1.0, 1.0], size=(t.size, probes))
            y = np.concatenate([y, self.z], 1)
        self.rhs = np.zeros((ng, y.shape[1]))
        obs = [(k0, L, w, y)]
        if rates is not None and rates.t.size:
            # rate observations: rows of the derivative of the same interpolation, weights
            # 1/σ_v²; they enter the data columns only (the probes trace the positions' hat)
            kr, dL = lagrange_rate_rows(t0, self.dt, ng, rates.t)
            yr = np.zeros((rates.t.size, y.shape[1]))
            yr[:, :d] = rates.v
            obs.append((kr, dL, rates.w, yr))
        for k, M, ww, yy in obs:
            for a in range(4):
                for b in range(a, 4):
                    self.ab[u - (b - a)] += np.bincount(k + b, ww * M[:, a] * M[:, b], ng)
            for a in range(4):
                wl = ww * M[:, a]
                for j in range(yy.shape[1]):
                    self.rhs[:, j] += np.bincount(k + a, wl * yy[:, j], ng)
        self.c = np.array([(-1.0) ** (ORDER - j) * math.comb(ORDER, j) for j in range(ORDER + 1)])

    def matrix(self, lam: float) -> np.ndarray:
        """Return the banded normal matrix ``Bᵀ W B + λ Dᵀ D`` at ``lam`` (upper, (u+1, ng))."""
        ab, u, c, m = self.ab.copy(), self.u, self.c, ORDER
        lamd = lam * self.dt ** (1 - 2 * m)
        r = np.arange(self.ng - m)
        for a in range(m + 1):
            for b in range(a, m + 1):
                ab[u - (b - a), r + b] += lamd * c[a] * c[b]
        return ab

    def solve(self, lam: float) -> tuple[np.ndarray, np.ndarray, float]:
        """Grid values (ng, d), the fit at the samples (n, d) and the degrees of freedom."""
        from scipy.linalg import solveh_banded

        g = solveh_banded(self.matrix(lam), self.rhs, lower=False, check_finite=False)
        fit = on_grid(g, self.rows)
        p = self.probes
        if not p:
            return g, fit, 0.0
        edf = float(np.mean(np.sum(self.z * fit[:, -p:], 0)))
        return g[:, :-p], fit[:, :-p], edf


def _bisquare(z: np.ndarray, c: float) -> np.ndarray:
    return np.where(z < c, (1.0 - (z / c) ** 2) ** 2, 0.0)


@dataclass(frozen=True)
class PathFit:
    """How :func:`fit_path` fits one component: its noise components and its robustness.

    Parameters
    ----------
    dof : int
        Noise components per sample (2 for a horizontal position in 3-D coordinates, 1 for a
        height).
    edf_correction : bool
        λ with the degrees-of-freedom correction of Buja, Hastie & Tibshirani (1989); False:
        Reinsch's (1967) own criterion.
    floor : float
        Residuals within ``floor`` of the fit are never outliers. Units: m.
    max_run : int
        Runs of more outliers than this are real motion the fit has yet to follow.
    """

    dof: int
    edf_correction: bool = True
    floor: float = 0.0
    max_run: int = 7

    def __post_init__(self) -> None:
        if (
            isinstance(self.dof, bool)
            or not isinstance(self.dof, (int, np.integer))
            or self.dof < 1
        ):
            raise InputError(f"dof must be a positive integer, got {self.dof!r}")
        if not (math.isfinite(self.floor) and self.floor >= 0.0):
            raise InputError(f"floor must be >= 0 metres, got {self.floor!r}")
        if isinstance(self.max_run, bool) or not isinstance(self.max_run, (int, np.integer)):
            raise InputError(f"max_run must be an integer, got {self.max_run!r}")


def fit_path(
    grid: tuple[float, float, int],
    t: np.ndarray,
    y: np.ndarray,
    sigma: np.ndarray,
    settings: PathFit,
    *,
    energy: np.ndarray | None = None,
    rates: Rates | None = None,
    lam: float | None = None,
) -> dict[str, Any]:
    """Robust :class:`Whittaker` fit of ``y`` (n, d) with λ from the noise σ (m, per sample).

    λ. Weights ``u/σ²``; λ solves ``Σ u |y − fit|² / σ² = dof Σ u (e / σ²) (1 − edf(λ) / n)``:
    the residuals are as large as the noise energy ``e`` (default σ², then the right side is
    ``dof (n − edf)``) leaves them once the fit has used ``edf`` degrees of freedom (Reinsch's
    1967 criterion with the correction of Buja, Hastie & Tibshirani 1989; without it,
    ``edf_correction=False``, Reinsch's own: a little smoother and monotone in λ). Brent's
    method on log λ. ``dof``: noise components per sample (2 for a horizontal position in 3-D
    coordinates, 1 for a height): ``settings`` (:class:`PathFit`) holds it and the robustness
    settings; the 0.1 call ``fit_path(grid, t, y, sigma, dof, max_run=...)`` still works, with a
    ``DeprecationWarning``.

    Robustness. Iteratively reweighted (Garcia 2010): Tukey's bisquare weights ``u`` of the
    residuals in units of σ times their MAD scale (at least 1), c = 4.685 (Beaton & Tukey
    1974). Samples with weight 0 are outliers, unless within ``floor`` (m) of the fit or in a
    run longer than ``max_run`` samples (real motion the fit has yet to follow: weight 1).

    Rates. ``rates`` (:class:`Rates`): observed velocities of the component (the log's own:
    ADS-B ground speed and track, vertical rate), least-squares rows of the derivative of the
    same interpolation with their weights, in every solve; they hold the path's velocity where
    the positions are noisy or missing (gaps). ``lam``: a λ to keep (that of the positions
    alone: rates that disagree with the positions in a way the noise model does not hold, e.g.
    late fixes, would drive the discrepancy to the roughest λ); default: from the discrepancy.

    Returns ``g`` (grid values), ``fit`` (at the samples), ``lam``, ``edf``, ``rms`` (residual
    RMS per noise component of the inliers, m) and ``outlier`` (n,) bool.
    """
    from scipy.linalg import LinAlgError
    from scipy.optimize import brentq

    dof, edf_correction = settings.dof, settings.edf_correction
    floor, max_run = settings.floor, settings.max_run

    n = t.size
    y0 = y.mean(axis=0)
    yc = y - y0
    sig = np.broadcast_to(np.asarray(sigma, dtype=np.float64), (n,))
    w0 = 1.0 / sig**2
    e = sig**2 if energy is None else np.asarray(energy, dtype=np.float64)
    dtm = float(np.median(np.diff(t)))
    scale = dtm ** (2 * ORDER - 1) * float(np.mean(w0))

    def lam_of(logb: float) -> float:
        # β = e^logb: the equivalent kernel's half-width in samples (Silverman 1984)
        return math.exp(2 * ORDER * logb) * scale

    def discrepancy(wt: Whittaker, w: np.ndarray, u: np.ndarray, lo: float, hi: float) -> float:
        budget, neff = float(np.sum(w * e)), float(np.sum(u))

        def excess(logb: float) -> float:
            # log of (residual sum / its expected value): < 0 too rough, > 0 too smooth
            try:
                _, fit, edf = wt.solve(lam_of(logb))
            except (LinAlgError, ValueError):
                return 1.0
            rhs = budget * (1.0 - edf / neff) if edf_correction else budget
            lhs = float(np.sum(w[:, None] * (yc - fit) ** 2)) / dof
            return -1.0 if rhs <= 1e-9 * budget or lhs <= 0.0 else math.log(lhs / rhs)

        if excess(lo) >= 0.0:
            return lo
        if excess(hi) <= 0.0:
            return hi
        return brentq(excess, lo, hi, xtol=1e-2)

    u = np.ones(n)
    wt = Whittaker(grid, t, yc, w0, PROBES, rates)
    if lam is None:
        logb = discrepancy(wt, w0, u, math.log(0.01), math.log(100.0))
    else:
        logb = math.log(lam / scale) / (2 * ORDER)
    for _ in range(IRLS_ITER):  # reweighting at a fixed λ
        _, fit, _ = wt.solve(lam_of(logb))
        r = np.linalg.norm(yc - fit, axis=1) / math.sqrt(dof)
        z = r / sig
        z = z / max(1.0, MAD_SCALE * float(np.median(z[u > 0])))
        bad = (z >= BISQUARE_C) & (r > floor)
        d = np.diff(np.concatenate([[0], bad.astype(np.int8), [0]]))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            if b - a > max_run:
                z[a:b] = 0.0
        unew = np.where(r <= floor, 1.0, _bisquare(z, BISQUARE_C))
        done = np.max(np.abs(unew - u)) < 1e-3
        u = unew
        wt = Whittaker(grid, t, yc, w0 * u, PROBES, rates)
        if done:
            break
    # the final fit: outliers out, every other sample at full weight, λ again
    u = (u > 0.0).astype(np.float64)
    if not u.all():
        wt = Whittaker(grid, t, yc, w0 * u, PROBES, rates)
        if lam is None:
            logb = discrepancy(wt, w0 * u, u, logb - 1.5, logb + 1.5)
    g, fit, edf = wt.solve(lam_of(logb))
    r = np.linalg.norm(yc - fit, axis=1) / math.sqrt(dof)
    outlier = u == 0.0
    rms = float(np.sqrt(np.mean(r[~outlier] ** 2))) if (~outlier).any() else 0.0
    return {
        "g": g + y0,
        "fit": fit + y0,
        "lam": lam_of(logb),
        "edf": edf,
        "rms": rms,
        "outlier": outlier,
    }


def refit(
    grid: tuple[float, float, int],
    t: np.ndarray,
    y: np.ndarray,
    sigma: np.ndarray,
    lam: float,
    rates: Rates | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:class:`Whittaker` fit at a given λ with weights ``1/σ²``: grid values, fit at ``t``."""
    y0 = y.mean(axis=0)
    w = 1.0 / np.asarray(sigma) ** 2
    g, fit, _ = Whittaker(grid, t, y - y0, w, 0, rates).solve(lam)
    return g + y0, fit + y0


def posterior_sigma(
    grid: tuple[float, float, int],
    t: np.ndarray,
    sigma: np.ndarray,
    lam: float,
    nodes: np.ndarray,
    rates: Rates | None = None,
) -> np.ndarray:
    r"""Posterior σ of the fitted path at grid ``nodes`` (per component, m).

    The penalised spline is the posterior mean of a Bayesian model (Wahba 1983): the samples
    with independent errors of σ, the path an integrated random walk whose second differences
    have the precision ``λ DᵀD``. Its posterior covariance is the inverse of the normal matrix,

    .. math:: \operatorname{Cov}(g) = (B^T W B + \lambda D^T D)^{-1}, \quad W = \sigma^{-2},

    so the σ at node k is ``√((A⁻¹)_kk)`` (observed rates ``rates`` add their rows to A): a
    few metres where samples are dense, growing as
    ``T^{3/2}`` across a gap of T without samples. Wahba, G. (1983) J. R. Statist. Soc. B 45,
    133-150.
    """
    from scipy.linalg import solveh_banded

    nodes = np.asarray(nodes, dtype=np.int64)
    if nodes.size == 0:
        return np.zeros(0)
    w = 1.0 / np.asarray(sigma, dtype=np.float64) ** 2
    if rates is not None:  # the covariance does not depend on the values: any d = 1 will do
        rates = Rates(rates.t, np.zeros((rates.t.size, 1)), rates.w)
    wt = Whittaker(grid, t, np.zeros((t.size, 1)), w, 0, rates)
    e = np.zeros((wt.ng, nodes.size))
    e[nodes, np.arange(nodes.size)] = 1.0
    x = solveh_banded(wt.matrix(lam), e, lower=False, check_finite=False)
    return np.sqrt(np.maximum(x[nodes, np.arange(nodes.size)], 0.0))


def quintic_kinematics(g: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Acceleration and jerk magnitudes of the quintic interpolating grid values (ng, d).

    The spline :class:`~fieldmap.nav.trajectory.FlightTrajectory` flies (``make_interp_spline``,
    k = 5, not-a-knot ends); at each node the larger of its value there and at the midpoints
    next to it. Two arrays (ng,).
    """
    from scipy.interpolate import make_interp_spline

    t = dt * np.arange(g.shape[0])
    sp = make_interp_spline(t, g, k=5)
    out = []
    for nu in (2, 3):
        a = np.linalg.norm(sp(t, nu), axis=1)
        mid = np.linalg.norm(sp(t[:-1] + 0.5 * dt, nu), axis=1)
        a[:-1] = np.maximum(a[:-1], mid)
        a[1:] = np.maximum(a[1:], mid)
        out.append(a)
    return out[0], out[1]


def quintic_load_factor(
    gh: np.ndarray, gv: np.ndarray, dt: float, g0: float
) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest load factor of the quintics through horizontal and vertical grids.

    ``gh`` (ng, 3): the surface ECEF path; ``gv`` (ng, 1): heights. The load factor is the
    specific force in units of ``g0``, ``n = √(|a_h|² + (a_v + g0)²) / g0`` (the Coriolis term,
    under 0.5 % of g at airliner speeds, and the variation of gravity left out: this is the
    limit the smoothing keeps, not the reported kinematics), evaluated at each node and the
    midpoints next to it, as :func:`quintic_kinematics`. Two arrays (ng,).
    """
    from scipy.interpolate import make_interp_spline

    t = dt * np.arange(gh.shape[0])
    sh, sv = make_interp_spline(t, gh, k=5), make_interp_spline(t, gv, k=5)

    def load(x: np.ndarray) -> np.ndarray:
        ah = np.linalg.norm(sh(x, 2), axis=1)
        return np.hypot(ah, sv(x, 2)[:, 0] + g0) / g0

    at, mid = load(t), load(t[:-1] + 0.5 * dt)
    lo, hi = at.copy(), at.copy()
    for k in (slice(None, -1), slice(1, None)):
        lo[k], hi[k] = np.minimum(lo[k], mid), np.maximum(hi[k], mid)
    return lo, hi


# -- the log's own velocities as observations of the path ----------------------------------
#: velocities: beyond OUTLIER_K robust σ of the residual from the positions-only fit, and
#: over OUTLIER_FLOOR m/s, an outlier
OUTLIER_K, OUTLIER_FLOOR = 5.0, 5.0
#: velocities that disagree with the positions by more than CONTRADICTION × the speed and
#: CONTRADICTION_MIN m/s for the median sample contradict them
CONTRADICTION, CONTRADICTION_MIN = 0.25, 15.0
#: vertical: by more than half the rate and CONTRADICTION_V m/s
CONTRADICTION_V = 5.0
#: fewer than this fraction of the velocities agreeing with the positions: the log's
#: velocities contradict them (refused); else the others are left out (stale, wrong)
AGREE_MIN = 0.1
#: tracks are compared where the ground speed exceeds this (m/s)
MOVING = 10.0


@dataclass(frozen=True)
class Observed:
    """The velocities of one flown segment, as observations of the horizontal and height fits.

    ``ih``, ``iv``: indices (into the ordered log) of the samples with a horizontal, a vertical
    velocity; ``h``, ``v``: the :class:`~fieldmap.nav.logs.fit.Rates` of each (None when
    none); ``sigma``: the σ (m/s) of each, per horizontal axis and vertical; ``east_north``
    (m, 2) and ``up`` (m,): the observed values (m/s) for the residuals.
    """

    ih: np.ndarray
    iv: np.ndarray
    h: Rates | None
    v: Rates | None
    sigma: tuple[float, float]
    east_north: np.ndarray
    up: np.ndarray
    names: tuple[str, ...]
    outliers: int = 0


def _radii(lat_deg: np.ndarray, ell: Any) -> tuple[np.ndarray, np.ndarray]:
    """Prime vertical and meridian radii of curvature (m) at geodetic latitudes."""
    e2 = ell.f * (2.0 - ell.f)
    w2 = 1.0 - e2 * np.sin(np.radians(lat_deg)) ** 2
    return ell.a / np.sqrt(w2), ell.a * (1.0 - e2) / w2**1.5


def _run_lengths(x: np.ndarray) -> np.ndarray:
    """Length of the run of equal rows each row of ``x`` (m, k) is in, (m,)."""
    if x.shape[0] == 0:
        return np.ones(0)
    same = np.all(x[1:] == x[:-1], axis=1)
    start = np.concatenate([[True], ~same])
    ident = np.cumsum(start) - 1
    return np.bincount(ident)[ident].astype(np.float64)


def _loo_sigma(t: np.ndarray, v: np.ndarray) -> float:
    z = loo_noise(t, v)
    return noise_sigma(z)[0] if z.size else 0.0


def observations(log: Any, track: Any, idx: np.ndarray) -> Observed | None:
    """Return the velocities of the ordered samples ``idx`` of ``log`` (an ``OrderedLog``).

    ``track``: the :class:`~fieldmap.nav.logs.read.RawTrack` whose ``velocity`` the ordered
    samples index (``log.index``). Only finite values are used.
    """
    vel = getattr(track, "velocity", None)
    if vel is None or idx.size == 0:
        return None
    src = log.index[idx]
    speed, course = vel.speed[src], vel.track[src]
    climb = vel.climb[src] if vel.climb is not None else np.full(idx.size, np.nan)
    okh = np.isfinite(speed) & np.isfinite(course) & (speed >= 0.0)
    okv = np.isfinite(climb)
    if okh.sum() < ORDER + 3 and okv.sum() < ORDER + 3:
        return None
    chi = np.radians(course)
    en = np.stack([speed * np.sin(chi), speed * np.cos(chi)], -1)
    q_s, q_c, q_v = (r / np.sqrt(12.0) for r in vel.resolution)
    ih, iv = idx[okh], idx[okv]
    # per horizontal axis: half the variance of the speed's and the track's rounding
    s_q = np.sqrt(0.5 * (q_s**2 + (np.nanmedian(speed[okh]) * np.radians(q_c)) ** 2))
    s_h = max(float(s_q), _loo_sigma(log.t[ih], en[okh]))
    s_v = max(float(q_v), _loo_sigma(log.t[iv], climb[okv, None])) if iv.size else 0.0
    rh = rv = None
    run_h = _run_lengths(np.stack([speed[okh], course[okh]], -1))
    run_v = _run_lengths(climb[okv, None])
    if ih.size:
        n_rad, m_rad = _radii(log.lat[ih], log.ellipsoid)
        hh = log.h[ih]
        e = en[okh, 0] * n_rad / (n_rad + hh)
        n = en[okh, 1] * m_rad / (m_rad + hh)
        v_ecef = e[:, None] * log.en[ih, 0, :] + n[:, None] * log.en[ih, 1, :]
        rh = Rates(log.t[ih], v_ecef, 1.0 / (s_h**2 * run_h))
    if iv.size:
        rv = Rates(log.t[iv], climb[okv, None], 1.0 / (s_v**2 * run_v))
    return Observed(ih, iv, rh, rv, (s_h, s_v), en[okh], climb[okv], tuple(vel.names))


def fitted_rates(grid: tuple[float, float, int], g: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rates (m, d) at the times ``t`` of the grid values ``g`` (cubic Lagrange derivative)."""
    t0, dt, ng = grid
    return on_grid(g, lagrange_rate_rows(t0, dt, ng, t))


def check(
    obs: Observed, rate_h: np.ndarray, rate_v: np.ndarray, source: str, lines: np.ndarray
) -> Observed:
    """Refuse velocities that contradict the positions; leave out outliers (module docstring).

    ``rate_h`` (m, 3), ``rate_v`` (m, 1): the positions-only fit's rates at the observations.
    ``lines``: the line of each ordered sample, for the message. Returns the observations
    without their outliers.
    """
    keep_h = np.ones(obs.ih.size, bool)
    keep_v = np.ones(obs.iv.size, bool)
    s_h, s_v = obs.sigma
    if obs.h is not None and obs.ih.size:
        d = obs.h.v - rate_h
        r = np.linalg.norm(d, axis=1)
        speed = np.linalg.norm(rate_h, axis=1)
        agree = r <= np.maximum(CONTRADICTION * speed, CONTRADICTION_MIN)
        if agree.mean() < AGREE_MIN:
            names = "/".join(obs.names[:2])
            raise InputError(
                f"{source} lines {lines[obs.ih[0]]}..{lines[obs.ih[-1]]}: the log's velocities "
                f"({names}) contradict its positions: {100 * agree.mean():.0f} % agree within "
                f"{100 * CONTRADICTION:g} % of the speed (the median differs by "
                f"{np.median(r):.0f} m/s at a median speed of {np.median(speed):.0f} m/s from "
                "the positions): a unit or a column mixed up, or velocities that are stale or "
                "from another source",
                Advice("; ", Pass("log_velocities", False), " to fly the positions alone"),
                param="log_velocities",
            )
        s = MAD_SCALE * float(np.median(r[agree])) if agree.any() else 0.0
        keep_h = agree & ((r <= OUTLIER_K * s) | (r <= OUTLIER_FLOOR))
    if obs.v is not None and obs.iv.size:
        r = np.abs(obs.v.v[:, 0] - rate_v[:, 0])
        agree = r <= np.maximum(0.5 * np.abs(rate_v[:, 0]), CONTRADICTION_V)
        if agree.mean() < AGREE_MIN and obs.iv.size >= 10:
            names = obs.names[2] if len(obs.names) > 2 else "vertical rate"
            raise InputError(
                f"{source} lines {lines[obs.iv[0]]}..{lines[obs.iv[-1]]}: the log's vertical "
                f"rates ({names}) contradict its heights: {100 * agree.mean():.0f} % agree "
                f"within half the rate or {CONTRADICTION_V:g} m/s: a unit or a column mixed up "
                "(the altitudes' ",
                Keyword("alt_units"),
                ", the rates')?",
                param="alt_units",
            )
        # barometric heights go wrong for minutes (held, from another source) where the
        # vertical rates do not: a rate is an outlier against its own neighbours only
        z = np.abs(loo_noise(obs.v.t, obs.v.v))[:, 0]
        s = MAD_SCALE * float(np.median(z)) if z.size else 0.0
        keep_v[2:-2] = (z <= OUTLIER_K * s) | (z <= OUTLIER_FLOOR)

    def sub(rt: Rates | None, keep: np.ndarray, sig: float) -> Rates | None:
        if rt is None:
            return None
        return Rates(rt.t[keep], rt.v[keep], np.full(int(keep.sum()), 1.0 / sig**2))

    return Observed(
        obs.ih[keep_h],
        obs.iv[keep_v],
        sub(obs.h, keep_h, s_h),
        sub(obs.v, keep_v, s_v),
        (s_h, s_v),
        obs.east_north[keep_h],
        obs.up[keep_v],
        obs.names,
        int((~keep_h).sum() + (~keep_v).sum()),
    )


def residuals(
    obs: Observed | None,
    samples: Any,
    t_start: float,
    ellipsoid: Any,
    every: Observed | None = None,
) -> dict | None:
    """Compare the flown velocity with the log's (JSON-ready; None without velocities).

    The flown velocity is that of the quintic spline :class:`~fieldmap.nav.trajectory.
    FlightTrajectory` flies (as :func:`fieldmap.nav.logs.report.kinematics`), at the times of
    the observations within the flown span. Returns the RMS and largest residual (flown − log)
    of the ground speed (m/s), the track (degrees, where faster than 10 m/s) and the vertical
    rate (m/s), the number of each, the σ the fit gave them and the outliers left out. With
    ``every`` (the observations before :func:`check` left its outliers out) and outliers
    left out, the same against every velocity of the log (keys ``..._all_...``): a path that
    parts from the log where its velocities were judged wrong shows there.
    """
    from scipy.interpolate import make_interp_spline

    from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef

    if obs is None:
        return None
    s = samples
    r = np.stack(geodetic_to_ecef(s.lat, s.lon, s.h, ellipsoid), -1)
    sp = make_interp_spline(s.t, r, k=5)
    out: dict[str, Any] = {
        "columns": list(obs.names),
        "sigma_h_m_s": float(obs.sigma[0]),
        "sigma_v_m_s": float(obs.sigma[1]),
        "outliers": int(obs.outliers),
    }

    def enu(tt: np.ndarray) -> np.ndarray:
        lat, lon = (np.interp(tt, s.t, x) for x in (s.lat, s.lon))
        return np.einsum("nij,nj->ni", C_e_to_enu(lat, lon), sp(tt, 1))

    def stats(x: np.ndarray) -> tuple[float, float]:
        return (float(np.sqrt(np.mean(x**2))), float(np.max(np.abs(x)))) if x.size else (0, 0)

    def horizontal(o: Observed) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Count, ground-speed and track residuals, flown and log east/north of ``o``."""
        assert o.h is not None
        tt = o.h.t - t_start
        inside = (tt >= s.t[0]) & (tt <= s.t[-1])
        v = enu(tt[inside])
        en = o.east_north[inside]
        gs_f, gs_o = np.hypot(v[:, 0], v[:, 1]), np.hypot(en[:, 0], en[:, 1])
        fast = (gs_o > MOVING) & (gs_f > MOVING)
        d_tr = np.degrees(
            np.angle(np.exp(1j * (np.arctan2(v[fast, 0], v[fast, 1]) - np.arctan2(*en[fast].T))))
        )
        return int(inside.sum()), gs_f - gs_o, d_tr, v[:, :2], en

    def vertical(o: Observed) -> tuple[int, np.ndarray]:
        assert o.v is not None
        tt = o.v.t - t_start
        inside = (tt >= s.t[0]) & (tt <= s.t[-1])
        return int(inside.sum()), enu(tt[inside])[:, 2] - o.up[inside]

    if obs.h is not None:
        n, d_gs, d_tr, v, en = horizontal(obs)
        out["horizontal_count"] = n
        out["groundspeed_rms_m_s"], out["groundspeed_max_m_s"] = stats(d_gs)
        out["track_rms_deg"], out["track_max_deg"] = stats(d_tr)
        out["east_north_rms_m_s"] = stats(np.linalg.norm(v - en, axis=1) / np.sqrt(2))[0]
    if obs.v is not None:
        n, d_v = vertical(obs)
        out["vertical_count"] = n
        out["vertical_rate_rms_m_s"], out["vertical_rate_max_m_s"] = stats(d_v)
    if every is not None and obs.outliers:
        if every.h is not None:
            n, d_gs, d_tr, _, _ = horizontal(every)
            out["horizontal_all_count"] = n
            out["groundspeed_all_rms_m_s"], out["groundspeed_all_max_m_s"] = stats(d_gs)
            out["track_all_rms_deg"], out["track_all_max_deg"] = stats(d_tr)
        if every.v is not None:
            n, d_v = vertical(every)
            out["vertical_all_count"] = n
            out["vertical_rate_all_rms_m_s"], out["vertical_rate_all_max_m_s"] = stats(d_v)
    return out
