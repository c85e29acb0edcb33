"""The flight study's figures and text report, as a user opens them (issue 36).

Every figure the command line writes is opened as an image: a fixed size whatever the flight
and its recommendation, the title and every text inside the canvas, no log axis over 8
decades, a legend and a caption saying what is drawn. The error budget's bars are sorted and
hold the gravity terms (a), (b), (c) beside the IMU's sources, with the values of the results
they are drawn from. The text report has a unit under every column, opens a GNSS study with
its coasting errors, and says when the 10 % rule rests on few draws.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from fieldmap.cli import main
from fieldmap.errors import InputError
from fieldmap.nav.aiding import GnssSpec
from fieldmap.nav.report import format_covariance, format_flight
from fieldmap.nav.study import FlightStudy, run_flight

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.legend import Legend  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402
from matplotlib.text import Text  # noqa: E402
from PIL import Image  # noqa: E402

ROUTE = "47,8,800;47.3,8.8,800"
#: the 13 error sources of a navigation-grade IMU with a baro altimeter
SOURCES = 13


def _study(**kw):
    opts = dict(
        speed_mps=150, imu="navigation", imu_name="navigation", models="j2,j4,sh20",
        truth_lmax=20, rate_hz=10, duration=300.0, altitude_aiding="baro", seed=1, draws=3,
    )  # fmt: skip
    opts.update(kw)
    return FlightStudy(ROUTE, **opts)


@pytest.fixture(scope="module")
def mc():
    return run_flight(_study())


@pytest.fixture(scope="module")
def mc20():
    return run_flight(_study(draws=20))


@pytest.fixture(scope="module")
def cov():
    return run_flight(_study(method="covariance", draws=20))


@pytest.fixture(scope="module")
def aided_cov():
    return run_flight(_study(method="covariance", draws=20, gnss=GnssSpec(outages="60:60,150:100")))


# --------------------------------------------------------------------------- what a figure shows
def _all_axes(fig):
    return [a for a in fig.findobj(Axes)]


def _check_readable(fig):
    """Title and all texts inside the canvas; log axes ≤ 8 decades; a legend and a caption."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    box = fig.bbox
    # everything drawn (axes with their tick labels, legends, texts) lies inside the canvas
    tight = fig.get_tightbbox(r).transformed(fig.dpi_scale_trans)  # inches -> pixels
    assert tight.x0 >= box.x0 - 1 and tight.y0 >= box.y0 - 1, (tight, box)
    assert tight.x1 <= box.x1 + 1 and tight.y1 <= box.y1 + 1, (tight, box)
    titles = [t for t in fig.findobj(Text) if t.get_text() and t.get_fontweight() == "bold"]
    assert titles, "no title"
    for t in titles:
        e = t.get_window_extent(r)
        assert box.x0 <= e.x0 and e.x1 <= box.x1 and box.y0 <= e.y0 and e.y1 <= box.y1, e
        assert len(t.get_text()) < 120  # a short title: the recommendation is the caption
    for ax in _all_axes(fig):
        for lo, hi, scale in (
            (*ax.get_ylim(), ax.get_yscale()), (*ax.get_xlim(), ax.get_xscale()),
        ):  # fmt: skip
            if scale == "log":
                assert np.log10(hi / lo) <= 8.0, (ax.get_title(loc="left"), lo, hi)
    assert fig.findobj(Legend), "no legend"
    texts = " ".join(t.get_text() for t in fig.findobj(Text))
    assert "Recommendation (10% rule):" in texts
    return texts


def _png_size(path):
    with Image.open(path) as im:
        return im.size


def test_monte_carlo_figures_are_readable(mc):
    for kind in ("errors", "budget", "track"):
        fig = mc.plot(kind)
        try:
            assert isinstance(fig, Figure)
            if kind == "track":  # a map: its own title, a legend, degrees of latitude
                fig.canvas.draw()
                assert fig.findobj(Legend) and "ground track" in fig.axes[0].get_title()
                continue
            texts = _check_readable(fig)
            if kind == "errors":
                # 3 draws: medians, no 5-95 % band, and the caption and the legend say so
                assert "Lines: medians over the 3 draws (no 5–95 % band" in texts
                assert "line: median over 3 draws" in texts
                assert all(len(ax.collections) == 0 for ax in fig.axes[:2])
        finally:
            plt.close(fig)


