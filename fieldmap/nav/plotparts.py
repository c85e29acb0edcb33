"""Pieces shared by the figures of the navigation studies (:mod:`fieldmap.nav.plots`).

Line styles (colour, line style, marker) per case, display names of the navigation gravity
models, the figure frame (two columns: position and velocity error; one or two rows), curves
with staggered markers, the paper's values as hollow markers right of the run, and the legend
and titles.
"""

from __future__ import annotations

import numpy as np

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


def _groups(labels) -> dict[str, list[int]]:
    """Run indices by case (the part of a run label before ``/``), in order of appearance."""
    out: dict[str, list[int]] = {}
    for i, lab in enumerate(labels):
        out.setdefault(lab.split("/")[0], []).append(i)
    return out


def _line(ax, t, y, style, label, k, n_lines, **kw):
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


def _paper_marks(ax, t_end, values, styles):
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


def _finish(fig, axes, title, subtitle, handles, ncol, bottom=None, log_bottom=True):
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


def _figure(n_rows):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    height = (4.0 if n_rows == 1 else 7.4) + 1.6
    fig, axes = plt.subplots(
        n_rows, 2, figsize=(12.5, height), sharex=True, squeeze=False, layout="constrained"
    )
    return fig, axes


def _assign_styles(keys, preferred) -> dict:
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


def _ratio(a, b):
    """Return a / b where b > 0, NaN elsewhere (the errors are 0 at launch)."""
    return np.divide(a, b, out=np.full(np.broadcast(a, b).shape, np.nan), where=b > 0)


def _proxy(**kw):
    from matplotlib.lines import Line2D

    return Line2D([], [], **kw)


def at_paper_duration(meta) -> bool:
    """Whether a study ran the paper's 800 s (only then are the paper's values shown)."""
    return abs(meta["duration_s"] - 800.0) < 0.5


def _paper_proxy(table: str, extra: str = ""):
    label = f"right of the dotted line: Chen et al. (2022) {table}, 800 s, truth EIGEN-6C4{extra}"
    return _proxy(ls="none", marker="o", ms=9, mfc="none", mec="k", mew=1.6, label=label)
