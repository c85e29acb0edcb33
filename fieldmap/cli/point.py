"""Sub-command ``fieldmap point``: gravity at points read from stdin.

``fieldmap point`` works like GeographicLib's ``Gravity``. (``fieldmap verify`` lives in
:mod:`fieldmap.cli.verify`.)

``fieldmap point`` reads lines ``lat lon [h]`` or ``lat,lon[,h]`` (geodetic degrees, metres above
WGS84; h defaults to 0 as in ``Gravity``) and prints one line per input line: east north up of
the disturbance in mGal (default), of gravity in m/s² (incl. centrifugal) or of normal gravity in
m/s². A line that
cannot be used prints ``ERROR: <reason>`` in its place, the other lines are still computed (in
one batched kernel launch) and the exit status is 1.

``--quantity disturbance-sigma|anomaly-sigma|geoid-sigma`` prints the commission error instead:
the standard deviation propagated from the model's coefficient σ
(:func:`fieldmap.field.commission.commission_sigma`, uncorrelated coefficient errors) of δg
east north up (mGal), of Δg (mGal) or of N (m, h must be 0). A model without σ columns is
refused in one line (exit status 2).

``--quantity gradient|gradient-disturbance`` prints the gradient tensor ∂g_i/∂x_j of gravity
(incl. centrifugal) or of the disturbance δg: 9 numbers, east north up, row-major, in Eötvös
(:func:`fieldmap.field.gradient.gradient_tensor`).

Heavy modules (Warp, the engine) are imported only when a command runs, so that ``fieldmap
point`` starts quickly.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable
from typing import IO, TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from fieldmap.models.shmodel import SHModel
    from fieldmap.products.tables.model import CompensationTable

QUANTITIES = (
    "disturbance",
    "gravity",
    "normal",
    "anomaly",
    "geoid",
    "potential",
    "disturbance-sigma",
    "anomaly-sigma",
    "geoid-sigma",
    "gradient",
    "gradient-disturbance",
    "height-anomaly",
    "anomaly-classical",
    "disturbance-sa",
    "trr",
    "ewh",
    "gradient-invariants",
)
#: ICGEM's functionals (:mod:`fieldmap.field.geodesy`, :mod:`fieldmap.field.water`): one value
#: a line
FUNCTIONALS = ("height-anomaly", "anomaly-classical", "disturbance-sa", "trr", "ewh")
#: the quantities defined on the ellipsoid's surface: h must be 0
_SURFACE = ("geoid", "geoid-sigma", "height-anomaly", "ewh")
#: The names of :data:`fieldmap.field.normal.NORMAL_MODELS` (kept here so that ``--help`` does
#: not import Warp; a test checks that both agree).
NORMALS = ("exact", "j2", "j4", "j6", "groves-j2")
#: model-file options of :func:`fieldmap.models.registry.model_options` left at their defaults
_DEFAULT_MODEL_OPTIONS = {
    "model_dir": None,
    "gm": None,
    "radius": None,
    "cache": True,
    "tide_system": None,
}
#: as GeographicLib's Gravity (no T there: 4 decimals of m²/s² are 0.01 mm of geoid height)
_DEFAULT_DECIMALS = {
    "disturbance": 3,
    "gravity": 5,
    "normal": 5,
    "anomaly": 3,
    "geoid": 4,
    "potential": 4,
    "disturbance-sigma": 3,
    "anomaly-sigma": 3,
    "geoid-sigma": 4,
    "gradient": 3,
    "gradient-disturbance": 3,
    "height-anomaly": 4,
    "anomaly-classical": 3,
    "disturbance-sa": 3,
    "trr": 4,
    "ewh": 4,
    "gradient-invariants": 3,
}


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``point`` sub-command."""
    p = subparsers.add_parser(
        "point",
        help="gravity at points read from stdin (lat lon h per line)",
        description=(
            "Read 'lat lon [h]' or 'lat,lon[,h]' lines (degrees, degrees, metres above WGS84; "
            "whitespace- or comma-separated) and print east north "
            "up per line: the gravity disturbance in mGal (default), gravity incl. centrifugal "
            "in m/s², or normal gravity in m/s². Accepted: |lat| <= 90, lon in [-540, 540), "
            "h from -10 km to 1e5 km. A bad line prints 'ERROR: reason' in its place (one "
            "summary line on stderr, exit status 1); bad options: one line on stderr, exit 2. "
            "Empty input: no output, exit 0. An option the quantity does not use (--normal "
            "without --quantity normal, a model option with it) is refused the same way."
        ),
    )
    p.add_argument(
        "--quantity",
        choices=QUANTITIES,
        default="disturbance",
        help="disturbance (mGal), gravity (m/s², incl. centrifugal), normal (m/s²); "
        "anomaly: Δg (mGal), ξ north, η east (arcsec), as Gravity -A; geoid: N (m), as "
        "Gravity -H (h must be 0); potential: disturbing potential T (m²/s²); "
        "disturbance-sigma, anomaly-sigma, geoid-sigma: the commission error (standard "
        "deviation propagated from the model's coefficient sigmas, uncorrelated) of δg east "
        "north up (mGal), of Δg (mGal) or of N (m, h must be 0); gradient, "
        "gradient-disturbance: the 9 components dg_i/dx_j (east north up, row-major, in "
        "Eötvös, 1 E = 1e-9 s⁻²) of gravity incl. centrifugal or of the disturbance; ICGEM's "
        "functionals (Barthelmes 2013): height-anomaly: ζ on the ellipsoid (m, h must be 0), "
        "anomaly-classical: |∇W(h)| − |∇U(h − ζ)| (mGal), disturbance-sa: −∂T/∂r (mGal), trr: "
        "∂²T/∂r² (Eötvös), ewh: equivalent water height (m, h must be 0) of --model minus "
        "--minus; gradient-invariants: I1 (E²), I2 (E³) and the eigenvalues (E, decreasing) of "
        "the model gravitation's tensor",
    )
    p.add_argument(
        "--minus",
        default=None,
        metavar="REFERENCE",
        help="--quantity ewh: the reference field subtracted from --model (a mean field, "
        "another month, or the same time-variable model: with --epoch T the change since its "
        "reference epoch); loaded with --lmax and the model-file options",
    )
    p.add_argument(
        "--normal",
        choices=NORMALS,
        type=lambda s: str(s).lower().replace("_", "-"),
        default="exact",
        help="normal-gravity model for --quantity normal, the normal= of the Python API "
        "(default: exact)",
    )
    p.add_argument(
        "--model",
        default="eigen-6s",
        help="bundled model name, model file (ICGEM .gfc[.gz], NGA coefficients, GeographicLib "
        ".egm) or GeographicLib model name (default: eigen-6s); table:FILE: a compensation "
        "table of 'fieldmap table' (table.nc or table.bin), --quantity disturbance only",
    )
    from fieldmap.cli.model_options import add_model_options

    add_model_options(p)
    p.add_argument(
        "--lmax",
        type=int,
        default=None,
        help="truncation degree, 0..the model's (default: the model's full degree)",
    )
    p.add_argument(
        "--epoch",
        default=None,
        help="epoch of time-variable terms: decimal year (1900..2200) or YYYY-MM-DD "
        "(default: the model's reference epoch; refused for a model without such terms)",
    )
    p.add_argument("--device", default=None, help="Warp device: cpu, cuda, cuda:N (default: auto)")
    p.add_argument(
        "--precision",
        type=int,
        default=None,
        help="decimals printed (default: 3 for mGal, 5 for m/s², as Gravity)",
    )
    p.add_argument("--input", default="-", help="read points from this file (default: stdin)")
    p.set_defaults(func=run_point)


