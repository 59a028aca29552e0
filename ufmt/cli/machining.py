"""CLI sub-commands of the cutting dynamics: ``ufmt simulate`` and ``ufmt frf``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

DEFAULT_FRF_DIR = Path("results") / "frf"


def register(subparsers) -> None:
    """Add the ``simulate`` and ``frf`` sub-parsers."""
    from ufmt.cli.common import positive

    p = subparsers.add_parser("simulate", help="cutting response, machined surface and PV")
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    p.add_argument("--rpm", type=positive(float), default=300.0, help="spindle speed (300)")
    p.add_argument("--feed", type=positive(float), default=15.0, help="feed [mm/min] (15)")
    p.add_argument("--depth", type=positive(float), default=4.0, help="depth of cut [um] (4)")
    p.add_argument(
        "--method",
        choices=["periodic", "time"],
        default="periodic",
        help="periodic steady state (fast) or whole-workpiece time domain (exact)",
    )
    p.add_argument("--modes", type=positive(int), default=30, help="modes kept (30)")
    p.add_argument(
        "--zeta",
        type=positive(float, below=1.0),
        default=None,
        help="modal damping ratio (default 0.03)",
    )
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.add_argument("--plot", metavar="DIR", help="write Figs. 6, 7, 13, 14 as PNGs to DIR")
    p.set_defaults(func=cmd_simulate)

    p = subparsers.add_parser("frf", help="tool-workpiece receptance in z (table and plot)")
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    p.add_argument("--fmin", type=positive(float), default=1.0, help="[Hz] (1)")
    p.add_argument("--fmax", type=positive(float), default=1000.0, help="[Hz] (1000)")
    p.add_argument(
        "--points", type=positive(int, at_most=10**6), default=4000, help="log-spaced (4000)"
    )
    p.add_argument("--modes", type=positive(int), default=30, help="modes kept (30)")
    p.add_argument(
        "--zeta", type=positive(float, below=1.0), default=None, help="damping ratio (0.03)"
    )
    p.add_argument("--output-dir", default=str(DEFAULT_FRF_DIR), help=f"({DEFAULT_FRF_DIR})")
    p.add_argument("--json", action="store_true", help="summary as one JSON object")
    p.set_defaults(func=cmd_frf)


def cmd_simulate(args) -> int:
    """Run one process on a model and report the surface metrics."""
    from ufmt.cli.common import load
    from ufmt.machining.process import Process
    from ufmt.simulate import simulate

    model = load(args.model)
    process = Process(args.rpm, args.feed, args.depth)
    options = {} if args.zeta is None else {"zeta": args.zeta}
    result = simulate(model, process, n_modes=args.modes, method=args.method, **options)
    metrics = {k: float(v) for k, v in result.metrics.items()}
    if args.plot:
        result.plot(args.plot)
    if args.json:
        print(
            json.dumps(
                {
                    "model": model.name,
                    "method": args.method,
                    "rpm": args.rpm,
                    "feed_mm_min": args.feed,
                    "depth_um": args.depth,
                    **metrics,
                }
            )
        )
        return 0
    print(
        f"{model.name}: {args.rpm:g} rpm, {args.feed:g} mm/min, {args.depth:g} um ({args.method})"
    )
    for key, value in metrics.items():
        print(f"  {key:<22} {value:12.4f}")
    if args.plot:
        print(f"plots in {args.plot}")
    return 0


def cmd_frf(args) -> int:
    """Tool-workpiece receptance in z: CSV table and magnitude/phase plot."""
    import pandas as pd

    from ufmt.cli.common import load
    from ufmt.errors import UfmtError
    from ufmt.machining.frf import tool_workpiece_receptance
    from ufmt.machining.modal import modal_basis
    from ufmt.model.machine import machine_of
    from ufmt.plots.response import plot_frf

    if args.fmin >= args.fmax:
        raise UfmtError(f"--fmin {args.fmin} must be below --fmax {args.fmax}")
    model = load(args.model)
    basis = modal_basis(model, args.modes)
    freq = np.geomspace(args.fmin, args.fmax, args.points)
    options = {} if args.zeta is None else {"zeta": args.zeta}
    h = tool_workpiece_receptance(basis, machine_of(model), freq, **options)
    out = Path(args.output_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = pd.DataFrame(
        {
            "frequency_hz": freq,
            "magnitude_m_per_N": np.abs(h),
            "phase_deg": np.degrees(np.angle(h)),
            "real_m_per_N": h.real,
            "imag_m_per_N": h.imag,
        }
    )
    table.to_csv(out / "frf.csv", index=False, float_format="%.8g")
    plot_frf(freq, h, out / "frf.png")
    peak = int(np.argmax(np.abs(h)))
    summary = {
        "model": model.name,
        "static_compliance_m_per_N": float(abs(h[0])),
        "peak_hz": float(freq[peak]),
        "peak_m_per_N": float(abs(h[peak])),
        "table": str(out / "frf.csv"),
        "plot": str(out / "frf.png"),
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"{model.name}: peak receptance {summary['peak_m_per_N']:.3e} m/N at "
            f"{summary['peak_hz']:.1f} Hz; wrote {summary['table']} and {summary['plot']}"
        )
    return 0
