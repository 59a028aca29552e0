"""CLI sub-commands ``calibrate``, ``validate`` and ``plot-mode`` (registered by ufmt.cli).

* ``ufmt calibrate [--prior PATH] [--settings PATH] [--output PATH] [--log PATH]``: identify the
  hinge stiffnesses against Table 3 (:mod:`ufmt.calibration.identify`), fit the uncertain
  ``[machine]`` parameters to the response measurements (:mod:`ufmt.calibration.response_fit`),
  write the packaged model and the log; tqdm progress on stderr.
* ``ufmt validate [MODEL] [--output-dir DIR] [--modes LIST]``: the validation table
  ``frequencies.csv``, the chart ``frequencies.png``, ``mode-N.png`` for the listed modes and,
  for a model with ``[machine]``, ``response.csv`` (one row per paper response quantity).
* ``ufmt plot-mode N [MODEL] [--output PNG] [--scale S]``: one mode shape in 3-D.

User errors raise :class:`~ufmt.errors.UfmtError`; the CLI prints one line and exits 2.
"""

from __future__ import annotations

import argparse
import io
import math
import time
from pathlib import Path

from ufmt.cli.common import load, positive, results_dir
from ufmt.defaults import PAPER_MODES
from ufmt.errors import UfmtError
from ufmt.model.load import packaged_path

RESULTS = Path("results") / "validation"
DEFAULT_LOG = RESULTS / "identification-log.csv"
DEFAULT_PLOTTED_MODES = "1,11,12,18,29"  # mode 1 and the tool-tip z modes of section 4.1


