"""Tables and output files of the navigation studies (paper's Tables 1, 3, 4 and user flights).

:func:`format_table` and :func:`write_outputs` serve the paper's studies
(:mod:`fieldmap.nav.paper`); :func:`format_flight` and :func:`write_flight_outputs` the flight
study (:mod:`fieldmap.nav.study`). Files go through :mod:`fieldmap.products.io` (all of a
batch or none).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fieldmap.nav.study import flight_dataset, to_dataset

if TYPE_CHECKING:
    from fieldmap.nav.covariance import CovarianceStudyResult
    from fieldmap.nav.paper import StudyResult
    from fieldmap.nav.study import FlightResult
    from fieldmap.products.io import OutputBatch


def _num(x: float | None, fmt: str, width: int) -> str:
    """``x`` formatted, or a dash when missing/non-finite; never wider than ``width``."""
    if x is None or not np.isfinite(x):
        return f"{'-':>{width}s}"
    s = format(x, fmt)
    if len(s) > width:
        s = format(x, f">{width}.2e")
    return f"{s:>{width}s}"


def format_table(res: StudyResult) -> str:
    """Plain-text table of a study's rows; the paper's values only for the paper's 800 s run.

    Columns never overflow: values too wide for their column are printed in exponent form, missing
    or non-finite ones as ``-``; diverged runs are listed below the table.
    """
    from fieldmap.nav.paper_tables import PAPER_TABLE1, PAPER_TABLE3
    from fieldmap.nav.plots import at_paper_duration

    paper = at_paper_duration(res.meta)
    lines = [
        f"== {res.study}: truth {res.meta['truth_model']} degree {res.meta['truth_degree']}, "
        f"{res.meta['duration_s']:g} s, IMU {res.meta['imu_rate_hz']:g} Hz =="
    ]
    if res.study == "table1":
        lines.append(
            f"{'model':8s} {'|dv| m/s':>10s} {'|dp| m':>10s} {'horiz m':>10s} {'vert m':>10s} "
            f"{'eval s':>10s}" + ("   paper: |dv| |dp| eval" if paper else "")
        )
        for r in res.rows:
            p = PAPER_TABLE1.get(r["model"], ("", "", "")) if paper else ("", "", "")
            lines.append(
                f"{r['model']:8s} {_num(r['final_velocity_error_m_s'], '10.4f', 10)} "
                f"{_num(r['final_position_error_m'], '10.2f', 10)} "
                f"{_num(r.get('final_horizontal_error_m'), '10.2f', 10)} "
                f"{_num(r.get('final_vertical_error_m'), '10.2f', 10)} "
                f"{_num(r.get('gravity_eval_seconds'), '10.2e', 10)}"
                + (f"   {p[0]} {p[1]} {p[2]}" if paper else "")
            )
        fl = res.meta["floor"]
        lines.append(
            f"floor ({fl['nav_gravity']} = truth): |dv| {fl['final_velocity_error_m_s']:.3e} m/s, "
            f"|dp| {fl['final_position_error_m']:.3e} m "
            f"(smallest effect / floor: {fl['margin_position']:.3g}x, "
            f"{fl['margin_velocity']:.3g}x)"
        )
    else:
        key = "group" if res.study == "table3" else "case"
        show = paper and res.study == "table3"
        lines.append(
            f"{key:14s} {'|dv| mean':>10s} {'rms':>8s} {'|dp| mean':>10s} {'rms':>8s} "
            f"{'p95':>8s} {'horiz rms':>10s} {'vert rms':>10s}"
            + ("   paper |dv| |dp|" if show else "")
        )
        for r in res.rows:
            q = PAPER_TABLE3.get(r["group"], ("", "")) if show else ("", "")
            lines.append(
                f"{str(r[key]):14s} {_num(r['final_velocity_error_m_s_mean'], '10.4f', 10)} "
                f"{_num(r['final_velocity_error_m_s_rms'], '8.4f', 8)} "
                f"{_num(r['final_position_error_m_mean'], '10.2f', 10)} "
                f"{_num(r['final_position_error_m_rms'], '8.2f', 8)} "
                f"{_num(r['final_position_error_m_p95'], '8.2f', 8)} "
                f"{_num(r.get('final_horizontal_error_m_rms'), '10.2f', 10)} "
                f"{_num(r.get('final_vertical_error_m_rms'), '10.2f', 10)}"
                + (f"   {q[0]} {q[1]}" if show else "")
            )
    for d in res.meta.get("diverged", []):
        lines.append(f"DIVERGED: run {d['run']} (model {d['model']}) at t = {d['time_s']:.0f} s")
    return "\n".join(lines)


def _json_doc(res: StudyResult) -> dict[str, Any]:
    from fieldmap.nav.paper_tables import PAPER_TABLE1, PAPER_TABLE3

    doc: dict[str, Any] = {
        "study": res.study,
        "truth_model": res.meta["truth_model"],
        "truth_degree": res.meta["truth_degree"],
        "diverged": res.meta.get("diverged", []),
        "meta": res.meta,
    }
    if res.study == "table1":
        doc["floor"] = res.meta["floor"]
        for r in res.rows:
            doc[r["model"]] = {k: v for k, v in r.items() if k != "model"}
        doc["paper"] = {
            k: dict(
                zip(
                    ("final_velocity_error_m_s", "final_position_error_m", "gravity_eval_seconds"),
                    v,
                )
            )
            for k, v in PAPER_TABLE1.items()
        }
    else:
        doc["rows"] = res.rows
        if res.study == "table3":
            doc["paper"] = {
                f"group{k}": dict(zip(("final_velocity_error_m_s", "final_position_error_m"), v))
                for k, v in PAPER_TABLE3.items()
            }
    return doc


def write_outputs(
    res: StudyResult, out: str | Path | OutputBatch, *, figures: bool = True
) -> list[str]:
    """CSV, JSON, NetCDF and PNG of one study; return the paths.

    ``out`` is a folder (the four files are written as one
    :func:`fieldmap.products.io.output_batch`)
    or an open :class:`fieldmap.products.io.OutputBatch` (committed by its owner).
    ``figures=False``: no PNG (``fieldmap navsim --no-plots``).
    """
    from fieldmap.products.io import OutputBatch, output_batch, signals_deferred

    if not isinstance(out, OutputBatch):
        with output_batch(out) as batch:
            paths: list = write_outputs(res, batch, figures=figures)
        return paths
    base = f"navsim_{res.study}"
    buf = io.StringIO()
    keys = list(dict.fromkeys(k for r in res.rows for k in r))
    w = csv.DictWriter(buf, fieldnames=keys)
    w.writeheader()
    w.writerows(res.rows)
    paths = [
        out.text(buf.getvalue(), base + ".csv"),
        out.text(json.dumps(_json_doc(res), indent=2, default=float) + "\n", base + ".json"),
        out.netcdf(to_dataset(res), base + ".nc"),
    ]
    if not figures:
        return [str(p) for p in paths]
    with signals_deferred():  # see fieldmap.products.io.signals_deferred
        plot(res, str(out.path(base + ".png")))
    paths.append(out.folder / (base + ".png"))
    return [str(p) for p in paths]


def plot(res: StudyResult, path: str) -> None:
    """Write the study's figure (Figs. 11-13 like; see :mod:`fieldmap.nav.plots`) as PNG."""
    from fieldmap.nav.plots import plot as _plot

    _plot(res, path)