def parse_point_line(line: str) -> tuple[float, float, float]:
    """Return ``(lat, lon, h)`` of one input line, or raise ValueError with the reason.

    The numbers are separated by commas (``30,105,20000``, the usual CSV export; spaces around
    them allowed) or by whitespace (``30 105 20000``, as GeographicLib's ``Gravity``); a line
    with a comma is read as comma-separated, so an empty field (``30,,105``) is an error, not
    a missing number skipped. Only the syntax is checked here (2 or 3 finite numbers); the
    ranges are those of the API, checked for all lines at once by
    :func:`fieldmap.limits.point_errors`. Units: degrees, degrees, m.
    """
    fields = [f.strip() for f in line.split(",")] if "," in line else line.split()
    if len(fields) not in (2, 3):
        raise ValueError(f"expected 'lat lon [h]', got {len(fields)} fields")
    if "" in fields:
        raise ValueError(f"empty field {fields.index('') + 1} in {line.strip()!r}")
    vals = []
    for name, text in zip(("latitude", "longitude", "height"), fields):
        try:
            v = float(text.replace("_", "!"))  # float() alone would read 3_0 as 30
        except ValueError:
            raise ValueError(f"{name} {text!r} is not a number") from None
        if not math.isfinite(v):
            raise ValueError(f"{name} {text!r} is not finite")
        vals.append(v)
    return vals[0], vals[1], vals[2] if len(vals) == 3 else 0.0


