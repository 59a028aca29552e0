"""CLI sub-command ``ufmt report``: one self-contained HTML page of the results folder."""

from __future__ import annotations

from pathlib import Path

from ufmt.cli.common import load, results_dir


def register(subparsers) -> None:
    """Add the ``report`` sub-parser."""
    p = subparsers.add_parser(
        "report", help="one self-contained HTML page of results/ (figures embedded)"
    )
    p.add_argument("model", nargs="?", help="model summarised (default: packaged UFMT)")
    p.add_argument(
        "--results",
        type=Path,
        help="results folder (default results/, or results/<model file name>/ for your model)",
    )
    p.add_argument("--output", type=Path, help="HTML file (default RESULTS/report.html)")
    p.set_defaults(func=cmd_report)


def cmd_report(args) -> int:
    """Write the report from the files in ``--results`` (nothing is recomputed)."""
    from ufmt.errors import UfmtError
    from ufmt.report import write_report

    results = args.results or results_dir(args.model, "", Path("results"))
    if not Path(results).is_dir():
        raise UfmtError(f"--results: {results} is not a directory of results")
    path = write_report(results, load(args.model), args.output)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0