# --- flight study ---------------------------------------------------------------------------
#: fewest Monte Carlo draws the text report trusts the 10 % rule with: the IMU-only RMS of n
#: draws of a 2-D Gaussian error is uncertain by about 1/(2√n) (16 % at 10 draws, 29 % at 3),
#: and a model's RMS can come out below the IMU-only one although it adds error
MIN_RULE_DRAWS = 10


def _columns(cols: list[tuple[str, str, int]]) -> list[str]:
    """Two header lines, names over units: ``cols`` is ``[(name, unit, width), ...]``."""
    names = " ".join(f"{n:{w}s}" if k == 0 else f"{n:>{w}s}" for k, (n, _, w) in enumerate(cols))
    units = " ".join(f"{u:{w}s}" if k == 0 else f"{u:>{w}s}" for k, (_, u, w) in enumerate(cols))
    return [names, units]


def _gravity_cells(g: dict[str, Any]) -> str:
    """Return the gravity contribution and its terms (a), (b), (c), horizontal, as table cells."""
    gt = g.get("horizontal_terms_m") or {}
    return (
        f"{_num(g.get('horizontal_m'), '14.3f', 14)} "
        f"{_num(gt.get('model_difference'), '10.3f', 10)} "
        f"{_num(gt.get('omission'), '13.3f', 13)} {_num(gt.get('commission'), '15.3f', 15)}"
    )