def test_bands_from_twenty_draws(mc20):
    fig = mc20.plot()
    try:
        texts = _check_readable(fig)
        assert "shaded bands: their 5th to 95th percentile" in texts
        rows = len(set(mc20.models))  # imu_only and each model: one band each
        for ax in fig.axes[:2]:
            assert len(ax.collections) == rows
            # the band holds 90 % of the draws: at the flight's end, between the 5th and 95th
            # percentile of the final horizontal (vertical) errors of the IMU-only runs
        band = fig.axes[0].collections[0].get_paths()[0].vertices
        d = mc20.dpos[np.array(mc20.models) == "imu_only", -1]
        h = np.hypot(d[:, 0], d[:, 1])
        at_end = band[np.isclose(band[:, 0], mc20.t[-1] / 60.0), 1]
        np.testing.assert_allclose(np.sort(at_end)[[0, -1]], np.percentile(h, [5, 95]), rtol=1e-9)
    finally:
        plt.close(fig)


def test_thirteen_sources_have_their_own_styles(cov):
    fig = cov.plot()
    try:
        _check_readable(fig)
        assert len(cov.covariance.sources) == SOURCES
        for ax in fig.axes[:2]:
            lines = {ln.get_label(): ln for ln in ax.get_lines()}
            styles = [
                (matplotlib.colors.to_hex(lines[s].get_color()), lines[s].get_linestyle())
                for s in cov.covariance.sources
            ]
            assert len(set(styles)) == SOURCES, styles
            # what each line is: the source's horizontal σ (N, E together) of the covariance
            y = lines["gyro bias"].get_ydata()
            if ax is fig.axes[0]:
                np.testing.assert_allclose(y, cov.covariance.horizontal("gyro bias"), rtol=1e-12)
    finally:
        plt.close(fig)


def _bars(fig):
    """Return the budget's bars from the top: (label, value at the bar's right end)."""
    ax = fig.axes[0]
    rects = sorted((p for p in ax.patches if isinstance(p, Rectangle)), key=lambda p: -p.get_y())
    labels = {round(t): lab.get_text() for t, lab in zip(ax.get_yticks(), ax.get_yticklabels())}
    return [(labels[round(p.get_y() + p.get_height() / 2)], p.get_x() + p.get_width())
            for p in rects]  # fmt: skip


@pytest.mark.parametrize("which", ["mc", "cov"])
def test_budget_bars_sorted_with_the_gravity_terms(which, request):
    res = request.getfixturevalue(which)
    fig = res.plot("budget")
    try:
        _check_readable(fig)
        bars = _bars(fig)
        ends = [v for _, v in bars]
        assert ends == sorted(ends, reverse=True)
        labels = [lab for lab, _ in bars]
        for term in ("(a) model difference, j2", "(b) omission", "(c) commission"):
            assert any(lab.startswith(term) for lab in labels), (term, labels)
        # the values are those of the results, at the flight's end
        g = res.budget.summary("j2")["horizontal_terms_m"]
        value = dict(bars)
        assert value["(a) model difference, j2"] == pytest.approx(g["model_difference"])
        om = next(v for lab, v in bars if lab.startswith("(b) omission"))
        assert om == pytest.approx(g["omission"])
        if which == "cov":  # every IMU and baro source beside the gravity terms
            assert {s for s in res.covariance.sources} <= set(labels)
            assert value["gyro bias"] == pytest.approx(res.covariance.horizontal("gyro bias")[-1])
        else:  # the Monte Carlo: all sources together, the RMS of the IMU-only draws
            d = res.dpos[np.array(res.models) == "imu_only", -1, :2]
            mc_bar = next(v for lab, v in bars if lab.startswith("all sources: Monte Carlo"))
            assert mc_bar == pytest.approx(np.sqrt(np.mean(np.sum(d * d, -1))))
    finally:
        plt.close(fig)


