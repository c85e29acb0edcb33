"""Every flight of the public corpus flown as it was flown (issue 34).

Each piece of ``tests/data/corpus`` (the ``traffic`` package's sample flights by category and
100 pieces of its large collections: ``tests/data/corpus/README.md``) is flown through
:func:`fieldmap.nav.logs.load_flight` with the defaults (pressure altitudes) and checked
against what the aircraft itself reported, with :mod:`corpus_checks` (which reads only the
flown samples and the raw log):

- the flown ground speed within 5 % of what the aircraft reported when it flew it: at each
  instant, the larger of the log's robust top speed (the 99.5th percentile of its
  ``groundspeed`` column) and the speed reported there (the running median of three reports);
- the specific force inside the vehicle class's envelope (its load factor range);
- at least 95 % of the log's span flown;
- the heights of at least 99 % of the fixes within 3σ of the flown path (σ the height noise
  the conditioning estimated, floored at 1 m), take-off and landing included.

No piece is refused for a local defect and none raises anything but a one-line
:class:`~fieldmap.errors.InputError` for a log with nothing flyable. The pieces that do not
meet the checks yet are listed in ``known.json`` with what is in their data, as strict
expected failures: a piece that starts to meet them fails the run until it is taken off the
list.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from corpus_checks import check_piece

from fieldmap.errors import InputError
from fieldmap.nav.logs import load_flight

CORPUS = Path(__file__).parent / "data" / "corpus"
PIECES = json.loads((CORPUS / "manifest.json").read_text())["pieces"]
#: piece name -> why it does not meet the checks yet (what is in its data)
KNOWN: dict[str, str] = json.loads((CORPUS / "known.json").read_text())
#: pieces with nothing to fly, and why (a refusal is their right answer)
NOTHING_TO_FLY = {
    "calfire_a5eca1_01": "the aircraft never leaves a 30 m circle in its 300 fixes (parked)",
}


def _param(piece: dict) -> object:
    name = piece["name"]
    marks = []
    if name in KNOWN:
        marks.append(pytest.mark.xfail(strict=True, reason=KNOWN[name]))
    return pytest.param(piece, id=f"{piece['category']}/{name}", marks=marks)


@pytest.mark.slow
@pytest.mark.parametrize("piece", [_param(p) for p in PIECES])
def test_corpus_piece_flown_as_reported(piece):
    path = CORPUS / piece["category"] / f"{piece['name']}.csv.gz"
    if piece["name"] in NOTHING_TO_FLY:
        with pytest.raises(InputError, match="not a flight") as e:
            load_flight(path, height_ref="pressure")
        assert "\n" not in str(e.value)
        return
    _, cf = load_flight(path, height_ref="pressure")
    rep = cf.report
    sigma = max(rep["fit"]["sigma_v_m"], 1.0)
    chk = check_piece(
        path, cf.samples, sigma_h=sigma, height_time_sigma=rep["fit"]["height_time_sigma_s"]
    )
    lo, hi = rep["vehicle"]["load_factor_g"]
    why = chk.corpus_reasons(envelope=(lo, hi))
    assert not why, f"{rep['vehicle']['class']}: " + "; ".join(why)


def test_known_list_names_corpus_pieces():
    """Every exception is a corpus piece with a reason of one line."""
    names = {p["name"] for p in PIECES}
    assert set(KNOWN) <= names
    assert all(reason and "\n" not in reason for reason in KNOWN.values())


@pytest.mark.slow
def test_zero_gravity_flown_with_its_parabolas():
    """The Airbus parabolic flight is an airliner's, each parabola flown at the loads it flew.

    Issue 34: the specific force below 0.3 g at each parabola's top and at most 2.2 g at the
    pull-ups (the aircraft flies 1.8 g there). The parabolas are found in the log alone: each
    run of vertical rates over 15,000 ft/min, its top the highest altitude the log reports in
    the 40 s after the run.
    """
    import csv
    import gzip

    import numpy as np
    from corpus_checks import path_kinematics

    from fieldmap.nav.logs.read import read_track

    path = CORPUS / "featured" / "zero_gravity.csv.gz"
    _, cf = load_flight(path, height_ref="pressure")
    assert cf.report["vehicle"]["class"] == "airliner"
    log = read_track(path, height_ref="pressure", alt_units="ft")
    with gzip.open(path, "rt") as f:
        rate = {
            i: float(row["vertical_rate"])
            for i, row in enumerate(csv.DictReader(f), start=2)
            if row["vertical_rate"]
        }
    steep = np.array([rate.get(int(line), 0.0) > 15_000.0 for line in log.lines])
    idx = np.flatnonzero(steep)
    runs = np.split(idx, np.flatnonzero(np.diff(log.t[idx]) > 60.0) + 1)
    s = cf.samples
    t = s.t_start + s.t
    tops = []
    for run in runs:
        after = (log.t > log.t[run[-1]]) & (log.t <= log.t[run[-1]] + 40.0)
        if not after.any():
            continue
        t_top = log.t[after][np.argmax(log.h[after])]
        near = np.abs(t - t_top) <= 10.0
        tops.append(
            path_kinematics(s.t[near], s.lat[near], s.lon[near], s.h[near]).specific_force_min_g
        )
    assert len(tops) >= 30
    assert max(tops) < 0.3, tops
    whole = path_kinematics(s.t, s.lat, s.lon, s.h)
    assert whole.specific_force_max_g <= 2.2


@pytest.mark.slow
def test_a_spoofed_stretch_keeps_the_loads_and_says_the_speed_bound_did_not_hold():
    """``traffic``'s spoofing sample: positions that leap to a far, self-consistent stretch.

    The fit keeps them as fixes, so no path within the log's top ground speed passes near
    them: one forced towards them flew 46 g, beyond any airliner's acceleration. The path is
    the unbounded one, within the airliner's loads, and the report says the bound was not
    held.
    """
    from corpus_checks import path_kinematics

    _, cf = load_flight(CORPUS / "noisy" / "noisy_spoofing.csv.gz", height_ref="pressure")
    model = cf.report["model"]["horizontal"]
    assert model["top_speed_m_s"] is not None and not model["speed_bound_holds"]
    assert "could not be held" in cf.format_report()
    s = cf.samples
    k = path_kinematics(s.t, s.lat, s.lon, s.h)
    assert 0.3 <= k.specific_force_min_g and k.specific_force_max_g <= 1.8
