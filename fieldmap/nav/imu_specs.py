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

TOML keys (each optional, unknown keys are an error; ``name`` and ``description`` are text)::

    accel_bias_ug, accel_vrw_ug_per_sqrt_hz, accel_bias_instability_ug,
    accel_bias_instability_tau_s, accel_scale_factor_ppm, accel_misalignment_arcsec,
    gyro_bias_deg_per_h, gyro_arw_deg_per_sqrt_h, gyro_bias_instability_deg_per_h,
    gyro_bias_instability_tau_s, gyro_scale_factor_ppm, gyro_misalignment_arcsec,
    scale_factor_ppm, misalignment_arcsec, bias_instability_tau_s   (both sensor triads)

A file must set at least one error term (a key other than the correlation times): an empty file
is refused rather than read as a perfect IMU; the preset ``ideal`` (``--imu ideal``) asks for one.

Allowed ranges (:data:`RANGES`; a value outside, NaN or infinite is refused with the key, the
value, the file and the range). Zero means the source is absent. The upper limits lie well above
the worst consumer MEMS part before calibration, so that no real unit is refused while a typo in
the exponent (``1e300``, a value in the wrong unit by 10⁶) is (``*`` stands for ``accel_``,
``gyro_`` and the shared key of both triads):

==================================  ===========  =============================================
key                                 range        upper limit
==================================  ===========  =============================================
accel_bias_ug                       0 … 1e5      100 mg: 5x the ±20 mg zero-g offset of an
                                                 uncalibrated consumer part (BMI088), 20x
                                                 ``consumer``
accel_vrw_ug_per_sqrt_hz            0 … 1e4      10 mg/√Hz: 25x the noisiest consumer parts
                                                 (≈ 400 µg/√Hz), 70x ``consumer``
accel_bias_instability_ug           0 … 1e4      10 mg: 100x ``consumer``
gyro_bias_deg_per_h                 0 … 1e5      ≈ 28 °/s: above the ±20 °/s zero-rate offset
                                                 of an uncalibrated consumer part (MPU-6050)
gyro_arw_deg_per_sqrt_h             0 … 30       0.5 °/s/√Hz: 10x the noisiest consumer parts
                                                 (≈ 0.05 °/s/√Hz = 3 °/√h), 50x ``consumer``
gyro_bias_instability_deg_per_h     0 … 1000     20x the ≈ 50 °/h of low-cost MEMS gyros,
                                                 100x ``consumer``
``*scale_factor_ppm``               0 … 1e5      10 %: 3x the ±3 % sensitivity tolerance of an
                                                 uncalibrated consumer part, 20x ``consumer``
``*misalignment_arcsec``            0 … 18000    5°: 4x the ±2 % (≈ 1.1°) cross-axis
                                                 sensitivity of consumer parts, 10x
                                                 ``consumer``
``*bias_instability_tau_s``         0.01 … 1e6   > 0; below 0.01 s the Gauss–Markov bias is
                                                 white noise (a noise-density key), above
                                                 11.6 days a constant bias over any flight
==================================  ===========  =============================================
"""

from __future__ import annotations

import math
import numbers
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

#: TOML key -> (lowest, highest, unit) accepted; see the module docstring for the reasons
RANGES: dict[str, tuple[float, float, str]] = {
    "accel_bias_ug": (0.0, 1e5, "µg"),
    "accel_vrw_ug_per_sqrt_hz": (0.0, 1e4, "µg/√Hz"),
    "accel_bias_instability_ug": (0.0, 1e4, "µg"),
    "accel_bias_instability_tau_s": (0.01, 1e6, "s"),
    "accel_scale_factor_ppm": (0.0, 1e5, "ppm"),
    "accel_misalignment_arcsec": (0.0, 18000.0, "arcsec"),
    "gyro_bias_deg_per_h": (0.0, 1e5, "°/h"),
    "gyro_arw_deg_per_sqrt_h": (0.0, 30.0, "°/√h"),
    "gyro_bias_instability_deg_per_h": (0.0, 1000.0, "°/h"),
    "gyro_bias_instability_tau_s": (0.01, 1e6, "s"),
    "gyro_scale_factor_ppm": (0.0, 1e5, "ppm"),
    "gyro_misalignment_arcsec": (0.0, 18000.0, "arcsec"),
    "scale_factor_ppm": (0.0, 1e5, "ppm"),
    "misalignment_arcsec": (0.0, 18000.0, "arcsec"),
    "bias_instability_tau_s": (0.01, 1e6, "s"),
}
_SHARED_KEYS = ("scale_factor_ppm", "misalignment_arcsec", "bias_instability_tau_s")


def _check_value(key: str, val, source: str) -> float:
    """Return ``val`` of ``key`` as a float, or raise the one-line InputError naming it."""
    if isinstance(val, bool) or not isinstance(val, numbers.Real):
        raise InputError(f"{source}: {key} = {val!r} is not a number")
    if type(val) not in (int, float):  # a NumPy scalar (mapping from Python): shown as a number
        val = int(val) if isinstance(val, numbers.Integral) else float(val)
    if isinstance(val, float) and not math.isfinite(val):
        raise InputError(f"{source}: {key} = {val!r} is not a finite number")
    lo, hi, unit = RANGES[key]
    if not lo <= val <= hi:
        raise InputError(
            f"{source}: {key} = {val!r} is outside the allowed range {lo:.15g} … {hi:.15g} {unit} "
            "(see fieldmap.nav.imu_specs)"
        )
    return float(val)


def spec_from_mapping(data: dict, source: str = "IMU spec") -> ImuErrorSpec:
    """Build an :class:`ImuErrorSpec` from TOML-style keys (see the module docstring).

    Raises
    ------
    InputError
        An unknown key, a value that is no number, not finite or outside its range
        (:data:`RANGES`), or no error term at all (``{}`` is no ideal IMU: use the preset).
    """
    unknown = sorted(k for k in data if k not in TOML_KEYS and k not in _TEXT_KEYS)
    if unknown:
        raise InputError(
            f"{source}: unknown key(s) {', '.join(unknown)} (known: {', '.join(TOML_KEYS)})"
        )
    values: dict[str, float] = {}
    for key, val in data.items():
        if key in _TEXT_KEYS:
            continue
        number = _check_value(key, val, source)
        for field in TOML_KEYS[key]:
            if field in values and key in _SHARED_KEYS:
                continue  # a specific accel_/gyro_ key wins over the shared one
            values[field] = number
    if not any(k in data and not k.endswith("_tau_s") for k in TOML_KEYS):
        raise InputError(
            f"{source} sets no error terms (no key such as accel_bias_ug or "
            "gyro_arw_deg_per_sqrt_h); for an IMU without errors use the preset 'ideal' "
            "(--imu ideal)"
        )
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