def _mode_number(text: str, highest: int | None = None) -> int:
    """A mode number (1-based, as every table numbers modes), at most ``highest`` if given."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a mode number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"mode {value}: mode numbers start at 1")
    if highest is not None and value > highest:
        raise argparse.ArgumentTypeError(f"mode {value} is outside 1..{highest}")
    return value


def _mode_list(text: str) -> list[int]:
    """Modes of the validation (the paper's first PAPER_MODES), comma-separated."""
    return [_mode_number(t, PAPER_MODES) for t in text.split(",") if t.strip()]


def register(subparsers) -> None:
    """Add the ``calibrate``, ``validate`` and ``plot-mode`` sub-parsers."""
    p = subparsers.add_parser(
        "calibrate", help="identify hinge stiffness (Table 3), fit the response (Table 4)"
    )
    p.add_argument("--prior", help="prior model (default: the calibration file's)")
    p.add_argument(
        "--test",
        metavar="FILE",
        help="your modal-test file: modes (CSV, UFF 55) or measured FRFs (UFF 58, CSV FRF table; "
        "docs/modal-test.md): calibrate --prior against it; "
        "--settings is then a model-update file (docs/modal-test.md), optional",
    )
    _add_frf_options(p)
    _test_unit_option(p)
    p.add_argument("--settings", help="calibration file (default: packaged calibration.toml)")
    p.add_argument(
        "--output",
        help="identified model (default: the calibration file's; with --test "
        "results/<prior file name>/calibration/<prior file name>-calibrated.toml)",
    )
    p.add_argument("--log", default=str(DEFAULT_LOG), help=f"iteration log (default {DEFAULT_LOG})")
    p.set_defaults(func=cmd_calibrate)

    p = subparsers.add_parser(
        "validate", help="modes against a modal test (--test FILE) or the paper's Table 3"
    )
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    p.add_argument(
        "--test",
        metavar="FILE",
        help="modal-test file: modes (CSV, UFF 55) or measured FRFs (UFF 58, CSV FRF table), "
        "docs/modal-test.md: pair the modes by MAC or order, write correlation.csv, mac.csv, "
        "mac.png (FRFs: also frf-modes.csv, stabilisation.csv/png, frf-overlay.csv/png)",
    )
    _add_frf_options(p)
    _test_unit_option(p)
    p.add_argument("--json", action="store_true", help="with --test: one JSON object on stdout")
    p.add_argument(
        "--output-dir",
        help=f"default {RESULTS} (packaged model), results/<model file name>/validation/ (yours)",
    )
    p.add_argument(
        "--modes",
        type=_mode_list,
        help=f"model modes to draw, comma-separated (default {DEFAULT_PLOTTED_MODES}; with "
        "--test: none)",
    )
    p.set_defaults(func=cmd_validate)

    p = subparsers.add_parser("plot-mode", help="draw mode N in 3-D to a PNG")
    p.add_argument("mode", type=_mode_number, help="mode number, 1-based (1 = the lowest)")
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    p.add_argument(
        "--output",
        help=f"PNG (default {RESULTS}/mode-N.png, or results/<model file name>/mode-N.png)",
    )
    p.add_argument("--scale", type=positive(float), help="displacement factor (default: automatic)")
    p.add_argument(
        "--gif", action="store_true", help="also write the mode animated over one period (GIF)"
    )
    p.set_defaults(func=cmd_plot_mode)


def _floats(text: str) -> list[float]:
    """Comma-separated positive numbers."""
    try:
        values = [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of numbers") from None
    if not values or not all(v > 0 and math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"{text!r}: finite numbers > 0, comma-separated")
    return values


def _band(text: str) -> list[float]:
    """FMIN,FMAX [Hz]."""
    values = _floats(text)
    if len(values) != 2 or not values[0] < values[1]:
        raise argparse.ArgumentTypeError(f"{text!r}: FMIN,FMAX with FMIN < FMAX [Hz]")
    return values


def _add_frf_options(p) -> None:
    """The modal-extraction options of a measured-FRF test (ufmt.calibration.frf_modes)."""
    p.add_argument(
        "--frf-band",
        type=_band,
        metavar="FMIN,FMAX",
        help="measured FRFs: the band of the modal extraction [Hz] (default: the whole file)",
    )
    p.add_argument(
        "--frf-order",
        type=positive(int, at_least=6, at_most=100),
        default=30,
        metavar="N",
        help="measured FRFs: highest LSCF model order / 2 (default 30)",
    )
    p.add_argument(
        "--frf-poles",
        type=_floats,
        metavar="F1,F2,...",
        help="measured FRFs: approximate frequencies [Hz] of the modes to take (default: "
        "every pole stable over the last orders, docs/modal-test.md)",
    )


def _frf_modes(args):
    """The modes extracted from a measured-FRF test file (None: the file holds modes)."""
    from ufmt.calibration.frf_file import is_frf_file
    from ufmt.calibration.frf_modes import extract_modes

    if not is_frf_file(args.test):
        return None
    band = args.frf_band or (None, None)
    return extract_modes(
        args.test, *band, order=args.frf_order, approx_hz=args.frf_poles, unit=args.test_unit
    )


def _test_unit_option(p) -> None:
    """``--test-unit``: the length unit of the test file's positions."""
    from ufmt.calibration.uff import LENGTH_UNITS

    p.add_argument(
        "--test-unit",
        choices=tuple(LENGTH_UNITS),
        help="length unit of the test's positions (a UFF without units dataset 164 needs it; "
        "default: the file's, metres for a CSV)",
    )


def cmd_calibrate(args) -> int:
    """Identify, fit the response parameters, write the model and the log, print the result."""
    from ufmt.calibration.pipeline import calibrate

    if args.prior and args.output and Path(args.output).resolve() == Path(args.prior).resolve():
        raise UfmtError(
            f"--output {args.output}: the prior itself; a calibration never overwrites its prior "
            "(a rerun would compound the factors): choose another output path"
        )
    if args.test_unit and not args.test:
        raise UfmtError("--test-unit: only with --test FILE")
    if args.test:
        return _calibrate_test(args)
    t0 = time.perf_counter()
    run = calibrate(
        args.settings or packaged_path("calibration.toml"),
        args.prior,
        args.output,
        args.log,
        progress=True,
    )
    result = run.identification
    print(
        f"identified {len(result.parameters)} factors in {time.perf_counter() - t0:.1f} s "
        f"(global start {'used' if result.used_global_start else 'not needed'})"
    )
    for p, s in zip(result.parameters, result.scales, strict=True):
        print(f"  {p.name:<24} s = {s:8.4f}   band [{p.band[0]:g}, {p.band[1]:g}]")
    shares = result.evaluation.shares
    if shares.size:
        print(
            f"spindle-bearing constraint: largest strain-energy share {shares.max():.3f}, "
            f"violation {result.evaluation.constraint.max():.2e} (ln f)"
        )
    _print_summary(run.model, run.validation.summary)
    if run.response is not None:
        _print_response(run)
    print(f"wrote {run.output} and {args.log}")
    return 0


def _calibrate_test(args) -> int:
    """Calibrate a model against its modal test (:mod:`ufmt.calibration.model_update`): write
    the calibrated model, parameters.csv, residuals.csv and its correlation; print them."""
    from ufmt.calibration.modal_test import read_modal_test
    from ufmt.calibration.model_update import read_update_settings, update_model, write_model

    prior = load(args.prior)
    extracted = _frf_modes(args)
    test = read_modal_test(args.test, args.test_unit) if extracted is None else extracted.test
    settings, parameters = (
        read_update_settings(args.settings, prior) if args.settings else (None, None)
    )
    t0 = time.perf_counter()
    update = update_model(prior, test, parameters, settings)
    stem = "ufmt" if args.prior is None else Path(args.prior).stem
    folder = results_dir(args.prior, "calibration", Path("results") / "calibration")
    output = write_model(update, args.output or folder / f"{stem}-calibrated.toml", args.settings)
    written = update.save(Path(args.output).parent if args.output else folder)
    print(f"{update!r} in {time.perf_counter() - t0:.1f} s ({update.evaluations} MSTMM solves)")
    print(update.to_frame().to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    paired = update.before.summary()["paired"]
    print(
        f"data rank {update.rank} for {len(update.parameters)} factors ({paired} paired test "
        f"modes); singular values of d ln f / d ln s: "
        + ", ".join(f"{v:.3g}" for v in update.singular_values)
    )
    if update.held:
        print(f"held at the prior (the test cannot identify them): {', '.join(update.held)}")
    if update.at_bound:
        print(f"AT BOUND (the test asks for more than the band): {', '.join(update.at_bound)}")
    print(update.residuals().to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"wrote {output} and {', '.join(p.name for p in written)} in {written[0].parent}")
    return 0


def _print_response(run) -> None:
    from ufmt.calibration.response import implied_forces

    fit = run.response
    print(f"response fit ({fit.settings.method} path, {fit.evaluations} simulations):")
    for p in fit.settings.parameters:
        flag = "" if p.fit else "  held (fit = false)"
        if p.key in fit.at_bound:
            flag = (
                f"  AT BOUND: the fit asks for {fit.wanted[p.key]:.6g} at the band's edge;"
                " held at its documented value"
            )
        print(f"  {p.key:<26} = {fit.values[p.key]:.6g} {p.unit}  band {list(p.band)}{flag}")
    for key in fit.settings.skipped:
        print(f"  {key:<26}   skipped: not a [machine] field of this version")
    print(fit.to_frame().to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    forces = implied_forces(run.model, fit.metrics, fit.process)
    print(
        "implied peak forces at the reference cut: "
        + ", ".join(
            f"{k} {v['force_n']:.3g} N ({v['specific_gpa']:.3g} GPa)" for k, v in forces.items()
        )
    )


def _print_summary(model, s: dict) -> None:
    print(
        f"{model.name}: tested modes max |error| {s['max_abs_error_percent']:.3f} %, "
        f"mean {s['mean_abs_error_percent']:.3f} % (MSTMM); {s['modes_below_30_hz']} modes "
        f"below 30 Hz, mode 6 at {s['mode_6_hz']:.2f} Hz"
    )
    tip = s["tool_tip_z_modes_above_neighbours"]
    print(
        "tool tip moves most in z among neighbours: "
        + ", ".join(f"mode {k}: {v}" for k, v in tip.items())
    )
    if s["tag_mismatches"]:
        print(
            "Table 3 shape tags not matched: "
            + ", ".join(f"mode {k} ({v})" for k, v in s["tag_mismatches"].items())
        )


def cmd_validate(args) -> int:
    """With ``--test``: correlate the model with the modal test (:func:`_validate_test`).
    Without: write frequencies.csv, frequencies.png, the mode plots and (for a model with a
    ``[machine]`` table) response.csv of section 4.2 / Table 4; print the summary."""
    from ufmt import files
    from ufmt.calibration.frequencies import read_reference, tag_bodies, validate
    from ufmt.mstmm.solve import describe
    from ufmt.plots import DPI
    from ufmt.plots.modes import plot_frequencies, plot_mode

    files.check_set_target(args.output_dir)
    model = load(args.model)
    out = Path(args.output_dir or results_dir(args.model, "validation", RESULTS))
    if args.test:
        return _validate_test(model, args, out)
    if args.test_unit:
        raise UfmtError("--test-unit: only with --test FILE")
    if args.json:
        raise UfmtError("--json: only with --test FILE (the validation against a modal test)")
    reference = read_reference(packaged_path("paper_reference.toml"))
    missing = sorted(tag_bodies(reference) - {b.name for b in model.bodies})
    if missing:
        raise UfmtError(
            f"{model.source}: no modal test given, and the paper's Table 3 (the default test) "
            f"describes the packaged UFMT: bodies {', '.join(missing)} are not in this model; "
            "give your machine's test with --test FILE (docs/modal-test.md)"
        )
    args.modes = args.modes or _mode_list(DEFAULT_PLOTTED_MODES)
    result = validate(model, reference, PAPER_MODES)
    lines = describe(model, result.modes.shares, top=3)
    response = None
    if model.machine:
        from ufmt.calibration.response import response_table

        # the response's default basis (every mode below the cutoff), not the validated 30
        response = response_table(model, packaged_path("paper_reference.toml"))
    with files.FileSet(out) as written:  # every file of the validation or none
        written.add("frequencies.csv", _csv(result.table, "%.10g"))
        written.add("frequencies.png", files.figure_png(plot_frequencies(result.table), DPI))
        for n in args.modes:
            figure = plot_mode(model, result.solution.shapes, n - 1, description=lines[n - 1])
            written.add(f"mode-{n}.png", files.figure_png(figure, DPI))
        if response is not None:
            written.add("response.csv", _csv(response, "%.6g"))
    _print_summary(model, result.summary)
    plots = ", ".join(f"mode-{n}.png" for n in args.modes)
    print(f"wrote frequencies.csv, frequencies.png, {plots} in {out}")
    if response is not None:
        print(response.drop(columns=["source"]).to_string(index=False))
        print(f"wrote response.csv in {out}")
    return 0


def _validate_test(model, args, out: Path) -> int:
    """Pair the model's modes with the test's, write correlation.csv, mac.csv, mac.png and
    ``mode-N.png`` of the ``--modes`` in ``out`` (measured FRFs: the extraction's and the
    overlay's files too), print the pair table (or, with ``--json``, one JSON object)."""
    from ufmt.calibration.correlation import correlate
    from ufmt.calibration.frf_overlay import overlay
    from ufmt.jsonout import dumps_strict

    test = args.test
    extracted = _frf_modes(args)
    if extracted is None:
        result = correlate(model, test, unit=args.test_unit)
    else:
        result = correlate(model, extracted.test)
    written = result.save(out) + _mode_plots(model, args.modes or [], out)
    frf = {}
    if extracted is not None:
        both = overlay(model, extracted.measured)
        written += extracted.save(out) + both.save(out)
        frf = {"frf": _frf_json(extracted, both)}
    if args.json:
        print(dumps_strict(result.to_dict() | frf))
        return 0
    s = result.summary()
    if extracted is not None:
        print(f"{extracted!r}; {both!r}")
    print(result.table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    mac = "no shapes" if math.isnan(s["min_mac"]) else f"lowest MAC {s['min_mac']:.3f}"
    print(
        f"{model.name} against {test}: {s['paired']} of {len(result.table)} test modes paired, "
        f"max |error| {s['max_abs_error_percent']:.3f} %, mean "
        f"{s['mean_abs_error_percent']:.3f} %, {mac}"
    )
    print(f"wrote {', '.join(p.name for p in written)} in {out}")
    return 0


def _frf_json(extracted, both) -> dict:
    """The ``frf`` object of ``validate --test FRFS --json``."""
    return {
        "frfs": len(extracted.measured.outputs),
        "kind": extracted.measured.kind,
        "band_hz": list(extracted.band_hz),
        "modes": int(extracted.test.modes.size),
        "frequencies_hz": extracted.test.frequencies_hz.tolist(),
        "damping_ratios": extracted.test.damping_ratio.tolist(),
        "overlay_median_log10_ratio": both.log_ratio(),
    }


def _mode_plots(model, modes: list[int], out: Path) -> list[Path]:
    """``mode-N.png`` of each model mode N in ``modes`` (``validate --test --modes``)."""
    if not modes:
        return []
    from ufmt.mstmm.solve import describe, solve_modes
    from ufmt.plots import save_figure
    from ufmt.plots.modes import plot_mode

    solution = solve_modes(model, count=max(modes), shapes=True)
    have = solution.frequencies_hz.size
    if max(modes) > have:
        raise UfmtError(f"{model.source}: --modes {max(modes)}: the model has only {have} modes")
    lines = describe(model, solution.energy_shares(model), top=3)
    return [
        save_figure(
            plot_mode(model, solution.shapes, n - 1, description=lines[n - 1]),
            out / f"mode-{n}.png",
        )
        for n in modes
    ]


def _csv(table, float_format: str) -> bytes:
    """A table as CSV bytes."""
    buffer = io.BytesIO()
    table.to_csv(buffer, index=False, float_format=float_format)
    return buffer.getvalue()


def cmd_plot_mode(args) -> int:
    """Solve the first N modes by the MSTMM and draw mode N."""
    from ufmt.mstmm.solve import describe, solve_modes
    from ufmt.plots import save_figure
    from ufmt.plots.modes import animate_mode, plot_mode

    model = load(args.model)
    solution = solve_modes(model, count=args.mode, method="mstmm", shapes=True)
    if solution.frequencies_hz.size < args.mode:
        raise UfmtError(
            f"{model.source}: mode {args.mode}: the model has only "
            f"{solution.frequencies_hz.size} modes"
        )
    line = describe(model, solution.energy_shares(model), top=3)[args.mode - 1]
    name = f"mode-{args.mode}.png"
    path = Path(args.output) if args.output else _plot_mode_default(args.model, model) / name
    if path.is_dir():  # an existing directory: the plot goes into it
        path = path / name
    figure = plot_mode(model, solution.shapes, args.mode - 1, args.scale, line)
    written = [save_figure(figure, path)]
    if args.gif:
        written.append(
            animate_mode(
                model,
                solution.shapes,
                args.mode - 1,
                Path(path).with_suffix(".gif"),
                args.scale,
                line,
            )
        )
    names = " and ".join(str(p) for p in written)
    print(f"mode {args.mode}: {solution.frequencies_hz[-1]:.3f} Hz ({line}); wrote {names}")
    return 0


def _plot_mode_default(path: str | None, model) -> Path:
    """Default folder of ``plot-mode``: results/validation/ for the packaged model, else
    results/<model file stem>/ (a user's model never writes into the validation folder)."""
    return RESULTS if path is None else Path("results") / Path(model.source).stem
