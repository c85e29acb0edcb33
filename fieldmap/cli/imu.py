"""``fieldmap imu allan``: Allan deviation of a simulated IMU (preset or TOML) at rest.

Writes ``imu_allan_<name>.csv`` (τ, gyro and accelerometer Allan deviation), ``.json`` (the
spec and what it predicts) and ``.png`` (log-log plot with the white-noise line N/√τ and the
bias-instability floor) under ``--out``, all or nothing.
"""

from __future__ import annotations

import argparse
import io
import json
import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

import numpy as np

from fieldmap import durations
from fieldmap.errors import InputError


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``imu`` sub-command (``imu allan``)."""
    p = subparsers.add_parser(
        "imu",
        help="IMU error models: Allan deviation of a preset or TOML unit",
        description="Tools for the IMU error models of fieldmap navsim.",
    )
    sub = p.add_subparsers(dest="imu_command", metavar="IMU_COMMAND", required=True)
    a = sub.add_parser(
        "allan",
        help="Allan deviation of the simulated sensors (plot + table)",
        description="Simulate the gyros and accelerometers at rest and write their Allan "
        "deviation, to compare with a datasheet. Bad input: one line, exit 2, nothing written.",
    )
    a.add_argument(
        "--imu",
        default="tactical",
        help="preset (ideal consumer industrial tactical navigation strategic table2-groupN "
        "table4) or a TOML file (default tactical)",
    )
    a.add_argument(
        "--duration",
        type=durations.argument,
        default=7200.0,
        metavar="TIME",
        help="record length in s, or with a unit s, min, h (default 7200 s, 2h)",
    )
    a.add_argument("--rate", type=float, default=100.0, help="sample rate in Hz (default 100)")
    a.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    a.add_argument("--out", default="outputs", help="output folder (default outputs/)")
    a.add_argument("--no-plots", action="store_true", help="write CSV and JSON only")
    a.set_defaults(func=run_allan)


def run_allan(args: argparse.Namespace) -> int:
    """Simulate, write the table, JSON and plot, print the table."""
    from fieldmap.cli import given
    from fieldmap.nav.sensors import allan_table, load_imu
    from fieldmap.products.io import check_out_dir, output_batch, signals_deferred

    for name, v in (("--duration", args.duration), ("--rate", args.rate)):
        if not np.isfinite(v) or v <= 0:
            raise InputError(f"{name} must be a positive number, got {v}")
    if args.seed < 0:
        raise InputError(f"--seed must be >= 0, got {args.seed}")
    label, spec = load_imu(args.imu)
    if spec.is_ideal and given(args, "seed"):
        raise InputError(f"--seed: IMU {label!r} has no random errors to draw")
    check_out_dir(args.out)
    tab = allan_table(spec, args.duration, args.rate, seed=args.seed)
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", label)
    base = f"imu_allan_{safe}"
    buf = io.StringIO()
    buf.write("tau_s,gyro_adev_deg_h,accel_adev_ug\n")
    for t, g, a in zip(tab["tau_s"], tab["gyro_adev_deg_h"], tab["accel_adev_ug"]):
        buf.write(f"{t:.6g},{g:.6g},{a:.6g}\n")
    doc = {"imu": label, "spec": spec.__dict__, "duration_s": args.duration, "rate_hz": args.rate}
    doc |= {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in tab.items()}
    with output_batch(args.out) as batch:
        batch.text(buf.getvalue(), base + ".csv")
        batch.text(json.dumps(doc, indent=2) + "\n", base + ".json")
        if not args.no_plots:
            with signals_deferred():
                batch.png(_figure(label, tab), base + ".png")
    print(f"Allan deviation of {label!r} ({args.duration:g} s at {args.rate:g} Hz, axis x)")
    print(f"{'tau s':>10s} {'gyro deg/h':>12s} {'accel ug':>12s}")
    for t, g, a in zip(tab["tau_s"][::4], tab["gyro_adev_deg_h"][::4], tab["accel_adev_ug"][::4]):
        print(f"{t:10.3g} {g:12.4g} {a:12.4g}")
    print(
        f"spec: ARW -> {tab['gyro_arw_at_1s_deg_h']:.4g} deg/h at 1 s, VRW -> "
        f"{tab['accel_vrw_at_1s_ug']:.4g} ug at 1 s; bias instability floors "
        f"{tab['gyro_bias_instability_deg_per_h']:.4g} deg/h, "
        f"{tab['accel_bias_instability_ug']:.4g} ug"
    )
    return 0


def _figure(label: str, tab: dict) -> Figure:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = tab["tau_s"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
    for ax, key, unit, wn, bi in (
        (
            axes[0],
            "gyro_adev_deg_h",
            "deg/h",
            tab["gyro_arw_at_1s_deg_h"],
            "gyro_bias_instability_deg_per_h",
        ),
        (axes[1], "accel_adev_ug", "µg", tab["accel_vrw_at_1s_ug"], "accel_bias_instability_ug"),
    ):
        y = tab[key]
        good = y > 0
        ax.loglog(t[good], y[good], "o-", ms=3, label="simulated")
        if wn > 0:
            ax.loglog(t, wn / np.sqrt(t), "--", color="0.4", label="white noise N/√τ (spec)")
        if tab[bi] > 0:
            ax.axhline(tab[bi], color="tab:red", ls=":", label="bias instability (spec)")
        ax.set_xlabel("averaging time τ (s)")
        ax.set_ylabel(f"Allan deviation ({unit})")
        ax.set_title("gyro" if key.startswith("gyro") else "accelerometer")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"IMU {label}: Allan deviation at rest")
    return fig
