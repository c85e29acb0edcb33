r"""The vehicle's motion as a state-space model, and its robust smoother over a whole log.

One model carries the conditioning of every flight log (:mod:`fieldmap.nav.logs.condition`).

**Motion.** Each axis of the path (the three ECEF axes of the horizontal position's surface
point, and the height) is a Singer (1970) manoeuvre model with a damped velocity:

.. math::

    \dot p = v, \qquad \dot v = a - \beta v, \qquad \dot a = -a/\tau + w(t),
    \qquad \mathrm E[w(t)\,w(s)] = q\,\delta(t - s),

the acceleration a first-order Gauss–Markov process of correlation time :math:`\tau` (the
duration of a manoeuvre) and stationary standard deviation :math:`\sigma_a = \sqrt{q\tau/2}`,
driven by white jerk of intensity :math:`q` (m²/s⁵). Horizontally :math:`\beta = 0` (a vehicle
holds its speed); vertically :math:`\beta = 1/\tau_v` makes the vertical speed stationary too:
over a long gap the expected climb decays to zero instead of integrating into invented height
swings (Singer 1970; Bar-Shalom, Li & Kirubarajan 2001 §8.2). On a regular grid of step
:math:`\Delta` the states :math:`x_k = (p, v, a)_k` follow :math:`x_{k+1} = F x_k + e_k`,
:math:`e_k \sim N(0, Q)`, with :math:`F = e^{A\Delta}` and
:math:`Q = \int_0^\Delta e^{As} G q G^\top e^{A^\top s} ds` (Van Loan 1978), both from one
matrix exponential (:meth:`MotionModel.transition`).

**Manoeuvres.** A vehicle flies level for minutes, then pulls up, levels off or pushes over
within seconds: a jerk of one intensity all flight long either lags the manoeuvres by tens of
metres or flies the fixes' noise in between. The height's jerk is heavy-tailed instead, a
Student-t scale mixture (Lange, Little & Taylor 1989): step :math:`k` of the grid has
:math:`e_k \sim N(0, Q/\lambda_k)`, :math:`\lambda_k \sim \mathrm{Gamma}(\nu/2, \nu/2)`,
and the EM expectation

.. math::

    \lambda_k = \frac{\nu + p}{\nu + \mathrm E[m_k]}, \qquad
    \mathrm E[m_k] = \hat e_k^\top Q^{-1} \hat e_k + \mathrm{tr}(Q^{-1}\Sigma_{e_k}),
    \qquad e_k = x_{k+1} - F x_k,

(:math:`p` = 3 the step's degrees of freedom; :math:`\hat e_k` at the smoothed path,
:math:`\Sigma_{e_k}` its posterior covariance, from the blocks of :math:`A^{-1}` beside the
diagonal: a selected inversion, :func:`_block_covariances`) weights each step of the process
term of :math:`J` below (:meth:`AxisSmoother.manoeuvres`). :math:`\nu` = 1
(:data:`VERTICAL_JERK_DOF`): a Cauchy jerk, for manoeuvres that are rare and brief. The noise
levels are those of the Gaussian model (:math:`\lambda = 1`): heavy tails in both the jerk and
the fixes' noise make the likelihood unbounded as the noise vanishes (the path would fly
every fix exactly). The weights are estimated on the estimation grid, as coarse as the fixes
(a manoeuvre is resolved no finer than the data resolve it), by :data:`MANOEUVRE_STEPS`
EM steps, and carried to the output grid. Horizontally the jerk stays Gaussian: ADS-B
positions scatter by tens of metres, and a heavy-tailed horizontal jerk flies that scatter
as manoeuvres (tried on the corpus: the calibration flights at 1.5–3 × their reported speed).

**Mean acceleration.** The horizontal axes follow the ECEF surface point, whose acceleration
is not zero in straight flight: following the Earth's curvature takes
:math:`a_c = -|v|^2\,\hat r/|r|` (0.01 m/s² at 250 m/s, 110 m of sag over a 5-minute gap
if it relaxed to zero). The acceleration relaxes to :math:`a_c` instead,
:math:`\dot a = -(a - a_c)/\tau + w`, a known input computed from the path itself and
updated with it (:meth:`AxisSmoother.set_mean_acceleration`): the process residual is
:math:`x_{k+1} - F x_k - B a_{c,k}` (:meth:`MotionModel.forcing`).

**Measurements.** A fix at time :math:`t_i = t_k + \delta` (:math:`|\delta| \le \Delta/2`, the
nearest node) measures :math:`y_i = h_i^\top x_k + \varepsilon_i` with
:math:`h = (1, \delta, \delta^2/2)` for a position and :math:`(0, 1, \delta)` for a rate
(the log's ground velocity or vertical rate); :math:`\varepsilon_i` is drawn from a mixture:
with probability :math:`1 - \epsilon` the channel's noise :math:`N(0, s^2 \rho_i^2)` (scale
:math:`s` estimated, :math:`\rho_i` known, 1 for every channel a log gives), with
probability :math:`\epsilon` a fault, uniform over the range the log spans (a fix from
elsewhere, a glitch, a stretch with wrong time tags).

**Held values.** A sample whose printed value repeats the one before it exactly is either a
new measurement that happens to fall in the same printed cell, or the earlier value sent
again (a log resampled to a clock and filled forward, a receiver that holds its last rate
while it has none): a copy, which says nothing of the path at its own time. Its measurement
is a three-way mixture: fault :math:`\epsilon`, copy :math:`(1 - \epsilon)\eta`, fresh
:math:`(1 - \epsilon)(1 - \eta)`. In probabilities of the printed value (the densities times
the cell :math:`c` of one printed value: the channel's resolution, to the power :math:`d_i`),
a copy repeats the value with probability 1, a fresh value with
:math:`N(y_i; h_i^\top x, s^2\rho_i^2)\,c`, a fault with :math:`f c`. So the posterior
probability that sample :math:`i` is a copy is

.. math::

    \kappa_i = \frac{(1-\epsilon)\,\eta}{\epsilon f c + (1-\epsilon)(1-\eta)\,
               N(y_i; h_i^\top x, s^2\rho_i^2)\,c + (1-\epsilon)\,\eta},

its fault probability :math:`\pi_i` the same with :math:`\epsilon f c` on top, and its
weight :math:`w_i = 1 - \pi_i - \kappa_i`; :math:`\eta` is the mean of :math:`\kappa` over the
channel's repeats (EM). A value held while the path moves on (a vertical rate repeated for
two minutes while the heights level off) is explained as copies, not as a path that follows
it; where the values are fresh (a rate held at zero in level flight, resolved within a
quarter of the noise), :math:`N c > 1` and :math:`\eta` goes to zero. A path that weighs
the repeats from the start follows a value held for minutes, and the fixes that contradict
it turn faults: a local maximum the EM does not leave (ADS-B's last airborne ground speed,
103 kt, held through a 5-minute taxi: the taxi's positions rejected, the path a 4 km loop
at 53 m/s). The horizontal EM therefore has a second start, the path of the fresh samples
alone (each repeat at weight 0: :func:`fieldmap.nav.logs.condition._horizontal`).

**Time errors.** A position stamped when its message was received or relayed, not when it
was fixed, lies along the track by its time error: fix :math:`i` measures
:math:`p(t_i + \tau_i)`, :math:`\tau_i \sim N(0, \sigma_\tau^2)`. The positions'
:math:`\sigma_\tau` is the along-track spread of their residuals beyond the across-track one,
and each fix is re-timed by its posterior mean (:meth:`AxisSmoother.retime`). A height in the
same row carries the same stamp: at its stamped time it is off by :math:`\dot z_i \tau_i`, so
its noise variance is

.. math::

    \sigma_i^2 = s^2\rho_i^2 + (\dot z_i\,\sigma_\tau)^2,

:math:`\dot z_i` the path's vertical speed there (from a solve without the term,
:attr:`Channel.time_variance`), on the rows whose position is a fix (a repeated or
interpolated position, a row sent again, has no time error that the positions measure: its
height keeps :math:`s\rho_i`). The heights' :math:`\sigma_\tau` is at least the positions'
(one message, one stamp); an altitude updated less often than its rows (held a second or two
in a climb) is older than its stamp by more, and a larger :math:`\sigma_\tau` is taken where
the heights' own mixture likelihood says so (:func:`fieldmap.nav.logs.condition.estimate`).
In level flight nothing changes; in a climb at 15 m/s, time errors of 0.5 s are 7.5 m of
noise: not faults, and not a zig-zag for the path to fly. A GNSS logger's positions and
heights show none, and keep :math:`\sigma_i = s\rho_i`. The term enters as E-steps from the
solution without it, at its noise levels (:math:`q`, :math:`s`, the steps' :math:`\lambda`)
and from its weights. Not re-estimated: with the term, :math:`s` is identified by the level
stretches alone, where an altitude held at one printed value has the same rounding error at
every sample, which the model (independent errors) reads as none: its estimate falls to its
floor (``vancouver``: 2.3 m → 1 cm, every level fix then a fault). Not started again either:
a fresh start may settle in another mode of the mixture (``noisy_time_issue``'s replayed
climb, flown at 40 m/s instead of rejected). Known defect: where the positions' σ_τ is no time
error (a tanker's turns cut between fixes a minute apart read as 17-30 s of it, the sparse
fixes' defect below), the heights carry it too, and their climbs weigh little: five CAL FIRE
pieces are flown with 96.6-99.0 % of their heights within 3 s (100 % before), and within 3σ
only with that σ. Letting the heights' own likelihood reject it fails too: with :math:`s`
held at the estimate without the term (which took up the climbs' scatter), the heights reject
the fixes' 0.2 s on 1 Hz airliners as well.

**Smoother.** The smoothed path minimises

.. math::

    J(x) = \sum_k \lambda_k (x_{k+1} - F x_k)^\top Q^{-1} (x_{k+1} - F x_k)
         + \sum_i \frac{w_i}{\sigma_i^2} (y_i - h_i^\top x_{k(i)})^2,

(:math:`\sigma_i^2 = s^2\rho_i^2`, with the time errors' term where a channel has one) whose
normal equations :math:`A x = b` are block tridiagonal (banded, 5 off-diagonals): one
banded Cholesky solve gives the Rauch–Tung–Striebel smoother's mean (Rauch, Tung & Striebel
1965; the equivalence: Bell 1994). The weights are the EM expectation of the mixture: with
:math:`\pi_i` the posterior probability that fix :math:`i` is a fault,
:math:`w_i = 1 - \pi_i` (:math:`1 - \pi_i - \kappa_i` for a repeat), and :math:`\epsilon` the
mean of :math:`\pi` (Dempster, Laird & Rubin 1977). A fix is rejected when
:math:`\pi_i > 1/2`: the fault explains it better than the path does.

**Speed.** A vehicle flies no faster than it can; where a log reports its ground speed, the
fastest speed that a measurement (a rate sample of weight over 1/2) and the path both say it
flew (per sample the smaller of the two) at all but 0.5 % of the samples (the log's robust
top speed: one report does not set it), and no less than its consecutive measured
positions require at all but 1 % of the steps (:meth:`AxisSmoother.top_speed`), is the
envelope the path keeps within, :math:`|v_k| \le V` at every node (the surface point's
velocity: its speed over the ground, all of it; a bound on its projection on the tangent plane
alone let a path held off a far stretch of fixes escape along the radius, through the Earth,
at km/s). Without it a
gap's path is the jerk's least-effort curve: a vehicle that enters a gap heading away from
where it leaves it swings out wide and catches up at speeds it never flew (a tanker turning
in a 6-minute gap at 1.3 × its top speed). Where the log's velocities are left out of the
fit (they contradict its positions: tracks off, a stretch resampled), their speeds still set
the envelope the same way (not where they are a constant factor off the positions': then they
are no speeds of the path), per sample the smaller of the reported speed and the path's. A log
of positions alone (IGC, GPX, an ADS-B table without velocity columns) reports its speeds
through them: each step between consecutive measured positions flies at its mean speed at
least, and the smaller of that and the path's speed at the step's end is a sample of the same
envelope (without it such logs were flown unbounded: of the 261 corpus pieces written without
their velocity columns, 86 flew over 1.05 × the speeds the aircraft reported, gliders at up to
2 ×). The
bounded path minimises :math:`J` over the bounded set (a convex problem:
:meth:`AxisSmoother._speed_bounded`); like the height's climb and load factor it is a bound,
not data: the likelihood and the noise levels are those of the unbounded problem. So where the
fit keeps fixes the vehicle could not have reached at that speed (a spoofed stretch of
positions, self-consistent and far away), no path within the bound passes near them: it would
only trade speed for loads (46 g on ``traffic``'s spoofing sample). A bounded path that
accelerates harder than the class's largest acceleration (the 3σ manoeuvre of its jerk bound)
and than the unbounded path is not flyable either: there the bound is not held, the path is
the unbounded one, and the report says so (:meth:`AxisSmoother._flyable`).

**Noise levels** (:math:`q`, and each channel's :math:`s`) maximise the marginal likelihood
of the data (diffuse initial state),

.. math::

    -2\log L = J(\hat x) + d\,\log\det A - d\sum_k \log\det(\lambda_k Q^{-1})
             + \sum_i w_i\,d_i \log \sigma_i^2 + \mathrm{const},

(:math:`d` axes sharing one :math:`A`, :math:`d_i` the measured degrees of freedom of fix
:math:`i`, :math:`Q^{-1}` of step :math:`k` weighted by :math:`\lambda_k`), with
:math:`q` held inside the bounds that the vehicle class gives
(:mod:`fieldmap.nav.logs.vehicles`): its process noise, not a loop that softens the result
afterwards.

Known defect: the noise levels are not converged. The EM makes two passes of E-steps and
maximisations (on the estimation grid), and from the annealed start (the positions' σ 30 ×
its first guess, where rates are measured) two passes leave the positions' σ at 60-300 m on
ADS-B logs where it converges to 5-35 m: the calibration flights' fixes are flown about
110 m off at the median (``brussels_ils``: σ 263 m, converged 25 m). Tried: passes until
every level settles to the precision it is maximised to (at most 8), horizontally: the median
offsets fell by more than 5 % on 22 of the 24 calibration flights (none rose), 31 of the 75
Swiss pieces (4 rose), 12 of the 16 featured ones (none rose); but on
``dreamliner_airfrance_39c424`` the σ converged to 1.2 m (the positions alone give the same),
and the path kept a stale fix (line 2405: 365 m from the fix 29 s before it, 11.3 km from the
one 31 s after, which are 194 m/s apart), which the speed bound could not hold: 1.85 × the
reported speed. ``belevingsvlucht``'s heights fell below 99 % within 3σ, and the EM took 45 %
longer. Not kept: a converged σ needs such a fix rejected first (the EM's weights keep it from
its first path on).

Known defect: for the surface point, :math:`d = 3` counts the radial axis in the determinants,
while :math:`d_i = 2` normalises only the measured ones; the unpaid radial term favours a
wide positions' σ. Where fixes are dense the data outweigh it; on a log with fixes far apart
in its turns (20 s, 60° of turn) the σ is not identified by the data and goes to its ceiling
(CAL FIRE tankers: about 1 km, the path hundreds of metres off the fixes). Counting the
measured axes alone sends it to its floor instead. What is missing: a prior on σ from the
sensor's accuracy, and a model that holds a turn (a sustained 4-7 m/s² orbit costs the
zero-mean acceleration, relaxing in τ, more than rejecting fixes does);
``tests/test_position_noise.py`` records it.

**Uncertainty.** The posterior covariance is :math:`A^{-1}`; the σ of the path at a node (in a
gap, say) is one banded solve with a unit vector (:meth:`SmoothedAxis.sigma_at`).

References: Singer, R. A. (1970) IEEE Trans. AES 6, 473-483. Van Loan, C. F. (1978) IEEE Trans.
AC 23, 395-404. Rauch, H. E., Tung, F. & Striebel, C. T. (1965) AIAA J. 3, 1445-1450. Bell, B.
M. (1994) SIAM J. Optim. 4, 626-636. Dempster, A. P., Laird, N. M. & Rubin, D. B. (1977) J. R.
Statist. Soc. B 39, 1-38. Bar-Shalom, Y., Li, X. R. & Kirubarajan, T. (2001) Estimation with
Applications to Tracking and Navigation. Lange, K. L., Little, R. J. A. & Taylor, J. M. G.
(1989) J. Am. Statist. Assoc. 84, 881-896. Takahashi, K., Fagan, J. & Chin, M.-S. (1973)
Formation of a sparse bus impedance matrix and its application to short circuit study, 8th
PICA Conf. Proc., 63-69.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import cho_solve_banded, cholesky_banded, expm
from scipy.optimize import minimize_scalar

#: Huber's threshold (in σ) and the reweighting passes of the robust start (huber_weights)
HUBER_K = 1.0
HUBER_PASSES = 12
#: a bounded state is held by a penalty this many times its node's own weight
BOUND_STIFFNESS = 1e4
#: the active set of bounded states grows at most this many times
BOUND_PASSES = 12
#: a state leaves its bound when it passes it by more than this fraction of it
BOUND_TOLERANCE = 0.01
#: the shortest fraction of a Newton step the speed bound's line search tries
LINE_SEARCH_MIN = 1.0 / 64.0
#: the speed bound's penalties, in units of a node's own weight: raised in turn (continuation)
SPEED_STIFFNESS = (1.0, 1e2, 1e4)
#: the percentile of the speeds consecutive measured positions require that the speed bound
#: keeps above (a few steps across unrejected glitches do not set it)
POSITION_SPEED_PERCENTILE = 99.0
#: the percentile of the speeds that the log reports and the path flies (per sample the
#: smaller) that sets the speed bound: the log's robust top speed, which no single report sets
REPORTED_SPEED_PERCENTILE = 99.5
#: the precision (in the logarithm) the noise scales are maximised to
SCALE_XATOL = 0.05
#: iterative refinement steps of each banded solve (:func:`_solve_refined`)
REFINE_STEPS = 2
#: degrees of freedom ν of the height's Student-t jerk (module docstring): 1, a Cauchy jerk
VERTICAL_JERK_DOF = 1.0
#: E-steps of the steps' weights λ, after the noise levels (module docstring)
MANOEUVRE_STEPS = 8
#: the share η of a channel's repeats taken for copies before the first E-step: no preference
HELD_START = 0.5
#: the largest σ of a channel's time errors (s)
TIMING_MAX_S = 30.0
#: states per axis (position, velocity, acceleration)
NS = 3
#: off-diagonals of the normal equations (blocks of NS states, tridiagonal)
BAND = 2 * NS - 1


@dataclass(frozen=True)
class MotionModel:
    """The Singer manoeuvre model of one axis (module docstring).

    Attributes
    ----------
    tau_s : float
        Correlation time of the acceleration (a manoeuvre's duration). Units: s.
    beta : float
        Damping of the velocity (0: none). Units: 1/s.
    jerk_dof : float or None
        Degrees of freedom of the jerk's Student-t distribution (manoeuvres); None: Gaussian.
    """

    tau_s: float
    beta: float = 0.0
    #: degrees of freedom ν of the jerk's Student-t distribution (module docstring); None: the
    #: jerk is Gaussian
    jerk_dof: float | None = None

    def transition(self, dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(F, Q)`` of one grid step ``dt`` (s) for jerk intensity ``q`` (m²/s⁵).

        Van Loan (1978): ``expm([[-A, G q Gᵀ], [0, Aᵀ]] dt) = [[·, F⁻¹Q], [0, Fᵀ]]``.
        """
        A = np.array([[0.0, 1.0, 0.0], [0.0, -self.beta, 1.0], [0.0, 0.0, -1.0 / self.tau_s]])
        GQG = np.zeros((3, 3))
        GQG[2, 2] = q
        M = np.zeros((6, 6))
        M[:3, :3], M[:3, 3:], M[3:, 3:] = -A, GQG, A.T
        E = expm(M * dt)
        F = E[3:, 3:].T
        Q = F @ E[:3, 3:]
        return F, 0.5 * (Q + Q.T)

    def forcing(self, dt: float) -> np.ndarray:
        r"""Return the state change ``B`` (3,) over a step ``dt`` of a unit mean acceleration.

        With :math:`\dot a = -(a - a_c)/\tau + w` and :math:`a_c` constant over the step,
        :math:`x_{k+1} = F x_k + B a_c + e_k`, :math:`B = \int_0^{\Delta} e^{As} ds\,(0, 0,
        1/\tau)^\top` (one augmented matrix exponential).
        """
        A = np.array([[0.0, 1.0, 0.0], [0.0, -self.beta, 1.0], [0.0, 0.0, -1.0 / self.tau_s]])
        M = np.zeros((4, 4))
        M[:3, :3] = A
        M[2, 3] = 1.0 / self.tau_s
        return expm(M * dt)[:3, 3]

    def stationary_precision(self, q: float) -> np.ndarray:
        """Return the precision (3, 3) of the prior on the first node: its stationary state.

        The acceleration is stationary, variance qτ/2; the position and the velocity have a
        diffuse prior (zero precision: a log may start in a climb the jerk intensity says
        nothing of). Without it the path before the first fix would be the model run
        backwards, which grows the relaxing acceleration by e^{Δ/τ} a step.
        """
        out = np.zeros((3, 3))
        out[2, 2] = 2.0 / (q * self.tau_s)
        return out

    def sigma_accel(self, q: float) -> float:
        """Stationary σ of the acceleration (m/s²) for jerk intensity ``q``: √(qτ/2)."""
        return math.sqrt(q * self.tau_s / 2.0)


@dataclass(frozen=True)
class Grid:
    """Regular nodes ``t0 + dt * k`` for k from 0 to n - 1 (s)."""

    t0: float
    dt: float
    n: int

    @property
    def t(self) -> np.ndarray:
        """The node times (s)."""
        return self.t0 + self.dt * np.arange(self.n)

    def locate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nearest node ``k`` of each time and the offset ``δ = t − t_k`` (s)."""
        k = np.clip(np.rint((t - self.t0) / self.dt).astype(np.int64), 0, self.n - 1)
        return k, t - (self.t0 + self.dt * k)


@dataclass(frozen=True)
class Channel:
    """One kind of measurement of an axis group: positions (``order`` 0) or rates (1).

    Attributes
    ----------
    t : numpy.ndarray
        Times (s), (m,).
    y : numpy.ndarray
        Values, (m, d) for the d axes of the group. Units: m or m/s.
    rho : numpy.ndarray
        Relative σ of each (the channel's scale times this is its σ), (m,).
    order : int
        0: a position; 1: a rate.
    dof : int
        Degrees of freedom one measurement carries (2 for a horizontal position in 3 ECEF
        axes: the surface point's radial component is no measurement).
    fault_density : float
        Density of the fault distribution at any value (uniform over the range the log
        spans), in the units of ``y`` to the power ``-dof``; 0: no sample is a fault (a
        constraint of the model, not the log's).
    name : str
        For reports.
    timing : bool
        The samples' time tags err (a position stamped when the message was received or
        relayed, not when it was fixed): each has a time error τ_i, estimated with the path
        (module docstring).
    held : numpy.ndarray, optional
        The samples whose printed value repeats the previous sample's exactly, (m,) bool: a
        copy or a fresh value (module docstring, "Held values"). None: no repeats modelled.
    cell : float
        The size of one printed value (the channel's resolution to the power ``dof``), in the
        units of ``y`` to the power ``dof``.
    time_variance : numpy.ndarray, optional
        The variance each sample's time error adds at its stamped time (module docstring,
        "Time errors"), (m,), in the units of ``y`` squared: known, not scaled by ``s``. None:
        none.
    """

    t: np.ndarray
    y: np.ndarray
    rho: np.ndarray
    order: int
    dof: int
    fault_density: float
    name: str
    timing: bool = False
    held: np.ndarray | None = None
    cell: float = 0.0
    time_variance: np.ndarray | None = None

    def variance(self, s: float) -> np.ndarray:
        """Each sample's noise variance at the scale ``s`` (module docstring), (m,)."""
        var = (s * self.rho) ** 2
        return var if self.time_variance is None else var + self.time_variance


@dataclass
class SmoothedAxis:
    """A solved axis group: states, weights, noise levels and the Cholesky factor.

    Attributes
    ----------
    x : numpy.ndarray
        States at the nodes, (n, 3, d): position, velocity, acceleration per axis.
    q : float
        Jerk intensity (m²/s⁵).
    scales : list of float
        Each channel's noise scale ``s`` (m, m/s).
    fault_prob : list of numpy.ndarray
        Each channel's posterior fault probabilities π.
    fault_rate : list of float
        Each channel's fault fraction ε.
    neg2loglik : float
        The marginal likelihood's ``-2 log L`` at the solution.
    tau : list of numpy.ndarray
        Each channel's estimated time errors (s; zeros where the channel has none).
    sigma_tau : list of float
        Each channel's σ of the time errors (s; 0 where none).
    scale_bounds : list of (float, float)
        Each channel's bounds of ``s`` (its floor and ceiling): where the maximiser stopped at
        one (:meth:`SmoothedAxis.scale_at_bound`), the likelihood wanted a value beyond it.
    fixed : list of bool
        Each channel's ``s`` given, not estimated.
    """

    grid: Grid
    model: MotionModel
    x: np.ndarray
    q: float
    scales: list[float]
    fault_prob: list[np.ndarray]
    fault_rate: list[float]
    neg2loglik: float
    chol: np.ndarray = field(repr=False)
    tau: list[np.ndarray] = field(default_factory=list, repr=False)
    #: the equilibration of the factored matrix (:func:`_factor`)
    dscale: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    sigma_tau: list[float] = field(default_factory=list)
    #: the steps' weights λ of the heavy-tailed jerk (module docstring), (n - 1,)
    lam: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    #: each channel's posterior probabilities κ that a repeat is a copy (module docstring)
    held_prob: list[np.ndarray] = field(default_factory=list, repr=False)
    #: each channel's share η of its repeats that are copies (0 where it has none)
    held_rate: list[float] = field(default_factory=list)
    #: the speed bound of the surface point (m/s; module docstring, "Speed"), None where none
    top_speed: float | None = None
    #: the nodes the speed bound holds (the path there would fly faster without it)
    speed_held: int = 0
    #: False where the bound could not be held against the fixes the fit keeps (the path is
    #: then the unbounded one: :meth:`AxisSmoother._flyable`)
    speed_bound_holds: bool = True
    scale_bounds: list[tuple[float, float]] = field(default_factory=list)
    fixed: list[bool] = field(default_factory=list)
    #: ``-2 log L`` with each measurement's mixture density (fault, inlier, copy) in place of
    #: its weighted square and weighted normaliser (:meth:`AxisSmoother.mixture_loglik`): two
    #: solutions of one log compared by it (the conditioning's two starts of the height)
    mixture_neg2loglik: float = float("nan")

    def scale_at_bound(self, i: int) -> str | None:
        """Return the bound (``"floor"``, ``"ceiling"``) channel ``i``'s estimate stopped at.

        Within twice the maximiser's tolerance (:data:`SCALE_XATOL`) of it; None where the
        estimate is inside its bounds, or the scale was given.
        """
        lo, hi = self.scale_bounds[i]
        if self.fixed[i] or hi <= lo:
            return None
        ls = math.log(self.scales[i])
        if ls >= math.log(hi) - 2.0 * SCALE_XATOL:
            return "ceiling"
        return "floor" if ls <= math.log(lo) + 2.0 * SCALE_XATOL else None

    def weights(self) -> list[np.ndarray]:
        """Each channel's measurement weights ``1 − π − κ`` (module docstring)."""
        return [1.0 - p - k for p, k in zip(self.fault_prob, self.held_prob)]

    def copies(self, i: int) -> int:
        """Return how many samples of channel ``i`` are taken for copies (κ over 1/2)."""
        return int(np.sum(self.held_prob[i] > 0.5))

    def value_at(self, t: np.ndarray, order: int = 0) -> np.ndarray:
        """Return the path's position (``order`` 0) or rate (1) at times ``t``, (m, d)."""
        k, d = self.grid.locate(np.asarray(t, dtype=np.float64))
        h = _rows(d, order)
        return _apply(h, self.x[k])

    def sigmas_at(self, nodes: np.ndarray, state: int = 0, chunk: int = 64) -> np.ndarray:
        """Posterior σ of state ``state`` at each of ``nodes`` (``chunk`` banded solves at once)."""
        nodes = np.asarray(nodes, dtype=np.int64)
        out = np.empty(nodes.size)
        for a in range(0, nodes.size, chunk):
            rows = NS * nodes[a : a + chunk] + state
            cols = np.arange(rows.size)
            e = np.zeros((NS * self.grid.n, rows.size))
            e[rows, cols] = 1.0
            z = _solve_factored(self.chol, self.dscale, e)
            out[a : a + rows.size] = np.sqrt(np.maximum(z[rows, cols], 0.0))
        return out

    def sigma_at(self, k: int, state: int = 0) -> float:
        """Posterior σ of state ``state`` (0 position) at node ``k`` (one banded solve)."""
        return float(self.sigmas_at(np.array([k]), state)[0])


def _rows(delta: np.ndarray, order: int) -> np.ndarray:
    """Measurement rows (m, 3): position ``(1, δ, δ²/2)`` or rate ``(0, 1, δ)``."""
    one, zero = np.ones_like(delta), np.zeros_like(delta)
    if order == 0:
        return np.stack([one, delta, 0.5 * delta * delta], -1)
    return np.stack([zero, one, delta], -1)


def _factor(ab: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cholesky factor of the banded matrix equilibrated by its diagonal, and the scaling.

    ``D A D`` with ``D = diag(A)^(-1/2)``: the states' precisions span many decades (a
    position's against an acceleration's, a stiff prior against faint fixes); scaled to a unit
    diagonal the factor keeps the digits the solution needs.
    """
    band = ab.shape[0] - 1
    dscale = 1.0 / np.sqrt(ab[band])
    abs_ = ab.copy()
    n = ab.shape[1]
    for r in range(band):
        k = band - r  # row r holds A[j - k, j]
        abs_[r, k:] *= dscale[: n - k] * dscale[k:]
    abs_[band] = 1.0
    try:
        cb = cholesky_banded(abs_, lower=False, check_finite=False)
    except np.linalg.LinAlgError:
        # a grid stretch without measurements and a stiff model: a whisper of a prior on
        # the states keeps the system definite without moving the solution measurably
        abs_[band] += 1e-12
        cb = cholesky_banded(abs_, lower=False, check_finite=False)
    return cb, dscale


def _solve_factored(cb: np.ndarray, dscale: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` with :func:`_factor`'s factor and scaling."""
    y = cho_solve_banded((cb, False), b * dscale[:, None], check_finite=False)
    return y * dscale[:, None]


def _band_matvec(ab: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Return ``A x`` for the symmetric ``A`` in upper banded form ``ab``, ``x`` (n, d)."""
    band = ab.shape[0] - 1
    y = ab[band][:, None] * x
    for k in range(1, band + 1):
        vals = ab[band - k, k:][:, None]  # A[j - k, j]
        y[:-k] += vals * x[k:]
        y[k:] += vals * x[:-k]
    return y


def _solve_refined(ab: np.ndarray, fac: tuple[np.ndarray, np.ndarray], b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` and refine it twice against ``A`` itself (iterative refinement).

    A smooth path pinned by faint fixes under a stiff model has a normal matrix whose
    condition number reaches 1e13 (the straight lines are held by the fixes alone); each
    refinement step divides the error by about that number times the machine epsilon.
    """
    x = _solve_factored(*fac, b)
    for _ in range(REFINE_STEPS):
        x = x + _solve_factored(*fac, b - _band_matvec(ab, x))
    return x


def _block_covariances(cb: np.ndarray, dscale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the diagonal and next blocks of ``A⁻¹`` from :func:`_factor`'s factor.

    ``A`` is block tridiagonal (NS × NS blocks), so its Cholesky factor ``D A D = Uᵀ U`` is
    block upper bidiagonal, and the blocks of ``W = (Uᵀ U)⁻¹`` beside the diagonal follow
    from the last node up (the selected inversion of Takahashi, Fagan & Chin 1973), with
    ``G_k = U_kk⁻¹ U_k,k+1``:

    ``W_kk = U_kk⁻¹ U_kk⁻ᵀ + G_k W_k+1,k+1 G_kᵀ``, ``W_k,k+1 = −G_k W_k+1,k+1``;

    then ``A⁻¹ = D W D``. Returns ``(C_kk (n, NS, NS), C_k,k+1 (n − 1, NS, NS))``.
    """
    N = cb.shape[1]
    n = N // NS
    U = np.zeros((n, NS, 2 * NS))  # rows of node k: columns of nodes k and k + 1
    for r in range(NS):
        i = NS * np.arange(n) + r
        for c in range(r, 2 * NS):
            o = c - r
            ok = i + o < N
            U[ok, r, c] = cb[BAND - o, (i + o)[ok]]
    Ukk_inv = np.linalg.inv(U[:, :, :NS])
    G = np.matmul(Ukk_inv[:-1], U[:-1, :, NS:])
    W = np.matmul(Ukk_inv, Ukk_inv.transpose(0, 2, 1))  # U_kk⁻¹ U_kk⁻ᵀ, then W_kk
    W1 = np.zeros((max(n - 1, 0), NS, NS))
    for k in range(n - 2, -1, -1):
        GW = G[k] @ W[k + 1]
        W1[k] = -GW
        W[k] += GW @ G[k].T
    d = dscale.reshape(n, NS)
    C_kk = d[:, :, None] * W * d[:, None, :]
    C_k1 = d[:-1, :, None] * W1 * d[1:, None, :]
    return C_kk, C_k1


def _apply(h: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Rows ``h`` (m, 3) applied to states ``x`` (m, 3, d): (m, d)."""
    return h[:, 0, None] * x[:, 0] + h[:, 1, None] * x[:, 1] + h[:, 2, None] * x[:, 2]


def _process_band(P: np.ndarray, F: np.ndarray, n: int, lam: np.ndarray) -> np.ndarray:
    """Return the process part of the normal matrix in upper banded form.

    Step ``k`` (node k to k + 1) has the precision ``lam[k] P`` (``P = Q⁻¹``, ``lam`` the
    steps' weights, (n - 1,)).
    """
    FtPF, mFtP = F.T @ P @ F, -F.T @ P
    ab = np.zeros((BAND + 1, NS * n))
    for r in range(NS):
        for c in range(r, NS):
            row = BAND + r - c
            col = np.arange(n) * NS + c
            vals = np.zeros(n)
            vals[1:] += lam * P[r, c]
            vals[:-1] += lam * FtPF[r, c]
            ab[row, col] = vals
        for c in range(NS):
            # block (k, k+1): rows NS k + r, columns NS (k+1) + c
            row = BAND + r - (NS + c)
            col = np.arange(n - 1) * NS + NS + c
            ab[row, col] = lam * mFtP[r, c]
    return ab


def mixture_components(
    c: Channel, r: np.ndarray, s: float, eps: float, eta: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Return the log densities of each sample of ``c`` as a fault, an inlier and a copy.

    At the residuals ``r`` (m, d) from a path, the noise scale ``s``, the fault share
    :math:`\epsilon` (``eps``) and the copy share :math:`\eta` (``eta``; module docstring):
    :math:`\log \epsilon f`, :math:`\log (1-\epsilon)(1-\eta_i) N(r_i; 0, \sigma_i^2)` with
    :math:`\sigma_i^2` from :meth:`Channel.variance` and :math:`\log (1-\epsilon)\eta_i / c`
    (:math:`\eta_i = \eta` on a sample that repeats the one before it, else 0; a channel
    without faults, density 0, has :math:`-\infty` for the first).
    """
    var = c.variance(s)
    z2 = np.sum(r * r, axis=1) / var
    # log of the inlier density (dof-dimensional isotropic Gaussian)
    log_in = -0.5 * z2 - 0.5 * c.dof * np.log(2.0 * np.pi * var)
    # a channel without faults (density 0: a constraint of the model) has none
    log_out = math.log(max(c.fault_density, 1e-300)) if c.fault_density > 0 else -np.inf
    a = np.full(r.shape[0], np.log(eps) + log_out)
    bb = np.log1p(-eps) + log_in
    if eta > 0.0 and c.held is not None:
        # in probabilities of the printed value: densities per cell, a copy's 1 per cell
        bb = np.where(c.held, bb + math.log1p(-eta), bb)
        cc = np.where(c.held, math.log1p(-eps) + math.log(eta) - math.log(c.cell), -np.inf)
    else:
        cc = np.full(r.shape[0], -np.inf)
    return a, bb, cc


def log_mixture(a: np.ndarray, bb: np.ndarray, cc: np.ndarray) -> np.ndarray:
    """Return each sample's log-likelihood from its three :func:`mixture_components`."""
    m = np.maximum(np.maximum(a, bb), cc)
    return m + np.log(np.exp(a - m) + np.exp(bb - m) + np.exp(cc - m))


class AxisSmoother:
    """The robust smoother of one axis group (module docstring) on a grid.

    Parameters
    ----------
    grid : Grid
        The nodes (the measurements lie within them).
    model : MotionModel
        The motion model of the group's axes.
    channels : list of Channel
        The measurements.
    q_bounds : (float, float)
        The jerk intensity's bounds (m²/s⁵), from the vehicle class.
    scale_bounds : list of (float, float)
        Each channel's noise scale bounds (m or m/s): its floor (the rounding of the values) and
        a ceiling.
    fixed_scales : list of float or None
        Scales given by the user (not estimated) per channel, None where estimated.
    origin : numpy.ndarray, optional
        For the ECEF surface point: the point its positions are relative to; the acceleration
        then relaxes to the curvature's (module docstring).
    bounds : dict, optional
        For a one-axis group (the height): state (1 velocity, 2 acceleration) -> (lower,
        upper) bounds the path keeps within (the vehicle's climb and vertical load factor).
    reported_speeds : (numpy.ndarray, numpy.ndarray), optional
        Times (s) and magnitudes (m/s, the surface point's) of a log's ground speeds that are
        no channel of the fit (its velocities left out): the evidence of the speed envelope
        in their place (:meth:`top_speed`).
    speeds_of_positions : bool
        The log reports no speeds that are speeds of the path (no velocity columns, or speeds
        a constant factor off its positions'): the steps between its measured positions are
        the evidence of the speed envelope (:meth:`top_speed`).
    """

    def __init__(
        self,
        grid: Grid,
        model: MotionModel,
        channels: list[Channel],
        q_bounds: tuple[float, float],
        scale_bounds: list[tuple[float, float]],
        fixed_scales: list[float | None] | None = None,
        bounds: dict[int, tuple[float, float]] | None = None,
        origin: np.ndarray | None = None,
        reported_speeds: tuple[np.ndarray, np.ndarray] | None = None,
        speeds_of_positions: bool = False,
    ) -> None:
        self.grid, self.model, self.channels = grid, model, channels
        self.speeds_of_positions = speeds_of_positions
        #: the log's speeds outside the fit, their nodes and rate rows (for top_speed)
        self.reported_speeds: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        if reported_speeds is not None and np.size(reported_speeds[0]):
            k, d = grid.locate(np.asarray(reported_speeds[0], float))
            self.reported_speeds = (np.asarray(reported_speeds[1], float), k, _rows(d, 1))
        #: state index (1 velocity, 2 acceleration) -> (lower, upper) bound, one-axis groups
        self.bounds = dict(bounds or {})
        #: for the three ECEF axes of a surface point: the ECEF point the positions are
        #: relative to (the curvature input is on); None: no mean acceleration
        self.origin = origin
        self.q_bounds, self.scale_bounds = q_bounds, scale_bounds
        self.fixed = fixed_scales or [None] * len(channels)
        self.d = channels[0].y.shape[1]
        self._unit: tuple[np.ndarray, float, np.ndarray, np.ndarray, np.ndarray] | None = None
        #: the steps' weights λ_k of the heavy-tailed jerk (module docstring), (n - 1,)
        self.lam = np.ones(max(grid.n - 1, 0))
        #: the mean acceleration input per node and axis (n, d), and its state change per step
        self.a_c = np.zeros((grid.n, self.d))
        self._B = model.forcing(grid.dt)
        #: each channel's share η of its repeats that are copies (module docstring)
        self.held_rates = [
            HELD_START if c.held is not None and np.any(c.held) and c.cell > 0.0 else 0.0
            for c in channels
        ]
        #: the speed bound of the last path solved within it, and the nodes it holds
        self.speed_held: tuple[float | None, int] = (None, 0)
        #: whether the last path solved within it keeps that bound (see _flyable)
        self.speed_bound_holds = True
        self.tau = [np.zeros(c.t.size) for c in channels]
        self.sigma_tau = [1.0 if c.timing else 0.0 for c in channels]
        #: the last solve's -2 log L without the measurements' terms (its process, initial
        #: state and determinants), for :attr:`SmoothedAxis.mixture_neg2loglik`
        self._last_unmeasured = 0.0
        self.k: list[np.ndarray] = [np.zeros(0, np.int64)] * len(channels)
        self.h: list[np.ndarray] = [np.zeros((0, NS))] * len(channels)
        for i in range(len(channels)):
            self._locate(i)
        self.x_ref = self._reference()

    def _reference(self) -> np.ndarray:
        """Return a path the model moves along without process noise, near the data, (n, 3, d).

        The smoother solves for the path's departure from it: the normal matrix of a stiff model
        pinned by faint fixes reaches condition numbers of 1e13, and what it leaves of the
        solution's digits must not be those of the Earth's radius. Undamped axes: the
        least-squares straight line through the first channel's values (constant velocity, no
        acceleration: ``F`` carries it exactly); damped ones (the height): their mean, at rest.
        """
        c = self.channels[0]
        t = self.grid.t
        out = np.zeros((self.grid.n, NS, self.d))
        if c.t.size == 0:
            return out
        tc = float(np.mean(c.t))
        if self.model.beta > 0.0 or c.t.size < 2 or np.ptp(c.t) == 0.0:
            out[:, 0, :] = np.mean(c.y, axis=0)
            return out
        A = np.stack([np.ones_like(c.t), c.t - tc], -1)
        coef, *_ = np.linalg.lstsq(A, c.y, rcond=None)
        out[:, 0, :] = coef[0] + np.outer(t - tc, coef[1])
        out[:, 1, :] = coef[1]
        return out

    def _locate(self, i: int) -> None:
        """Return the nodes and measurement rows of channel ``i`` at its (re-timed) times."""
        c = self.channels[i]
        k, d = self.grid.locate(c.t + self.tau[i])
        self.k[i], self.h[i] = k, _rows(d, c.order)

    def set_mean_acceleration(self, x: np.ndarray) -> None:
        """Return the surface point's curvature acceleration ``−|v|² r̂/|r|`` of the path ``x``."""
        r = x[:, 0, :] + self.origin
        v = x[:, 1, :]
        rn = np.linalg.norm(r, axis=1)
        vt = v - (np.sum(v * r, axis=1) / rn**2)[:, None] * r
        self.a_c = -(np.sum(vt * vt, axis=1) / rn**2)[:, None] * r

    def retime(self, x: np.ndarray, scales: list[float], weights: list[np.ndarray]) -> None:
        r"""Update the time errors of the channels that have them (module docstring).

        A time error :math:`\tau_i` moves a fix along the path's velocity :math:`v`: the
        residual at the stamped time, :math:`r = y - p(t)`, has along the track the variance
        :math:`s^2 + |v|^2\sigma_\tau^2` and across it :math:`s^2`. So
        :math:`\sigma_\tau^2 = \overline{(a^2 - c^2)}/\overline{|v|^2}` (moments of the
        along and across components over the inliers), taken only where that excess is
        significant (over 3 standard errors; else the fixes have no time errors); then each
        fix's posterior mean

        .. math:: \hat\tau = \frac{v\cdot r}{|v|^2 + s^2/\sigma_\tau^2}.
        """
        for i, c in enumerate(self.channels):
            if not c.timing or c.t.size < 10:
                continue
            k, h = self.k[i], self.h[i]
            pos = _apply(h, x[k])
            vel = _apply(_rows(h[:, 1], 1), x[k])
            r = c.y - pos + vel * self.tau[i][:, None]  # the residual at the stamped time
            v2 = np.sum(vel * vel, axis=1)
            along = np.sum(r * vel, axis=1) / np.sqrt(np.maximum(v2, 1e-12))
            excess = (2.0 * along**2 - np.sum(r * r, axis=1))[v2 > 1.0]
            w = weights[i][v2 > 1.0]
            neff = float(np.sum(w))
            sig2 = 0.0
            if neff > 10.0:
                mean = float(np.sum(w * excess) / neff)
                se = float(np.sqrt(np.sum(w * (excess - mean) ** 2) / neff / neff))
                if mean > 3.0 * se:
                    sig2 = min(mean / float(np.sum(w * v2[v2 > 1.0]) / neff), TIMING_MAX_S**2)
            self.sigma_tau[i] = math.sqrt(sig2)
            if sig2 == 0.0:
                self.tau[i] = np.zeros(c.t.size)
            else:
                s2 = c.variance(scales[i])
                self.tau[i] = np.sum(vel * r, axis=1) / (v2 + s2 / sig2)
            self._locate(i)

    # -- one solve ---------------------------------------------------------------------------

    def _process(self, q: float) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
        """Banded process matrix, ``Σ_k log det(λ_k Q⁻¹)``, ``Q⁻¹`` and ``F`` for ``q``.

        ``Q`` is linear in ``q`` (``F`` does not depend on it): one matrix exponential per grid;
        the band is rebuilt when the steps' weights λ change.
        """
        if self._unit is None or self._unit[4] is not self.lam:
            F, Q1 = self.model.transition(self.grid.dt, 1.0)
            P1 = np.linalg.inv(Q1)
            P1 = 0.5 * (P1 + P1.T)
            logdet = (self.grid.n - 1) * float(np.linalg.slogdet(P1)[1])
            logdet += NS * float(np.sum(np.log(self.lam)))
            self._unit = (_process_band(P1, F, self.grid.n, self.lam), logdet, P1, F, self.lam)
        ab1, logdet1, P1, F, _ = self._unit
        ab = ab1 / q
        P0 = self.model.stationary_precision(q)
        for r in range(NS):
            for c in range(r, NS):
                ab[BAND + r - c, c] += P0[r, c]
        return ab, logdet1 - (self.grid.n - 1) * NS * math.log(q), P1 / q, F

    def measurements(self, weights: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray] | None]:
        """Each channel's part of the normal equations at unit scale: (banded matrix, rhs).

        A channel with a time errors' variance has none at unit scale (its variance is not
        the scale's square times a constant): :meth:`solve` builds its part at its scale.
        """
        return [
            self._part(i, w / c.rho**2) if c.time_variance is None else None
            for i, (c, w) in enumerate(zip(self.channels, weights))
        ]

    def _part(self, i: int, wi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Channel ``i``'s part of the normal equations with the samples' weights ``wi``."""
        n, d = self.grid.n, self.d
        c, k, h = self.channels[i], self.k[i], self.h[i]
        ab = np.zeros((BAND + 1, NS * n))
        b = np.zeros((NS * n, d))
        yd = c.y - _apply(h, self.x_ref[k])  # the values' departure from the reference
        for r in range(NS):
            for cc in range(r, NS):
                ab[BAND + r - cc, cc::NS] = np.bincount(k, wi * h[:, r] * h[:, cc], minlength=n)
            for j in range(d):
                b[r::NS, j] = np.bincount(k, wi * h[:, r] * yd[:, j], minlength=n)
        return ab, b

    def solve(
        self,
        q: float,
        scales: list[float],
        weights: list[np.ndarray],
        parts: list[tuple[np.ndarray, np.ndarray] | None] | None = None,
        bounded: bool = True,
        speed: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """States (n, 3, d), the Cholesky factor and ``-2 log L`` (module docstring).

        ``parts``: :meth:`measurements` of ``weights`` when already computed. ``bounded``: keep
        the states within :attr:`bounds` (:meth:`_bounded`); ``speed``: and the surface point's
        speed within :meth:`top_speed` (:meth:`_speed_bounded`: the path returned, not each
        E-step's); the likelihood is that of the unbounded problem (the bounds are no data).
        """
        n, d = self.grid.n, self.d
        ab0, logdetP, P, F = self._process(q)
        parts = self.measurements(weights) if parts is None else parts
        ab = ab0.copy()
        b = np.zeros((NS * n, d))
        norm = 0.0
        forced = self.origin is not None and np.any(self.a_c)
        if forced:
            # the process residual x_{k+1} − F x_k − f_k, f_k = B a_c,k: rhs P f_k for node k+1
            # and −Fᵀ P f_k for node k
            f = self._B[None, :, None] * self.a_c[:-1, None, :]
            Pf = np.matmul(P, f) * self.lam[:, None, None]
            FtPf = np.matmul(F.T, Pf)
            bb = b.reshape(n, NS, d)
            bb[1:] += Pf
            bb[:-1] -= FtPf
        for i, (c, w, s, part) in enumerate(zip(self.channels, weights, scales, parts)):
            if part is None:  # a time errors' variance: the part at this scale
                abc, bc = self._part(i, w / c.variance(s))
                ab += abc
                b += bc
            else:
                ab += part[0] / s**2
                b += part[1] / s**2
            norm += float(np.sum(w * c.dof * np.log(c.variance(s))))
        cb, dscale = _factor(ab)
        logdetA = 2.0 * float(np.sum(np.log(cb[BAND]))) - 2.0 * float(np.sum(np.log(dscale)))
        dx = _solve_refined(ab, (cb, dscale), b).reshape(n, NS, d)
        if bounded and self.bounds:
            xb, fb = self._bounded(ab, b, dx)
            if xb is not None:
                dx, (cb, dscale) = xb, fb
        top = (
            self.top_speed(weights, self.x_ref + dx, scales)
            if speed and self.origin is not None
            else None
        )
        if speed:
            self.speed_held, self.speed_bound_holds = (top, 0), True
        if top is not None:
            xs = self._speed_bounded(ab, b, dx, top)
            if xs is not None and self._flyable(xs, dx):
                dx = xs
            elif xs is not None:
                self.speed_bound_holds = False
        self._last_factor = (cb, dscale)
        x = self.x_ref + dx
        # J at the solution: process + measurements
        e = dx[1:] - np.matmul(F, dx[:-1])  # the reference moves without process noise
        if forced:
            e = e - f
        J = float(np.sum(self.lam[:, None, None] * e * np.matmul(P, e)))
        P0 = self.model.stationary_precision(q)
        J += float(np.sum(x[0] * np.matmul(P0, x[0])))  # the reference is at rest there
        w0 = np.linalg.eigvalsh(P0)
        logdetP0 = float(np.sum(np.log(w0[w0 > 0.0])))
        self._last_unmeasured = J + d * logdetA - d * logdetP - d * logdetP0
        for c, k, h, w, s in zip(self.channels, self.k, self.h, weights, scales):
            r = c.y - _apply(h, x[k])
            J += float(np.sum(w / c.variance(s) * np.sum(r * r, axis=1)))
        neg2 = J + d * logdetA - d * logdetP - d * logdetP0 + norm
        return x, cb, neg2

    def _bounded(
        self, ab: np.ndarray, b: np.ndarray, x: np.ndarray
    ) -> tuple[np.ndarray | None, tuple[np.ndarray, np.ndarray]]:
        """Keep the states within :attr:`bounds` (an active set of penalised nodes).

        Each node whose state leaves its bound is held at the bound by a penalty
        ``W (x − bound)²`` with ``W`` :data:`BOUND_STIFFNESS` times the node's diagonal; the set
        grows until no state leaves its bounds by more than 1 % (at most
        :data:`BOUND_PASSES` passes). Returns None when no state leaves them.
        """
        n, d = self.grid.n, self.d
        active: dict[int, float] = {}
        fac = None
        for _ in range(BOUND_PASSES):
            new = False
            for state, (lo, hi) in self.bounds.items():
                v = x[:, state, 0] + self.x_ref[:, state, 0]
                tol = BOUND_TOLERANCE * max(abs(lo), abs(hi))
                for idx, val in (
                    (np.flatnonzero(v > hi + tol), hi),
                    (np.flatnonzero(v < lo - tol), lo),
                ):
                    for k in idx:
                        key = NS * int(k) + state
                        if key not in active:
                            active[key], new = val - self.x_ref[k, state, 0], True
            if not new:
                break
            keys = np.fromiter(active.keys(), np.int64)
            vals = np.fromiter(active.values(), np.float64)
            abk, bk = ab.copy(), b.copy()
            W = BOUND_STIFFNESS * abk[BAND, keys]
            abk[BAND, keys] += W
            bk[keys, :] += (W * vals)[:, None]
            fac = _factor(abk)
            x = _solve_refined(abk, fac, bk).reshape(n, NS, d)
        if fac is None:
            return None, (ab, ab[BAND])
        return x, fac

    def top_speed(
        self, weights: list[np.ndarray], x: np.ndarray, scales: list[float]
    ) -> float | None:
        r"""Return the robust top speed that the log and the path ``x`` both say was flown.

        Per rate sample that is a measurement (weight over 1/2), the smaller of its speed and
        the path's there: a reported speed the path does not follow (a noisy value), or a path
        speed no sample reports (a swing into a gap), does not raise it; and of those, the
        :data:`REPORTED_SPEED_PERCENTILE`-th percentile, the log's robust top speed: the few
        fastest reports that the path flies as fast do not set it (a glider's 13 reports of
        85-94 kt of 2,697, 99.5 % at most 84 kt, while fixes 14 s apart 1.3 km apart pull the
        path along; a tanker's one report of 110 m/s beside fixes 100 s apart). No less than the
        positions themselves require: two consecutive measured positions :math:`i, j`
        (re-timed) are flown at :math:`(|y_j - y_i| - 3\sqrt{2 d}\, s)/(t_j - t_i)` at least
        (their distance less three σ of its noise, ``d`` the positions' degrees of freedom),
        and the bound keeps above the :data:`POSITION_SPEED_PERCENTILE`-th percentile of that
        over the steps: a log whose speeds cover only part of the flight (the taxi at each end)
        does not hold the rest to them, while a single step across an unrejected glitch or a
        gap (one pair of fixes against every speed the log reports) does not set it. The
        surface point's speed bound (module docstring, "Speed"); where no rate channel has a
        measurement, the :attr:`reported_speeds` (every one: none is judged by the fit) take
        their place; without either, where the log reports no speeds of the path
        (:attr:`speeds_of_positions`: a log of positions alone, IGC, GPX, an ADS-B table
        without its velocity columns), the speeds its positions report: per step between two
        consecutive measured positions, the smaller of its mean speed and the path's speed
        at the later one, at the same percentile (a step's mean speed is no more than the
        fastest the vehicle flew in it, up to the positions' noise, which the path's speed
        does not carry; a gap's step, one of many, does not set it). None without positions.
        """
        flown, least, stepped = [], 0.0, []
        for c, w, k, h, s, tau in zip(self.channels, weights, self.k, self.h, scales, self.tau):
            on = w > 0.5
            if c.order == 0 and np.sum(on) > 1:
                t = (c.t + tau)[on]
                dy = np.linalg.norm(np.diff(c.y[on], axis=0), axis=1)
                dt = np.diff(t)
                ok = dt > 0.0
                margin = 3.0 * math.sqrt(2.0 * c.dof) * s * c.rho[on][1:][ok]
                req = (dy[ok] - margin) / dt[ok]
                if req.size:
                    least = max(least, float(np.percentile(req, POSITION_SPEED_PERCENTILE)))
                    # each step's mean speed, and the path's speed at its end fix
                    rate = np.stack([np.zeros(len(h)), np.ones(len(h)), h[:, 1]], -1)
                    path = np.linalg.norm(_apply(rate, x[k])[on][1:][ok], axis=1)
                    stepped.append(np.minimum(dy[ok] / dt[ok], path))
            if c.order != 1 or not np.any(on):
                continue
            path = np.linalg.norm(_apply(h, x[k]), axis=1)
            flown.append(np.minimum(np.linalg.norm(c.y, axis=1), path)[on])
        if not flown and self.reported_speeds is not None:
            speed, k, h = self.reported_speeds
            path = np.linalg.norm(_apply(h, x[k]), axis=1)
            flown.append(np.minimum(speed, path))
        if not flown and self.speeds_of_positions:
            flown = stepped
        if not flown:
            return None
        return max(float(np.percentile(np.concatenate(flown), REPORTED_SPEED_PERCENTILE)), least)

    def _speed_bounded(
        self, ab: np.ndarray, b: np.ndarray, x: np.ndarray, top: float
    ) -> np.ndarray | None:
        r"""Keep the surface point's speed at or below ``top`` (module docstring, "Speed").

        The bound is held by a penalty on each node's excess speed,

        .. math::

            f(x) = \tfrac12 x^\top A x - b^\top x
                 + \tfrac12 \sum_k W_k \big(s_k - V'\big)_+^2,
            \qquad s_k = |v_k|,

        (:math:`v_k` the surface point's velocity at the node, :math:`V'` the bound
        plus half of :data:`BOUND_TOLERANCE`, so that a path flying the top speed itself, a
        log at constant speed, is left alone), a convex function minimised by Newton's method
        with a backtracking line search on :math:`f(x + ts) - f(x)` (computed from the
        differences: :math:`f` is a sum of large terms). The penalty's Hessian at a node over
        :math:`V'`, :math:`W_k[u u^\top + (1 - V'/s_k)(I - u u^\top)]`
        (:math:`u = v_k / s_k`), couples its axes, so each step is solved in the
        interleaved order (node, state, axis): a band of ``BAND·d + d − 1``. :math:`W_k` is
        :data:`SPEED_STIFFNESS` times the node's own weight, raised in turn from the last
        minimum (a stiff penalty from the start would have its Newton steps overshoot at the
        nodes just under the bound), until no node passes the bound by more than
        :data:`BOUND_TOLERANCE`; each stiffness takes at most :data:`BOUND_PASSES` steps.
        Returns None when no node passes it.
        """
        n, d = self.grid.n, self.d
        band = BAND * d + d - 1
        ref_v = self.x_ref[:, 1, :]

        def velocities(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            """Return the surface point's velocities (n, d) and speeds."""
            v = x[:, 1, :] + ref_v
            return v, np.linalg.norm(v, axis=1)

        vt, speed = velocities(x)
        if np.max(speed) <= top * (1.0 + BOUND_TOLERANCE):
            return None
        # the penalty starts halfway to the tolerance: a path that flies the top speed itself
        # (a log at constant speed) leaves it alone, and the bound holds what passes it
        level, limit = top * (1.0 + 0.5 * BOUND_TOLERANCE), top * (1.0 + BOUND_TOLERANCE)
        held = int(np.sum(speed > limit))
        abx0 = np.zeros((band + 1, NS * n * d))
        for o in range(BAND + 1):
            for j in range(d):
                abx0[band - o * d, j::d] = ab[BAND - o]
        for stiffness in SPEED_STIFFNESS:
            W = stiffness * ab[BAND, NS * np.arange(n) + 1]
            for _ in range(BOUND_PASSES):
                on = np.flatnonzero(speed > level)
                u = vt[on] / speed[on, None]
                grad = _band_matvec(ab, x.reshape(NS * n, d)) - b  # of the quadratic part
                g = grad.reshape(n, NS, d).copy()
                g[on, 1, :] += (W[on] * (speed[on] - level))[:, None] * u
                uu = u[:, :, None] * u[:, None, :]
                H = W[on, None, None] * (
                    uu + (1.0 - level / speed[on])[:, None, None] * (np.eye(d) - uu)
                )
                abx = abx0.copy()
                base = (NS * on + 1) * d
                for j in range(d):
                    for jj in range(j, d):
                        abx[band - (jj - j), base + jj] += H[:, j, jj]
                step = -_solve_refined(abx, _factor(abx), g.reshape(-1)[:, None])
                step = step.reshape(n, NS, d)
                # f(x + t s) − f(x), from the differences (f itself is a sum of large terms)
                S = step.reshape(NS * n, d)
                q1 = float(np.sum(grad * S))
                q2 = float(np.sum(S * _band_matvec(ab, S)))
                pen = float(np.sum(W * np.maximum(speed - level, 0.0) ** 2))
                t = 1.0
                while t >= LINE_SEARCH_MIN:
                    trial = x + t * step
                    vt_t, speed_t = velocities(trial)
                    pen_t = float(np.sum(W * np.maximum(speed_t - level, 0.0) ** 2))
                    if t * q1 + 0.5 * t * t * q2 + 0.5 * (pen_t - pen) <= 0.0:
                        break
                    t *= 0.5
                else:
                    break  # no step lowers f: this stiffness's minimum to the precision
                x, vt, speed = trial, vt_t, speed_t
                if t * float(np.max(np.abs(step[:, 1, :]))) <= BOUND_TOLERANCE * top:
                    break
            if np.max(speed) <= limit:
                break
        self.speed_held = (top, held)
        return x

    def _flyable(self, bounded: np.ndarray, free: np.ndarray) -> bool:
        r"""Return whether the speed-bounded path keeps within the class's accelerations.

        The class's largest acceleration is the 3σ manoeuvre of its jerk bound,
        :math:`3\sqrt{q_{max}\tau/2}` (:mod:`~fieldmap.nav.logs.vehicles`); the bounded path
        may accelerate up to it, or as hard as the unbounded path does where that is harder
        (the fixes' own manoeuvres). Past both, the fixes the fit keeps hold the path off the
        bound (a stretch of positions the vehicle could not have reached, kept as fixes): the
        bound would only trade speed for loads (module docstring, "Speed"). "Past" by more than
        :data:`BOUND_TOLERANCE`, the precision the bounded path is solved to (its Newton steps
        stop there): where the hardest manoeuvre is one the bound leaves alone, the two paths'
        largest accelerations are the same number to its last bits, and a comparison without
        it was decided by their rounding (``belevingsvlucht``'s 6.054884 m/s², flown bounded on
        one CPU kind and unbounded on another).
        """
        a_max = 3.0 * self.model.sigma_accel(self.q_bounds[1])
        acc = self.x_ref[:, 2, :]
        worst = float(np.max(np.linalg.norm(bounded[:, 2, :] + acc, axis=1)))
        free_worst = float(np.max(np.linalg.norm(free[:, 2, :] + acc, axis=1)))
        return worst <= max(a_max, free_worst) * (1.0 + BOUND_TOLERANCE)

    # -- the mixture's weights ----------------------------------------------------------------

    def posteriors(
        self, x: np.ndarray, scales: list[float], rates: list[float]
    ) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Posterior fault probabilities π and copy probabilities κ (module docstring).

        Per channel, at the path ``x``, with the fault shares ``rates`` and the copy shares
        :attr:`held_rates`; κ is 0 for a sample that repeats nothing.
        """
        faults, copies = [], []
        for a, bb, cc in self._components(x, scales, rates):
            m = np.maximum(np.maximum(a, bb), cc)
            ea, eb, ec = np.exp(a - m), np.exp(bb - m), np.exp(cc - m)
            tot = ea + eb + ec
            faults.append(ea / tot)
            copies.append(ec / tot)
        return faults, copies

    def mixture_loglik(self, x: np.ndarray, scales: list[float], rates: list[float]) -> float:
        r"""Return the measurements' log-likelihood under the mixture at the path ``x``.

        :math:`\sum_i \log[\epsilon f + (1-\epsilon)(1-\eta_i) N(y_i; h_i^\top x,
        s^2\rho_i^2) + (1-\epsilon)\eta_i/c]` over every channel (module docstring: the
        fault, the inlier and, for a repeat, the copy), each a density of the value:
        :math:`\eta_i` is the channel's copy share :math:`\eta` on a sample that repeats the
        one before it and 0 elsewhere (and on every sample of a channel without copies).
        """
        return float(sum(log_mixture(*parts).sum() for parts in self._components(x, scales, rates)))

    def _components(
        self, x: np.ndarray, scales: list[float], rates: list[float]
    ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Each channel's log densities of a sample as a fault, an inlier and a copy."""
        return [
            mixture_components(c, c.y - _apply(h, x[k]), s, eps, eta)
            for c, k, h, s, eps, eta in zip(
                self.channels, self.k, self.h, scales, rates, self.held_rates
            )
        ]

    def huber_weights(
        self, q: float, scales: list[float], passes: int = HUBER_PASSES
    ) -> list[np.ndarray]:
        r"""Return the weights of the Huber M-estimate of the path (a robust start).

        The path minimising the process term of :math:`J` (module docstring; steps' weights
        :attr:`lam`) plus :math:`\sum_i \rho(z_i)`, :math:`z_i = |y_i - h_i^\top x| /
        s\rho_i`, with Huber's :math:`\rho` (quadratic within :data:`HUBER_K`, linear beyond),
        by ``passes`` of iteratively reweighted least squares from least squares: weights
        :math:`w_i = \min(1, k / z_i)`. The objective is convex (the bounds held by
        :meth:`_bounded` aside), so its minimum does not depend on a start, and a run of
        glitches, however far off, pulls the path with a bounded force per sample instead of
        one that grows with its offset. The scales are taken as :meth:`run` takes them (within
        their bounds; a user's fixed σ as given).
        """
        scales = self._start_scales(scales)
        weights = [np.ones(c.t.size) for c in self.channels]
        for _ in range(passes):
            x, _, _ = self.solve(q, scales, weights)
            new = []
            for c, k, h, s in zip(self.channels, self.k, self.h, scales):
                r = c.y - _apply(h, x[k])
                z = np.sqrt(np.sum(r * r, axis=1) / c.variance(s))
                new.append(np.minimum(1.0, HUBER_K / np.maximum(z, 1e-300)))
            weights = new
        return weights

    # -- the whole estimate -------------------------------------------------------------------

    def _start_scales(self, scales0: list[float]) -> list[float]:
        """Return first guesses of the scales within their bounds, a user's fixed σ as given."""
        return [
            float(f) if f is not None else float(np.clip(s, *sb))
            for s, sb, f in zip(scales0, self.scale_bounds, self.fixed)
        ]

    def run(
        self,
        q0: float,
        scales0: list[float],
        passes: int = 2,
        weights0: list[np.ndarray] | None = None,
        tau0: tuple[list[np.ndarray], list[float]] | None = None,
        lam0: np.ndarray | None = None,
        shares0: tuple[list[float], list[float]] | None = None,
        hold_noise: bool = False,
    ) -> SmoothedAxis:
        """EM for the mixture, alternating with the marginal-likelihood noise levels.

        Starts from ``q0`` and ``scales0`` (robust first guesses); each of the ``passes``: the
        weights from the fault probabilities (twice: the path moves once the gross faults lose
        their weight), then ``q`` and the scales maximising the likelihood with the weights
        held; a last E-step gives the weights of the final path. ``weights0``: the weights to
        start from (default 1: every measurement an inlier); ``tau0``: the time errors and their
        σ to start from; ``lam0``: the steps' weights to start from (default 1); ``shares0``:
        the fault and copy shares ε, η to start from (default: from ``weights0``, and
        :data:`HELD_START`); ``hold_noise``: ``q`` and the scales stay at ``q0`` and
        ``scales0`` (the passes are E-steps only).
        """
        if lam0 is not None:
            self.lam = np.asarray(lam0, dtype=np.float64).copy()
        if tau0 is not None:
            self.tau = [np.asarray(t, dtype=np.float64).copy() for t in tau0[0]]
            self.sigma_tau = list(tau0[1])
            for i in range(len(self.channels)):
                self._locate(i)
        q = float(np.clip(q0, *self.q_bounds))
        scales = self._start_scales(scales0)
        weights = weights0 or [np.ones(c.t.size) for c in self.channels]
        rates = [float(np.clip(1.0 - np.mean(w), 1e-4, 0.5)) for w in weights]
        if shares0 is not None:
            rates, self.held_rates = list(shares0[0]), list(shares0[1])
        x, cb, neg2 = self.solve(q, scales, weights)
        for _ in range(passes):
            for _ in range(2):
                x, cb, neg2, weights, rates = self._e_step(x, q, scales, rates)
            if not hold_noise:
                q, scales = self._maximise(q, scales, weights)
                x, cb, neg2 = self.solve(q, scales, weights)
        for _ in range(MANOEUVRE_STEPS if self.model.jerk_dof and lam0 is None else 0):
            x, cb, neg2, weights, rates = self._e_step(x, q, scales, rates, heavy=True)
        x, cb, neg2, weights, rates = self._e_step(x, q, scales, rates, final=True)
        pi, kappa = self.posteriors(x, scales, rates)
        mixture = self._last_unmeasured - 2.0 * self.mixture_loglik(x, scales, rates)
        return SmoothedAxis(
            self.grid,
            self.model,
            x,
            q,
            scales,
            pi,
            rates,
            neg2,
            cb,
            tau=[t.copy() for t in self.tau],
            sigma_tau=list(self.sigma_tau),
            dscale=self._last_factor[1],
            lam=self.lam.copy(),
            held_prob=kappa,
            held_rate=list(self.held_rates),
            top_speed=self.speed_held[0],
            speed_held=self.speed_held[1],
            speed_bound_holds=self.speed_bound_holds,
            scale_bounds=list(self.scale_bounds),
            fixed=[f is not None for f in self.fixed],
            mixture_neg2loglik=mixture,
        )

    def manoeuvres(self, x: np.ndarray, q: float) -> np.ndarray:
        r"""Return the steps' weights :math:`\lambda_k` at the path ``x`` (module docstring).

        :math:`\lambda_k = (\nu + p)/(\nu + \mathrm E[m_k])`, with
        :math:`\mathrm E[m_k] = \hat e_k^\top Q^{-1} \hat e_k + \mathrm{tr}(Q^{-1}
        \Sigma_{e_k})` over the group's axes: the step's process residual at the path and its
        posterior covariance (from the blocks of :math:`A^{-1}` next to the diagonal:
        :func:`_block_covariances`), :math:`p` = 3 × axes, :math:`\nu` the model's ``jerk_dof``.
        All ones for a Gaussian jerk.
        """
        nu = self.model.jerk_dof
        if not nu:
            return np.ones(self.grid.n - 1)
        _, _, P, F = self._process(q)
        dx = x - self.x_ref
        e = dx[1:] - np.matmul(F, dx[:-1])
        if self.origin is not None and np.any(self.a_c):
            e = e - self._B[None, :, None] * self.a_c[:-1, None, :]
        m = np.einsum("kid,ij,kjd->k", e, P, e)
        # the posterior covariance of e_k = x_{k+1} − F x_k, the same for each axis
        C, C1 = _block_covariances(*self._last_factor)
        C_kk, C_11 = C[:-1], C[1:]
        S = C_11 - np.matmul(F, C1) - np.matmul(C1.transpose(0, 2, 1), F.T)
        S = S + np.matmul(np.matmul(F, C_kk), F.T)
        m = m + self.d * np.einsum("ij,kji->k", P, S)
        return (nu + NS * self.d) / (nu + m)

    def _e_step(
        self,
        x: np.ndarray,
        q: float,
        scales: list[float],
        rates: list[float],
        heavy: bool = False,
        final: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, float, list[np.ndarray], list[float]]:
        """One E-step at the path ``x``: fault probabilities, weights and the path they give.

        The weights and fault shares from ``x``, the curvature input, the steps' weights and
        the time errors updated with the path, the path solved again (``final``: within the
        speed bound too): ``(x, factor, -2 log L, weights, rates)``.
        """
        pi, kappa = self.posteriors(x, scales, rates)
        rates = [float(np.clip(np.mean(p), 1e-4, 0.5)) for p in pi]
        self.held_rates = [
            float(np.clip(np.mean(kp[c.held]), 1e-4, 1.0 - 1e-4)) if eta > 0.0 else 0.0
            for c, kp, eta in zip(self.channels, kappa, self.held_rates)
        ]
        weights = [1.0 - p - kp for p, kp in zip(pi, kappa)]
        if self.origin is not None:
            self.set_mean_acceleration(x)
        if heavy:
            self.lam = self.manoeuvres(x, q)
        x, cb, neg2 = self.solve(q, scales, weights, speed=final)
        if any(c.timing for c in self.channels):
            self.retime(x, scales, weights)
            x, cb, neg2 = self.solve(q, scales, weights, speed=final)
        return x, cb, neg2, weights, rates

    def _maximise(
        self, q: float, scales: list[float], weights: list[np.ndarray]
    ) -> tuple[float, list[float]]:
        """One coordinate sweep of the marginal likelihood over ``log q`` and each ``log s``."""
        parts = self.measurements(weights)

        def over_q(lq: float) -> float:
            return self.solve(math.exp(lq), scales, weights, parts, bounded=False)[2]

        lo, hi = (math.log(b) for b in self.q_bounds)
        if hi > lo:
            q = math.exp(
                minimize_scalar(over_q, bounds=(lo, hi), method="bounded", options={"xatol": 0.1}).x
            )
        for i, (sb, f) in enumerate(zip(self.scale_bounds, self.fixed)):
            if f is not None or sb[1] <= sb[0]:
                continue

            def over_s(ls: float, i: int = i) -> float:
                trial = list(scales)
                trial[i] = math.exp(ls)
                return self.solve(q, trial, weights, parts, bounded=False)[2]

            res = minimize_scalar(
                over_s,
                bounds=(math.log(sb[0]), math.log(sb[1])),
                method="bounded",
                options={"xatol": SCALE_XATOL},
            )
            scales = list(scales)
            scales[i] = math.exp(res.x)
        return q, scales