def evaluate_points(
    lat: npt.ArrayLike,
    lon: npt.ArrayLike,
    h: npt.ArrayLike,
    *,
    quantity: str = "disturbance",
    normal: str = "exact",
    model: str = "eigen-6s",
    device: str | None = None,
    model_options: dict[str, Any] | None = None,
) -> np.ndarray:
    """East, north, up of ``quantity`` at the points, in one batched launch.

    Parameters
    ----------
    lat, lon : numpy.ndarray
        Geodetic latitude and longitude. Units: degrees.
    h : numpy.ndarray
        Height above WGS84. Units: m.
    quantity : str
        One of :data:`QUANTITIES`: disturbance (mGal), gravity incl. centrifugal (m/s²), normal
        gravity (m/s²), anomaly and deflection (mGal, arcsec, arcsec), geoid height (m),
        disturbing potential (m²/s²), see :mod:`fieldmap.field.geodesy`; ``*-sigma``: their
        commission error (:mod:`fieldmap.field.commission`).
    normal : {"exact", "j2", "j4", "j6", "groves-j2"}
        Normal model of ``quantity="normal"``.
    model : str
        A bundled model name, a model file or ``table:FILE``, loaded here with
        ``model_options`` (while Warp is imported: :mod:`fieldmap.cli.startup`).
    device : str, optional
        Warp device.
    model_options : dict, optional
        Keywords of :func:`fieldmap.models.registry.load_model`: ``lmax``, ``epoch``,
        ``model_dir``, ``gm``, ``radius``, ``cache``, ``tide_system``.

    Returns
    -------
    numpy.ndarray
        Shape ``(n, 3)``, ``(n, 9)`` for the gradients (E, row-major), or ``(n, 1)`` for geoid,
        potential, anomaly-sigma and geoid-sigma.
    """
    from fieldmap.cli.startup import load_model_early
    from fieldmap.models.registry import table_path

    table = table_path(model) is not None
    early = load_model_early(model, model_options, quantity, device, table)
    from fieldmap import _warp

    device = _warp.resolve_device(device)
    if quantity == "normal":
        from fieldmap.field.normal import normal_gravity

        return normal_gravity(
            lat, lon, h, normal=normal, centrifugal=True, frame="enu", device=device
        )
    import numpy as np

    from fieldmap.field import gravity as fg
    from fieldmap.models.registry import announce

    if table:  # a compensation table: its interpolated δg (NumPy)
        return fg.disturbance(lat, lon, h, model=model, units="mGal", frame="enu")
    sh_model = early.settle()  # loaded while Warp was imported; its error after the device's
    announce(sh_model)
    if quantity.endswith("-sigma"):
        from fieldmap.field.commission import commission_sigma

        what = quantity[: -len("-sigma")]
        sig = commission_sigma(lat, lon, h, model=sh_model, quantity=what)
        return sig if what == "disturbance" else sig[:, None]
    if quantity.startswith("gradient"):
        from fieldmap.field.gradient import gradient_tensor

        what = {"gradient": "gravity", "gradient-invariants": "gravitation"}.get(
            quantity, "disturbance"
        )
        t = gradient_tensor(lat, lon, h, model=sh_model, quantity=what, device=device)
        if quantity == "gradient-invariants":
            from fieldmap.field.gradient import INVARIANTS, gradient_invariants

            inv = gradient_invariants(t)
            return np.stack([inv[k] for k in INVARIANTS], axis=-1)
        return t.reshape(-1, 9)
    if quantity == "gravity":
        return fg.gravity(lat, lon, h, model=sh_model, frame="enu", device=device)
    if quantity in FUNCTIONALS[:-1]:  # ewh: run_point, with its reference
        from fieldmap.field import geodesy

        if quantity == "height-anomaly":
            return geodesy.height_anomaly(lat, lon, model=sh_model, device=device)[:, None]
        func = {
            "anomaly-classical": geodesy.classical_anomaly,
            "disturbance-sa": geodesy.disturbance_sa,
            "trr": geodesy.second_radial_derivative,
        }[quantity]
        return func(lat, lon, h, model=sh_model, device=device)[:, None]
    if quantity in ("anomaly", "geoid", "potential"):
        from fieldmap.field import geodesy

        if quantity == "anomaly":
            return np.stack(
                geodesy.gravity_anomaly(lat, lon, h, model=sh_model, device=device), axis=-1
            )
        if quantity == "geoid":
            return geodesy.geoid_height(lat, lon, model=sh_model, device=device)[:, None]
        return geodesy.disturbing_potential(lat, lon, h, model=sh_model, device=device)[:, None]
    return fg.disturbance(lat, lon, h, model=sh_model, units="mGal", frame="enu", device=device)


