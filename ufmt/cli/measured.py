"""CLI sub-commands of measured surfaces: ``ufmt surface`` (a measured map through the
instrument pipeline) and ``ufmt compare`` (beside the prediction of a simulated cut)."""

from __future__ import annotations

from ufmt.jsonout import dumps_strict

#: Keys ``ufmt surface`` prints first, in this order (the rest follow).
HEADLINE = ("pv_measured_nm", "rms_measured_nm", "sq_nm", "psd1_rms_nm", "psd2_rms_nm")


def register(subparsers) -> None:
    """Add the ``surface`` and ``compare`` sub-parsers."""
    from ufmt.cli.common import positive

    p = subparsers.add_parser("surface", help="metrics of a measured surface map")
    _add_map_arguments(p)
    p.add_argument("--plot", metavar="DIR", help="write the map and its PSDs as PNGs")
    p.set_defaults(func=cmd_surface)

    p = subparsers.add_parser("compare", help="a measured surface beside the simulated one")
    _add_map_arguments(p)
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    _add_process_arguments(p, positive)
    p.add_argument(
        "--fmax",
        type=positive(float),
        default=1000.0,
        metavar="HZ",
        help="natural frequencies below HZ attributed in the spectrum (1000)",
    )
    p.add_argument("--plot", metavar="DIR", help="write comparison.png, .csv and .json")
    p.set_defaults(func=cmd_compare)


def _add_process_arguments(p, positive) -> None:
    """--rpm, --feed, --depth of the cut to predict (the reference process by default)."""
    from ufmt.defaults import REFERENCE_DEPTH_UM, REFERENCE_FEED_MM_MIN, REFERENCE_RPM

    for flag, default, help_text in (
        ("--rpm", REFERENCE_RPM, "spindle speed"),
        ("--feed", REFERENCE_FEED_MM_MIN, "feed [mm/min]"),
        ("--depth", REFERENCE_DEPTH_UM, "depth of cut [um]"),
    ):
        p.add_argument(
            flag, type=positive(float), default=default, help=f"{help_text} ({default:g})"
        )


def _add_map_arguments(p) -> None:
    """FILE, --feed-direction, --unit, --aperture-margin, --cutoff, --json."""
    from ufmt.cli.common import positive
    from ufmt.measured.analysis import FEED_DIRECTIONS
    from ufmt.measured.read import UNITS

    p.add_argument("file", help="height map: MetroPro .dat/.datx, .x3p, .sdf, .xyz, ufmt .npz")
    p.add_argument(
        "--feed-direction",
        choices=FEED_DIRECTIONS,
        default="y",
        help="map axis the feed runs along (y: the columns, as ufmt writes maps)",
    )
    p.add_argument("--unit", choices=sorted(UNITS), help="unit of a file that has none (default m)")
    p.add_argument(
        "--aperture-margin",
        type=float,
        default=None,
        metavar="MM",
        help="clear-aperture edge exclusion [mm] (default 5 on maps >= 20 mm, else 0)",
    )
    p.add_argument(
        "--cutoff",
        type=positive(float),
        default=None,
        metavar="MM",
        help="ISO 16610-21 Gaussian cutoff lambda_c [mm]: also the areal parameters of the "
        "S-L surface (keys *_lc)",
    )
    p.add_argument("--json", action="store_true", help="one strict JSON object on stdout")


def _read(args):
    """The :class:`ufmt.measured.analysis.MeasuredSurface` the arguments ask for."""
    from ufmt.measured.analysis import read_surface

    margin = None if args.aperture_margin is None else args.aperture_margin * 1e-3
    cutoff = None if args.cutoff is None else args.cutoff * 1e-3
    return read_surface(args.file, args.feed_direction, margin, cutoff, args.unit)


def cmd_surface(args) -> int:
    """Read a measured map and report its metrics."""
    from ufmt import files

    files.check_set_target(args.plot)
    measured = _read(args)
    if args.plot:
        measured.save(args.plot)
    out = measured.to_dict()
    if args.json:
        print(dumps_strict(out))
        return 0
    print(
        f"{out['file']}: {out['nx']} x {out['ny']} pixels of {out['spacing_x_mm']:.4g} x "
        f"{out['spacing_y_mm']:.4g} mm, {out['missing_share']:.1%} missing, feed along "
        f"{out['feed_direction']}, clear-aperture margin {out['aperture_margin_mm']:g} mm"
    )
    keys = [*HEADLINE, *(k for k in measured.metrics if k not in HEADLINE)]
    for key in keys:
        value = out[key]
        print(f"  {key:<24} {'not resolved' if value is None else f'{value:.4g}'}")
    return 0


def cmd_compare(args) -> int:
    """A measured map beside the simulation of the process on the model."""
    import warnings

    from ufmt import files
    from ufmt.cli.common import load
    from ufmt.machining.process import Process
    from ufmt.measured.compare import compare
    from ufmt.simulate import simulate
    from ufmt.solvers import solve_modes

    files.check_set_target(args.plot)
    measured = _read(args)
    model = load(args.model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        process = Process(args.rpm, args.feed, args.depth)
    for warning in caught:
        warnings.warn(warning.message, warning.category, stacklevel=1)
    result = simulate(model, process)
    modes = solve_modes(model, fmax_hz=args.fmax, shapes=False).frequencies_hz
    comparison = compare(measured, result, modes)
    if args.plot:
        comparison.save(args.plot)
    if args.json:
        print(dumps_strict({"model": model.name, **comparison.to_dict()}))
        return 0
    print(f"{measured.map.path} against {model.name} at {args.rpm:g} rpm, {args.feed:g} mm/min,"
          f" {args.depth:g} um")  # fmt: skip
    print(f"  {'metric':<24} {'measured':>11} {'predicted':>11} {'ratio':>8}")
    for row in comparison.to_frame().itertuples():
        print(f"  {row.metric:<24} {row.measured:>11.4g} {row.predicted:>11.4g} {row.ratio:>8.3g}")
    for band, directions in comparison.attribution.items():
        for direction, shares in directions.items():
            ranked = sorted(shares.items(), key=lambda item: -item[1])
            text = ", ".join(f"{name} {share:.0%}" for name, share in ranked)
            print(f"  {band} {direction}: {text}")
    return 0
