r"""Real flight logs made flyable: from a raw track to samples a :class:`FlightTrajectory` flies.

:class:`~fieldmap.nav.flight.FlightTrajectory` interpolates its samples exactly (a quintic
spline), so the metre-level noise of a real log becomes tens of g and a kilometre-level outlier
hundreds. :func:`condition` turns a raw track (an ADS-B or GNSS log as read by
:func:`fieldmap.nav.readers.read_track`) into clean, smooth samples on a regular grid, with the
vehicle's real kinematics, and a report of what it did (:attr:`ConditionedFlight.report`,
:meth:`ConditionedFlight.format_report`, :func:`plot_conditioning`).

Steps (the positions as the ECEF of the ellipsoid-surface point, no singularity at the poles or
the antimeridian; the heights on their own; :mod:`fieldmap.nav.conditioning_steps`,
:mod:`fieldmap.nav.conditioning_fit`)

1. **Order.** Non-finite samples are dropped (counted). Times that go back are sorted (stable;
   counted, the first line named) or, with ``reorder=False``, refused. Of samples sharing a
   time the first in the file is kept. A horizontal position repeated exactly while the vehicle
   moves is *stale* (a receiver re-sending its last position): its height is used, not it.
2. **Outliers**, per stretch without gaps, for positions (local east/north metres) and heights
   apart: a Hampel identifier (Hampel 1974) on the offsets from a robust local trend (running
   medians of the step velocities and of the detrended positions; Tukey 1977), beyond
   ``threshold`` (5) local robust standard deviations (1.4826 × MAD, widened by the 90th
   percentile for heavy-tailed noise) and at least 30 m (heights: 15 m and 3 quanta, so that
   25 ft steps are never outliers), iterated; runs longer than a burst (7 samples, 10 s) are
   motion, not outliers. Short runs between jumps (steps faster than ``max_speed_mps``,
   heights ``max_climb_mps``) are outliers too. A height held and then left faster than
   50 m/s was not updated (stale). Later, the robust fit rejects what is left (step 6).
3. **Breaks**: gaps longer than ``max_gap_s`` and jumps that are no short bursts (a displaced
   stretch: spoofing, a wrong altitude held for minutes) split the log into segments.
4. **Ground.** With ``airborne_only``, leading and trailing parts of each segment slower than
   ``min_speed_mps`` and within 30 m of the segment's first (last) height are trimmed.
5. **Segment.** ``on_long_gap="longest"`` (default) flies the longest segment and lists the
   others in the report; ``"refuse"`` raises an :class:`InputError` naming the first break.
   :func:`condition_segments` conditions each.
6. **Smoothing** on a regular grid (``dt_out``, default the median sample interval within
   0.1..1 s, extended past the data so that the ends are no free ends): a penalised
   least-squares path, the discrete cubic smoothing spline (Whittaker 1923, Reinsch 1967,
   Eilers 2003), with weights ``1/σ²`` and λ from the discrepancy principle: the residuals as
   large as the noise σ leaves them given the fit's degrees of freedom (Hutchinson's 1989
   trace estimate). σ is ``position_noise_m`` or estimated from leave-one-out cubic predictions
   (a local RMS: ADS-B noise grows with speed); heights quantised in ``q`` have at least
   ``q/√12`` and no noise in level flight. Iteratively reweighted (Tukey's bisquare; Garcia
   2010): samples beyond 4.685 robust σ are outliers. Gaps up to ``max_gap_s`` are bridged.
7. **Vehicle limits.** Where the path as flown (the quintic through the output) exceeds
   ``max_accel_g`` (2.5 g) or ``max_jerk`` (5 m/s³), the noise σ of the samples there is
   raised and the path refitted, until it keeps within them: stale or late ADS-B positions and
   the corners of resampled tracks demand more than an aircraft can do.

``smooth=False`` does step 1 only: today's exact interpolation of the ordered samples. Either
way a log whose vehicle never moves (within 30 m horizontally and 15 m vertically of one place)
is refused: it is no flight.

Messages that say what to change name the keyword arguments here, and the command-line options
when called from ``fieldmap navsim`` (:mod:`fieldmap.nav.spelling`).

The references (Hampel 1974, Tukey 1977, Theil 1950, Sen 1968, Whittaker 1923, Reinsch 1967,
Eilers 2003, Buja et al. 1989, Hutchinson 1989, Beaton & Tukey 1974, Garcia 2010) are given in
full in :mod:`fieldmap.nav.conditioning_fit`.
"""

from __future__ import annotations

import numpy as np

from fieldmap.errors import InputError
from fieldmap.field.ellipsoid import WGS84, Ellipsoid
from fieldmap.nav.conditioning_report import (
    STATUS_NAMES,
    ConditionedFlight,
    finish,
    format_report,
    kinematics,
    plot_conditioning,
)
from fieldmap.nav.conditioning_stages import Stages
from fieldmap.nav.spelling import keyword

__all__ = [
    "STATUS_NAMES",
    "ConditionedFlight",
    "condition",
    "condition_segments",
    "format_report",
    "kinematics",
    "plot_conditioning",
]


