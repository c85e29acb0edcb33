r"""What a log's samples are, as measurements: repeats, interpolations, and the faults found.

Two facts about a sample decide whether it is a measurement at all, before any fit:

- **A repeated position** (the same latitude and longitude as the sample before it) is the
  earlier fix sent again (ADS-B state vectors, a GNSS receiver without a new solution): the
  measurement it carries is that of the first sample of its run, at the first sample's time.
  Only the first of a run is a measurement (:func:`repeated`); a parked vehicle's run is still
  one fix of where it stood.
- **An interpolated position** (a track resampled to a clock): a sample on the straight line
  through its two neighbours at equal time steps, within the rounding of the digits printed
  (:func:`printed_step`), is a linear interpolation between the fixes either side: a function
  of them, not a measurement (:func:`interpolated`). Only where that rounding is finer than a
  real fix's noise (1 m): there, three noisy fixes are collinear within it only by chance,
  and leaving out such a chance fix loses one sample of many.

- **An extrapolated position** (dead reckoning while the log holds its last state): a sample
  whose every other column (height, ground speed, track, vertical rate) repeats the sample
  before it exactly while its position moves on at the same velocity as over the step
  before, within the rounding of the digits printed, in a run that the next fix cannot be
  reached from within the vehicle's top speed while the run's first fix can
  (:func:`extrapolated`). A receiver that has lost the vehicle advances its last fix at its
  last velocity: the positions are a function of that fix, not measurements, and the next
  real fix is off their line by more than the vehicle flies, and the track goes on from it
  (the sample after it is within the top speed of it). A real straight run at a held
  state (straight and level, or a receiver's perfect dead reckoning) reaches the next fix
  within the vehicle's speed: its positions stay measurements. So does a run followed by a
  jump to a position that the track does not go on from (an earlier position sent again, the
  rows after it interpolated from there: the jump is the fault, not the run before it).

- **A frozen end**: a log whose last rows repeat every value of the row before them
  (position, height and each velocity column it has; an empty cell equal to an empty cell)
  has measured nothing after the first row of that run: its values were written again (a
  receiver that lost the vehicle holding its last state, a track filled forward to a clock).
  The measurements end there, and so does the flown path (:func:`frozen_tail`): past it a
  path would be the motion model's prediction from one side only, a flight the log never
  saw. A vehicle parked at the end repeats its values too: its last row with a new value
  is where it stood, and no more is known after it.

A rounded value (a height in 25 ft steps, a ground speed in knots) is a measurement with at
least the rounding's σ, q/√12: the conditioning floors each channel's noise there.

After the fit, the samples that the smoother's fault model claims (:mod:`fieldmap.nav.logs.motion`:
posterior fault probability over 1/2) are grouped into runs and described
(:func:`describe_faults`): a single outlier; a run of positions that the path explains at
another time (a stretch whose time tags are wrong: the same positions sent again, or stamped
late), found by the time shift that brings the run's positions closest to the path; or a
displaced stretch (positions or heights off the path by the offset given).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Fault:
    """A run of samples the fault model rejected.

    Attributes
    ----------
    channel : str
        ``position``, ``height``, ``velocity`` or ``vertical rate``.
    kind : str
        ``outlier`` (one sample), ``time-shifted`` (the path explains the rejected run
        ``time_shift_s`` later or earlier), ``re-timed`` (kept, each fix moved by its time
        error, beyond 3 σ of the log's time errors), ``displaced`` (off the path).
    lines : (int, int)
        First and last line of the run in the source.
    t_start_s, t_end_s : float
        Times of its first and last sample (s, the track's time scale).
    samples : int
        Samples in the run.
    offset_m : float
        Largest distance from the path. Units: m (m/s for rates).
    time_shift_s : float or None
        The time shift that explains a ``time-shifted`` run (s).
    """

    channel: str
    kind: str
    lines: tuple[int, int]
    t_start_s: float
    t_end_s: float
    samples: int
    offset_m: float
    time_shift_s: float | None = None

    def text(self, t0: float = 0.0) -> str:
        """Return the fault in words (times relative to ``t0``)."""
        what = {
            "outlier": f"{self.channel} outlier",
            "time-shifted": f"{counted(self.samples, self.channel)} with wrong time tags (the path "
            f"passes there {abs(self.time_shift_s or 0.0):.0f} s "
            f"{'earlier' if (self.time_shift_s or 0.0) < 0 else 'later'})",
            "displaced": f"{counted(self.samples, self.channel)} off the path",
            "re-timed": f"{counted(self.samples, self.channel)} re-timed by up to "
            f"{abs(self.time_shift_s or 0.0):.1f} s (time tags off; kept)",
        }[self.kind]
        unit = "m/s" if self.channel in ("velocity", "vertical rate") else "m"
        return (
            f"lines {self.lines[0]}..{self.lines[1]} (t = {self.t_start_s - t0:.0f} s): {what}, "
            f"up to {self.offset_m:.0f} {unit}"
        )


def plural(channel: str) -> str:
    """Return a channel's name in the plural: "velocities", "heights", "vertical rates"."""
    return f"{channel[:-1]}ies" if channel.endswith("y") else f"{channel}s"


def counted(n: int, channel: str) -> str:
    """Return ``n`` samples of a channel in words: "1 velocity", "6 velocities", "2 heights"."""
    return f"1 {channel}" if n == 1 else f"{n} {plural(channel)}"


def printed_step(x: np.ndarray) -> float:
    """Return the finest decimal step printed in ``x``: 10^-d for the most decimals d (≥ 1e-12).

    A value read from text printed with d decimals is within float rounding of a multiple of
    10^-d; values with more (computed, binary sources) give 1e-12.
    """
    x = np.asarray(x, dtype=np.float64)
    x = x[np.isfinite(x)]
    for k in range(12):
        if np.all(np.abs(np.round(x, k) - x) <= 1e-9 * 10.0**-k):
            return 10.0**-k
    return 1e-12


def repeated(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """Return the samples repeating the previous sample's position exactly, (n,) bool."""
    out = np.zeros(lat.size, bool)
    out[1:] = (lat[1:] == lat[:-1]) & (lon[1:] == lon[:-1])
    return out


def frozen_tail(columns: list[np.ndarray]) -> int:
    """Return how many rows at the end repeat every value of the row before (module docstring).

    ``columns``: the log's values, (n,) each; NaN equals NaN (an empty cell repeated).
    """
    n = columns[0].size if columns else 0
    same = np.ones(max(n - 1, 0), bool)
    for c in columns:
        a, b = c[1:], c[:-1]
        same &= (a == b) | (np.isnan(a) & np.isnan(b))
    new = np.flatnonzero(~same)
    return n - 1 - (int(new[-1]) + 1) if new.size else max(n - 1, 0)


def interpolated(
    t: np.ndarray, lat: np.ndarray, lon: np.ndarray, metres_per_degree: float, max_rounding_m: float
) -> tuple[np.ndarray, float]:
    """Positions interpolated between fixes, (n,) bool, and the tolerance (degrees; 0: none).

    Collinear with both neighbours at equal time steps within ``2 q`` (``q`` the printed step,
    each value within ``q/2`` of the number it stands for), moving, where ``q`` is finer than
    ``max_rounding_m`` (module docstring).
    """
    n = t.size
    out = np.zeros(n, bool)
    if n < 3:
        return out, 0.0
    tol = 2.0 * max(printed_step(lat), printed_step(lon))
    if tol * metres_per_degree > max_rounding_m:
        return out, 0.0
    dt = np.diff(t)
    out[1:-1] = (
        (dt[1:] == dt[:-1])
        & (np.abs(lat[2:] - 2.0 * lat[1:-1] + lat[:-2]) <= tol)
        & (np.abs(lon[2:] - 2.0 * lon[1:-1] + lon[:-2]) <= tol)
        & ((lat[2:] != lat[1:-1]) | (lon[2:] != lon[1:-1]))
    )
    return out, tol


def extrapolated(
    t: np.ndarray,
    lat: np.ndarray,
    lon: np.ndarray,
    state: np.ndarray,
    state_tol: np.ndarray,
    xyz: np.ndarray,
    max_speed: float,
) -> np.ndarray:
    """Positions extrapolated from a held state, (n,) bool (module docstring).

    ``state``: the sample's other columns, (n, k) (NaN where empty: an empty column is held
    when empty again), each repeated within its ``state_tol`` (k,) (what a conversion adds to
    a held value: a geoid height along the line). A sample is extrapolated when its state
    repeats the previous sample's and its position moves at the previous step's velocity
    (degrees per second) within ``q/Δt_k + q/Δt_(k-1)``, the most that rounding each of the
    three positions to ``q`` (the printed step of the latitudes and longitudes) changes the
    difference of the two; and when, for its run ``a..b`` of such samples, the next sample
    ``b + 1`` is further from ``b`` than ``max_speed`` (m/s) flies in their time apart while
    it is within that of the run's first fix ``a - 1`` and the sample after it, ``b + 2``, is
    within that of it (``xyz``: the samples' positions, (n, 3), m).
    """
    n = t.size
    out = np.zeros(n, bool)
    if n < 3 or state.shape[1] == 0:
        return out
    q = max(printed_step(lat), printed_step(lon))
    st = np.where(np.isnan(state), 0.0, state)
    empty = np.isnan(state)
    same_state = (np.abs(st[1:] - st[:-1]) <= state_tol) & (empty[1:] == empty[:-1])
    held = np.all(same_state, axis=1)  # sample k + 1 repeats sample k
    dt = np.diff(t)
    if np.any(dt <= 0.0):
        return out
    tol = q / dt[1:] + q / dt[:-1]
    same = np.ones(n - 2, bool)
    for x in (lat, lon):
        v = np.diff(x) / dt
        same &= np.abs(v[1:] - v[:-1]) <= tol
    cand = np.zeros(n, bool)
    cand[2:] = held[1:] & same & ((lat[2:] != lat[1:-1]) | (lon[2:] != lon[1:-1]))

    def reach(i: int, j: int) -> float:
        return float(np.linalg.norm(xyz[j] - xyz[i])) / (t[j] - t[i])

    for a, b in runs(cand):
        c = b + 1
        if (
            c < n
            and reach(b, c) > max_speed
            and reach(a - 1, c) <= max_speed
            and (c + 1 == n or reach(c, c + 1) <= max_speed)
        ):
            out[a : b + 1] = True
    return out


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Inclusive index ranges of the runs of True in ``mask``."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1) - 1))


def retimed_runs(
    channel: str,
    t: np.ndarray,
    lines: np.ndarray,
    tau: np.ndarray,
    sigma_tau: float,
    rejected: np.ndarray,
) -> list[Fault]:
    """Return the runs of kept fixes whose time error is beyond 3 σ of the log's (stamped late).

    ``tau`` (s): each fix's estimated time error; ``offset_m`` of the fault is then the largest
    time error times nothing (0): the fix is on the path once re-timed.
    """
    out = []
    for a, b in runs((np.abs(tau) > 3.0 * sigma_tau) & ~rejected):
        idx = np.arange(a, b + 1)
        j = idx[int(np.argmax(np.abs(tau[idx])))]
        out.append(
            Fault(
                channel,
                "re-timed",
                (int(lines[a]), int(lines[b])),
                float(t[a]),
                float(t[b]),
                int(b - a + 1),
                0.0,
                float(tau[j]),
            )
        )
    return out


def describe_faults(
    channel: str,
    t: np.ndarray,
    lines: np.ndarray,
    rejected: np.ndarray,
    offset: np.ndarray,
    distance_at: Callable[[np.ndarray, float], np.ndarray] | None = None,
    noise: float = 0.0,
    shifts: np.ndarray | None = None,
) -> list[Fault]:
    """Group the rejected samples of one channel into runs and say what each is.

    Parameters
    ----------
    channel : str
        The channel's name.
    t, lines : numpy.ndarray
        Times (s) and lines of the channel's samples, (m,).
    rejected : numpy.ndarray
        The samples rejected, (m,) bool.
    offset : numpy.ndarray
        Each sample's distance from the path, (m,).
    distance_at : callable, optional
        ``distance_at(idx, shift)``: the distances of the samples ``idx`` from the path at their
        times plus ``shift`` (s); given for positions, whose runs may be time-shifted.
    noise : float
        The channel's noise σ (a time-shifted run is within 3 σ of the shifted path).
    shifts : numpy.ndarray, optional
        The time shifts (s) tried.
    """
    out = []
    for a, b in runs(rejected):
        idx = np.arange(a, b + 1)
        kind, shift = ("outlier" if a == b else "displaced"), None
        if distance_at is not None and b > a and shifts is not None and shifts.size:
            med = np.array([np.median(distance_at(idx, s)) for s in shifts])
            j = int(np.argmin(med))
            if med[j] <= 3.0 * noise and shifts[j] != 0.0:
                kind, shift = "time-shifted", float(shifts[j])
        out.append(
            Fault(
                channel,
                kind,
                (int(lines[a]), int(lines[b])),
                float(t[a]),
                float(t[b]),
                int(b - a + 1),
                float(np.max(offset[idx])),
                shift,
            )
        )
    return out
