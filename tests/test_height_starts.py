"""A long run of wrong altitudes at a log's end does not pull the landing up (issue 34).

``quickstart_398564`` (a corpus piece: an Air France airliner landing at Paris-CDG, one row a
second) descends to the runway by line 1350. Its altitude column holds 144 m (475 ft) for
12 s from line 1329 while its vertical rate reports a descent of 3.6-3.9 m/s, then reads
106 m and the runway's 75.6 m (100 ft) to line 1350. From line 1341 its position, ground
speed and vertical rate are frozen, and from line 1351 its altitude column reads 7,950 ft for
6 s, then 35,000 ft: a transponder's stale values. From line 1369 every value repeats the
row before (a frozen end: no measurement, not flown).

Started from the least-squares path (every fix an inlier, the heights' σ annealed wide), the
smoother's EM took the stale altitudes for the path's and the 140 s of approach before them
for faults: 97 altitudes 10 km up outweighed, in squares, the 240 fixes of the approach. The
path climbed from 630 m to 2,470 m while the aircraft landed (1.8 km above the log's heights;
75 % of its fixes before line 1341 within 3σ). The height is now also started from the Huber
M-estimate (convex: a run of glitches, however far off, pulls it with a bounded force per
sample; :meth:`fieldmap.nav.logs.motion.AxisSmoother.huber_weights`), and of the two
solutions the likelier under the mixture, compared at one set of noise levels, is kept
(:func:`fieldmap.nav.logs.condition._height`): it flies the approach and the landing at the
log's heights and rejects the stale altitudes. Until the frozen end was trimmed, the path
also flew level through the held 144 m and on, 41-90 m above the runway, climbing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fieldmap.nav.logs import load_flight
from fieldmap.nav.logs.read import read_track

PIECE = Path(__file__).parent / "data" / "corpus" / "quickstart" / "quickstart_398564.csv.gz"
HELD_LINE = 1329  # the altitude column holds 144 m from here, in the descent
STALE_LINE = 1351  # the first stale airborne altitude after the touchdown
FROZEN_LINE = 1369  # every value repeats the row before from here to the end
TOUCHDOWN = (1344, 1350)  # the runway's altitude, 100 ft


@pytest.fixture(scope="module")
def flown():
    _, cf = load_flight(PIECE, height_ref="pressure")
    log = read_track(PIECE, height_ref="pressure", alt_units="ft")
    s = cf.samples
    off = np.interp(log.t, s.t_start + s.t, s.h) - log.h
    return cf, log, off


def test_the_approach_and_landing_are_flown_at_the_logs_heights(flown):
    """The approach within 3σ at ≥ 99 % of its fixes, the touchdown at every fix.

    Within 3σ of the fit's own height σ; the 12 s of a held altitude descended through.

    75 % of the approach from the least-squares start alone (flown up to 1.8 km too high);
    the touchdown 73-90 m above the runway, climbing, before the frozen end was trimmed.
    """
    cf, log, off = flown
    s = cf.samples
    sigma = max(cf.report["channels"]["height"]["noise_sigma"], 1.0)
    approach = log.lines < HELD_LINE
    within = np.mean(np.abs(off[approach]) <= 3.0 * sigma)
    worst = int(np.argmax(np.abs(off[approach])))
    assert within >= 0.99, (
        f"{100 * within:.1f} % within 3σ ({sigma:.1f} m); worst {off[approach][worst]:.0f} m "
        f"at line {log.lines[approach][worst]}"
    )
    touchdown = (log.lines >= TOUCHDOWN[0]) & (log.lines <= TOUCHDOWN[1])
    assert np.all(np.abs(off[touchdown]) <= 3.0 * sigma), off[touchdown]
    held = (log.lines >= 1336) & (log.lines <= 1340)  # below the held value, descending
    vz = np.interp(log.t[held], s.t_start + s.t[1:], np.diff(s.h) / np.diff(s.t))
    assert np.all(off[held] < 0.0) and np.all(vz < -3.0), (off[held], vz)


def test_the_stale_altitudes_are_rejected_and_little_else(flown):
    """The stale airborne altitudes up to the frozen end, and no more than 2 % of the log besides.

    426 of its 1,452 heights were rejected from the least-squares start alone.
    """
    cf, log, _ = flown
    stale = np.sum((log.lines >= STALE_LINE) & (log.lines < FROZEN_LINE))
    assert stale == 18
    rejected = cf.report["channels"]["height"]["rejected"]
    assert stale <= rejected <= stale + 0.02 * log.t.size, rejected


def test_the_frozen_end_is_trimmed_and_reported(flown):
    """From line 1369 every value repeats the row before: not flown, the rows named."""
    cf, log, _ = flown
    s = cf.samples
    last = log.t[log.lines == FROZEN_LINE - 1][0]
    assert s.t_start + s.t[-1] == pytest.approx(last)
    (note,) = [n for n in cf.report["notes"] if "the log froze there" in n]
    assert f"lines {FROZEN_LINE}..{log.lines[-1]}" in note
    assert np.all(cf.raw["status"][cf.raw["lines"] >= FROZEN_LINE] == 5)  # trimmed


def _axis(y: np.ndarray, t: np.ndarray, fault_density: float, held=None, cell: float = 0.0):
    from fieldmap.nav.logs.motion import AxisSmoother, Channel, Grid, MotionModel

    ch = Channel(t, y[:, None], np.ones(t.size), 0, 1, fault_density, "height", False, held, cell)
    grid = Grid(0.0, 1.0, int(t.max()) + 2)
    model = MotionModel(tau_s=20.0, beta=0.01)
    return AxisSmoother(grid, model, [ch], (1e-12, 1.0), [(0.01, 100.0)])


def test_the_mixture_likelihood_is_each_samples_mixture_density():
    """Against scipy's normal density, at the path's Taylor rows computed here."""
    from scipy.stats import norm

    rng = np.random.default_rng(3)
    t = np.arange(60.0) + 0.3
    y = 50.0 + 0.5 * t + rng.standard_normal(t.size)
    y[[10, 40]] += 300.0
    sm = _axis(y, t, 1.0 / 400.0)
    x, _, _ = sm.solve(0.01, [1.5], [np.ones(t.size)])
    k = np.rint(t).astype(int)
    d = t - k
    path = x[k, 0, 0] + d * x[k, 1, 0] + 0.5 * d * d * x[k, 2, 0]
    eps, s = 0.05, 1.5
    expect = np.sum(np.log(eps / 400.0 + (1.0 - eps) * norm.pdf(y, path, s)))
    assert sm.mixture_loglik(x, [s], [eps]) == pytest.approx(expect, rel=1e-12)


def test_the_mixture_likelihood_counts_a_repeat_as_a_copy_or_a_fresh_value():
    """A repeated value: fault, fresh with (1 − η) or copy, η/c per unit of the value."""
    from scipy.stats import norm

    rng = np.random.default_rng(5)
    t = np.arange(80.0)
    y = np.round(20.0 + 0.2 * t + 0.8 * rng.standard_normal(t.size))  # printed to 1 m
    held = np.r_[False, y[1:] == y[:-1]]
    assert 5 < held.sum() < 60
    sm = _axis(y, t, 1.0 / 300.0, held=held, cell=1.0)
    eta, eps, s = 0.3, 0.02, 0.9
    sm.held_rates = [eta]
    x, _, _ = sm.solve(0.01, [s], [np.ones(t.size)])
    path = x[np.rint(t).astype(int), 0, 0]
    fresh = (1.0 - eps) * np.where(held, 1.0 - eta, 1.0) * norm.pdf(y, path, s)
    copy = np.where(held, (1.0 - eps) * eta / 1.0, 0.0)
    expect = np.sum(np.log(eps / 300.0 + fresh + copy))
    assert sm.mixture_loglik(x, [s], [eps]) == pytest.approx(expect, rel=1e-12)


def test_held_noise_levels_stay_as_given():
    """``run(hold_noise=True)``: the E-steps move the path and the weights, not q or the σ."""
    rng = np.random.default_rng(6)
    t = np.arange(120.0)
    y = 300.0 + 0.1 * t + 1.5 * rng.standard_normal(t.size)
    y[50:60] += 400.0
    sm = _axis(y, t, 1.0 / 1000.0)
    out = sm.run(0.003, [1.7], hold_noise=True)
    assert out.q == 0.003 and out.scales == [1.7]
    assert np.all(out.fault_prob[0][50:60] > 0.5)
    free = _axis(y, t, 1.0 / 1000.0).run(0.003, [1.7])
    assert free.q != 0.003 and free.scales != [1.7]


def test_the_huber_start_is_the_huber_location_for_a_level_path():
    """A path nearly level (a faint jerk): the Huber M-estimate of its level.

    Against scipy's minimisation of Huber's loss over one level (k = 1 σ): two runs of
    glitches 2 km up (a quarter of the samples) move it by less than 1 σ, where least
    squares moves it by 500 m.
    """
    from scipy.optimize import minimize_scalar

    from fieldmap.nav.logs.motion import HUBER_K

    rng = np.random.default_rng(4)
    t = np.arange(200.0)
    y = 1000.0 + 2.0 * rng.standard_normal(t.size)
    y[20:45] += 2000.0
    y[150:175] += 2000.0
    s = 2.0

    def loss(level: float) -> float:
        z = np.abs(y - level) / s
        return float(np.sum(np.where(z <= HUBER_K, 0.5 * z * z, HUBER_K * z - 0.5 * HUBER_K**2)))

    expect = minimize_scalar(
        loss, bounds=(900.0, 1200.0), method="bounded", options={"xatol": 1e-9}
    ).x
    sm = _axis(y, t, 1.0 / 4000.0)
    w = sm.huber_weights(1e-9, [s])
    x, _, _ = sm.solve(1e-9, [s], w)
    level = x[np.rint(t).astype(int), 0, 0]
    assert abs(expect - 1000.0) < s
    # the path wanders by a few hundredths of σ at this jerk (it is not held exactly level)
    np.testing.assert_allclose(level, expect, atol=0.2 * s)
