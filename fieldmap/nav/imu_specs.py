"""IMU grades by name and custom IMUs from TOML files with unit-carrying keys.

Presets (1σ, typical datasheet values of each grade; ``ideal`` has no errors):

===========  ========  ========  ======  =========  ========  =========  =====  =======
grade        acc bias  acc VRW   acc BI  gyro bias  gyro ARW  gyro BI    scale  misalign
             µg        µg/√Hz    µg      °/h        °/√h      °/h        ppm    arcsec
===========  ========  ========  ======  =========  ========  =========  =====  =======
consumer     5000      150       100     360        0.6       10         5000   1800
industrial   500       25        10      10         0.2       2          500    300
tactical     1000      100       50      1          0.125     0.3        300    100
navigation   25        10        5       0.003      0.002     0.001      30     10
strategic    1         1         0.5     0.0001     0.0001    0.00005    1      1
===========  ========  ========  ======  =========  ========  =========  =====  =======

Bias-instability correlation time: 3600 s for every preset. Sources of the ranges: Groves (2013)
*Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed., §4.4
(Tables 4.1 and 4.2: accelerometer and gyro biases by grade: marine/strategic ≤ 10 µg and
0.0001 °/h, aviation/navigation 25–50 µg and 0.001–0.01 °/h, tactical 100–1000 µg and 1–100 °/h,
consumer > 3000 µg and > 100 °/h; ARW 0.002 °/√h for aviation, 0.03–0.5 °/√h for tactical) and
datasheets of representative units: consumer — Bosch BMI088 and TDK InvenSense ICM-20948 (noise
densities 150–230 µg/√Hz, 0.014–0.015 °/s/√Hz, zero-rate offsets of degrees per second before
calibration); industrial — Analog Devices ADIS16470/ADIS16495 (in-run bias stability 0.8–8 °/h
and 3–13 µg, ARW 0.1–0.34 °/√h); tactical — Honeywell HG1700/HG1930 (1 mg, 1–20 °/h,
0.125 °/√h); navigation — Honeywell HG9900 class ring-laser units (25 µg, 0.003 °/h,
0.002 °/√h); strategic — submarine/ICBM-class systems as tabulated by Titterton & Weston (2004)
*Strapdown Inertial Navigation Technology*, 2nd ed., Table 4.1 and §10.

Also named: ``table2-group1`` … ``table2-group4`` and ``table4`` (Chen et al. 2022 Tables 2 and
4, see :mod:`fieldmap.nav.imu_errors`).

TOML keys (all optional, unknown keys are an error; ``name`` and ``description`` are text)::

    accel_bias_ug, accel_vrw_ug_per_sqrt_hz, accel_bias_instability_ug,
    accel_bias_instability_tau_s, accel_scale_factor_ppm, accel_misalignment_arcsec,
    gyro_bias_deg_per_h, gyro_arw_deg_per_sqrt_h, gyro_bias_instability_deg_per_h,
    gyro_bias_instability_tau_s, gyro_scale_factor_ppm, gyro_misalignment_arcsec,
    scale_factor_ppm, misalignment_arcsec, bias_instability_tau_s   (both sensor triads)
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

from fieldmap.errors import InputError
from fieldmap.nav.imu_errors import TABLE2_GROUPS, TABLE4, ImuErrorSpec


def _grade(ab, avrw, abi, gb, garw, gbi, sf, mis) -> ImuErrorSpec:
    return ImuErrorSpec(
        acc_bias_ug=ab,
        acc_noise_ug_rthz=avrw,
        acc_bi_ug=abi,
        acc_scale_ppm=sf,
        acc_misalign_arcsec=mis,
        gyro_bias_deg_h=gb,
        gyro_arw_deg_rth=garw,
        gyro_bi_deg_h=gbi,
        gyro_scale_ppm=sf,
        gyro_misalign_arcsec=mis,
    )


#: named IMUs (see the module docstring for the sources)
PRESETS: dict[str, ImuErrorSpec] = {
    "ideal": ImuErrorSpec(),
    "consumer": _grade(5000.0, 150.0, 100.0, 360.0, 0.6, 10.0, 5000.0, 1800.0),
    "industrial": _grade(500.0, 25.0, 10.0, 10.0, 0.2, 2.0, 500.0, 300.0),
    "tactical": _grade(1000.0, 100.0, 50.0, 1.0, 0.125, 0.3, 300.0, 100.0),
    "navigation": _grade(25.0, 10.0, 5.0, 0.003, 0.002, 0.001, 30.0, 10.0),
    "strategic": _grade(1.0, 1.0, 0.5, 0.0001, 0.0001, 0.00005, 1.0, 1.0),
    **{f"table2-group{k}": v for k, v in TABLE2_GROUPS.items()},
    "table4": TABLE4,
}

#: TOML key -> ImuErrorSpec field(s)
TOML_KEYS = {
    "accel_bias_ug": ("acc_bias_ug",),
    "accel_vrw_ug_per_sqrt_hz": ("acc_noise_ug_rthz",),
    "accel_bias_instability_ug": ("acc_bi_ug",),
    "accel_bias_instability_tau_s": ("acc_bi_tau_s",),
    "accel_scale_factor_ppm": ("acc_scale_ppm",),
    "accel_misalignment_arcsec": ("acc_misalign_arcsec",),
    "gyro_bias_deg_per_h": ("gyro_bias_deg_h",),
    "gyro_arw_deg_per_sqrt_h": ("gyro_arw_deg_rth",),
    "gyro_bias_instability_deg_per_h": ("gyro_bi_deg_h",),
    "gyro_bias_instability_tau_s": ("gyro_bi_tau_s",),
    "gyro_scale_factor_ppm": ("gyro_scale_ppm",),
    "gyro_misalignment_arcsec": ("gyro_misalign_arcsec",),
    "scale_factor_ppm": ("acc_scale_ppm", "gyro_scale_ppm"),
    "misalignment_arcsec": ("acc_misalign_arcsec", "gyro_misalign_arcsec"),
    "bias_instability_tau_s": ("acc_bi_tau_s", "gyro_bi_tau_s"),
}
_TEXT_KEYS = ("name", "description")


def spec_from_mapping(data: dict, source: str = "IMU spec") -> ImuErrorSpec:
    """Build an :class:`ImuErrorSpec` from TOML-style keys (see the module docstring)."""
    unknown = sorted(k for k in data if k not in TOML_KEYS and k not in _TEXT_KEYS)
    if unknown:
        raise InputError(
            f"{source}: unknown key(s) {', '.join(unknown)} (known: {', '.join(TOML_KEYS)})"
        )
    values: dict[str, float] = {}
    for key, val in data.items():
        if key in _TEXT_KEYS:
            continue
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            raise InputError(f"{source}: {key} = {val!r} is not a number")
        if not (val == val and abs(val) != float("inf")) or val < 0:
            raise InputError(f"{source}: {key} = {val!r} must be finite and >= 0")
        if key.endswith("tau_s") and val <= 0:
            raise InputError(f"{source}: {key} = {val!r} must be > 0 s")
        for field in TOML_KEYS[key]:
            if field in values and key in ("scale_factor_ppm", "misalignment_arcsec"):
                continue  # a specific accel_/gyro_ key wins over the shared one
            values[field] = float(val)
    return replace(ImuErrorSpec(), **values)


def load_imu(name_or_path) -> tuple[str, ImuErrorSpec]:
    """Return ``(label, spec)`` for a preset name or a TOML file path.

    Raises
    ------
    InputError
        Unknown name, unreadable or malformed file, unknown key or bad value.
    """
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # Python 3.10: the same parser, from PyPI
        import tomli as tomllib

    key = str(name_or_path).strip()
    if key.lower() in PRESETS:
        return key.lower(), PRESETS[key.lower()]
    path = Path(key)
    if not path.suffix.lower() == ".toml" and not path.is_file():
        raise InputError(f"unknown IMU {key!r}: a preset ({', '.join(PRESETS)}) or a .toml file")
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: IMU file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the IMU file ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    spec = spec_from_mapping(data, str(path))
    return str(data.get("name", path.stem)), spec
