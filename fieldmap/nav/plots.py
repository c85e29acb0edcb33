"""Figures of the navigation studies: the paper's Figs. 11-13 and the flight study's figures.

**The paper's studies** (Chen et al. 2022 §5, Tables 1, 3, 4): two columns (position error,
velocity error) and two rows:

- top: the error norms over time on a log scale, one line per navigation case, each with its own
  colour, line style and marker (the J4, J6 and exact-normal curves of Fig. 11 coincide to the
  eye, so colour alone would not tell them apart); Monte Carlo cases show the median over the
  draws and, from :data:`MIN_BAND_DRAWS` draws, a shaded 5th-95th percentile band; the paper's
  values at 800 s are drawn as hollow markers where the run covers 800 s;
- bottom: each case relative to a reference case, which makes the small differences the paper
  discusses visible: Table 1, ``| |δx_Jn| / |δx_exact| − 1 |`` for the truncated normal models
  against the exact normal field; Table 3, the ratio to group 4 (no accelerometer error);
  Table 4, the ratio to the IMU-only case, paired by draw.

:func:`make_figure` returns the :class:`matplotlib.figure.Figure` of a study; :func:`plot`
writes it as PNG.

**The flight study** (:mod:`fieldmap.nav.study`, no paper values: a user's flight is not the
paper's boost-glide path), each figure of a fixed size (:data:`FIGURE_SIZE`) with a short title
and a caption below the plots (the set-up, what the lines are, the recommendation):

- :func:`errors_figure` (Monte Carlo) and :func:`sigma_figure` (covariance analysis): the
  position errors over time, per navigation model or per error source, with the gravity terms;
- :func:`budget_figure`: the error budget, one bar per error source at the flight's end (or the
  worst GNSS outage's), the gravity terms (a), (b), (c) beside the IMU's sources;
- :func:`track_figure`: the ground track over the truth's disturbance.

``FlightResult.plot(kind)`` and ``CovarianceStudyResult.plot(kind)`` draw them
(:func:`flight_figure`); log axes show :data:`LOG_DECADES` decades below their largest value.
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterable, Mapping, Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fieldmap.products import coastline

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure, SubFigure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from fieldmap.models.shmodel import SHModel

#: a flight study's results (fieldmap.nav.study.FlightResult, Monte Carlo: its draws' errors in
#: ``dpos``; fieldmap.nav.covariance.CovarianceStudyResult), whose plot() draws with this
#: module: named here without importing them, so the modules stay acyclic
FlightResult = Any
CovarianceStudyResult = Any
#: the paper study's result (fieldmap.nav.paper.StudyResult), likewise
StudyResult = Any


def _monte_carlo(res: Any) -> bool:
    """Tell a Monte Carlo flight result (its draws' errors, ``dpos``) from a covariance one."""
    return hasattr(res, "dpos")


__all__ = [
    "FIGURE_SIZE", "KINDS", "LOG_DECADES", "MIN_BAND_DRAWS", "at_paper_duration", "budget_bars",
    "budget_figure", "budget_moment", "disturbance_grid", "errors_figure", "flight_figure",
    "make_figure", "model_label", "plot", "short_label", "sigma_figure", "source_styles",
    "track_aspect", "track_figure", "track_view",
]  # fmt: skip

#: (colour, line style, marker) of a curve
_Style = tuple[str, Any, str | None]

#: (colour, line style, marker) per Table 1 navigation model; Okabe-Ito colours (colour-blind safe)
MODEL_STYLE = {
    "j2": ("#D55E00", "-", "o"),
    "j4": ("#0072B2", "--", "s"),
    "j6": ("#009E73", ":", "^"),
    "exact": ("#CC79A7", "-.", "D"),
    "sh18": ("#E69F00", "-", "v"),
    "sh200": ("#56B4E9", (0, (5, 1, 1, 1)), "P"),
}
#: fallback styles for other cases, in order of appearance
CYCLE = (
    ("#D55E00", "-", "o"),
    ("#0072B2", "--", "s"),
    ("#009E73", ":", "^"),
    ("#CC79A7", "-.", "D"),
    ("#E69F00", (0, (5, 1, 1, 1)), "v"),
    ("#56B4E9", (0, (3, 1, 1, 1, 1, 1)), "P"),
    ("#F0E442", "-", "X"),
)
FLOOR_STYLE = ("0.35", (0, (1, 1.5)), None)
NORMAL_FAMILY = ("j2", "j4", "j6", "exact")
PANELS = (
    ("pos", "position error |δp| (m)", "m"),
    ("vel", "velocity error |δv| (m/s)", "m/s"),
)
TIME_LABEL = "time since launch (s)"
NOTE = dict(xytext=(4, 0), textcoords="offset points", va="center", fontsize=8)
#: fewest draws for a 5th-95th percentile band. With n draws the empirical 5th and 95th
#: percentiles lie between the extreme draws until n × 5 % reaches 1 (below 20 draws not even
#: one draw is expected beyond either edge): fewer draws would shade their range, not a 5–95 %
#: band. The flight study's default (20 draws) draws it.
MIN_BAND_DRAWS = 20
#: decades a log axis shows below the largest value it holds (its top margin adds 0.2)
LOG_DECADES = 6


def model_label(name: str, meta: dict) -> str:
    """Display name of a navigation gravity model (``j2 j4 j6 exact shN``)."""
    if name in ("j2", "j4", "j6"):
        return f"J{name[1]} normal gravity (WGS84)"
    if name == "exact":
        return "exact normal gravity (WGS84, closed form)"
    if name.startswith("sh"):
        return f"{meta['truth_model']} to degree {name[2:]}"
    return name


def short_label(name: str, meta: dict) -> str:
    """Short display name (no ellipsoid): ``J4 normal gravity``, ``EIGEN-6S degree 18``."""
    if name.startswith("sh"):
        return f"{meta['truth_model']} degree {name[2:]}"
    return model_label(name, meta).split(" (")[0]


def _context(meta: dict) -> str:
    return (
        f"truth {meta['truth_model']} to degree {meta['truth_degree']} · "
        f"{meta['trajectory']} trajectory, {meta['duration_s']:g} s, launch-centred inertial "
        f"frame · IMU {meta['imu_rate_hz']:g} Hz ({meta['n_gauss']} Gauss nodes per sample)"
    )


def _groups(labels: Iterable[str]) -> dict[str, list[int]]:
    """Run indices by case (the part of a run label before ``/``), in order of appearance."""
    out: dict[str, list[int]] = {}
    for i, lab in enumerate(labels):
        out.setdefault(lab.split("/")[0], []).append(i)
    return out


def _line(
    ax: Axes,
    t: npt.NDArray[np.float64],
    y: npt.ArrayLike,
    style: _Style,
    label: str | None,
    k: int,
    n_lines: int,
    **kw: Any,
) -> Line2D:
    """One curve; markers every ~1/8 of the run, staggered between curves so they don't overlap."""
    colour, ls, marker = style
    step = max(1, len(t) // 8)
    return ax.plot(
        t,
        y,
        color=colour,
        ls=ls,
        lw=kw.pop("lw", 1.6),
        marker=marker,
        markevery=(int(k * step / max(n_lines, 1)) + step // 4, step),
        ms=5,
        mfc="white" if marker else None,
        label=label,
        **kw,
    )[0]


def _paper_marks(
    ax: Axes, t_end: float, values: Mapping[str, float], styles: Mapping[str, _Style]
) -> None:
    """Hollow markers for the paper's values (``{case: value}``) in a column right of ``t_end``.

    Each case gets its own x position (staggered by 3.5 % of the run), so that markers of
    nearly equal values (the paper's J4 and J6) and the ends of our curves never overlap; a
    dotted line marks where the run ends and the paper's column begins.
    """
    # right of the value labels that the lower panels print at t_end
    ax.axvline(t_end * 1.14, color="0.6", lw=0.8, ls=":", zorder=0)
    for k, (case, v) in enumerate(values.items()):
        colour, _, marker = styles[case]
        x = t_end * (1.17 + 0.04 * k)
        ax.plot([x], [v], ls="none", marker=marker or "o", ms=9, mfc="none", mec=colour, mew=1.8)
    ax.set_xlim(right=max(ax.get_xlim()[1], t_end * (1.2 + 0.04 * len(values))))
    # no time ticks over the paper's column: it is not a time axis there
    ax.set_xticks([x for x in ax.get_xticks() if 0.0 <= x <= t_end * 1.001])


def _finish(
    fig: Figure,
    axes: np.ndarray,
    title: str,
    subtitle: str,
    handles: list[Any],
    ncol: int,
    bottom: str | None = None,
    log_bottom: bool = True,
) -> None:
    """Scales, labels, panel titles ((a), (b): errors; (c), (d): ``bottom``), title, legend."""
    for ax, (_, ylab, _) in zip(axes[0], PANELS):
        ax.set_yscale("log")
        ax.set_ylabel(ylab)
    for ax in axes.ravel():
        ax.grid(True, which="major", alpha=0.35)
        ax.grid(True, which="minor", alpha=0.12)
    for ax in axes[-1]:
        ax.set_xlabel(TIME_LABEL)
        if log_bottom and ax.get_yscale() != "log":
            ax.set_yscale("log")
    names = ["position error", "velocity error"] + [bottom or ""] * 2
    for ax, tag, name in zip(axes.ravel(), "abcd", names):
        ax.set_title(f"({tag}) {name}", loc="left", fontsize=9.5)
    width = fig.get_figwidth() - 0.4  # the title wrapped to the canvas, never cut at its edges
    fig.suptitle(_wrap(title + "\n" + subtitle, width, 10.5), fontsize=10.5)
    fig.legend(handles=handles, loc="outside lower center", ncol=ncol, fontsize=8.5, frameon=False)


def _figure(n_rows: int) -> tuple[Figure, np.ndarray]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    height = (4.0 if n_rows == 1 else 7.4) + 1.6
    fig, axes = plt.subplots(
        n_rows, 2, figsize=(12.5, height), sharex=True, squeeze=False, layout="constrained"
    )
    return fig, axes


def _assign_styles(keys: Sequence[str], preferred: Mapping[str, _Style]) -> dict[str, _Style]:
    """Give each key a distinct (colour, line style, marker): ``preferred[key]`` or a free one."""
    out, used = {}, set()
    for key in keys:
        if key in preferred and preferred[key][0] not in used:
            out[key] = preferred[key]
            used.add(out[key][0])
    for key in keys:
        if key not in out:
            out[key] = next((s for s in CYCLE if s[0] not in used), CYCLE[len(out) % len(CYCLE)])
            used.add(out[key][0])
    return out


def _ratio(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Return a / b where b > 0, NaN elsewhere (the errors are 0 at launch)."""
    return np.divide(a, b, out=np.full(np.broadcast(a, b).shape, np.nan), where=b > 0)


def _proxy(**kw: Any) -> Line2D:
    from matplotlib.lines import Line2D

    return Line2D([], [], **kw)


def at_paper_duration(meta: Mapping[str, Any]) -> bool:
    """Whether a study ran the paper's 800 s (only then are the paper's values shown)."""
    return abs(meta["duration_s"] - 800.0) < 0.5


def _paper_proxy(table: str, extra: str = "") -> Line2D:
    label = f"right of the dotted line: Chen et al. (2022) {table}, 800 s, truth EIGEN-6C4{extra}"
    return _proxy(ls="none", marker="o", ms=9, mfc="none", mec="k", mew=1.6, label=label)


def _mc_context(meta: dict) -> str:
    return (
        f"{meta['draws']} Monte Carlo draws per case (seed {meta['seed']}, "
        f"constant errors drawn per run: {meta['bias_mode']})"
    )


def _is_table4(spec: dict) -> bool:
    """Whether an IMU spec (as a dict) is the paper's Table 4 unit."""
    from fieldmap.nav.sensors import TABLE4

    return all(spec.get(k) == v for k, v in TABLE4.__dict__.items())


def _imu_grade(spec: dict) -> str:
    grade = "IMU grade (Table 4, 1σ)" if _is_table4(spec) else "IMU (1σ)"
    return (
        f"{grade}: gyro bias {spec['gyro_bias_deg_per_h']:g} °/h, angle random walk "
        f"{spec['gyro_arw_deg_per_sqrt_h']:g} °/√h, scale factor "
        f"{spec['gyro_scale_factor_ppm']:g} ppm, misalignment "
        f"{spec['gyro_misalignment_arcsec']:g}″\naccelerometer bias {spec['accel_bias_ug']:g} µg, "
        f"white noise {spec['accel_vrw_ug_per_sqrt_hz']:g} µg/√Hz, scale factor "
        f"{spec['accel_scale_factor_ppm']:g} ppm, misalignment "
        f"{spec['accel_misalignment_arcsec']:g}″"
    )


def _band(
    ax: Axes,
    t: npt.NDArray[np.float64],
    runs: npt.NDArray[np.float64],
    style: _Style,
    label: str | None,
    k: int,
    n_lines: int,
    band_label: str | None = None,
    lw: float = 1.6,
) -> Line2D:
    """Median line of ``runs`` (draws × time) and, from :data:`MIN_BAND_DRAWS` draws, its band.

    The band is the 5th to 95th percentile over the draws; one run: the line alone.
    """
    if runs.shape[0] == 1:
        return _line(ax, t, runs[0], style, label, k, n_lines, lw=lw)
    line = _line(ax, t, np.median(runs, 0), style, label, k, n_lines, lw=lw)
    if runs.shape[0] >= MIN_BAND_DRAWS:
        ax.fill_between(
            t,
            np.percentile(runs, 5, 0),
            np.percentile(runs, 95, 0),
            color=style[0],
            alpha=0.18,
            lw=0,
            label=band_label,
        )
    return line


def _plain_log_ticks(ax: Axes) -> None:
    """Log axis of ratios labelled 0.5, 1, 2, 5 instead of 5×10⁻¹, 10⁰ ..."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())


def _band_proxy(n: int) -> Artist:
    """Legend entry saying what the lines (and the bands, if drawn) of ``n`` draws are."""
    if n >= MIN_BAND_DRAWS:
        from matplotlib.patches import Patch

        return Patch(
            color="0.5",
            alpha=0.3,
            label=f"shaded: 5th–95th percentile over {n} draws, line: median",
        )
    return _proxy(
        color="0.3",
        label=f"line: median over {n} draws (no 5–95 % band below {MIN_BAND_DRAWS} draws)",
    )


def _mc(
    res: StudyResult,
    cases: Sequence[str],
    styles: Mapping[str, _Style],
    labels: Mapping[str, str],
    ref: str | None,
    paper: Mapping[str, Sequence[float]],
    text: tuple[str, str, str, str],
) -> Figure:
    """Monte Carlo figure: medians and bands (top), ratios to case ``ref`` (bottom).

    ``cases`` are the run-label prefixes in plotting order; ``paper`` maps a case to the paper's
    (|δv|, |δp|) at 800 s; ``text`` is (title, subtitle, lower panels' title, reference name).
    Ratios are taken run by run: a case with as many runs as ``ref`` is
    paired draw by draw (the same error draw), a one-run ``ref`` divides every run.
    """
    meta, t = res.meta, res.t[1:]
    groups = _groups(res.labels)
    fig, axes = _figure(2 if ref else 1)
    n = len(cases)
    handles: list[Artist] = []
    for k, c in enumerate(cases):
        for ax, (key, _, _) in zip(axes[0], PANELS):
            h = _band(ax, t, getattr(res, key)[groups[c], 1:], styles[c], labels[c], k, n)
        handles.append(h)
        if not ref:
            continue
        for ax, (key, _, _) in zip(axes[1], PANELS):
            data = getattr(res, key)
            if c == ref:
                ax.axhline(1.0, color=styles[c][0], ls=styles[c][1], lw=1.6)
                continue
            num, den = data[groups[c], 1:], data[groups[ref], 1:]
            if den.shape[0] not in (1, num.shape[0]):
                raise ValueError(f"cannot pair {num.shape[0]} runs of {c} with {ref}")
            _band(ax, t, _ratio(num, den), styles[c], None, k, n)
    draws = max(len(v) for v in groups.values())
    if draws > 1:
        handles.append(_band_proxy(draws))
    if paper and at_paper_duration(meta):
        for ax, col in zip(axes[0], (1, 0)):
            _paper_marks(ax, res.t[-1], {c: v[col] for c, v in paper.items()}, styles)
        if ref is not None and ref in paper:
            for ax, col in zip(axes[1], (1, 0)):
                ratios = {c: v[col] / paper[ref][col] for c, v in paper.items() if c != ref}
                _paper_marks(ax, res.t[-1], ratios, styles)
        handles.append(_paper_proxy("Table 3", "; (c), (d): its ratios"))
    if ref:
        for ax, (key, _, _) in zip(axes[1], PANELS):
            q = "p" if key == "pos" else "v"
            _plain_log_ticks(ax)
            sym = f"$|\\delta {q}|\\,/\\,|\\delta {q}|_{{\\rm ref}}$"
            ax.set_ylabel(f"ratio to {text[3]}\n{sym} (–)")
    _finish(fig, axes, text[0], text[1], handles, 1, bottom=text[2])
    return fig


def _table3(res: StudyResult) -> Figure:
    from fieldmap.nav.paper_tables import PAPER_TABLE3

    meta = res.meta
    rows = {f"group{r['group']}": r for r in res.rows}
    cases = list(_groups(res.labels))
    styles = _assign_styles(cases, dict(zip(("group1", "group2", "group3", "group4"), CYCLE)))
    nav = short_label(meta["nav_gravity"], meta)
    labels, ref = {}, None
    for c in cases:
        r = rows[c]
        if r["accel_bias_ug"] == 0 and r["accel_vrw_ug_per_sqrt_hz"] == 0:
            what = f"no accelerometer error (gravity-model error of {nav} only)"
            ref = ref or c
        else:
            what = (
                f"accelerometer bias {r['accel_bias_ug']:g} µg, noise "
                f"{r['accel_vrw_ug_per_sqrt_hz']:g} µg/√Hz (1σ)"
            )
        stat = "median" if r["draws"] > 1 else "single run"
        labels[c] = (
            f"group {r['group']}: {what} — {stat} {r['final_position_error_m_p50']:.2f} m, "
            f"{r['final_velocity_error_m_s_p50']:.3f} m/s at {res.t[-1]:g} s"
        )
    paper = {f"group{g}": v for g, v in PAPER_TABLE3.items() if f"group{g}" in cases}
    if meta["nav_gravity"] != "j4":
        paper = {}  # the paper's Table 3 is for J4
    refname = f"group {rows[ref]['group']}" if ref else ""
    text = (
        f"Fig. 12 / Table 3 — navigation with {nav} plus the accelerometer errors of "
        "Table 2 (groups 1–4; gyros error-free)",
        _context(meta) + "\n" + _mc_context(meta) + " (group 4 has no random error: one run)",
        f"ratio to {refname} (same gravity-model error, no accelerometer error)",
        refname,
    )
    return _mc(res, cases, styles, labels, ref, paper, text)


def _table4(res: StudyResult) -> Figure:
    meta = res.meta
    rows = {r["case"]: r for r in res.rows}
    cases = list(_groups(res.labels))
    pref = {
        c: MODEL_STYLE[rows[c]["nav_gravity"]]
        for c in cases
        if rows[c]["gravity_model_error"] and rows[c]["nav_gravity"] in MODEL_STYLE
    }
    pref["imu_only"] = ("0.15", "-", "o")
    styles = _assign_styles(cases, pref)
    labels = {}
    for c in cases:
        r, m = rows[c], short_label(rows[c]["nav_gravity"], meta)
        what = (
            f"IMU errors + gravity-model error of {m}"
            if r["gravity_model_error"]
            else f"IMU errors only (navigation with {m} on IMU data generated with {m})"
        )
        labels[c] = (
            f"{what} — median {r['final_position_error_m_p50']:.2f} m, "
            f"{r['final_velocity_error_m_s_p50']:.3f} m/s at {res.t[-1]:g} s"
        )
    ref = "imu_only" if "imu_only" in cases else None
    sub = f"{_context(meta)}\n{_mc_context(meta)}; the same draws in every case\n"
    text = (
        ("Fig. 13 / Table 4 — " if _is_table4(meta["imu_errors"]) else "")
        + "navigation error from the full IMU error model, with and without "
        "the gravity-model error",
        sub + _imu_grade(meta["imu_errors"]),
        "ratio to the IMU-only case, draw by draw (the same IMU error draw)",
        "IMU errors only",
    )
    return _mc(res, cases, styles, labels, ref, {}, text)


def _table1(res: StudyResult) -> Figure:
    from fieldmap.nav.paper_tables import PAPER_TABLE1

    meta, t = res.meta, res.t[1:]
    groups = _groups(res.labels)
    floor = next((k for k in groups if k.startswith("floor:")), None)
    models = [k for k in groups if k != floor]
    styles = _assign_styles(models, MODEL_STYLE)
    family = [m for m in NORMAL_FAMILY if m in models]
    ref = "exact" if "exact" in family else (family[-1] if family else None)
    rel = [m for m in family if m != ref]
    fig, axes = _figure(2 if rel else 1)
    n = len(models) + 1
    handles = []
    final = {r["model"]: r for r in res.rows}
    for k, m in enumerate(models):
        r = final[m]
        lab = (
            f"{model_label(m, meta)}: {r['final_position_error_m']:.2f} m, "
            f"{r['final_velocity_error_m_s']:.3f} m/s at {res.t[-1]:g} s"
        )
        for ax, (key, _, _) in zip(axes[0], PANELS):
            h = _line(ax, t, getattr(res, key)[groups[m][0], 1:], styles[m], lab, k, n)
        handles.append(h)
    if floor:
        fl = meta["floor"]
        lab = (
            f"numerical floor: navigation gravity = truth ({meta['truth_model']} to degree "
            f"{meta['truth_degree']}), error-free IMU: {fl['final_position_error_m']:.1e} m, "
            f"{fl['final_velocity_error_m_s']:.1e} m/s"
        )
        for ax, (key, _, _) in zip(axes[0], PANELS):
            h = _line(
                ax, t, getattr(res, key)[groups[floor][0], 1:], FLOOR_STYLE, lab, 0, n, lw=1.3
            )
        handles.append(h)
    paper = (
        {m: PAPER_TABLE1[m] for m in models if m in PAPER_TABLE1} if at_paper_duration(meta) else {}
    )
    if paper:
        for ax, col in zip(axes[0], (1, 0)):
            _paper_marks(ax, res.t[-1], {m: v[col] for m, v in paper.items()}, styles)
    if rel and ref is not None:  # rel is empty without a reference
        for ax, (key, _, _) in zip(axes[1], PANELS):
            data = getattr(res, key)
            e_ref = data[groups[ref][0], 1:]
            for k, m in enumerate(rel):
                d = _ratio(data[groups[m][0], 1:], e_ref) - 1.0
                _line(ax, t, np.abs(d), styles[m], None, k, n)
                ax.annotate(f"{d[-1]:+.1e}", (t[-1], abs(d[-1])), color=styles[m][0], **NOTE)
            # no floor here: the integration error is common to all runs (same integrator, same
            # path) and cancels in these differences, which are resolved far below it
            q = "p" if key == "pos" else "v"
            name = "exact" if ref == "exact" else ref.upper()
            ax.set_ylabel(
                f"relative to {model_label(ref, meta).split(' (')[0]}\n"
                f"$|\\,|\\delta {q}| / |\\delta {q}|_{{\\rm {name}}} - 1\\,|$ (–)"
            )
            if paper and ref == "exact" and "j6" in paper:
                # the paper has no exact normal model: its J6 (closest to it) is the reference
                col = 1 if key == "pos" else 0
                rel_paper = {m: abs(paper[m][col] / paper["j6"][col] - 1) for m in paper}
                _paper_marks(ax, res.t[-1], {m: rel_paper[m] for m in rel if m in paper}, styles)
            ax.margins(x=0.0)
            ax.set_xlim(right=max(ax.get_xlim()[1], t[-1] * 1.13))  # shared with the top
    if paper:
        extra = "; (c), (d): vs its J6" if rel and ref == "exact" else ""
        handles.append(_paper_proxy("Table 1", extra))
    title = (
        "Fig. 11 / Table 1 — navigation error caused by the navigation gravity model alone "
        "(error-free IMU)"
    )
    bottom = f"J-truncation effect on the normal field (labels: signed value at {t[-1]:g} s)"
    _finish(fig, axes, title, _context(meta), handles, 2, bottom=bottom)
    return fig


#: study -> its figure (Fig. 11, 12, 13 like)
_FIGURES = {"table1": _table1, "table3": _table3, "table4": _table4}


def make_figure(res: StudyResult) -> Figure:
    """Build the figure of one study result (:class:`fieldmap.nav.paper.StudyResult`)."""
    return _FIGURES[res.study](res)


def plot(res: StudyResult, path: str) -> None:
    """Write the figure of ``res`` (Fig. 11, 12 or 13 like) to ``path`` as PNG."""
    import matplotlib.pyplot as plt

    fig = make_figure(res)
    try:
        fig.savefig(path, format="png", dpi=110)
    finally:
        plt.close(fig)


def _plt() -> ModuleType:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


# ---------------------------------------------------------------------- the flight study's figures
#: size (inches, width × height) of each kind of flight figure: a file (130 dpi) has the same
#: size whatever the flight, its name, its models or its recommendation
FIGURE_SIZE = {
    "errors": (12.0, 9.0),
    "sigma": (12.0, 8.5),
    "budget": (11.0, 8.0),
    "track": (7.5, 6.5),
}
TITLE_SIZE = 11.5
CAPTION_SIZE = 9.0
#: the kinds of figure a flight result draws (``FlightResult.plot(kind=...)``)
KINDS = ("errors", "budget", "track")
#: colours and line styles whose pairs tell the curves of a flight figure apart
#: (Okabe–Ito colours, colour-blind safe, and black)
COLOURS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")
LINE_STYLES: tuple[Any, ...] = ("-", "--", ":", "-.", (0, (5, 1, 1, 1)), (0, (3, 1, 1, 1, 1, 1)))
#: colours of the gravity model differences where the error sources take :data:`COLOURS`
GRAVITY_COLOURS = ("#8C510A", "#5D3A9B", "#01665E", "#B2182B", "#7F7F00", "#1B3A6B")
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")
#: an error source's colour says what kind of error it is ...
SOURCE_KIND_COLOUR = (
    ("bias instability", "#E69F00"),
    ("bias", "#0072B2"),
    ("scale factor", "#009E73"),
    ("misalignment", "#CC79A7"),
    ("random walk", "#D55E00"),
    ("noise", "#D55E00"),
    ("drift", "#56B4E9"),
)
#: ... and its line style which sensor it belongs to
SOURCE_SENSOR_STYLE: tuple[tuple[str, Any], ...] = (
    ("accelerometer", "-"),
    ("velocity random walk", "-"),
    ("gyro", "--"),
    ("angle random walk", "--"),
    ("baro", ":"),
    ("GNSS", "-."),
)
#: the gravity terms of a flight's error budget (:mod:`fieldmap.nav.budget`) as drawn
GRAVITY_TERM_LABEL = {
    "model_difference": "gravity (a) model difference",
    "omission": "gravity (b) omission",
    "commission": "gravity (c) commission",
}
IMU_ONLY_STYLE = ("0.1", "-", None)


def _wrap(text: str, width_in: float, size: float) -> str:
    """``text`` wrapped, paragraph by paragraph, to lines ``width_in`` inches wide at ``size`` pt.

    0.6 em a character: DejaVu Sans' digits are 0.64 em wide, its lower-case letters 0.5-0.6.
    """
    chars = max(24, int(width_in * 72.0 / (0.6 * size)))
    return "\n".join(textwrap.fill(p, chars) if p else "" for p in text.split("\n"))


def _flight_figure(kind: str, title: str, caption: str) -> tuple[Figure, SubFigure]:
    """Return a figure of ``FIGURE_SIZE[kind]`` and the part of it the plots go in.

    A short title on top, the ``caption`` (the flight, what the lines are, the recommendation)
    wrapped to the width in a box of its own at the bottom; constrained layout fits the axes,
    their labels and a legend (``part.legend(loc="outside lower center")``) in between, so
    nothing is drawn outside the canvas.
    """
    plt = _plt()
    w, h = FIGURE_SIZE[kind]
    fig = plt.figure(figsize=(w, h), layout="constrained")
    text = _wrap(caption, w - 0.6, CAPTION_SIZE)
    band = min(0.4, ((text.count("\n") + 1) * CAPTION_SIZE * 1.25 / 72.0 + 0.3) / h)
    part, foot = fig.subfigures(2, 1, height_ratios=(1.0 - band, band))
    foot.text(
        0.15 / w,
        1.0 - 0.08 / (band * h),
        text,
        ha="left",
        va="top",
        fontsize=CAPTION_SIZE,
        linespacing=1.25,
        bbox=dict(boxstyle="round,pad=0.45", fc="0.965", ec="0.75", lw=0.8),
    )
    part.suptitle(_wrap(title, w - 0.4, TITLE_SIZE), fontsize=TITLE_SIZE, fontweight="bold")
    return fig, part


def _flight_line(meta: Mapping[str, Any]) -> str:
    """One line saying which flight, IMU, mechanization and truth a figure shows."""
    rate = meta.get("imu_rate_hz")
    return (
        f"Flight {meta['trajectory']}, {meta['duration_s']:g} s · IMU {meta['imu']}"
        + (f" at {rate:g} Hz" if rate else "")
        + f" · frame {meta['frame']} · altitude aiding {meta['altitude_aiding']}"
        + (" · GNSS-aided" if meta.get("gnss") else "")
        + f" · truth {meta['truth_model']} degree {meta['truth_degree']}"
    )


def _recommendation_line(summary: Mapping[str, Any]) -> str:
    return f"Recommendation ({summary['fraction']:.0%} rule): {summary['recommendation']}"


def _distinct_styles(
    keys: Sequence[str], preferred: Mapping[str, _Style], colours: Sequence[str] = COLOURS
) -> dict[str, _Style]:
    """Give each key its own (colour, line style) pair and a marker: ``preferred[key]`` if free.

    Other keys take the first free pair of ``colours`` (:data:`COLOURS`) × :data:`LINE_STYLES`,
    a colour not yet used first: up to seven curves differ in colour, more in colour or line
    style.
    """
    out: dict[str, _Style] = {}
    used: set[tuple[str, str]] = set()
    for key in keys:
        style = preferred.get(key)
        if style is not None and (style[0], str(style[1])) not in used:
            out[key] = style
            used.add((style[0], str(style[1])))
    for k, key in enumerate(keys):
        if key in out:
            continue
        taken = {c for c, _ in used}
        pairs = [(c, ls) for ls in LINE_STYLES for c in colours if (c, str(ls)) not in used]
        pairs.sort(key=lambda p: p[0] in taken)  # stable: the order above among equals
        c, ls = pairs[0] if pairs else (colours[0], LINE_STYLES[k % len(LINE_STYLES)])
        out[key] = (c, ls, MARKERS[k % len(MARKERS)])
        used.add((c, str(ls)))
    return out


def source_styles(sources: Sequence[str]) -> dict[str, tuple[str, Any]]:
    """(colour, line style) of each IMU, baro or GNSS error source, every pair its own.

    The colour says the kind of error (bias, bias instability, scale factor, misalignment,
    noise or random walk, drift), the line style the sensor (accelerometer solid, gyro dashed,
    baro dotted, GNSS dash-dot): the 13 sources of a navigation IMU with a baro all differ. A
    source named otherwise, or whose pair is taken, gets the next free pair.
    """
    out: dict[str, tuple[str, Any]] = {}
    used: set[tuple[str, str]] = set()
    for s in sources:
        c = next((c for word, c in SOURCE_KIND_COLOUR if word in s), None)
        ls = next((ls for word, ls in SOURCE_SENSOR_STYLE if s.startswith(word)), None)
        if c is not None and ls is not None and (c, str(ls)) not in used:
            out[s] = (c, ls)
            used.add((c, str(ls)))
    free = ((c, ls) for ls in LINE_STYLES for c in COLOURS if (c, str(ls)) not in used)
    for k, s in enumerate(sources):
        if s not in out:
            out[s] = next(free, (COLOURS[k % len(COLOURS)], LINE_STYLES[k % len(LINE_STYLES)]))
    return out


def _limit_log(ax: Axes, decades: int = LOG_DECADES) -> None:
    """Show at most ``decades`` decades below the largest value a log axis holds.

    The errors of a flight start at 0; their first milliseconds (1e-13 m) would otherwise
    stretch the axis over a dozen decades and squeeze the ones that matter.
    """
    top, minpos = ax.dataLim.y1, ax.dataLim.minposy
    if not (np.isfinite(top) and top > 0):
        return
    ax.set_ylim(max(minpos, top * 10.0**-decades), top * 1.6)


def _log_decades(ax: Axes) -> float:
    lo, hi = ax.get_ylim()
    return float(np.log10(hi / lo))


def _outages(axes: Iterable[Axes], summary: Mapping[str, Any]) -> None:
    """Shade the GNSS outages of an aided study (time in minutes)."""
    g = summary.get("gnss")
    if not g:
        return
    for ax in axes:
        for j, (a, b) in enumerate(g["outages_s"]):
            ax.axvspan(a / 60.0, b / 60.0, color="0.9", zorder=0, lw=0,
                       label="GNSS outage" if j == 0 else None)  # fmt: skip


def _lines_note(draws: int) -> str:
    """Say what the lines and the bands of a Monte Carlo flight figure are."""
    if draws >= MIN_BAND_DRAWS:
        return f"Lines: medians over the {draws} draws; shaded bands: their 5th to 95th percentile."
    if draws > 1:
        return (
            f"Lines: medians over the {draws} draws (no 5–95 % band: it needs "
            f"{MIN_BAND_DRAWS} draws or more)."
        )
    return "Lines: one run per model (the IMU has no error to draw)."


def _model_label(name: str, meta: Mapping[str, Any]) -> str:
    """``j2: J2 normal gravity``, ``sh240: EIGEN-6S degree 240``, ``table:FILE``."""
    if name == "imu_only":
        return "IMU errors only (no gravity-model error)"
    if name.startswith("table:"):
        return name
    if name.startswith("sh") and not name[2:].isdigit():
        return name
    return f"{name}: {short_label(name, dict(meta))}"


def errors_figure(res: FlightResult) -> Figure:
    """Errors of a Monte Carlo flight study over time, and the gravity error behind them.

    (a) horizontal and (b) vertical position error of each navigation gravity model, the
    IMU-only reference in black: lines are medians over the draws, shaded bands their 5th to
    95th percentile (with :data:`MIN_BAND_DRAWS` draws or more); (c) δg = model − truth along
    the track (mGal); (d) the horizontal error each model adds: the Monte Carlo difference to
    the IMU-only run of the same draw (median), its prediction ∬δg dt² (free inertial flights:
    a GNSS fix resets what the integral keeps adding up), the gravity terms
    through the linear error model ((a) model difference; (b) omission and (c) commission,
    RMS over their draws). GNSS outages are shaded. Log axes show :data:`LOG_DECADES` decades
    below their largest value. The title names the flight; the caption (below the plots) its
    set-up, what the lines are and the recommendation.
    """
    meta = res.summary["meta"]
    models = np.asarray(res.models)
    rows = list(dict.fromkeys(res.models))
    names = [r for r in rows if r != "imu_only"]
    draws = int(np.sum(models == rows[0]))
    styles = _distinct_styles(names, MODEL_STYLE)
    title = f"Flight {meta['trajectory']}: position error by navigation gravity model"
    caption = "\n".join(
        (
            _flight_line(meta) + f" · Monte Carlo, {draws} draw(s) per model.",
            _lines_note(draws),
            _recommendation_line(res.summary),
        )
    )
    fig, part = _flight_figure("errors", title, caption)
    axes = part.subplots(2, 2, sharex=True)
    t = res.t / 60.0
    handles: list[Any] = []
    for k, row in enumerate(rows):
        sel = models == row
        style = IMU_ONLY_STYLE if row == "imu_only" else styles[row]
        lw = 2.6 if row == "imu_only" else 1.5
        with np.errstate(invalid="ignore"):
            h = np.hypot(res.dpos[sel, :, 0], res.dpos[sel, :, 1])
            v = np.abs(res.dpos[sel, :, 2])
        for ax, val in ((axes[0, 0], h), (axes[0, 1], v)):
            line = _band(ax, t, val, style, _model_label(row, meta), k, len(rows), lw=lw)
        handles.append(line)
    if getattr(res, "sigma_h", None) is not None:
        (line,) = axes[0, 0].plot(
            t, res.sigma_h, color="0.1", ls=(0, (1, 1)), lw=1.2,
            label="the filter's σ of the IMU-only error",
        )  # fmt: skip
        handles.append(line)
    # (c) the gravity each model misses along the track
    ax = axes[1, 0]
    for name, dg in res.dg.items():
        for j, ls in enumerate(("-", "--", ":")):
            ax.plot(t, dg[:, j] * 1e5, color=styles[name][0], ls=ls, lw=1.2)
    ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
    ax.legend(
        handles=[_proxy(color="0.4", ls=ls, label=c) for ls, c in zip(("-", "--", ":"), "NED")],
        title="component",
        fontsize=7.5,
        title_fontsize=7.5,
        loc="best",
    )
    # (d) the horizontal error each model adds, simulated and predicted
    ax = axes[1, 1]
    ref = models == "imu_only"
    b = getattr(res, "budget", None)
    aided = bool(res.summary.get("gnss"))
    for name in res.dg:
        colour, marker = styles[name][0], styles[name][2]
        d = res.dpos[models == name, :, :2] - res.dpos[ref, :, :2]
        with np.errstate(invalid="ignore"):
            sim = np.median(np.hypot(d[..., 0], d[..., 1]), 0)
        ax.plot(t, sim, color=colour, ls="-", lw=1.5)
        if not aided:  # a GNSS fix resets what ∬δg dt² keeps adding up
            p = res.predicted[name]
            ax.plot(t, np.hypot(p[:, 0], p[:, 1]), color=colour, ls="--", lw=1.2)
        if b is not None:
            a = b.model_difference[name]
            step = max(1, t.size // 8)
            ax.plot(t, np.hypot(a[:, 0], a[:, 1]), color=colour, ls=":", lw=1.8,
                    marker=marker, markevery=(step // 2, step), ms=4, mfc="white")  # fmt: skip
    kinds = [_proxy(color="0.4", ls="-", label="Monte Carlo: model − IMU only, same draw (median)")]
    if not aided:
        integral = "∬δg dt² (the horizontal δg integrated twice)"
        kinds.append(_proxy(color="0.4", ls="--", label=integral))
    if b is not None:
        kinds.append(_proxy(color="0.4", ls=":", label="(a) model difference, linear model"))
        for term, colour in (("omission", "0.15"), ("commission", "0.55")):
            x = getattr(b, term)
            if x is not None:
                rms = np.sqrt(np.mean(x[..., 0] ** 2 + x[..., 1] ** 2, axis=0))
                lab = f"{GRAVITY_TERM_LABEL[term][8:]} (RMS of {b.draws} draws)"
                kinds.append(ax.plot(t, rms, color=colour, ls="-.", lw=1.8, label=lab)[0])
    ax.legend(handles=kinds, fontsize=7, loc="lower right")
    _outages(axes.ravel(), res.summary)
    labels = (
        ("(a) horizontal position error", "horizontal error (m)"),
        ("(b) vertical position error", "vertical error (m)"),
        ("(c) gravity error along the track, δg = model − truth", "δg (mGal)"),
        ("(d) horizontal error added by the gravity model", "added horizontal error (m)"),
    )
    for ax, (name, ylabel) in zip(axes.ravel(), labels):
        ax.set_title(name, loc="left", fontsize=9.5)
        ax.set_ylabel(ylabel)
        ax.grid(True, which="major", alpha=0.35)
        if ax is not axes[1, 0]:
            ax.set_yscale("log")
            ax.grid(True, which="minor", alpha=0.12)
            _limit_log(ax)
    for ax in axes[1]:
        ax.set_xlabel("time (min)")
    handles.append(_band_proxy(draws))
    if res.summary.get("gnss"):
        handles.append(_outage_proxy())
    part.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    return fig


def _outage_proxy() -> Patch:
    from matplotlib.patches import Patch

    return Patch(color="0.9", label="GNSS outage")


def sigma_figure(res: CovarianceStudyResult) -> Figure:
    """σ(t) of the horizontal and vertical position error per error source, and the gravity terms.

    One line per IMU, baro (and GNSS) error source (:func:`source_styles`: colour the kind of
    error, line style the sensor), their root sum of squares in thick black, and the gravity
    terms through the linear error model (thick, with markers): (a) each model's difference,
    (b) omission, (c) commission (RMS over their draws). Log axes show :data:`LOG_DECADES`
    decades below their largest value; the caption says what is drawn and recommends.
    """
    cov = res.covariance
    meta = res.summary["meta"]
    b = res.budget
    title = f"Flight {meta['trajectory']}: position error σ by error source"
    caption = "\n".join(
        (
            _flight_line(meta) + " · linear covariance analysis.",
            "Lines: 1σ of each error source alone (colour: kind of error; line style: sensor, "
            "accelerometer solid, gyro dashed, baro dotted, GNSS dash-dot); thick black: all "
            "sources together (root sum of squares); thick with markers: the gravity terms "
            f"through the linear error model ((b), (c): RMS of {b.draws} draws).",
            _recommendation_line(res.summary),
        )
    )
    fig, part = _flight_figure("sigma", title, caption)
    axes = part.subplots(1, 2)
    t = res.t / 60.0
    styles = source_styles(cov.sources)
    grav = _distinct_styles(list(res.dg), {}, GRAVITY_COLOURS)
    step = max(1, t.size // 8)
    tot = cov.total()
    for ax, comp in ((axes[0], slice(0, 2)), (axes[1], slice(2, 3))):

        def norm(x: np.ndarray, comp: slice = comp) -> np.ndarray:
            return np.sqrt(np.sum(x[..., comp] ** 2, -1))

        ax.plot(t, norm(tot), color="k", lw=2.8, label="all sources (root sum of squares)")
        for s in cov.sources:
            colour, ls = styles[s]
            ax.plot(t, norm(cov.position[s]), color=colour, ls=ls, lw=1.3, label=s)
        for k, m in enumerate(res.dg):
            a = norm(b.model_difference[m])
            zero = " (0: the truth model)" if not np.any(a > 0) else ""
            ax.plot(t, a, color=grav[m][0], ls=grav[m][1], lw=2.2, marker=MARKERS[k % 10],
                    markevery=(step // 2 + k, step), ms=5, mfc="white",
                    label=f"{GRAVITY_TERM_LABEL['model_difference']}, {m}{zero}")  # fmt: skip
        for term, colour, marker in (("omission", "0.25", "o"), ("commission", "0.6", "s")):
            x = getattr(b, term)
            if x is not None:
                ax.plot(t, np.sqrt(np.mean(norm(x) ** 2, axis=0)), color=colour, ls="-.",
                        lw=2.2, marker=marker, markevery=(step // 3, step), ms=5, mfc="white",
                        label=GRAVITY_TERM_LABEL[term])  # fmt: skip
        _outages([ax], res.summary)
        ax.set_yscale("log")
        ax.set_xlabel("time (min)")
        ax.grid(True, which="major", alpha=0.35)
        ax.grid(True, which="minor", alpha=0.12)
        _limit_log(ax)
    axes[0].set_ylabel("horizontal position error σ (m)")
    axes[1].set_ylabel("vertical position error σ (m)")
    axes[0].set_title("(a) horizontal", loc="left", fontsize=9.5)
    axes[1].set_title("(b) vertical", loc="left", fontsize=9.5)
    handles, _ = axes[0].get_legend_handles_labels()
    part.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=7.5, frameon=False)
    return fig


def _source_group(name: str) -> str:
    """Return the sensor an error source belongs to (the budget chart's colour)."""
    for word, group in (
        ("accelerometer", "accelerometer"),
        ("velocity random walk", "accelerometer"),
        ("gyro", "gyro"),
        ("angle random walk", "gyro"),
        ("baro", "baro"),
        ("GNSS", "GNSS"),
    ):
        if name.startswith(word):
            return group
    return "other"


#: fill colour and hatch of each group of bars in the error budget
BUDGET_GROUPS = {
    "all sources": ("#3a3a3a", ""),
    "accelerometer": ("#0072B2", ""),
    "gyro": ("#E69F00", ""),
    "baro": ("#999999", ""),
    "GNSS": ("#CC79A7", ""),
    "other": ("#56B4E9", ""),
    "model_difference": ("#009E73", "//"),
    "omission": ("#D55E00", "\\\\"),
    "commission": ("#F0E442", "xx"),
}
BUDGET_GROUP_LABEL = {
    "all sources": "all sources together (IMU, and baro or GNSS where aided)",
    "accelerometer": "accelerometer",
    "gyro": "gyro",
    "baro": "baro altimeter",
    "GNSS": "GNSS",
    "other": "other source",
    "model_difference": "gravity (a): navigation model − truth model",
    "omission": "gravity (b): the field above the truth's degree",
    "commission": "gravity (c): the truth model's coefficient errors",
}


def budget_moment(res: FlightResult | CovarianceStudyResult) -> tuple[int, str, float]:
    """When a flight's error budget is read: (output index, its words, the IMU-only error in m).

    The flight's end; in a GNSS-aided study the end of the worst outage (the largest IMU-only
    error at its end, the recommendation's moment: :func:`fieldmap.nav.aiding.coasting_summary`),
    or the aided flight's end without outages.
    """
    doc = res.summary
    n = res.t.size - 1
    g = doc.get("gnss")
    if g is None:
        return n, f"the flight's end ({res.t[-1]:g} s)", float(doc["imu_only_horizontal_error_m"])
    if not g["outages"]:
        return n, f"the aided flight's end ({res.t[-1]:g} s)", _imu_only_horizontal(res, n)
    worst = max(g["outages"], key=lambda o: o["imu_only_horizontal_error_m"])
    i = int(np.argmin(np.abs(res.t - worst["time_s"])))
    words = f"the end of the worst GNSS outage ({worst['start_s']:g}–{worst['end_s']:g} s)"
    return i, words, float(worst["imu_only_horizontal_error_m"])


def _imu_only_horizontal(res: FlightResult | CovarianceStudyResult, i: int) -> float:
    """Return the IMU-only horizontal error at output ``i`` (Monte Carlo RMS or covariance σ)."""
    if not _monte_carlo(res):
        return float(res.covariance.horizontal()[i])
    d = res.dpos[np.asarray(res.models) == "imu_only", i, :2]
    return float(np.sqrt(np.mean(np.sum(d * d, -1))))


def budget_bars(res: FlightResult | CovarianceStudyResult, i: int) -> list[tuple[str, float, str]]:
    """Return the bars of a flight's error budget at output ``i``: ``(label, m, group)``.

    Each IMU, baro and GNSS source's 1σ alone and all of them together (the linear covariance
    analysis; a Monte Carlo study, whose draws hold every source at once, gives their RMS
    together, and the sources one by one where it has the covariance: a GNSS-aided study);
    then the gravity terms through the linear error model: (a) each model's difference
    (deterministic), (b) omission and (c) commission (the same for every model; RMS of their
    draws). Sorted from the largest.
    """
    bars: list[tuple[str, float, str]] = []
    mc = _monte_carlo(res)
    if mc:
        n = int(np.sum(np.asarray(res.models) == "imu_only"))
        bars.append(
            (f"all sources: Monte Carlo RMS of {n} draw(s)", _imu_only_horizontal(res, i),
             "all sources")
        )  # fmt: skip
    cov = res.covariance
    if cov is not None:
        for s in cov.sources:
            bars.append((s, float(cov.horizontal(s)[i]), _source_group(s)))
        if not mc or cov.sources:
            what = "all sources: root sum of squares" + (" (linear)" if mc else "")
            bars.append((what, float(cov.horizontal()[i]), "all sources"))
    b = res.budget
    if b is not None:
        for m in b.model_difference:
            v = b.summary(m, at=i)["horizontal_terms_m"]["model_difference"]
            bars.append((f"(a) model difference, {m}", float(v), "model_difference"))
        degree = res.summary["meta"].get("truth_degree", "L")
        first = next(iter(b.model_difference), None)
        for term, words in (
            ("omission", f"(b) omission, above degree {degree}"),
            ("commission", "(c) commission, the truth's σ"),
        ):
            if getattr(b, term) is not None and first is not None:
                v = b.summary(first, at=i)["horizontal_terms_m"][term]
                bars.append((words, float(v), term))
    return sorted(bars, key=lambda bar: -bar[1])


def budget_figure(res: FlightResult | CovarianceStudyResult) -> Figure:
    """Draw a flight's error budget: one horizontal bar per error source, sorted, gravity beside.

    At the flight's end, or in a GNSS-aided study at the end of the worst outage
    (:func:`budget_moment`): the horizontal position error each source causes alone
    (:func:`budget_bars`), on a log axis (:data:`LOG_DECADES` decades), the gravity terms
    (a) model difference (per model), (b) omission, (c) commission hatched beside the IMU's
    sources; a dashed line at the recommendation's limit (``fraction`` × the IMU-only error),
    which a model's gravity terms together must stay below.
    """
    meta = res.summary["meta"]
    i, when, imu = budget_moment(res)
    bars = budget_bars(res, i)
    mc = getattr(res, "dpos", None) is not None
    how = (
        "IMU sources: Monte Carlo RMS of all of them together"
        + (" and the filter's linear σ of each alone" if getattr(res, "covariance", None) else
           " (the draws hold every source at once: the covariance method splits them)")
        if mc
        else "IMU, baro and GNSS sources: 1σ of each alone, linear covariance analysis"
    )  # fmt: skip
    b = res.budget
    draws = f" ((b), (c): RMS of {b.draws} draws)" if b is not None else ""
    title = f"Flight {meta['trajectory']}: error budget at {when}"
    caption = "\n".join(
        (
            _flight_line(meta) + ".",
            f"Bars: horizontal position error at {when}, each source alone, largest first. "
            f"{how}; gravity terms through the linear error model{draws}. Independent "
            "sources add as the root of the sum of their squares.",
            _recommendation_line(res.summary),
        )
    )
    fig, part = _flight_figure("budget", title, caption)
    ax = part.subplots()
    values = np.array([v for _, v, _ in bars])
    pos = values[values > 0]
    top = float(pos.max()) if pos.size else 1.0
    lo = max(float(pos.min()) / 2.0 if pos.size else top, top * 10.0**-LOG_DECADES)
    y = np.arange(len(bars))[::-1]
    for (label, v, group), yk in zip(bars, y):
        colour, hatch = BUDGET_GROUPS[group]
        ax.barh(yk, max(v, lo) - lo, left=lo, height=0.72, color=colour, hatch=hatch,
                edgecolor="0.25", lw=0.6)  # fmt: skip
        ax.annotate(f"{v:.3g} m" if v > 0 else "0 m", (max(v, lo), yk), xytext=(3, 0),
                    textcoords="offset points", va="center", fontsize=7.5)  # fmt: skip
    ax.set_yticks(y, [label for label, _, _ in bars], fontsize=8)
    ax.set_xscale("log")
    ax.set_xlim(lo, top * 8.0)
    ax.set_ylim(-0.7, len(bars) - 0.3)
    ax.set_xlabel(f"horizontal position error at {when} (m)")
    ax.grid(True, axis="x", which="major", alpha=0.35)
    ax.grid(True, axis="x", which="minor", alpha=0.1)
    frac = float(res.summary["fraction"])
    handles: list[Any] = []
    if imu > 0 and frac * imu > lo:
        handles.append(
            ax.axvline(frac * imu, color="k", ls="--", lw=1.2,
                       label=f"{frac:.0%} of the IMU-only error ({frac * imu:.3g} m): the limit "
                       "for a model's gravity terms together")
        )  # fmt: skip
    from matplotlib.patches import Patch

    for group in BUDGET_GROUPS:
        if any(g == group for _, _, g in bars):
            colour, hatch = BUDGET_GROUPS[group]
            handles.append(Patch(facecolor=colour, hatch=hatch, edgecolor="0.25",
                                 label=BUDGET_GROUP_LABEL[group]))  # fmt: skip
    part.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    return fig


def flight_figure(res: FlightResult | CovarianceStudyResult, kind: str = "errors") -> Figure:
    """Draw a flight study's figure of ``kind`` (``FlightResult.plot``, ``...Result.plot``).

    ``kind``: ``"errors"`` the errors over time (:func:`errors_figure`, or for a covariance
    study :func:`sigma_figure`), ``"budget"`` the error budget (:func:`budget_figure`),
    ``"track"`` the ground track (:func:`track_figure`, without the disturbance map the command
    line draws beneath it).
    """
    from fieldmap.errors import InputError

    if kind not in KINDS:
        raise InputError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}", param="kind")
    if kind == "budget":
        return budget_figure(res)
    if kind == "track":
        return track_figure(res)
    if getattr(res, "dpos", None) is None:
        return sigma_figure(res)
    return errors_figure(res)


def track_aspect(lat_limits: Sequence[float]) -> float:
    """Axis aspect (degrees of latitude per degree of longitude on screen) of a local map.

    A degree of longitude is cos φ times a degree of latitude at the map's middle latitude φ
    (clipped at ±85° so that a polar map stays finite): equal distances look equal.
    """
    mid = 0.5 * (lat_limits[0] + lat_limits[1])
    return float(1.0 / np.cos(np.radians(np.clip(mid, -85.0, 85.0))))


def track_view(track: npt.ArrayLike) -> tuple[tuple[float, float], tuple[float, float]]:
    """Return the (latitude, longitude) limits, degrees, of a map of a ground track.

    A tenth of the track's extent around it, at least 0.05° (5 km); the narrower side at
    least 3/4 of the wider, measured in kilometres (a degree of longitude is cos φ of one of
    latitude), so that a track along a meridian is not a line on a sliver of map.
    """
    tr = np.asarray(track, dtype=np.float64)
    la, lo = tr[:, 0], tr[:, 1]
    cos = np.cos(np.radians(np.clip(0.5 * (la.min() + la.max()), -85.0, 85.0)))
    # half-widths in degrees of latitude
    hy, hx = 0.5 * np.ptp(la), 0.5 * np.ptp(lo) * cos
    pad = max(0.2 * max(hx, hy), 0.05)
    hy, hx = hy + pad, hx + pad
    hy, hx = max(hy, 0.75 * hx), max(hx, 0.75 * hy)
    mid_la, mid_lo = 0.5 * (la.min() + la.max()), 0.5 * (lo.min() + lo.max())
    lat = (float(max(mid_la - hy, -90.0)), float(min(mid_la + hy, 90.0)))
    return lat, (float(mid_lo - hx / cos), float(mid_lo + hx / cos))


def track_figure(
    res: FlightResult | CovarianceStudyResult,
    disturbance: tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike] | None = None,
) -> Figure:
    """Ground track over the truth model's disturbance (mGal, if given), with coastlines.

    Zoomed to the track (a tenth of its extent around it, at least 0.05°; the narrower side at
    least 3/4 of the wider), equal aspect: a kilometre east is as long as a kilometre north
    (:func:`track_aspect`); the coastlines are the bundled Natural Earth 1:50m ones
    (:mod:`fieldmap.products.coastline`).
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=FIGURE_SIZE["track"], layout="constrained")
    la, lo = res.track[:, 0], res.track[:, 1]
    (y0, y1), (x0, x1) = track_view(res.track)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.autoscale(False)
    if disturbance is not None:
        lat, lon, dg = (np.asarray(x) for x in disturbance)
        seen = dg[np.ix_((lat >= y0) & (lat <= y1), (lon >= x0) & (lon <= x1))]
        lim = float(np.nanmax(np.abs(seen if seen.size else dg)))  # the scale of what is shown
        pc = ax.pcolormesh(lon, lat, dg, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
        fig.colorbar(pc, ax=ax, shrink=0.85,
                     label="gravity disturbance δg_D at the mean flight height (mGal)")  # fmt: skip
    ax.plot(lo, la, "k-", lw=2, label="ground track")
    ax.plot(lo[0], la[0], "o", color="#009E73", ms=8, mec="k", label="start")
    ax.plot(lo[-1], la[-1], "s", color="#D55E00", ms=8, mec="k", label="end")
    ax.set_xlabel("longitude (°)")
    ax.set_ylabel("latitude (°)")
    coastline.draw(ax, lon_min=ax.get_xlim()[0], color="0.3", linewidth=0.8)
    ax.set_aspect(track_aspect(ax.get_ylim()))
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=3, fontsize=8, frameon=False)
    summary = getattr(res, "summary", None)
    name = f"Flight {summary['meta']['trajectory']}: " if summary else ""
    what = "ground track" + ("" if disturbance is None else " over the truth model's disturbance")
    ax.set_title(_wrap(name + what, 6.5, 10.5), fontsize=10.5)
    return fig


def disturbance_grid(
    res: FlightResult | CovarianceStudyResult,
    model: SHModel,
    n: int = 60,
    device: str | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Down component of g_truth − γ_normal (mGal) on a grid over the track's map at mean height.

    ``n`` × ``n`` points over :func:`track_view` and a cell beyond each side.
    """
    from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
    from fieldmap.nav.imu import Gravitation

    (y0, y1), (x0, x1) = track_view(res.track)  # the map's view, and a cell more each side
    dy, dx = (y1 - y0) / (n - 3), (x1 - x0) / (n - 3)
    lat = np.linspace(max(y0 - dy, -89.0), min(y1 + dy, 89.0), n)
    lon = np.linspace(x0 - dx, x1 + dx, n)
    LA, LO = np.meshgrid(lat, lon, indexing="ij")
    h = np.full(LA.size, float(np.mean(res.track[:, 2])))
    r = np.stack(geodetic_to_ecef(LA.ravel(), LO.ravel(), h), -1)
    d = Gravitation("sh", model=model, device=device)(r) - Gravitation("exact", device=device)(r)
    up = np.einsum("nj,nj->n", C_e_to_enu(LA.ravel(), LO.ravel())[:, 2], d)
    return lat, lon, (-up * 1e5).reshape(LA.shape)