GRAVITY_COLUMNS = [
    ("gravity horiz", "m", 14),
    ("(a) model", "m", 10),
    ("(b) omission", "m", 13),
    ("(c) commission", "m", 15),
]


def _rule_caveat(doc: dict[str, Any]) -> list[str]:
    """Return a caution line when the 10 % rule rests on fewer than :data:`MIN_RULE_DRAWS` draws."""
    m = doc["meta"]
    n = int(m.get("draws") or 0)
    spec = m.get("imu_spec") or {}
    ideal = not any(v for v in spec.values() if isinstance(v, (int, float)))
    if ideal or n >= MIN_RULE_DRAWS:
        return []
    return [
        f"caution: the {doc['fraction']:.0%} rule compares with the IMU-only RMS of {n} draw(s), "
        f"itself uncertain by about ±{50.0 / np.sqrt(n):.0f} % (1σ); with so few draws a model's "
        "RMS can come out below the IMU-only one although the model adds error ('added horiz'): "
        f"fly {MIN_RULE_DRAWS} draws or more, or the covariance method"
    ]


def format_flight(res: FlightResult) -> str:
    """Plain-text report of a flight study: final errors per model, units under each column.

    A GNSS-aided study opens with the coasting errors at the end of each outage (the numbers
    that matter: aided, the errors at the flight's end are a fix's noise), then the table at
    the flight's end. A caution line says when the recommendation's rule rests on fewer than
    :data:`MIN_RULE_DRAWS` draws.
    """
    doc = res.summary
    m = doc["meta"]
    w = max(10, *(len(name) for name in doc["models"]))  # a table:FILE name can be long
    lines = [
        f"== flight {m['trajectory']}: {m['duration_s']:g} s, IMU {m['imu']} at "
        f"{m['imu_rate_hz']:g} Hz, {m['draws']} draw(s), frame {m['frame']}, altitude aiding "
        f"{m['altitude_aiding']}, truth {m['truth_model']} degree {m['truth_degree']} =="
    ]
    if "gnss" in doc:  # an aided study (the module entered only then)
        from fieldmap.nav.aiding import format_gnss

        lines.extend(format_gnss(doc))
        lines.append("at the flight's end (GNSS-aided):")
    lines += _columns(
        [
            ("model", "", w),
            ("horiz rms", "m", 10),
            ("horiz p95", "m", 10),
            ("vert rms", "m", 10),
            ("|dv| rms", "m/s", 9),
            ("added horiz", "m", 12),
            *GRAVITY_COLUMNS,
        ]
    )
    for name, e in doc["models"].items():
        lines.append(
            f"{name:{w}s} {_num(e['final_horizontal_error_m']['rms'], '10.3f', 10)} "
            f"{_num(e['final_horizontal_error_m']['p95'], '10.3f', 10)} "
            f"{_num(e['final_vertical_error_m']['rms'], '10.3f', 10)} "
            f"{_num(e['final_velocity_error_m_s']['rms'], '9.4f', 9)} "
            f"{_num(e.get('added_horizontal_error_m'), '12.3f', 12)} "
            + _gravity_cells(e.get("gravity") or {})
            + ("  DIVERGED" if e["diverged"] else "")
        )
    terms = m.get("gravity_terms")
    if terms:
        om = terms["omission_model"]
        lines.append(
            "gravity terms (linear error model, "
            f"{terms['draws']} draws): (a) navigation model minus truth; (b) "
            + (
                f"omission: degrees {terms['omission_degrees'][0]}..{terms['omission_degrees'][1]}"
                f" of the {om} degree variances"
                if om
                else "omission: off"
            )
            + "; (c) commission: "
            + ("the truth's coefficient sigma" if terms["commission"] else "off")
        )
    lines.extend(_rule_caveat(doc))
    lines.append(f"recommended model: {doc['recommendation']}")
    return "\n".join(lines)


