"""Figures of the navigation studies: Figs. 11-13 of Chen et al. (2022) §5 (Tables 1, 3, 4).

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

Figs. 12 and 13 (Monte Carlo) are drawn by :mod:`fieldmap.nav.plots_montecarlo`; the styles,
labels and drawing pieces the three figures share live in :mod:`fieldmap.nav.plotparts` (their
public names are re-exported here). This module draws Fig. 11 and picks the figure of a study:
:func:`make_figure` returns the :class:`matplotlib.figure.Figure` (tests inspect it);
:func:`plot` writes it as PNG.
"""

from __future__ import annotations

import numpy as np

from fieldmap.nav.plotparts import CYCLE as CYCLE
from fieldmap.nav.plotparts import FLOOR_STYLE as FLOOR_STYLE
from fieldmap.nav.plotparts import MODEL_STYLE as MODEL_STYLE
from fieldmap.nav.plotparts import NORMAL_FAMILY as NORMAL_FAMILY
from fieldmap.nav.plotparts import NOTE as NOTE
from fieldmap.nav.plotparts import PANELS as PANELS
from fieldmap.nav.plotparts import TIME_LABEL as TIME_LABEL
from fieldmap.nav.plotparts import (
    _assign_styles,
    _context,
    _figure,
    _finish,
    _groups,
    _line,
    _paper_marks,
    _paper_proxy,
    _ratio,
)
from fieldmap.nav.plotparts import at_paper_duration as at_paper_duration
from fieldmap.nav.plotparts import model_label as model_label
from fieldmap.nav.plotparts import short_label as short_label
from fieldmap.nav.plots_montecarlo import _table3, _table4


def _table1(res):
    from fieldmap.nav.studies import PAPER_TABLE1

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
    if rel:
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


def make_figure(res):
    """Build the figure of one study result (:class:`fieldmap.nav.studies.StudyResult`)."""
    return _FIGURES[res.study](res)


def plot(res, path: str) -> None:
    """Write the figure of ``res`` (Fig. 11, 12 or 13 like) to ``path`` as PNG."""
    import matplotlib.pyplot as plt

    fig = make_figure(res)
    try:
        fig.savefig(path, format="png", dpi=110)
    finally:
        plt.close(fig)