def run_point(args: argparse.Namespace) -> int:
    """Run ``fieldmap point``; return the exit status (1 if any line was bad)."""
    import numpy as np

    from fieldmap.errors import InputError
    from fieldmap.models.registry import model_options
    from fieldmap.products.tables.model import outside_message

    _refuse_unused(args)
    table = _table(args)
    opts = model_options(args)
    ewh = _ewh_difference(args, opts) if args.quantity == "ewh" else None
    decimals = _DEFAULT_DECIMALS[args.quantity] if args.precision is None else args.precision
    if not 0 <= decimals <= 20:
        raise InputError(f"--precision must be within 0..20, got {decimals}")
    if args.lmax is not None and args.lmax < 0:
        raise InputError(f"--lmax must be >= 0, got {args.lmax}")
    if args.input == "-":
        text = _read_capped(getattr(sys.stdin, "buffer", sys.stdin), "stdin")
    else:
        with open(args.input, "rb") as f:
            text = _read_capped(f, args.input)
    from fieldmap.limits import point_errors

    lines = text.splitlines()
    parsed: list[tuple[float, float, float]] = []
    results: list = []  # None: a point to compute, then its printed line
    for line in lines:
        try:
            pt = parse_point_line(line)
            if args.quantity in _SURFACE and pt[2] != 0.0:
                what = "the geoid height" if args.quantity.startswith("geoid") else args.quantity
                raise ValueError(f"{what} is defined on the ellipsoid: h must be 0")
            parsed.append(pt)
            results.append(None)
        except ValueError as exc:
            results.append(f"ERROR: {exc}")
    if parsed:  # the ranges of the API, with its messages
        where = [k for k, r in enumerate(results) if r is None]
        for k, why in zip(where, point_errors(*zip(*parsed))):
            if why is not None:
                results[k] = f"ERROR: {why}"
    if parsed and table is not None:  # a point outside the compensation table: a bad line
        for k, pt in zip(where, parsed):
            if results[k] is None and not table.contains(*pt)[0]:
                results[k] = f"ERROR: {outside_message(table, *pt)}"
    points = [p for p, k in zip(parsed, where) if results[k] is None] if parsed else []
    if points:
        lat, lon, h = (np.array(c, dtype=np.float64) for c in zip(*points))
        given = {k: v for k, v in opts.items() if v != _DEFAULT_MODEL_OPTIONS[k]}
        for key in ("lmax", "epoch"):
            if getattr(args, key) is not None:
                given[key] = getattr(args, key)
        if args.quantity == "ewh":
            from fieldmap.field.water import equivalent_water_height

            assert ewh is not None  # loaded above for this quantity
            values = equivalent_water_height(lat, lon, model=ewh, device=args.device)[:, None]
        else:
            values = evaluate_points(
                lat,
                lon,
                h,
                quantity=args.quantity,
                normal=args.normal,
                model=args.model,
                device=args.device,
                model_options=given or None,
            )
        it = iter(values)
        # never print NaN or inf: a point where the series does not converge is a bad line
        results = [r if r is not None else _format(next(it), decimals) for r in results]
    _write_all(sys.stdout, "".join(r + "\n" for r in results))
    bad = [k for k, r in enumerate(results) if r.startswith("ERROR:")]
    if bad:
        print(
            f"fieldmap point: {len(bad)} of {len(results)} input lines could not be used "
            f"(first: line {bad[0] + 1}: {results[bad[0]][7:]})",
            file=sys.stderr,
        )
        return 1
    return 0


def _ewh_difference(args: argparse.Namespace, opts: dict[str, Any]) -> SHModel:
    """``--quantity ewh``: the field ``--model`` minus ``--minus``, both loaded before any line.

    ``opts``: :func:`fieldmap.models.registry.model_options` of the command line; ``--lmax``
    applies to both, ``--epoch`` to ``--model`` only (the reference at its own epoch).
    """
    from fieldmap.field.water import field_difference
    from fieldmap.models.registry import announce, load_model

    model = load_model(args.model, lmax=args.lmax, epoch=args.epoch, **opts)
    announce(model)
    reference = load_model(args.minus, lmax=args.lmax, **opts)
    announce(reference)
    return field_difference(model, reference)


