"""Flight logs as they come, made flyable: read, conditioned, reported.

The path of a user's log, one module per step:

1. :mod:`~fieldmap.nav.logs.read`: a CSV file (any column layout, ADS-B exports), a table
   (DataFrame, Dataset, arrays) or, through :mod:`~fieldmap.nav.logs.gnss`, a GPX, NMEA 0183
   or IGC file, read as it comes (:func:`~fieldmap.nav.logs.read.read_track`): one meaning
   for every source, heights made ellipsoidal, units checked; the result is a
   :class:`~fieldmap.nav.logs.track.RawTrack` (:mod:`~fieldmap.nav.logs.track`: the records
   a reader fills).
2. :mod:`~fieldmap.nav.logs.condition`: order, stale values, outliers, breaks, ground, then
   the robust smoothing fit of :mod:`~fieldmap.nav.logs.fit` within the vehicle's limits
   (:func:`~fieldmap.nav.logs.condition.condition`).
3. :mod:`~fieldmap.nav.logs.report`: what was done, and the kinematics of the path that will
   be flown (:class:`~fieldmap.nav.logs.report.ConditionedFlight`, text and figure).
4. :mod:`~fieldmap.nav.logs.load`: all three, and the
   :class:`~fieldmap.nav.flight.FlightTrajectory` that a flight study flies
   (:func:`~fieldmap.nav.logs.load.load_flight`, what ``fieldmap navsim --trajectory`` calls).

Messages name the keyword arguments of these functions ("pass airborne_only=False to keep
ground movement", "60 s (max_gap_s)"), and an :class:`~fieldmap.errors.InputError` about one
carries its name as ``param``. The command line rewords them with its options from one table
(:mod:`fieldmap.cli.params`).
"""
