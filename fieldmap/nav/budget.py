r"""The gravity model's share of a navigation error: three terms, through the linear error model.

A navigator flying with gravity model m is in error by g_m − g_real, and the real field is the
truth model plus what the truth model lacks:

.. math::
    g_m - g_\mathrm{real} = \underbrace{(g_m - g_\mathrm{truth})}_{(a)}
        - \underbrace{\delta g_\mathrm{omission}}_{(b)}
        - \underbrace{\delta g_\mathrm{commission}}_{(c)} .

* (a) the **model difference**, deterministic: the navigation model against the truth model
  (degree L) at the true track points;
* (b) the **omission**: the field above degree L, an isotropic random field of a degree-variance
  model (:class:`fieldmap.field.omission.Omission`: Tscherning–Rapp 1974 model 4, Kaula's rule,
  or a power law fitted to the truth's own degrees), realised along the 3-D track;
* (c) the **commission**: the truth model's coefficient errors (its σ), realised as random
  coefficient sets synthesised by the point engine
  (:func:`fieldmap.field.commission.commission_draws`).

Each term is flown through the linear error model of :mod:`fieldmap.nav.linear` (the INS's
position error driven by a gravity error along the true path, the Schuler, vertical and
Earth-rate modes and the baro loop included). Being linear, the contributions add draw by draw,
the truth model's own (a) is exactly zero, and no term drowns in the spread of the IMU's
nonlinear error (the Monte Carlo "added" error of two nonlinear runs, still reported beside it,
carries that spread). (b) and (c) are the same for every navigation model: they are the part of
the real field the truth model does not hold, which no model built from it can supply.

(b) and (c) are realised :data:`GRAVITY_DRAWS` times at least (a draw costs a synthesis along
the track and one linear pass, not a strapdown run), so their RMS is good to about 1/√(2·draws).
Both are synthesised at :func:`path_nodes` along the path, an eighth of their shortest
wavelength apart (the truth's 2πR/L for (c); for (b) the one :func:`omission_spacing` finds at
each point's height), and interpolated by a cubic spline in time: a cubic between nodes
λ/8 apart errs by about 1e-3 of the term.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from fieldmap.field.ellipsoid import Ellipsoid
from fieldmap.models.shmodel import SHModel
from fieldmap.nav.gravity import NORMAL_MODELS, sh_degree, table_file
from fieldmap.nav.imu import Gravitation
from fieldmap.nav.linear import position_response

__all__ = [
    "GRAVITY_DRAWS", "GravityBudget", "GravityInputs", "GravityTerms", "gravity_budget",
    "gravity_error_along", "gravity_inputs",
    "omission_spacing", "path_nodes", "recommend", "simplicity_order",
]  # fmt: skip

#: fewest realisations of the omission and commission terms
GRAVITY_DRAWS = 32
#: fewest and most points along the path at which the omission and commission are synthesised
PATH_NODES = (16, 4000)
TERMS = ("model_difference", "omission", "commission")
#: words of each term in a recommendation
TERM_WORDS = {
    "model_difference": "the model's difference from the truth model",
    "omission": "the field above degree {L} (omission)",
    "commission": "the truth model's coefficient errors (commission)",
}


@dataclass(frozen=True)
class GravityTerms:
    """The gravity-error terms a study flies besides the model difference (resolved, trusted).

    ``omission`` the field above the truth's degree (an
    :class:`~fieldmap.field.omission.Omission`) or None; ``commission`` whether the truth's
    coefficient errors are realised; ``draws`` realisations of each; ``seed`` of the first
    (the commission uses ``seed + 1``).
    """

    omission: Any
    commission: bool
    draws: int
    seed: int


@dataclass
class GravityBudget:
    """Position errors (NED, m, at the study's output times) of each gravity term.

    ``model_difference`` {model: (n, 3)}, deterministic; ``omission`` and ``commission``
    (draws, n, 3) or None when the term is off; ``draws`` their realisations; ``omission_sigma``
    (n, 3) the omission's σ of δg along the track (m/s², north/east/down) or None.
    """

    model_difference: dict
    omission: np.ndarray | None
    commission: np.ndarray | None
    draws: int
    omission_sigma: np.ndarray | None = None

    def total(self, model: str) -> np.ndarray:
        """(draws, n, 3): the model's whole gravity contribution, draw by draw (a − b − c)."""
        tot = np.broadcast_to(self.model_difference[model], (self.draws,) + self.shape).copy()
        for x in (self.omission, self.commission):
            if x is not None:
                tot -= x
        return tot

    def curves(self, model: str) -> np.ndarray:
        """(4, n, 3): the RMS over draws of the total, (a), (b) and (c) (NaN: a term off).

        The total is the root sum of the terms' mean squares (see :meth:`summary`); (a), being
        deterministic, is its magnitude.
        """
        a = np.abs(self.model_difference[model])
        terms = [a] + [
            None if x is None else np.sqrt(np.mean(x * x, axis=0))
            for x in (self.omission, self.commission)
        ]
        total = np.sqrt(sum(x * x for x in terms if x is not None))
        b, c = (np.full(self.shape, np.nan) if x is None else x for x in terms[1:])
        return np.stack([total, a, b, c])

    @property
    def shape(self) -> tuple[int, int]:
        """(n, 3) of one term's error curve."""
        return next(iter(self.model_difference.values())).shape

    def summary(self, model: str, at: int = -1) -> dict[str, Any]:
        """Return each term's final horizontal and vertical contribution (RMS over draws), m.

        ``at``: the output index (default the last; an aided study: the end of an outage).

        ``horizontal_m``/``vertical_m``: the whole contribution, the root sum of the terms'
        mean squares (the expected RMS of a − b − c); ``dominant``: the largest horizontal term.
        """

        def rms(x: np.ndarray | None, comp: slice) -> float | None:
            if x is None:
                return None
            f = np.asarray(x)[..., at, comp]
            return float(np.sqrt(np.mean(np.sum(f * f, axis=-1))))

        doc: dict[str, Any] = {}
        for name, comp in (("horizontal", slice(0, 2)), ("vertical", slice(2, 3))):
            terms = {
                "model_difference": rms(self.model_difference[model], comp),
                "omission": rms(self.omission, comp),
                "commission": rms(self.commission, comp),
            }
            # the terms are independent and (b), (c) zero-mean: their mean squares add (the
            # draw-by-draw total would add the sample cross terms of a few dozen draws)
            doc[f"{name}_m"] = float(np.sqrt(sum(v * v for v in terms.values() if v is not None)))
            doc[f"{name}_terms_m"] = terms
        h = doc["horizontal_terms_m"]
        doc["dominant"] = max((t for t in TERMS if h[t] is not None), key=lambda t: h[t])
        return doc


def path_nodes(track: np.ndarray, spacing: Any) -> np.ndarray:
    """Return indices of track points about ``spacing`` apart along the path.

    ``spacing`` (m): one number, or one per track point (denser where it is smaller: the
    omission near the ground, sparser at altitude). The first and last points always included,
    within :data:`PATH_NODES`; every point when the track has fewer.
    """
    from fieldmap.field.frames import geodetic_to_ecef

    r = np.stack(geodetic_to_ecef(track[:, 0], track[:, 1], track[:, 2]), -1)
    ds = np.linalg.norm(np.diff(r, axis=0), axis=1)
    sp = np.broadcast_to(np.asarray(spacing, dtype=np.float64), (track.shape[0],))
    # node coordinate: path length in units of the local spacing (smaller of the two ends)
    u = np.concatenate([[0.0], np.cumsum(ds / np.minimum(sp[1:], sp[:-1]))])
    lo, hi = PATH_NODES
    k = int(np.clip(np.ceil(u[-1]) + 1, lo, hi))
    if k >= track.shape[0]:
        return np.arange(track.shape[0])
    idx = np.searchsorted(u, np.linspace(0.0, u[-1], k))
    idx[-1] = track.shape[0] - 1
    return np.unique(np.clip(idx, 0, track.shape[0] - 1))


def omission_spacing(omission: Any, height: Any) -> np.ndarray:
    """Return an eighth of the shortest wavelength that matters in the omission at ``height``.

    In m, for each height (m): the wavelength 2πR/n_q of the degree n_q below which 99.9 % of
    the omitted δg variance at that height lies (the attenuation (R/r)^(2n+2) sets it: tens of
    km at airliner heights, a few km near the ground). Computed on a table of 24 heights
    (geometric from 0 to the highest) and interpolated, never above the table's value at the
    next lower height.
    """
    h = np.maximum(np.atleast_1d(np.asarray(height, dtype=np.float64)), 0.0)
    levels = np.unique(np.concatenate([[0.0], np.geomspace(10.0, max(h.max(), 10.0) + 1.0, 23)]))
    n = omission.degrees
    c = omission.potential_variances(n) * ((n + 1.0) ** 2 + n * (n + 1.0))
    out = np.empty(levels.size)
    for i, z in enumerate(levels):
        w = c * np.exp((2.0 * n + 2.0) * np.log(omission.radius / (omission.radius + z)))
        cum = np.cumsum(w)
        nq = float(n[min(int(np.searchsorted(cum, 0.999 * cum[-1])), n.size - 1)])
        out[i] = 2.0 * np.pi * omission.radius / nq / 8.0
    # the spacing grows with height: take the table's value at the level at or below each height
    j = np.clip(np.searchsorted(levels, h, side="right") - 1, 0, levels.size - 1)
    return np.asarray(out[j])


def _at_nodes(t: np.ndarray, idx: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Values (…, k, 3) at the nodes ``idx`` of ``t`` → at every t (cubic spline in time)."""
    if idx.size == t.size:
        return values
    from scipy.interpolate import CubicSpline

    return np.asarray(CubicSpline(t[idx], values, axis=-2)(t))


def gravity_budget(
    t: np.ndarray,
    track: np.ndarray,
    dg: dict[str, np.ndarray],
    truth: SHModel,
    terms: Any,
    ellipsoid: Ellipsoid,
    baro_gains: tuple[float, float, float] | None = None,
    device: str | None = None,
) -> GravityBudget:
    """Fly each gravity term through the linear error model along the true track.

    Parameters
    ----------
    t, track : numpy.ndarray
        Output times (n,) in s and the true lat, lon, h (n, 3) there (deg, deg, m).
    dg : dict
        {model: (n, 3)} the model difference g_model − g_truth, NED, m/s².
    truth : SHModel
        The truth model (degree L; its σ for the commission).
    terms : GravityTerms
        Which terms, with what (validated by the study): ``omission`` (an
        :class:`~fieldmap.field.omission.Omission` or None), ``commission`` (bool), ``draws``
        and ``seed``.
    ellipsoid : Ellipsoid
        Of the track.
    baro_gains : (k1, k2, k3), optional
        The baro loop's gains when the vertical channel is aided.
    device : str, optional
        Warp device of the commission synthesis.
    """
    inp = gravity_inputs(t, track, dg, truth, terms, ellipsoid, device)
    return inp.budget(position_response(t, track, inp.stack, ellipsoid, baro_gains))


@dataclass
class GravityInputs:
    """The gravity errors a budget flies (NED, m/s², at the output times), stacked.

    ``stack`` (k, n, 3): the models' differences (``names``), then the omission's and the
    commission's draws (``n_om``, ``n_cm`` of them, 0 when off); ``draws`` per term;
    ``omission_sigma`` (n, 3) or None.
    """

    stack: np.ndarray
    names: list
    n_om: int
    n_cm: int
    draws: int
    omission_sigma: np.ndarray | None

    def budget(self, resp: np.ndarray) -> GravityBudget:
        """Return the :class:`GravityBudget` of the responses ``resp`` (k, n, 3) to ``stack``."""
        k = len(self.names)
        diff = {m: resp[i] for i, m in enumerate(self.names)}
        b = resp[k : k + self.n_om] if self.n_om else None
        k += self.n_om
        c_ = resp[k : k + self.n_cm] if self.n_cm else None
        return GravityBudget(diff, b, c_, self.draws, self.omission_sigma)


def gravity_inputs(
    t: np.ndarray,
    track: np.ndarray,
    dg: dict[str, np.ndarray],
    truth: SHModel,
    terms: Any,
    ellipsoid: Ellipsoid,
    device: str | None = None,
) -> GravityInputs:
    """Realise the gravity terms of :func:`gravity_budget` along the track (its parameters)."""
    names = list(dg)
    inputs = [np.asarray(dg[m]) for m in names]
    n_g = int(terms.draws)
    om = cm = sig = None
    if terms.omission is not None:
        idx = path_nodes(track, omission_spacing(terms.omission, track[:, 2]))
        lat, lon, h = track[idx, 0], track[idx, 1], track[idx, 2]
        om = _at_nodes(t, idx, terms.omission.realise(lat, lon, h, n_g, terms.seed, device=device))
        sig = _at_nodes(t, idx, terms.omission.sigma(h))
    if terms.commission:
        from fieldmap.field.commission import commission_draws

        idx = path_nodes(track, 2.0 * np.pi * truth.radius / max(int(truth.lmax), 1) / 8.0)
        c = commission_draws(
            truth, track[idx, 0], track[idx, 1], track[idx, 2], n_g, terms.seed + 1,
            ellipsoid, device,
        )  # fmt: skip
        cm = _at_nodes(t, idx, c)
    for term in (om, cm):
        if term is not None:
            inputs.extend(term)
    return GravityInputs(
        np.stack(inputs), names, 0 if om is None else n_g, 0 if cm is None else n_g, n_g, sig
    )


def simplicity_order(models: Any) -> list[str]:
    """Models from the simplest to the most complete: j2, j4, j6, exact, tables, shN, sh.

    A compensation table (a look-up a flight computer interpolates) counts as simpler than
    real-time spherical harmonics; tables among themselves keep their order.
    """

    def key(m: str) -> tuple[int, int]:
        if m in NORMAL_MODELS:
            return (0, NORMAL_MODELS.index(m))
        if table_file(m) is not None:
            return (1, 0)
        d = sh_degree(m)
        return (2, 10**9 if d is None else d)

    return sorted(models, key=key)


def gravity_error_along(
    track: Any,
    t: np.ndarray,
    names: list[str],
    model: SHModel,
    ell: Ellipsoid,
    device: str | None = None,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """δg = g_model − g_truth (NED, m/s²) at the track points and its double time integral.

    Returns two dicts keyed by model: δg (n, 3) and the predicted north/east position error
    (n, 2) in m (cumulative trapezoid twice, zero at t[0]).
    """
    from scipy.integrate import cumulative_trapezoid

    from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef

    r = np.stack(geodetic_to_ecef(track[:, 0], track[:, 1], track[:, 2], ell), -1)
    enu = C_e_to_enu(track[:, 0], track[:, 1])
    to_ned = lambda g: np.einsum("nij,nj->ni", enu, g)[:, [1, 0, 2]] * [1, 1, -1]  # noqa: E731
    g_true = to_ned(Gravitation("sh", model=model, device=device, ellipsoid=ell)(r))
    dg, pred = {}, {}
    for m in names:
        path = table_file(m)
        if path is not None:
            from fieldmap.nav.gravity import table_gravitation
            from fieldmap.products.tables.model import load_table

            tab = load_table(path)
            g_nav = table_gravitation(tab, *r.T, ellipsoid=ell, device=device)
        elif m in NORMAL_MODELS:
            g_nav = Gravitation(m, device=device, ellipsoid=ell)(r)
        else:
            from fieldmap.nav.gravity import parse_gravity

            lmax = parse_gravity(m, model)[1]
            g_nav = Gravitation("sh", model=model, lmax=lmax, device=device, ellipsoid=ell)(r)
        dg[m] = to_ned(g_nav) - g_true
        v = cumulative_trapezoid(dg[m][:, :2], t, axis=0, initial=0.0)
        pred[m] = cumulative_trapezoid(v, t, axis=0, initial=0.0)
    return dg, pred


def recommend(
    doc: dict[str, Any], order: list[str], imu_h: float, fraction: float, budget: bool, degree: Any
) -> None:
    """Set ``recommended_model``, ``recommendation`` (and the gravity floor) of a summary.

    ``doc["models"]`` holds each model's entry (``diverged``, and ``gravity`` from the budget
    or the Monte Carlo ``added_horizontal_error_m``); ``order`` the models from the simplest;
    ``imu_h`` the IMU's own horizontal error (m); ``degree`` the truth's, for the wording.
    """
    models = doc["models"]

    def cost(m: str) -> float:
        e = models[m]
        return float(e["gravity"]["horizontal_m"] if budget else e["added_horizontal_error_m"])

    ok = [m for m in order if not models[m].get("diverged") and cost(m) <= fraction * imu_h]
    what = "gravity contributes" if budget else "adds"
    if ok:
        pick = ok[0]
        doc["recommended_model"] = pick
        doc["recommendation"] = (
            f"{pick}: {what} {cost(pick):.3g} m horizontal error, below {fraction:.0%} of the "
            f"IMU-only {imu_h:.3g} m"
        )
    else:
        pick = min(order, key=cost)
        doc["recommended_model"] = None
        doc["recommendation"] = (
            f"no model stays below {fraction:.0%} of the IMU-only error ({imu_h:.3g} m); the "
            f"smallest {'gravity contribution' if budget else 'added error'} is "
            f"{pick}'s, {cost(pick):.3g} m"
        )
    if not budget:
        return
    g = models[pick]["gravity"]
    dom = g["dominant"]
    words = TERM_WORDS[dom].format(L=degree)
    terms = g["horizontal_terms_m"]
    parts = ", ".join(f"{t.replace('_', ' ')} {v:.3g} m" for t, v in terms.items() if v is not None)
    doc["recommendation"] += f" ({parts}). {words[0].upper()}{words[1:]} dominates"
    if dom != "model_difference" and not ok:
        doc["recommendation"] += (
            f": no model of degree <= {degree} can do better; a higher-degree model, or a table "
            "built from one, is needed"
        )
    doc["recommendation"] += "."
    floor = [terms[t] for t in ("omission", "commission") if terms[t] is not None]
    doc["gravity_floor_horizontal_m"] = float(np.sqrt(sum(v * v for v in floor))) if floor else 0.0
