r"""The field beyond a model's degree: a degree-variance model and its isotropic random field.

A spherical-harmonic model of degree L leaves out the degrees L+1, L+2, ... of the Earth's field
(the *omission*). Their coefficients are unknown; what is known is how much power each degree
holds on average, a **degree-variance model** :math:`c_n` of the disturbing potential T (the
mean square over the sphere of radius R of the degree-n part :math:`T_n`). The omitted field is
then an isotropic random field on and above the sphere (Moritz 1980, *Advanced Physical
Geodesy*, §§ 21-23; Tscherning & Rapp 1974):

.. math::
    \operatorname{cov}\bigl(T(P), T(Q)\bigr) = \sum_{n>L} c_n
        \left(\frac{R^2}{r_P r_Q}\right)^{n+1} P_n(\cos\psi_{PQ}).

Degree-variance models (:data:`DEGREE_VARIANCE_MODELS`, :attr:`Omission.kind`):

* ``"tscherning-rapp"`` — Tscherning & Rapp (1974) model 4, gravity-anomaly degree variances
  :math:`c_n^{\Delta g} = A\,(n-1)/((n-2)(n+B))\,s^{n+2}` for n ≥ 3 with A = 425.28 mGal²,
  B = 24, s = 0.999617 (:math:`s = (R_B/R)^2`, a Bjerhammar sphere 1.2 km inside the mean
  sphere); the potential's are :math:`c_n = (R/(n-1))^2 c_n^{\Delta g}` (the anomaly of
  degree n is :math:`(n-1)T_n/R`, Heiskanen & Moritz 1967 eq. 2-151c). With their degree-2
  value 7.5 mGal², the series sums to TR's published point-anomaly variance, 1795 mGal²
  (``tests/test_omission.py``). The default: it keeps the power of the short wavelengths
  that a satellite model cannot see.
* ``"kaula"`` — Kaula's rule: the RMS of a fully normalised coefficient of degree n is
  :math:`10^{-5}/n^2`, so :math:`c_n = (GM/R)^2 (2n+1)\,10^{-10}/n^4`.
* ``"fitted"`` — a power law :math:`c_n = a\,n^b` fitted (least squares in log c, log n) to the
  model's own degree variances :math:`(GM/R)^2\sum_m(\bar C_{nm}^2+\bar S_{nm}^2)` over its
  degrees :math:`\lfloor L_m/2\rfloor..L_m` (:math:`L_m` the degree it holds): the field
  the model's own spectrum implies (EIGEN-6S, degrees 120..240: :math:`b = -3.35`, between
  Kaula's −3 and the steeper fall of Tscherning-Rapp at high degree).

GM and R are the model's when one is given, else the bundled EIGEN-6S header's
(:data:`DEFAULT_GM`, :data:`DEFAULT_RADIUS`).

**Degrees summed.** Degrees L+1 .. :attr:`Omission.max_degree`. Unless given, the top degree is
the smallest that leaves less than :data:`TAIL_FRACTION` (0.1 %) of the omitted
gravity-disturbance variance at h = 0 beyond it (Tscherning-Rapp from L = 240: 12,005),
at most :data:`MAX_DEGREE_CAP` (100,000, a wavelength of 400 m). Kaula's rule does not converge
at h = 0 (the disturbance variance of degree n falls as 2/n, so the sum grows as 2 ln N): it, and
a fitted law whose tail beyond the cap still holds 0.1 %, are summed to the cap, and their σ at
h = 0 is that of the degrees to 100,000 (a few km up, the factor :math:`(R/r)^{2n+2}` has cut
the degrees above 10,000 anyway; pass ``max_degree`` to choose).

**σ at a height** (:meth:`Omission.sigma`), spherical approximation r = R + h, h above the
ellipsoid (the degree-variance models are defined on the mean sphere, i.e. at the Earth's
surface, whatever its latitude): with :math:`\delta g = \nabla T`,

.. math::
    \sigma^2_{down}(h) = \sum_{n=L+1}^{N} c_n \left(\frac{n+1}{r}\right)^2
        \left(\frac{R}{r}\right)^{2n+2},\qquad
    \sigma^2_{north} = \sigma^2_{east} = \frac12\sum_{n=L+1}^{N} c_n\,\frac{n(n+1)}{r^2}
        \left(\frac{R}{r}\right)^{2n+2}

(the mean square of the surface gradient of :math:`T_n` is :math:`n(n+1)/r^2` times that of
:math:`T_n`, shared equally by any two orthogonal horizontal directions).

**Covariances** (:meth:`Omission.covariance`), for a linear error model or a covariance
analysis: of δg down, and of the horizontal components along and across the great circle
through two points, at any distance and pair of heights (Legendre sums to the top degree).

**Realisations** (:meth:`Omission.realise`): a sum of random waves. The degrees are split
into :data:`N_BANDS` log-spaced bands; each band b holds :data:`WAVES_PER_BAND` = K waves, and
wave j has

* a degree :math:`n_j` drawn within the band with probability :math:`c_n/C_b`
  (:math:`C_b = \sum_{n\in b} c_n`),
* a pole :math:`p_j` uniform on the unit sphere and a phase :math:`\varphi_j` uniform in
  [0, 2π),
* the potential :math:`T_j = A_b (R/r)^{n_j+1}\cos(\nu_j\psi_j + \varphi_j)`, with
  :math:`\psi_j` the angle between :math:`p_j` and the point's direction,
  :math:`\nu_j = \sqrt{n_j(n_j+1)}` and :math:`A_b^2 = 2C_b/K`.

δg is the exact gradient of the sum: down :math:`(n_j+1)/r\;T_j`, horizontal
:math:`-(A_b/r)(R/r)^{n_j+1}\nu_j\sin(\nu_j\psi_j+\varphi_j)\,e_\psi` with
:math:`e_\psi = (\hat x\cos\psi - p)/\sin\psi` projected on north and east. Why it is right:

* *Variance, exactly, at every height.* For one wave, averaging over the phase,
  :math:`E[T_j^2] = E_n[A_b^2 (R/r)^{2n+2}]/2 = \sum_{n\in b} (c_n/K)(R/r)^{2n+2}`; the K waves
  of the band give back :math:`\sum_{n\in b}c_n(R/r)^{2n+2}`, and with the factors
  :math:`((n+1)/r)^2` and :math:`\nu^2/r^2 = n(n+1)/r^2` the σ above, degree by degree, at every
  r: no approximation enters the expected variance of any component at any height. The tests
  compare the σ of many draws with :meth:`Omission.sigma`.
* *Covariance.* Near a point a wave is a plane wave of wavenumber :math:`\nu/r` travelling in
  the direction :math:`e_\psi`, which is uniform in azimuth for a uniform pole; the covariance
  of the wave at two points a distance d apart is therefore
  :math:`E[\cos(\nu\,\Delta\psi)] = J_0(\nu d/r)`, and
  :math:`P_n(\cos\theta)\approx\sqrt{\theta/\sin\theta}\,J_0((n+\tfrac12)\theta)` (Hilb's
  formula; :math:`\nu = n+\tfrac12-1/(8n)+\dots`), which is the covariance of the isotropic
  field of degree n, to a relative O(θ²) where the correlation of degrees above L has long
  died out (θ ≪ 1/L). The horizontal components come from the same wave, so their
  longitudinal and transverse covariances are those of the gradient of one isotropic field.
* *In 3-D and along any path.* Every wave carries the exact radial factor of its degree,
  :math:`(R/r)^{n+1}`, so one realisation is consistent between 0 km and 30 km and along a
  hypersonic path thousands of km long that climbs and descends: the covariance between two
  points of a path at different heights is :math:`\sum c_n (R^2/(r_Pr_Q))^{n+1}J_0(\dots)`, as
  above. The field is defined everywhere, not along one track: two tracks crossing see the
  same values. A Gauss-Markov process fitted along a track (Jordan 1972, Kasper 1971) holds one
  altitude and one speed; this does not need either.
* *Gaussian enough.* A point sums :math:`N_{bands}\,K` = 640 independent terms of bounded
  amplitude; the bands of similar power make many of them comparable.

The waves of a draw are a few thousand numbers drawn from ``numpy.random.default_rng(seed)``
before any point is looked at, draw after draw (so the first k draws of ``draws=m`` are those
of ``draws=k``); the sum at a point runs over the waves in one fixed order with element-wise
NumPy operations, so the same inputs give the same bits however the points are chunked
(``tests/test_omission.py``). Cost: about 40 floating-point operations and a sine, cosine,
arctangent and exponential per wave and point (640 waves), in the Warp kernel
:func:`fieldmap.kernels.omission.wave_sum` (one thread per draw and point, every CPU core or a
GPU); its NumPy reference is :func:`fieldmap.reference.omission.wave_sum`.

References: Tscherning C.C. & Rapp R.H. (1974), *Closed covariance expressions for gravity
anomalies, geoid undulations, and deflections of the vertical implied by anomaly degree
variance models*, Report 208, Dept. of Geodetic Science, Ohio State University; Kaula W.M.
(1966), *Theory of Satellite Geodesy*; Moritz H. (1980), *Advanced Physical Geodesy*;
Jekeli C. (1978), OSU Report 275 (degree-variance models and their gradient variance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fieldmap import limits
from fieldmap.errors import InputError, Keyword, Label
from fieldmap.models.shmodel import SHModel

__all__ = [
    "DEGREE_VARIANCE_MODELS",
    "MAX_DEGREE_CAP",
    "Omission",
    "degree_variance_model",
    "grid_omission",
    "tscherning_rapp_anomaly_variances",
]

#: Degree-variance models of :class:`Omission` (``kind``)
DEGREE_VARIANCE_MODELS = ("tscherning-rapp", "kaula", "fitted")
#: Highest degree summed (a wavelength of 2πR/100,000 = 400 m). Units: degree.
MAX_DEGREE_CAP = 100_000
#: Part of the omitted δg variance at h = 0 that may lie above the top degree chosen.
TAIL_FRACTION = 1.0e-3
#: Bands and waves per band of a realisation (:meth:`Omission.realise`).
N_BANDS = 40
WAVES_PER_BAND = 16
#: Bundled EIGEN-6S header: ``earth_gravity_constant`` (m³/s²) and ``radius`` (m).
DEFAULT_GM = 3.986004415e14
DEFAULT_RADIUS = 6378136.46
#: Tscherning & Rapp (1974) model 4: A (mGal²), B, s; and their degree-2 anomaly variance (mGal²).
TR_A = 425.28
TR_B = 24.0
TR_S = 0.999617
TR_C2 = 7.5
#: Kaula's rule: RMS of a fully normalised coefficient of degree n is KAULA / n².
KAULA = 1.0e-5
MGAL = 1.0e5  # mGal per m/s²
_CHUNK = 1 << 24  # threads (draws x points) per launch


def tscherning_rapp_anomaly_variances(n: ArrayLike) -> NDArray[np.float64]:
    r"""Gravity-anomaly degree variances of Tscherning & Rapp (1974) model 4, at the surface.

    .. math::
        c_n^{\Delta g} = A\,\frac{n-1}{(n-2)(n+B)}\,s^{n+2}\quad(n\ge 3),\qquad
        c_2^{\Delta g} = 7.5\ \mathrm{mGal}^2

    with A = 425.28 mGal², B = 24, s = 0.999617 (TR 1974, model 4; the degree-2 value is
    theirs, with respect to GRS 1967).

    Parameters
    ----------
    n : array_like of int
        Degrees, ≥ 2.

    Returns
    -------
    numpy.ndarray
        Units: mGal².
    """
    nn = _degrees(n, 2)
    out = np.full(nn.shape, TR_C2)
    k = nn >= 3
    m = nn[k]
    out[k] = TR_A * (m - 1.0) / ((m - 2.0) * (m + TR_B)) * TR_S ** (m + 2.0)
    return out


def degree_variance_model(kind: object) -> str:
    """``kind`` checked against :data:`DEGREE_VARIANCE_MODELS` (any case), in lower case.

    Raises
    ------
    InputError
        An unknown model (``param="omission_model"``), one line.
    """
    if not isinstance(kind, str) or kind.lower() not in DEGREE_VARIANCE_MODELS:
        raise InputError(
            f"unknown degree-variance model {kind!r} for the omission: one of "
            f"{', '.join(DEGREE_VARIANCE_MODELS)}",
            Label("omission_model"),
            param="omission_model",
        )
    return kind.lower()


def _degrees(n: ArrayLike, lowest: int) -> NDArray[np.float64]:
    arr = np.asarray(n)
    if arr.dtype.kind not in "iu" and not (
        arr.dtype.kind == "f" and np.all(np.isfinite(arr)) and np.all(arr == np.round(arr))
    ):
        raise InputError("degrees must be whole numbers")
    if arr.size and np.min(arr) < lowest:
        raise InputError(f"degrees must be at least {lowest}, got {int(np.min(arr))}")
    return arr.astype(np.float64)


def _whole(value: object, name: str, param: str) -> int:
    """``value`` as an int (bools and fractions refused), else one line naming it."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        if isinstance(value, (float, np.floating)) and float(value).is_integer():
            return int(value)
        subject = Keyword(param) if name == param else name
        raise InputError(subject, f" must be a whole number, got {value!r}", param=param)
    return int(value)


