"""Monte Carlo figures of the navigation studies: Figs. 12 and 13 (Tables 3 and 4).

Each Monte Carlo case is drawn as the median over its draws with a shaded 5th-95th percentile
band (top row) and as the ratio to a reference case, run by run (bottom row): Table 3, the
ratio to group 4 (no accelerometer error); Table 4, the ratio to the IMU-only case, paired by
draw. :func:`fieldmap.nav.plots.make_figure` picks the figure of a study.
"""

from __future__ import annotations

import numpy as np

from fieldmap.nav.plotparts import (
    CYCLE,
    MODEL_STYLE,
    PANELS,
    _assign_styles,
    _context,
    _figure,
    _finish,
    _groups,
    _line,
    _paper_marks,
    _paper_proxy,
    _ratio,
    at_paper_duration,
    short_label,
)


def _mc_context(meta: dict) -> str:
    return (
        f"{meta['draws']} Monte Carlo draws per case (seed {meta['seed']}, "
        f"constant errors drawn per run: {meta['bias_mode']})"
    )


def _is_table4(spec: dict) -> bool:
    """Whether an IMU spec (as a dict) is the paper's Table 4 unit."""
    from fieldmap.nav.imu_errors import TABLE4

    return all(spec.get(k) == v for k, v in TABLE4.__dict__.items())


def _imu_grade(spec: dict) -> str:
    grade = "IMU grade (Table 4, 1σ)" if _is_table4(spec) else "IMU (1σ)"
    return (
        f"{grade}: gyro bias {spec['gyro_bias_deg_h']:g} °/h, angle random walk "
        f"{spec['gyro_arw_deg_rth']:g} °/√h, scale factor {spec['gyro_scale_ppm']:g} ppm, "
        f"misalignment {spec['gyro_misalign_arcsec']:g}″\naccelerometer bias "
        f"{spec['acc_bias_ug']:g} µg, white noise {spec['acc_noise_ug_rthz']:g} µg/√Hz, scale "
        f"factor {spec['acc_scale_ppm']:g} ppm, misalignment {spec['acc_misalign_arcsec']:g}″"
    )


def _band(ax, t, runs, style, label, k, n_lines, band_label=None):
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


def _plain_log_ticks(ax):
    """Log axis of ratios labelled 0.5, 1, 2, 5 instead of 5×10⁻¹, 10⁰ ..."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())


def _band_proxy(n: int):
    from matplotlib.patches import Patch

    return Patch(
        color="0.5", alpha=0.3, label=f"shaded: 5th–95th percentile over {n} draws, line: median"
    )


def _mc(res, cases, styles, labels, ref, paper, text):
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
    handles = []
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
        if ref in paper:
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


def _table3(res):
    from fieldmap.nav.studies import PAPER_TABLE3

    meta = res.meta
    rows = {f"group{r['group']}": r for r in res.rows}
    cases = list(_groups(res.labels))
    styles = _assign_styles(cases, dict(zip(("group1", "group2", "group3", "group4"), CYCLE)))
    nav = short_label(meta["nav_gravity"], meta)
    labels, ref = {}, None
    for c in cases:
        r = rows[c]
        if r["acc_bias_ug"] == 0 and r["acc_noise_ug_rthz"] == 0:
            what = f"no accelerometer error (gravity-model error of {nav} only)"
            ref = ref or c
        else:
            what = (
                f"accelerometer bias {r['acc_bias_ug']:g} µg, noise "
                f"{r['acc_noise_ug_rthz']:g} µg/√Hz (1σ)"
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


def _table4(res):
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