def format_covariance(res: CovarianceStudyResult) -> str:
    """Plain-text error budget of a covariance study: each source, then each gravity model.

    Units under each column. A GNSS-aided study opens with the coasting errors at the end of
    each outage, and gives the sources and the models at the end of the worst outage (the
    recommendation's moment) beside the flight's end (aided: a fix's noise).
    """
    from fieldmap.nav.plots import budget_moment

    doc = res.summary
    m = doc["meta"]
    cov = res.covariance
    lines = [
        f"== flight {m['trajectory']}: {m['duration_s']:g} s, IMU {m['imu']}, frame {m['frame']}, "
        f"altitude aiding {m['altitude_aiding']}, truth {m['truth_model']} degree "
        f"{m['truth_degree']}: linear covariance analysis =="
    ]
    aided = "gnss" in doc
    i, when, _ = budget_moment(res)
    total = "all sources (root sum of squares)"
    sw = max([len(total), *(len(name) for name in cov.sources)])
    if aided:  # the module entered only then
        from fieldmap.nav.aiding import format_gnss

        lines.extend(format_gnss(doc))
        lines.append(f"error sources at {when}, and at the flight's end (GNSS-aided):")
        cols = [
            ("error source", "", sw),
            ("horiz σ", "m", 9),
            ("vert σ", "m", 9),
            ("final horiz σ", "m", 14),
            ("final vert σ", "m", 13),
        ]
    else:
        cols = [("error source", "", sw), ("final horiz σ", "m", 14), ("final vert σ", "m", 13)]
    lines += _columns(cols)

    def row(name: str, sigma: np.ndarray) -> str:
        cells = []
        if aided:
            cells += [_num(float(np.hypot(*sigma[i, :2])), "9.3f", 9),
                      _num(float(sigma[i, 2]), "9.3f", 9)]  # fmt: skip
        cells += [_num(float(np.hypot(*sigma[-1, :2])), "14.3f", 14),
                  _num(float(sigma[-1, 2]), "13.3f", 13)]  # fmt: skip
        return f"{name:{sw}s} " + " ".join(cells)

    for name in cov.sources:
        lines.append(row(name, cov.position[name]))
    lines.append(row(total, cov.total()))
    w = max(10, *(len(name) for name in doc["models"]))
    at = f"at {when}" if aided else "at the flight's end"
    lines.append(f"navigation models {at}: IMU errors and gravity together, and gravity alone")
    lines += _columns([("model", "", w), ("horiz", "m", 10), *GRAVITY_COLUMNS])
    worst = None
    if aided and doc["gnss"]["outages"]:
        worst = max(doc["gnss"]["outages"], key=lambda o: o["imu_only_horizontal_error_m"])
    for name, e in doc["models"].items():
        if worst is not None:
            here = worst["models"][name]
            total, g = here["horizontal_error_m"], here["gravity"]
        else:
            total, g = e["final_horizontal_error_m"], e["gravity"]
        lines.append(f"{name:{w}s} {_num(total, '10.3f', 10)} " + _gravity_cells(g))
    lines.append(f"recommended model: {doc['recommendation']}")
    return "\n".join(lines)