def condition(
    track,
    *,
    position_noise_m: float | tuple[float, float] | None = None,
    max_gap_s: float = 60.0,
    airborne_only: bool = True,
    smooth: bool = True,
    reorder: bool = True,
    on_long_gap: str = "longest",
    ellipsoid: Ellipsoid = WGS84,
    min_speed_mps: float = 30.0,
    max_speed_mps: float = 1200.0,
    max_climb_mps: float = 300.0,
    max_accel_g: float | None = 2.5,
    max_jerk: float | None = 5.0,
    threshold: float = 5.0,
    dt_out: float | None = None,
) -> ConditionedFlight:
    """Clean, smooth samples of a raw flight log, and a report of what was done.

    Parameters
    ----------
    track : RawTrack
        Anything with arrays ``t`` (s), ``lat``, ``lon`` (degrees), ``h`` (m above the
        ellipsoid) and ``lines``, and a ``source`` string (:class:`fieldmap.nav.readers.RawTrack`);
        its ``notes``, ``height_ref`` and ``t0_utc`` go into the report.
    position_noise_m : float or (float, float), optional
        Position noise σ (m): one value, or (horizontal, per axis; vertical). Default:
        estimated from the data.
    max_gap_s : float
        Longest interval without samples the smoothing bridges (s); longer ones split the log.
    airborne_only : bool
        Trim leading and trailing ground movement (slower than ``min_speed_mps``).
    smooth : bool
        False: only order the samples and drop repeated times (exact interpolation).
    reorder : bool
        Sort times that go back; False: refuse them (:class:`InputError` naming the line).
    on_long_gap : {"longest", "refuse"}
        More than one segment left (gaps, jumps): fly the longest (the report lists the
        others), or refuse naming the first break.
    ellipsoid : Ellipsoid
    min_speed_mps : float
        Ground speed below which a vehicle near its first (last) height is on the ground.
    max_speed_mps, max_climb_mps : float
        Horizontal and vertical speeds between consecutive samples beyond which one of them is
        wrong (m/s): a short run between such jumps is an outlier burst, a longer one a break.
    max_accel_g, max_jerk : float or None
        Limits of the vehicle: acceleration (g, relative to the Earth) and jerk (m/s³) the
        conditioned path keeps within (None: no limit).
    threshold : float
        Outlier threshold in robust standard deviations.
    dt_out : float, optional
        Output sample interval (s). Default: the median sample interval, within 0.1..1 s.

    Returns
    -------
    ConditionedFlight

    Raises
    ------
    InputError
        Times going back with ``reorder=False``; more than one segment with
        ``on_long_gap="refuse"``; nothing left to fly (all on the ground, too few samples);
        no flight (the vehicle never leaves a 30 m circle and a 15 m height band, also with
        ``smooth=False`` or ``airborne_only=False``), each in one line naming the source and
        its lines; an invalid option.
    """
    if on_long_gap not in ("longest", "refuse"):
        raise InputError(f"on_long_gap must be 'longest' or 'refuse', got {on_long_gap!r}")
    opts = _options(**{k: v for k, v in locals().items() if k not in ("track", "on_long_gap")})
    st = Stages(track, opts, reorder, ellipsoid)
    if not smooth:
        return finish(st, st.exact())
    ids = st.segment_ids()
    if on_long_gap == "refuse" and len(ids) > 1:
        st.refuse_break(ids)
    return finish(st, st.fit(st.longest(ids)))


def condition_segments(track, **kw) -> list[ConditionedFlight]:
    """Condition every segment of a log (gaps and jumps separate them), in time order.

    Keywords as :func:`condition` (``on_long_gap`` and ``smooth`` excepted); segments too short
    to fly are left out. Raises :class:`InputError` when none is left.
    """
    kw = {k: v for k, v in kw.items() if k not in ("on_long_gap", "smooth")}
    reorder, ellipsoid = kw.pop("reorder", True), kw.pop("ellipsoid", WGS84)
    st = Stages(track, _options(**kw), reorder, ellipsoid)
    out = []
    for s in st.segment_ids():
        try:
            out.append(finish(st, st.fit(s)))
        except InputError:
            continue
    if not out:
        st.nothing_left()
    return out


def _options(
    *,
    position_noise_m=None,
    max_gap_s=60.0,
    airborne_only=True,
    smooth=True,
    reorder=True,
    ellipsoid=WGS84,
    min_speed_mps=30.0,
    max_speed_mps=1200.0,
    max_climb_mps=300.0,
    max_accel_g=2.5,
    max_jerk=5.0,
    threshold=5.0,
    dt_out=None,
) -> dict:
    """Check the options of :func:`condition`; return them JSON-ready (for the report)."""
    for name, v, optional in (
        ("max_gap_s", max_gap_s, False),
        ("min_speed_mps", min_speed_mps, False),
        ("max_speed_mps", max_speed_mps, False),
        ("max_climb_mps", max_climb_mps, False),
        ("threshold", threshold, False),
        ("max_accel_g", max_accel_g, True),
        ("max_jerk", max_jerk, True),
        ("dt_out", dt_out, True),
    ):
        if not (optional and v is None) and not (
            isinstance(v, (int, float)) and np.isfinite(v) and v > 0
        ):
            raise InputError(f"{keyword(name) or name} must be a positive number, got {v!r}")
    sig = position_noise_m
    if sig is not None:
        try:
            sig = [float(x) for x in np.broadcast_to(np.asarray(sig, dtype=float), (2,))]
        except (TypeError, ValueError):
            sig = [np.nan]
        if not all(np.isfinite(x) and x > 0 for x in sig):
            raise InputError(
                f"{keyword('position_noise_m') or 'position_noise_m'} must be positive metres, "
                f"got {position_noise_m!r}"
            )
    return {
        "position_noise_m": sig,
        "max_gap_s": float(max_gap_s),
        "airborne_only": bool(airborne_only),
        "smooth": bool(smooth),
        "min_speed_mps": float(min_speed_mps),
        "max_speed_mps": float(max_speed_mps),
        "max_climb_mps": float(max_climb_mps),
        "max_accel_g": None if max_accel_g is None else float(max_accel_g),
        "max_jerk": None if max_jerk is None else float(max_jerk),
        "threshold": float(threshold),
        "dt_out": None if dt_out is None else float(dt_out),
    }
