"""Figures of the navigation studies: the paper's Figs. 11-13 and the flight study's figures.

Pieces shared by the figures of the navigation studies (:mod:`fieldmap.nav.plots`).

Line styles (colour, line style, marker) per case, display names of the navigation gravity
models, the figure frame (two columns: position and velocity error; one or two rows), curves
with staggered markers, the paper's values as hollow markers right of the run, and the legend
and titles.

Monte Carlo figures of the navigation studies: Figs. 12 and 13 (Tables 3 and 4).

Each Monte Carlo case is drawn as the median over its draws with a shaded 5th-95th percentile
band (top row) and as the ratio to a reference case, run by run (bottom row): Table 3, the
ratio to group 4 (no accelerometer error); Table 4, the ratio to the IMU-only case, paired by
draw. :func:`fieldmap.nav.plots.make_figure` picks the figure of a study.

Figures of the navigation studies: Figs. 11-13 of Chen et al. (2022) §5 (Tables 1, 3, 4).

Each figure has two columns (position error, velocity error) and two rows:

- top: the error norms over time on a log scale, one line per navigation case, each with its own
  colour, line style and marker (the J4, J6 and exact-normal curves of Fig. 11 coincide to the
  eye, so colour alone would not tell them apart); Monte Carlo cases show the median over the
  draws and a shaded 5th-95th percentile band; the paper's values at 800 s are drawn as hollow
  markers where the run covers 800 s;
- bottom: each case relative to a reference case, which makes the small differences the paper
  discusses visible: Table 1, ``| |δx_Jn| / |δx_exact| − 1 |`` for the truncated normal models
  against the exact normal field (with the numerical floor on the same scale); Table 3, the ratio
  to group 4 (no accelerometer error); Table 4, the ratio to the IMU-only case, paired by draw.

Figs. 12 and 13 (Monte Carlo) are drawn by :mod:`fieldmap.nav.plots`; the styles,
labels and drawing pieces the three figures share live in :mod:`fieldmap.nav.plots` (their
public names are re-exported here). This module draws Fig. 11 and picks the figure of a study:
:func:`make_figure` returns the :class:`matplotlib.figure.Figure` (tests inspect it);
:func:`plot` writes it as PNG.

Figures of the flight study: errors over time, gravity error and its prediction, ground track.

No paper values are drawn here: a user's flight is not the paper's boost-glide path.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fieldmap.products import coastline

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from fieldmap.models.shmodel import SHModel
    from fieldmap.nav.covariance import CovarianceStudyResult
    from fieldmap.nav.paper import StudyResult
    from fieldmap.nav.study import FlightResult

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
    fig.suptitle(title + "\n" + subtitle, fontsize=10.5)
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
) -> Line2D:
    """Median line and 5th-95th percentile band of ``runs`` (draws × time); one run: the line."""
    if runs.shape[0] == 1:
        return _line(ax, t, runs[0], style, label, k, n_lines)
    line = _line(ax, t, np.median(runs, 0), style, label, k, n_lines)
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


def _band_proxy(n: int) -> Patch:
    from matplotlib.patches import Patch

    return Patch(
        color="0.5", alpha=0.3, label=f"shaded: 5th–95th percentile over {n} draws, line: median"
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
    from fieldmap.nav.paper import PAPER_TABLE3

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
    from fieldmap.nav.paper import PAPER_TABLE1

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


def _median_band(
    x: npt.NDArray[np.float64],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    return np.median(x, 0), np.percentile(x, 5, 0), np.percentile(x, 95, 0)


def _outages(axes: Iterable[Axes], summary: Mapping[str, Any]) -> None:
    """Shade the GNSS outages of an aided study (time in minutes)."""
    g = summary.get("gnss")
    if not g:
        return
    for ax in axes:
        for j, (a, b) in enumerate(g["outages_s"]):
            ax.axvspan(a / 60.0, b / 60.0, color="0.88", zorder=0, lw=0,
                       label="GNSS outage" if j == 0 else None)  # fmt: skip


def errors_figure(res: FlightResult) -> Figure:
    """Horizontal and vertical error per model (median, 5–95 % band), δg and its prediction."""
    plt = _plt()
    t = res.t / 60.0
    models = np.array(res.models)
    rows = list(dict.fromkeys(res.models))
    fig, axes = plt.subplots(2, 2, figsize=(12, 8), layout="constrained")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, row in enumerate(rows):
        sel = models == row
        c = colors[k % len(colors)]
        for ax, val in (
            (axes[0, 0], np.hypot(res.dpos[sel, :, 0], res.dpos[sel, :, 1])),
            (axes[0, 1], np.abs(res.dpos[sel, :, 2])),
        ):
            with np.errstate(invalid="ignore"):
                med, lo, hi = _median_band(np.where(np.isfinite(val), val, np.nan))
            ax.plot(t, med, color=c, label=row, lw=1.5 if row != "imu_only" else 2.5)
            if sel.sum() > 1:
                ax.fill_between(t, lo, hi, color=c, alpha=0.15, lw=0)
    if getattr(res, "sigma_h", None) is not None:
        axes[0, 0].plot(t, res.sigma_h, "k--", lw=1, label="filter σ (IMU only)")
    _outages(axes[0], res.summary)
    for ax, what in ((axes[0, 0], "horizontal"), (axes[0, 1], "vertical")):
        ax.set_yscale("log")
        ax.set_xlabel("time (min)")
        ax.set_ylabel(f"{what} position error (m)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(fontsize=8, title="navigation gravity")
    ax = axes[1, 0]
    for k, m in enumerate(res.dg):
        c = colors[(k + 1) % len(colors)]
        for j, ls in ((0, "-"), (1, "--"), (2, ":")):
            ax.plot(t, res.dg[m][:, j] * 1e5, ls, color=c, lw=1, label=m if j == 0 else None)
    ax.set_xlabel("time (min)")
    ax.set_ylabel("δg = model − truth (mGal); N solid, E dashed, D dotted")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    ref = models == "imu_only"
    for k, m in enumerate(res.dg):
        c = colors[(k + 1) % len(colors)]
        sel = models == m
        d = res.dpos[sel, :, :2] - res.dpos[ref, :, :2]
        ax.plot(t, np.median(np.hypot(d[..., 0], d[..., 1]), 0), color=c, label=f"{m} simulated")
        p = res.predicted[m]
        ax.plot(t, np.hypot(p[:, 0], p[:, 1]), "--", color=c, label=f"{m} ∬δg dt²")
        b = getattr(res, "budget", None)
        if b is not None:
            a = b.model_difference[m]
            ax.plot(t, np.hypot(a[:, 0], a[:, 1]), ":", color=c, lw=1.5, label=f"{m} (a) linear")
    b = getattr(res, "budget", None)
    for term, c, label in (
        ("omission", "0.2", "(b) omission"),
        ("commission", "0.55", "(c) commission"),
    ):
        x = None if b is None else getattr(b, term)
        if x is not None:
            rms = np.sqrt(np.mean(x[..., 0] ** 2 + x[..., 1] ** 2, axis=0))
            ax.plot(t, rms, "-.", color=c, lw=1.5, label=f"{label} RMS")
    ax.set_yscale("log")
    ax.set_xlabel("time (min)")
    ax.set_ylabel("horizontal error added by the model (m)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    m = res.summary["meta"]
    fig.suptitle(
        f"Flight {m['trajectory']}: IMU {m['imu']}, {m['draws']} draw(s), frame {m['frame']}, "
        f"altitude aiding {m['altitude_aiding']}, truth {m['truth_model']} {m['truth_degree']}\n"
        f"{res.summary['recommendation']}",
        fontsize=10,
    )
    return fig


def sigma_figure(res: CovarianceStudyResult) -> Figure:
    """σ(t) of the horizontal and vertical position error per source, and the gravity terms."""
    plt = _plt()
    cov = res.covariance
    t = res.t / 60.0
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), layout="constrained")
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    tot = cov.total()
    for ax, k, what in ((axes[0], slice(0, 2), "horizontal"), (axes[1], slice(2, 3), "vertical")):
        ax.plot(t, np.sqrt(np.sum(tot[:, k] ** 2, -1)), color="k", lw=2.5, label="IMU total")
        for j, s in enumerate(cov.sources):
            y = np.sqrt(np.sum(cov.position[s][:, k] ** 2, -1))
            ax.plot(t, y, color=colors[j % len(colors)], lw=1, ls="-" if j < 10 else "--",
                    label=s)  # fmt: skip
        b = res.budget
        for m in res.dg:
            a = b.model_difference[m][:, k]
            ax.plot(t, np.sqrt(np.sum(a * a, -1)), ":", lw=1.5, label=f"gravity (a) {m}")
        for term, c in (("omission", "0.2"), ("commission", "0.55")):
            x = getattr(b, term)
            if x is not None:
                y = np.sqrt(np.mean(np.sum(x[..., k] ** 2, -1), axis=0))
                ax.plot(t, y, "-.", color=c, lw=1.5, label=f"gravity ({term})")
        _outages([ax], res.summary)
        ax.set_yscale("log")
        ax.set_xlabel("time (min)")
        ax.set_ylabel(f"{what} position error σ (m)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7, ncol=2)
    m = res.summary["meta"]
    fig.suptitle(
        f"Covariance analysis, flight {m['trajectory']}: IMU {m['imu']}, frame {m['frame']}, "
        f"altitude aiding {m['altitude_aiding']}, truth {m['truth_model']} {m['truth_degree']}\n"
        f"{res.summary['recommendation']}",
        fontsize=9,
    )
    return fig


def track_aspect(lat_limits: Sequence[float]) -> float:
    """Axis aspect (degrees of latitude per degree of longitude on screen) of a local map.

    A degree of longitude is cos φ times a degree of latitude at the map's middle latitude φ
    (clipped at ±85° so that a polar map stays finite): equal distances look equal.
    """
    mid = 0.5 * (lat_limits[0] + lat_limits[1])
    return float(1.0 / np.cos(np.radians(np.clip(mid, -85.0, 85.0))))


def track_figure(
    res: FlightResult,
    disturbance: tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike] | None = None,
) -> Figure:
    """Ground track over the truth model's disturbance (mGal, if given), with coastlines.

    Equal aspect: a kilometre east is as long as a kilometre north (:func:`track_aspect`); the
    coastlines are the bundled Natural Earth 1:50m ones (:mod:`fieldmap.products.coastline`).
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 6), layout="constrained")
    if disturbance is not None:
        lat, lon, dg = disturbance
        lim = np.nanmax(np.abs(dg))
        pc = ax.pcolormesh(lon, lat, dg, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
        fig.colorbar(pc, ax=ax, label="gravity disturbance δg_D at flight height (mGal)")
    ax.plot(res.track[:, 1], res.track[:, 0], "k-", lw=2)
    ax.plot(res.track[0, 1], res.track[0, 0], "go", label="start")
    ax.plot(res.track[-1, 1], res.track[-1, 0], "rs", label="end")
    ax.set_xlabel("longitude (°)")
    ax.set_ylabel("latitude (°)")
    ax.autoscale_view()
    coastline.draw(ax, lon_min=ax.get_xlim()[0], color="0.3", linewidth=0.8)
    ax.set_aspect(track_aspect(ax.get_ylim()))
    ax.legend()
    ax.set_title("ground track over the truth model's disturbance")
    return fig


def disturbance_grid(
    res: FlightResult | CovarianceStudyResult,
    model: SHModel,
    n: int = 60,
    device: str | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Down component of g_truth − γ_normal (mGal) on a grid around the track at mean height."""
    from fieldmap.field.frames import C_e_to_enu, geodetic_to_ecef
    from fieldmap.nav.imu import Gravitation

    la, lo = res.track[:, 0], res.track[:, 1]
    pad = max(0.5, 0.1 * max(np.ptp(la), np.ptp(lo)))
    lat = np.linspace(max(la.min() - pad, -89.0), min(la.max() + pad, 89.0), n)
    lon = np.linspace(lo.min() - pad, lo.max() + pad, n)
    LA, LO = np.meshgrid(lat, lon, indexing="ij")
    h = np.full(LA.size, float(np.mean(res.track[:, 2])))
    r = np.stack(geodetic_to_ecef(LA.ravel(), LO.ravel(), h), -1)
    d = Gravitation("sh", model=model, device=device)(r) - Gravitation("exact", device=device)(r)
    up = np.einsum("nj,nj->n", C_e_to_enu(LA.ravel(), LO.ravel())[:, 2], d)
    return lat, lon, (-up * 1e5).reshape(LA.shape)
