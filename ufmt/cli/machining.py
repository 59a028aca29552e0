"""CLI sub-commands of the cutting dynamics: ``ufmt simulate`` and ``ufmt frf``."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ufmt.jsonout import dumps_strict

DEFAULT_FRF_DIR = Path("results") / "frf"


def register(subparsers) -> None:
    """Add the ``simulate`` and ``frf`` sub-parsers."""
    _register_simulate(subparsers)
    _register_frf(subparsers)


def _add_process_arguments(p) -> None:
    """--rpm, --feed, --depth with the reference process as defaults."""
    from ufmt.cli.common import positive
    from ufmt.defaults import REFERENCE_DEPTH_UM, REFERENCE_FEED_MM_MIN, REFERENCE_RPM

    p.add_argument(
        "--rpm",
        type=positive(float),
        default=REFERENCE_RPM,
        help=f"spindle speed ({REFERENCE_RPM:g})",
    )
    p.add_argument(
        "--feed",
        type=positive(float),
        default=REFERENCE_FEED_MM_MIN,
        help=f"feed [mm/min] ({REFERENCE_FEED_MM_MIN:g})",
    )
    p.add_argument(
        "--depth",
        type=positive(float),
        default=REFERENCE_DEPTH_UM,
        help=f"depth of cut [um] ({REFERENCE_DEPTH_UM:g})",
    )


def _add_basis_arguments(p) -> None:
    """--modes N (the paper's choice: 30) or --basis-cutoff HZ (default: every mode below it)."""
    from ufmt.cli.common import positive
    from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ
    from ufmt.limits import MAX_MODE_COUNT

    p.add_argument(
        "--modes",
        type=positive(int, at_most=MAX_MODE_COUNT),
        default=None,
        metavar="N",
        help="modal basis of the first N modes (the paper: 30; default: every mode below the "
        f"cutoff; at most {MAX_MODE_COUNT})",
    )
    p.add_argument(
        "--basis-cutoff",
        type=positive(float),
        default=DEFAULT_BASIS_CUTOFF_HZ,
        metavar="HZ",
        help=f"modal basis of every mode below HZ ({DEFAULT_BASIS_CUTOFF_HZ:g}; ignored with "
        "--modes)",
    )


def _register_simulate(subparsers) -> None:
    """Add the ``simulate`` sub-parser."""
    from ufmt.cli.common import positive
    from ufmt.limits import MAX_UNCERTAINTY_SAMPLES
    from ufmt.machining.recurrence import DEFAULT_ZETA
    from ufmt.machining.sources import SOURCES
    from ufmt.studies.intervals import DEFAULT_INPUTS

    p = subparsers.add_parser("simulate", help="cutting response, machined surface and PV")
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    _add_process_arguments(p)
    p.add_argument(
        "--method",
        choices=["periodic", "time"],
        default="periodic",
        help="periodic steady state (fast) or whole-workpiece time domain (exact)",
    )
    _add_basis_arguments(p)
    p.add_argument(
        "--samples-per-rev",
        type=positive(int, at_least=8, at_most=2**16, even=True),
        default=None,
        metavar="N",
        help="samples per revolution, even, 8-65536 (default: from the basis' highest mode)",
    )
    p.add_argument(
        "--zeta",
        type=positive(float, below=1.0),
        default=None,
        help="structural modal damping ratio (default: the model's machine.modal_damping_ratio,"
        f" {DEFAULT_ZETA:g} unless the file sets it; hinge dampers add to it)",
    )
    p.add_argument(
        "--sources",
        default=",".join(SOURCES),
        help=f"error sources switched on, comma-separated ({','.join(SOURCES)}: all)",
    )
    _add_surface_arguments(p)
    p.add_argument("--no-static", action="store_true", help="modal sum without static correction")
    p.add_argument(
        "--uncertainty",
        type=positive(int, at_most=MAX_UNCERTAINTY_SAMPLES),
        default=None,
        metavar="N",
        help=f"also simulate N <= {MAX_UNCERTAINTY_SAMPLES} Latin-hypercube samples of the "
        "model's documented bands ([[uncertain]]) and print each metric's 5-95 %% interval",
    )
    p.add_argument(
        "--uncertainty-inputs",
        default=None,
        metavar="PATTERNS",
        help="bands sampled, comma-separated shell patterns (default: every [[uncertain]] "
        f"input of the model; the packaged machine: {','.join(DEFAULT_INPUTS)})",
    )
    p.add_argument("--json", action="store_true", help="one strict JSON object on stdout")
    p.add_argument(
        "--plot",
        metavar="DIR",
        help="write Figs. 6, 7, 13, 14, the surface maps, the PSDs and the PV per source as PNGs",
    )
    p.add_argument(
        "--save",
        metavar="DIR",
        help="write metrics.json, summary.csv, time.csv, the surface (.xyz, .sdf, .npz), maps",
    )
    p.set_defaults(func=cmd_simulate)


def _add_surface_arguments(p) -> None:
    """--aperture-margin, --psd2-patch and --line-spacing of ``simulate``."""
    from ufmt.cli.common import positive
    from ufmt.machining.lines import DEFAULT_LINE_SPACING
    from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN, DEFAULT_PSD2_PATCH

    p.add_argument(
        "--aperture-margin",
        type=positive(float),
        default=DEFAULT_APERTURE_MARGIN * 1e3,
        help="clear-aperture edge exclusion [mm] of the interferometer's PV and the PSD bands"
        f" ({DEFAULT_APERTURE_MARGIN * 1e3:g})",
    )
    p.add_argument(
        "--psd2-patch",
        type=positive(float),
        default=None,
        metavar="MM",
        help="evaluate PSD2 on a centred square patch of this side [mm] at 0.05 mm "
        f"(e.g. {DEFAULT_PSD2_PATCH * 1e3:g}; superseded by the whole plate's line profiles)",
    )
    p.add_argument(
        "--line-spacing",
        type=positive(float),
        default=DEFAULT_LINE_SPACING * 1e3,
        metavar="MM",
        help="step [mm] of the line profiles along and across the feed that PSD1 and PSD2 read"
        f" over the clear aperture ({DEFAULT_LINE_SPACING * 1e3:g})",
    )


def _register_frf(subparsers) -> None:
    """Add the ``frf`` sub-parser."""
    from ufmt.cli.common import positive
    from ufmt.limits import MAX_FREQUENCY_HZ, MAX_FRF_POINTS
    from ufmt.machining.recurrence import DEFAULT_ZETA

    p = subparsers.add_parser(
        "frf", help="tool-workpiece or point-to-point FRF in any direction (table and plot)"
    )
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    p.add_argument(
        "--fmin", type=positive(float, at_most=MAX_FREQUENCY_HZ), default=1.0, help="[Hz] (1)"
    )
    p.add_argument(
        "--fmax",
        type=positive(float, at_most=MAX_FREQUENCY_HZ),
        default=1000.0,
        help=f"[Hz] (1000; at most {MAX_FREQUENCY_HZ:g})",
    )
    p.add_argument(
        "--points",
        type=positive(int, at_least=2, at_most=MAX_FRF_POINTS),
        default=4000,
        help=f"log-spaced (4000; 2-{MAX_FRF_POINTS})",
    )
    _add_basis_arguments(p)
    p.add_argument(
        "--zeta",
        type=positive(float, below=1.0),
        default=None,
        help="structural damping ratio (default: the model's machine.modal_damping_ratio,"
        f" {DEFAULT_ZETA:g} unless the file sets it)",
    )
    p.add_argument("--no-static", action="store_true", help="modal sum without static correction")
    p.add_argument(
        "--direction",
        default="z",
        help="response then force axis: x, y, z or a pair such as xz (default z = zz)",
    )
    p.add_argument(
        "--kind", choices=("receptance", "mobility", "accelerance"), default="receptance"
    )
    p.add_argument(
        "--at",
        nargs=2,
        metavar=("RESPONSE", "FORCE"),
        help="point-to-point: BODY:x,y,z [m] for the response and the force points (default: "
        "tool tip relative to the workpiece, force pair)",
    )
    p.add_argument(
        "--output-dir",
        help=f"default {DEFAULT_FRF_DIR} (packaged model), results/<model file name>/frf/ (yours)",
    )
    p.add_argument("--json", action="store_true", help="summary as one JSON object")
    p.set_defaults(func=cmd_frf)


def cmd_simulate(args) -> int:
    """Run one process on a model and report the surface metrics and the PV per source."""
    from ufmt import files
    from ufmt.cli.common import load
    from ufmt.errors import UfmtError
    from ufmt.machining.process import Process
    from ufmt.machining.sources import SOURCES
    from ufmt.machining.validity import check_cut, check_revolutions
    from ufmt.model.machine import machine_of
    from ufmt.plots.response import plot_simulation
    from ufmt.simulate import simulate

    for target in (args.plot, args.save):
        files.check_set_target(target)
    model = load(args.model)
    sources = [s.strip() for s in args.sources.split(",") if s.strip()]
    if not sources:
        raise UfmtError(f"--sources: {args.sources!r} names no source ({','.join(SOURCES)})")
    with warnings.catch_warnings(record=True) as caught:  # outside Table 1: said if valid
        warnings.simplefilter("always")
        process = Process(args.rpm, args.feed, args.depth)
    check_cut(process, machine_of(model))  # outside the validity domain: the one line
    check_revolutions(process, machine_of(model))
    for warning in caught:
        warnings.warn(warning.message, warning.category, stacklevel=1)
    patterns = _uncertainty_inputs(args, model)  # a model without bands: before the cut
    options = {} if args.zeta is None else {"zeta": args.zeta}
    if args.psd2_patch is not None:
        options["psd2_patch"] = args.psd2_patch * 1e-3
    options.update(
        n_modes=args.modes,
        basis_cutoff_hz=args.basis_cutoff,
        n_phi=args.samples_per_rev,
        method=args.method,
        sources=sources,
        static_correction=not args.no_static,
        aperture_margin=args.aperture_margin * 1e-3,
        line_spacing=args.line_spacing * 1e-3,
    )
    result = simulate(model, process, **options)
    if args.plot:
        plot_simulation(result, args.plot)
    if args.save:
        result.save(args.save)
    summary = {"model": model.name, **result.to_dict()}
    intervals = _intervals(args, model, process, patterns, options)
    if intervals is not None:
        summary["uncertainty"] = intervals
    if args.json:
        print(dumps_strict(summary))
        return 0
    print(
        f"{model.name}: {args.rpm:g} rpm, {args.feed:g} mm/min, {args.depth:g} um ({args.method}; "
        f"{result.n_modes} modes to {result.basis_cutoff_hz:.0f} Hz, "
        f"{result.samples_per_rev} samples/rev)"
    )
    if intervals is not None:
        print(
            f"  5-95 % intervals over {intervals['samples']} samples of the documented bands of"
            f" {', '.join(intervals['inputs'])}"
        )
    for key, value in result.metrics.items():
        band = (intervals or {}).get("metrics", {}).get(key)
        beside = f"   [{band['q05']:.4g}, {band['q95']:.4g}]" if band else ""
        if band and not np.isfinite(band["q05"]):
            beside = "   [not resolved in any sample]"
        print(f"  {key:<22} {value:12.4f}{beside}")
    print("  PV of each source alone [nm]:")
    for key, value in result.pv_by_source_nm.items():
        print(f"    {key:<20} " + ("off" if value is None else f"{value:12.4f}"))
    for flag, where in (("plots", args.plot), ("results", args.save)):
        if where:
            print(f"{flag} in {where}")
    return 0


def _uncertainty_inputs(args, model) -> list[str] | None:
    """The patterns of ``--uncertainty-inputs`` (None: the model's default), checked against
    the model's bands when ``--uncertainty`` is given."""
    patterns = args.uncertainty_inputs
    if patterns is not None:
        patterns = [p.strip() for p in patterns.split(",") if p.strip()]
    if args.uncertainty is not None:
        from ufmt.studies.intervals import input_bands

        input_bands(patterns, model)
    return patterns


def _intervals(args, model, process, patterns, options) -> dict | None:
    """The 5-95 % intervals of ``--uncertainty N`` (None without it)."""
    if args.uncertainty is None:
        return None
    from ufmt.studies.intervals import headline_intervals

    intervals = headline_intervals(
        model, process, args.uncertainty, patterns, progress=True, **options
    )
    return intervals.to_dict()


def cmd_frf(args) -> int:
    """An FRF of the model (:func:`ufmt.machining.frf.frf`): CSV table and magnitude/phase
    plot in the output folder (``frf.csv``/``frf.png`` for the tool-workpiece z receptance,
    ``frf-<directions>-<kind>.*`` otherwise)."""
    from ufmt import files
    from ufmt.cli.common import load, results_dir
    from ufmt.errors import UfmtError
    from ufmt.machining.frf import frf

    if args.fmin >= args.fmax:
        raise UfmtError(f"--fmin {args.fmin} must be below --fmax {args.fmax}")
    files.check_set_target(args.output_dir)
    model = load(args.model)
    output, force = (None, None) if args.at is None else (_point(t) for t in args.at)
    options = {} if args.zeta is None else {"zeta": args.zeta}
    if args.modes is not None:
        options["n_modes"] = args.modes
    if args.basis_cutoff is not None:
        options["basis_cutoff_hz"] = args.basis_cutoff
    result = frf(
        model,
        args.direction,
        args.kind,
        output=output,
        input=force,
        fmin_hz=args.fmin,
        fmax_hz=args.fmax,
        points=args.points,
        static_correction=not args.no_static,
        **options,
    )
    out = Path(args.output_dir or results_dir(args.model, "frf", DEFAULT_FRF_DIR))
    table, plot = result.save(out)
    h = np.abs(result.values)
    peak = int(np.argmax(h))
    summary = {
        "model": model.name,
        "kind": result.kind,
        "direction": "".join(result.direction),
        "output": result.output,
        "input": result.input,
        f"low_frequency_{result.unit}": float(h[0]),
        "peak_hz": float(result.frequencies_hz[peak]),
        f"peak_{result.unit}": float(h[peak]),
        "table": str(table),
        "plot": str(plot),
    }
    if result.unit == "m_per_N":
        summary["static_compliance_m_per_N"] = float(h[0])
    if args.json:
        print(dumps_strict(summary))
    else:
        print(
            f"{model.name}: peak {result.kind} {''.join(result.direction)} {h[peak]:.3e} "
            f"{result.unit} at {summary['peak_hz']:.1f} Hz; wrote {table} and {plot}"
        )
    return 0


def _point(text: str):
    """``BODY:x,y,z`` -> (body, (x, y, z)) [m]."""
    from ufmt.errors import UfmtError

    body, _, coords = text.partition(":")
    try:
        point = tuple(float(v) for v in coords.split(","))
    except ValueError:
        point = ()
    if not body or len(point) != 3:
        raise UfmtError(f"--at {text!r}: expected BODY:x,y,z with the point in metres")
    return body, point