@dataclass(frozen=True)
class Omission:
    """The gravity field above degree ``degree`` (a model's L) as an isotropic random field.

    See the module docstring for the degree-variance models, σ and the realisations.

    Parameters
    ----------
    degree : int
        L, the degree of the model; the omission is degrees L+1 .. ``max_degree``. At least 2.
    kind : {"tscherning-rapp", "kaula", "fitted"}
        Degree-variance model (:data:`DEGREE_VARIANCE_MODELS`).
    model : SHModel, optional
        The model whose omission this is: gives GM and R (default: the bundled EIGEN-6S's) and
        the degree variances of ``"fitted"`` (needed for it). Its degree must not exceed
        ``degree``.
    max_degree : int, optional
        Top degree summed, above ``degree`` and at most :data:`MAX_DEGREE_CAP`. Default: the
        smallest degree beyond which less than 0.1 % of the omitted gravity-disturbance
        variance at h = 0 remains (at most :data:`MAX_DEGREE_CAP`).

    Attributes
    ----------
    gm : float
        Units: m³/s². GM of ``model`` or :data:`DEFAULT_GM`.
    radius : float
        Units: m. R of ``model`` or :data:`DEFAULT_RADIUS` (r = R + h).
    fit : tuple of float or None
        ``(a, b)`` of the fitted law :math:`c_n = a n^b` (a in (m²/s²)²), for ``"fitted"``.

    Raises
    ------
    InputError
        Unknown ``kind`` (``param="omission_model"``), ``degree`` below 2 or not below
        ``max_degree``, or below the model's degree (``param="omission_degree"``), ``"fitted"``
        without a model.

    Examples
    --------
    >>> from fieldmap.field.omission import Omission
    >>> om = Omission(240)
    >>> om.max_degree
    12005
    >>> sig = om.sigma([0.0, 10e3]) * 1e5  # mGal: north, east, down
    >>> sig.round(1)
    array([[19.8, 19.8, 28. ],
           [ 7.6,  7.6, 10.7]])
    """

    degree: int
    kind: str = "tscherning-rapp"
    # compared through what it gives (gm, radius, fit): an SHModel's arrays have no truth value
    model: SHModel | None = field(default=None, compare=False)
    max_degree: int | None = None
    gm: float = field(init=False, repr=False)
    radius: float = field(init=False, repr=False)
    fit: tuple[float, float] | None = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "kind", degree_variance_model(self.kind))
        L = _whole(self.degree, "the omission degree", "omission_degree")
        if L < 2:
            raise InputError(
                f"the omission degree must be at least 2 (degrees 3 and up are omitted), got {L}",
                param="omission_degree",
            )
        if L >= MAX_DEGREE_CAP:
            raise InputError(
                f"the omission degree must be below {MAX_DEGREE_CAP}, got {L}",
                param="omission_degree",
            )
        set_(self, "degree", L)
        model = self.model
        if model is not None and not isinstance(model, SHModel):
            raise InputError(
                f"the omission's model must be an SHModel, got {type(model).__name__}",
                param="model",
            )
        if model is not None and L < model.lmax:
            raise InputError(
                f"omission asked from degree {L} but the model already has degrees up to "
                f"{model.lmax} ({model.name}): ask from degree {model.lmax} or truncate the model",
                param="omission_degree",
            )
        set_(self, "gm", DEFAULT_GM if model is None else float(model.gm))
        set_(self, "radius", DEFAULT_RADIUS if model is None else float(model.radius))
        if self.kind == "fitted":
            set_(self, "fit", self._fit_power_law())
        if self.max_degree is None:
            set_(self, "max_degree", self._resolve_max_degree())
        else:
            N = _whole(self.max_degree, "max_degree", "max_degree")
            if not L < N <= MAX_DEGREE_CAP:
                raise InputError(
                    f"max_degree must be above the omission degree {L} and at most "
                    f"{MAX_DEGREE_CAP}, got {N}",
                    param="max_degree",
                )
            set_(self, "max_degree", N)

    # ------------------------------------------------------------------ degree variances

    def potential_variances(self, n: ArrayLike) -> NDArray[np.float64]:
        """Degree variances of the disturbing potential T on the sphere of radius R.

        Parameters
        ----------
        n : array_like of int
            Degrees, ≥ 2.

        Returns
        -------
        numpy.ndarray
            :math:`c_n`, the mean square of :math:`T_n` over the sphere r = R.
            Units: (m²/s²)².
        """
        nn = _degrees(n, 2)
        if self.kind == "tscherning-rapp":
            # Δg_n = (n-1) T_n / R (H&M eq. 2-151c); degree 2: (n-1) = 1
            return tscherning_rapp_anomaly_variances(nn) * 1e-10 * (self.radius / (nn - 1.0)) ** 2
        if self.kind == "kaula":
            return (self.gm / self.radius) ** 2 * (2.0 * nn + 1.0) * KAULA**2 / nn**4
        assert self.fit is not None
        a, b = self.fit
        return a * nn**b

    def _fit_power_law(self) -> tuple[float, float]:
        model = self.model
        if model is None:
            raise InputError(
                "the fitted degree-variance model needs the model whose degree variances it "
                "fits (model=)",
                param="omission_model",
            )
        top = model.lmax
        n = np.arange(max(2, top // 2), top + 1)
        C, S = np.asarray(model.C), np.asarray(model.S)
        power = np.array([np.sum(C[k, : k + 1] ** 2 + S[k, : k + 1] ** 2) for k in n])
        ok = power > 0
        if np.count_nonzero(ok) < 2:
            raise InputError(
                f"the fitted degree-variance model needs a model with power at two or more "
                f"degrees from {n[0]} to {top}; {model.name} has degree {top}",
                param="omission_model",
            )
        b, log_a = np.polyfit(np.log(n[ok]), np.log(power[ok]), 1)
        return float(np.exp(log_a) * (self.gm / self.radius) ** 2), float(b)

    def _disturbance_weights(self, n: NDArray[np.float64]) -> NDArray[np.float64]:
        """δg variance (down + north + east) of degrees n at h = 0, r = R. Units: (m/s²)²."""
        return self.potential_variances(n) * ((n + 1.0) ** 2 + n * (n + 1.0)) / self.radius**2

    def _resolve_max_degree(self) -> int:
        n = np.arange(self.degree + 1, MAX_DEGREE_CAP + 1, dtype=np.float64)
        w = self._disturbance_weights(n)
        # beyond the cap: the integral of the local power law w ∝ n^β (β from cap/2 .. cap)
        w_half, w_top = w[(MAX_DEGREE_CAP // 2) - self.degree - 1], w[-1]
        if w_top == 0.0:
            beyond = 0.0
        else:
            beta = math.log(w_top / w_half) / math.log(2.0)
            beyond = w_top * MAX_DEGREE_CAP / (-beta - 1.0) if beta < -1.0 else math.inf
        tail = np.cumsum(w[::-1])[::-1]  # tail[i] = Σ_{k ≥ i} w[k]
        total = tail[0] + beyond
        if not math.isfinite(total) or beyond >= TAIL_FRACTION * total:
            return MAX_DEGREE_CAP
        # smallest N with Σ_{n > N} w < TAIL_FRACTION · total: tail[i] covers n ≥ degree+1+i
        above = np.append(tail[1:], 0.0) + beyond  # above[i] = Σ_{n > degree+1+i}
        i = int(np.argmax(above < TAIL_FRACTION * total))
        return self.degree + 1 + i

    @property
    def degrees(self) -> NDArray[np.float64]:
        """The omitted degrees L+1 .. ``max_degree`` (float64)."""
        assert self.max_degree is not None
        return np.arange(self.degree + 1, self.max_degree + 1, dtype=np.float64)

    # ------------------------------------------------------------------ σ

    def sigma(self, h: ArrayLike) -> NDArray[np.float64]:
        """Return the σ of the omitted gravity disturbance vector at heights ``h``.

        Spherical approximation, r = R + h (module docstring for the sums).

        Parameters
        ----------
        h : array_like
            Heights above the ellipsoid, in [-10 km, 1e8 m]. Below h = 0 the series is the
            truncated one (summed to ``max_degree``) and grows fast. Units: m.

        Returns
        -------
        numpy.ndarray
            Shape ``(h.size, 3)``: σ north, east, down of δg. Units: m/s².
        """
        hh = np.ravel(limits.check_geodetic(0.0, 0.0, h)[2])
        n = self.degrees
        c = self.potential_variances(n)
        down_w, hor_w = c * (n + 1.0) ** 2, c * n * (n + 1.0) * 0.5
        out = np.empty((hh.size, 3))
        for i in range(0, hh.size, 16):
            r = self.radius + hh[i : i + 16]
            att = np.exp(np.outer(np.log(self.radius / r), 2.0 * n + 2.0))  # (R/r)^(2n+2)
            # row by row (not BLAS): a height's σ has the same bits whatever the others
            out[i : i + 16, 2] = np.sqrt(np.sum(att * down_w, axis=1)) / r
            hor = np.sqrt(np.sum(att * hor_w, axis=1)) / r
            out[i : i + 16, 0] = hor
            out[i : i + 16, 1] = hor
        return out

    def covariance(
        self, distance_m: ArrayLike, h: float, h2: float | None = None
    ) -> NDArray[np.float64]:
        r"""Covariances of δg between two points a distance apart, at heights h and h2.

        With :math:`K(\psi) = \sum_n c_n (R^2/(r_1r_2))^{n+1} P_n(\cos\psi)` the covariance
        of T (Moritz 1980 §23; Tscherning & Rapp 1974 for its derivatives), t = cos ψ:

        .. math::
            C_{down} = \sum_n c_n \frac{(n+1)^2}{r_1r_2}\,s_n P_n(t),\quad
            C_{long} = \sum_n \frac{c_n s_n}{r_1r_2}\,\bigl(n(n+1)P_n(t) - tP_n'(t)\bigr),
            \quad C_{trans} = \sum_n \frac{c_n s_n}{r_1r_2}\,P_n'(t)

        (:math:`s_n = (R^2/(r_1r_2))^{n+1}`): the down components, the horizontal components
        along the great circle through the points (longitudinal, :math:`-K''/(r_1r_2)`) and
        across it (transverse, :math:`-K'/(r_1r_2\sin\psi)`). At distance 0 and h2 = h they
        are σ²: down, and north = east = long = trans. Legendre recursions to ``max_degree``.

        Parameters
        ----------
        distance_m : array_like
            Great-circle distances on the sphere of radius R, ≥ 0. Units: m.
        h, h2 : float
            Heights of the two points (h2 default h). Units: m.

        Returns
        -------
        numpy.ndarray
            Shape ``(distance.size, 3)``: down, longitudinal, transverse. Units: (m/s²)².
        """
        d = limits.as_float("distance_m", distance_m).ravel()
        if np.any(d < 0):
            raise InputError("distance_m must be non-negative", param="distance_m")
        h1 = float(np.ravel(limits.check_geodetic(0.0, 0.0, h)[2])[0])
        h2 = h1 if h2 is None else float(np.ravel(limits.check_geodetic(0.0, 0.0, h2)[2])[0])
        r1, r2 = self.radius + h1, self.radius + h2
        assert self.max_degree is not None
        n_all = np.arange(self.max_degree + 1, dtype=np.float64)
        c = np.zeros_like(n_all)
        c[self.degree + 1 :] = self.potential_variances(n_all[self.degree + 1 :])
        c *= np.exp((n_all + 1.0) * np.log(self.radius**2 / (r1 * r2))) / (r1 * r2)
        t = np.cos(d / self.radius)
        out = np.zeros((d.size, 3))
        p_prev, p = np.ones_like(t), t.copy()  # P_0, P_1
        dp_prev, dp = np.zeros_like(t), np.ones_like(t)  # P_0', P_1'
        for n in range(1, self.max_degree + 1):
            if n > self.degree:
                w = c[n]
                out[:, 0] += w * (n + 1.0) ** 2 * p
                out[:, 1] += w * (n * (n + 1.0) * p - t * dp)
                out[:, 2] += w * dp
            # P_{n+1} = ((2n+1) t P_n - n P_{n-1})/(n+1); P'_{n+1} = P'_{n-1} + (2n+1) P_n
            p_prev, p, dp_prev, dp = (
                p,
                ((2 * n + 1) * t * p - n * p_prev) / (n + 1),
                dp,
                dp_prev + (2 * n + 1) * p,
            )
        return out

    # ------------------------------------------------------------------ realisations

    def _bands(self) -> list[tuple[int, NDArray[np.float64]]]:
        """[(first degree, cumulative c_n within the band)] of the log-spaced bands."""
        assert self.max_degree is not None
        lo, hi = self.degree + 1, self.max_degree + 1  # degrees lo .. hi-1
        edges = np.unique(np.round(np.geomspace(lo, hi, N_BANDS + 1)).astype(np.int64))
        edges[0], edges[-1] = lo, hi
        out = []
        for a, b in zip(edges[:-1], edges[1:]):
            out.append((int(a), np.cumsum(self.potential_variances(np.arange(a, b)))))
        return out

    def waves(self, draws: int, seed: int) -> dict[str, NDArray[np.float64]]:
        """Draw the random waves of ``draws`` realisations (module docstring).

        Parameters
        ----------
        draws : int
            Number of independent realisations, 1 .. 10,000.
        seed : int
            Seed of ``numpy.random.default_rng``, ≥ 0.

        Returns
        -------
        dict
            Arrays of shape ``(draws, W)``, W = waves per draw: ``degree`` (n), ``amplitude``
            (A, m²/s²), ``phase`` (rad) and ``pole`` ``(draws, W, 3)`` (unit vectors, ECEF
            axes).
        """
        d = _whole(draws, "draws", "draws")
        if not 1 <= d <= limits.MAX_DRAWS:
            raise InputError(
                Keyword("draws"), f" must be within 1..{limits.MAX_DRAWS}, got {d}", param="draws"
            )
        s = _whole(seed, "seed", "seed")
        if s < 0:
            raise InputError(
                Keyword("seed"), f" must be a non-negative whole number, got {s}", param="seed"
            )
        bands = self._bands()
        K = WAVES_PER_BAND
        W = K * len(bands)
        u = np.random.default_rng(s).random((d, W, 4))  # degree, pole z, pole azimuth, phase
        degree = np.empty((d, W))
        amplitude = np.empty((d, W))
        for b, (first, cum) in enumerate(bands):
            k = slice(b * K, (b + 1) * K)
            total = cum[-1]
            idx = np.searchsorted(cum, u[:, k, 0] * total, side="right")
            degree[:, k] = first + np.minimum(idx, cum.size - 1)
            amplitude[:, k] = math.sqrt(2.0 * total / K)
        z = 2.0 * u[..., 1] - 1.0
        rho = np.sqrt(np.maximum(0.0, 1.0 - z * z))
        az = 2.0 * np.pi * u[..., 2]
        pole = np.stack([rho * np.cos(az), rho * np.sin(az), z], axis=-1)
        return {
            "degree": degree,
            "amplitude": amplitude,
            "phase": 2.0 * np.pi * u[..., 3],
            "pole": pole,
        }

    def realise(
        self,
        lat: ArrayLike,
        lon: ArrayLike,
        h: ArrayLike,
        draws: int,
        seed: int,
        *,
        device: str | None = None,
    ) -> NDArray[np.float64]:
        """Realisations of the omitted gravity disturbance vector at points.

        One independent random field per draw, consistent in 3-D for any set of points (a
        track, a grid, several tracks: the field is defined everywhere). The same inputs give
        the same bits whatever the number and order of the other points.

        Parameters
        ----------
        lat, lon : array_like
            Latitude and longitude (broadcast with ``h``), used as spherical coordinates.
            Units: degrees.
        h : array_like
            Height above the ellipsoid; r = R + h. Units: m.
        draws : int
            Number of realisations, 1 .. 10,000.
        seed : int
            Seed of ``numpy.random.default_rng`` (≥ 0).
        device : str, optional
            Warp device of the kernel (:mod:`fieldmap.kernels.omission`; default: the first
            CUDA device, else the CPU, every core).

        Returns
        -------
        numpy.ndarray
            Shape ``(draws, npoints, 3)``: δg north, east, down. Units: m/s².
        """
        import warp as wp

        from fieldmap import _warp
        from fieldmap.kernels import omission as kom

        la, lo, hh = (np.ravel(v) for v in limits.check_geodetic(lat, lon, h))
        waves = self.waves(draws, seed)
        dev = _warp.resolve_device(device)
        nd = waves["degree"].shape[0]
        out = np.empty((nd, la.size, 3))
        if la.size == 0:
            return out
        wv: dict[str, Any] = {
            k: wp.array(waves[k], dtype=wp.vec3d if k == "pole" else wp.float64, device=dev)
            for k in ("degree", "amplitude", "phase", "pole")
        }
        phi, lam = np.radians(la), np.radians(lo)
        sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
        frame = {
            "unit": np.stack([cp * cl, cp * sl, sp], axis=-1),
            "north": np.stack([-sp * cl, -sp * sl, cp], axis=-1),
            "east": np.stack([-sl, cl, np.zeros_like(sl)], axis=-1),
        }
        r = self.radius + hh
        step = max(1, _CHUNK // nd)  # points per launch: draws x points threads stay int32
        for i in range(0, la.size, step):
            k = slice(i, i + step)
            m = len(range(*k.indices(la.size)))
            ins: list[Any] = [wp.array(frame[c][k], dtype=wp.vec3d, device=dev) for c in frame]
            ins += [
                wp.array(np.log(self.radius / r[k]), dtype=wp.float64, device=dev),
                wp.array(1.0 / r[k], dtype=wp.float64, device=dev),
            ]
            res = wp.zeros((nd, m), dtype=wp.vec3d, device=dev)
            args = [*ins, wv["degree"], wv["amplitude"], wv["phase"], wv["pole"], m, res]
            _warp.launch_chunked(kom.wave_sum, nd * m, args, dev)
            out[:, k] = res.numpy()
        return out


#: variables of the ``omission-sigma`` map (:func:`grid_omission`)
GRID_VARIABLES = (
    "omission_sigma_north",
    "omission_sigma_east",
    "omission_sigma_down",
    "omission_sigma_modulus",
)


def grid_omission(
    model: SHModel, heights: ArrayLike, shape: tuple[int, int], kind: str
) -> dict[str, NDArray[np.float64]]:
    """σ of the omission above ``model``'s degree on a grid: {variable: (nh, nlat, nlon)}, mGal.

    The field is isotropic, so σ depends on the height only (spherical approximation,
    :meth:`Omission.sigma`); the modulus is the root of the three variances summed.
    """
    sig = Omission(model.lmax, kind, model=model).sigma(heights) * MGAL  # (nh, 3)
    cols = (sig[:, 0], sig[:, 1], sig[:, 2], np.sqrt(np.sum(sig * sig, axis=1)))
    return {
        name: np.broadcast_to(col[:, None, None], (col.size, *shape)).copy()
        for name, col in zip(GRID_VARIABLES, cols)
    }