def _table(args: argparse.Namespace) -> CompensationTable | None:
    """Return the table of ``--model table:FILE`` (read here: a bad file is exit 2), or None.

    A table holds δg only: any other ``--quantity`` and the options of spherical-harmonic models
    and of the Warp engine are refused in one line.
    """
    from fieldmap.cli import given
    from fieldmap.cli.model_options import MODEL_OPTIONS
    from fieldmap.errors import InputError
    from fieldmap.models.registry import table_path
    from fieldmap.products.tables.model import load_table

    path = table_path(args.model)
    if path is None:
        return None
    if args.quantity != "disturbance":
        raise InputError(
            f"--model table:FILE holds the disturbance only, not --quantity {args.quantity}"
        )
    for dest, option in {**MODEL_OPTIONS, "device": "--device"}.items():
        if dest != "model" and given(args, dest):
            raise InputError(
                f"{option} does not apply to --model table:FILE (a compensation table, "
                "interpolated with NumPy)"
            )
    return load_table(path)


def _refuse_unused(args: argparse.Namespace) -> None:
    """Refuse, in one line, an option given that the chosen ``--quantity`` does not use."""
    from fieldmap.cli import given
    from fieldmap.cli.common import check_minus
    from fieldmap.cli.model_options import MODEL_OPTIONS
    from fieldmap.errors import InputError

    check_minus(args)
    if args.quantity == "normal":
        for dest, option in MODEL_OPTIONS.items():
            if given(args, dest):
                raise InputError(
                    f"{option} applies to the gravity model, not to --quantity normal (the "
                    "normal field of --normal)"
                )
    elif given(args, "normal"):
        raise InputError(
            f"--normal applies to --quantity normal, not to --quantity {args.quantity}"
        )
    if args.quantity.endswith("-sigma"):
        # the commission error is a NumPy sum over the static coefficients' sigmas
        for dest, option in (("epoch", "--epoch"), ("device", "--device")):
            if given(args, dest):
                raise InputError(
                    f"{option} does not apply to --quantity {args.quantity} (the static "
                    "coefficients' sigmas, summed with NumPy)"
                )


def _write_all(out: TextIO, text: str) -> None:
    """Write ``text`` whole or raise (``BrokenPipeError`` when the reader has gone).

    One large ``sys.stdout.write`` that the pipe takes only in part (``| head -1``) loses the rest
    without an error (CPython's buffered writer returns the short count, and the text layer
    drops it): write through the byte buffer until every byte is taken.
    """
    out.flush()
    buf = getattr(out, "buffer", None)
    if buf is None:  # a text-only stream (tests capture stdout in a StringIO)
        out.write(text)
        out.flush()
        return
    view = memoryview(text.encode(out.encoding or "utf-8"))
    while view:
        view = view[buf.write(view) :]
    buf.flush()


#: most input read by ``fieldmap point`` (about 40 million points); ``--input /dev/zero``
#: must end with an error, not fill the memory. Units: bytes.
MAX_INPUT_BYTES = 2**30


def _read_capped(stream: IO[Any], name: str) -> str:
    """Read all of ``stream`` (bytes or text) up to :data:`MAX_INPUT_BYTES`.

    Undecodable bytes become U+FFFD, so that their line is reported as bad.
    """
    from fieldmap.errors import InputError

    parts, size = [], 0
    while chunk := stream.read(1 << 20):
        parts.append(chunk)
        size += len(chunk)
        if size > MAX_INPUT_BYTES:
            raise InputError(f"{name}: more than {MAX_INPUT_BYTES >> 30} GiB of input; split it")
    if parts and isinstance(parts[0], str):
        return "".join(parts)
    return b"".join(parts).decode("utf-8", "replace")


def _format(row: Iterable[float], decimals: int) -> str:
    if not all(math.isfinite(v) for v in row):
        return "ERROR: result is not finite (point too close to the masses for this model)"
    return " ".join(f"{v:.{decimals}f}" for v in row)


def _main(
    argv: list[str] | None = None,
) -> int:  # pragma: no cover - convenience for python -m fieldmap.cli.point
    parser = argparse.ArgumentParser(prog="fieldmap", allow_abbrev=False)
    register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(argv)
    return args.func(args)