def test_aided_budget_at_the_end_of_the_worst_outage(aided_cov):
    fig = aided_cov.plot("budget")
    try:
        texts = _check_readable(fig)
        assert "error budget at the end of the worst GNSS outage (150–250 s)" in texts
        value = dict(_bars(fig))
        i = int(np.argmin(np.abs(aided_cov.t - 250.0)))
        total = aided_cov.covariance.horizontal()[i]
        assert value["all sources: root sum of squares"] == pytest.approx(total)
        assert total > 3 * aided_cov.covariance.horizontal()[-1]  # coasting, not aided
        assert "GNSS noise" in value
    finally:
        plt.close(fig)


def test_plot_refuses_an_unknown_kind(mc):
    with pytest.raises(InputError, match="kind must be one of errors, budget, track") as e:
        mc.plot("map")
    assert e.value.param == "kind"


# ----------------------------------------------------------------------------- the files written
FAST = ["navsim", "--route", ROUTE, "--speed-mps", "150", "--imu", "navigation", "--models",
        "j2,sh20", "--lmax", "20", "--rate", "10", "--duration", "300"]  # fmt: skip


def test_cli_figures_have_fixed_sizes(tmp_path, capsys):
    short, long_ = tmp_path / "short", tmp_path / "long"
    assert main([*FAST, "--draws", "3", "--out", str(short)]) == 0
    # a GNSS study with outages: a recommendation three lines long, the figures the same size
    assert main([*FAST, "--draws", "3", "--gnss-outage", "60:60,150:100", "--out", str(long_)]) == 0
    capsys.readouterr()
    for name, (w, h) in (
        ("navsim_flight.png", (1560, 1170)),
        ("navsim_flight_budget.png", (1430, 1040)),
        ("navsim_flight_track.png", (975, 845)),
    ):
        for folder in (short, long_):
            pw, ph = _png_size(folder / name)
            # the tight bounding box trims or pads by a few pixels, never more
            assert abs(pw - w) <= 40 and abs(ph - h) <= 130, (folder.name, name, pw, ph)
        assert _png_size(short / name) == pytest.approx(_png_size(long_ / name), abs=12)


# ------------------------------------------------------------------------------- the text report
def test_report_units_and_few_draws(mc, mc20):
    text = format_flight(mc)
    lines = text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("model "))
    names, units = lines[k], lines[k + 1]
    for col in ("horiz rms", "|dv| rms", "gravity horiz", "(b) omission", "(c) commission"):
        assert col in names
    # a unit under the end of every column's name
    assert units.split() == ["m", "m", "m", "m/s", "m", "m", "m", "m", "m"]
    assert all(names[u.end() - 1] != " " for u in re.finditer(r"\S+", units))
    assert "caution: the 10% rule compares with the IMU-only RMS of 3 draw(s)" in text
    assert "caution" not in format_flight(mc20)


def test_report_of_an_aided_study_opens_with_coasting(aided_cov):
    text = format_covariance(aided_cov)
    lines = text.splitlines()
    first = next(i for i, ln in enumerate(lines) if ln.startswith("coasting (horiz m)"))
    table = next(i for i, ln in enumerate(lines) if ln.startswith("error source"))
    assert first < table
    assert "error sources at the end of the worst GNSS outage (150–250 s)" in text
    i = int(np.argmin(np.abs(aided_cov.t - 250.0)))
    row = next(ln for ln in lines if ln.startswith("all sources (root sum of squares)"))
    assert float(row.split()[-4]) == pytest.approx(aided_cov.covariance.horizontal()[i], abs=5e-4)
    # the sources' σ at the outage's end are not the aided flight's end's
    assert float(row.split()[-4]) > 3 * float(row.split()[-2])