def write_covariance_outputs(
    res: CovarianceStudyResult,
    out: OutputBatch,
    prefix: str = "navsim_flight",
    *,
    figures: bool = True,
) -> list[str]:
    """``<prefix>.{json,csv,nc,png}`` and ``<prefix>_budget.png`` of a covariance study.

    Into an open output batch: the σ(t) figure and the error budget (:mod:`fieldmap.nav.plots`);
    ``figures=False``: no PNG (``fieldmap navsim --no-plots``).
    """
    from fieldmap.nav import plots
    from fieldmap.products.io import signals_deferred

    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["source", "final_horizontal_sigma_m", "final_vertical_sigma_m"])
    for name, e in res.summary["sources"].items():
        w.writerow([name, e["final_horizontal_sigma_m"], e["final_vertical_sigma_m"]])
    for name, e in res.summary["models"].items():
        for term, v in e["gravity"]["horizontal_terms_m"].items():
            w.writerow([f"gravity {term} ({name})", v, e["gravity"]["vertical_terms_m"][term]])
    paths = [
        out.text(json.dumps(res.summary, indent=2, default=float) + "\n", f"{prefix}.json"),
        out.text(buf.getvalue(), f"{prefix}.csv"),
        out.netcdf(res.to_dataset(), f"{prefix}.nc"),
    ]
    if not figures:
        return [str(p) for p in paths]
    with signals_deferred():
        paths.append(out.png(plots.sigma_figure(res), f"{prefix}.png"))
        paths.append(out.png(plots.budget_figure(res), f"{prefix}_budget.png"))
    return [str(p) for p in paths]


def write_flight_outputs(
    res: FlightResult,
    out: str | Path | OutputBatch,
    disturbance: tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike] | None = None,
    prefix: str = "navsim_flight",
    *,
    figures: bool = True,
) -> list[str]:
    """``<prefix>.{json,csv,nc,png}``, ``<prefix>_track.png`` and ``_budget.png`` of a flight study.

    ``out`` is a folder or an open :class:`fieldmap.products.io.OutputBatch`. ``disturbance``:
    optional ``(lat, lon, dg_mgal)`` grid for the ground-track figure; ``prefix`` the file
    names' stem (default ``navsim_flight``); ``figures=False``: no PNG (``fieldmap navsim
    --no-plots``).
    """
    from fieldmap.nav import plots
    from fieldmap.products.io import OutputBatch, output_batch, signals_deferred

    if not isinstance(out, OutputBatch):
        with output_batch(out) as batch:
            return write_flight_outputs(res, batch, disturbance, prefix, figures=figures)
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(["model", "statistic", "horizontal_m", "vertical_m", "north_m", "east_m", "down_m"])
    for name, e in res.summary["models"].items():
        for st in ("mean", "rms", "p95"):
            w.writerow(
                [name, st]
                + [
                    e[k][st]
                    for k in (
                        "final_horizontal_error_m",
                        "final_vertical_error_m",
                        "final_north_error_m",
                        "final_east_error_m",
                        "final_down_error_m",
                    )
                ]
            )
    paths = [
        out.text(json.dumps(res.summary, indent=2, default=float) + "\n", f"{prefix}.json"),
        out.text(buf.getvalue(), f"{prefix}.csv"),
        out.netcdf(flight_dataset(res), f"{prefix}.nc"),
    ]
    if not figures:
        return [str(p) for p in paths]
    with signals_deferred():
        paths.append(out.png(plots.errors_figure(res), f"{prefix}.png"))
        paths.append(out.png(plots.track_figure(res, disturbance), f"{prefix}_track.png"))
        paths.append(out.png(plots.budget_figure(res), f"{prefix}_budget.png"))
    return [str(p) for p in paths]
