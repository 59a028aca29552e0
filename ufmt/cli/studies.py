"""``ufmt run STUDY.toml``: the command that runs a study file.

Arguments of ``ufmt run`` (built by :func:`add_run_parser`):

``study``
    Path of the study file (``studies/*.toml``).
``--jobs N``
    Worker processes (default: every core; more than the cores available: one warning and
    one per core).
``--backend {loky,dask}``
    joblib backend: ``loky`` (local processes, default) or ``dask`` (dask.distributed).
``--scheduler ADDRESS``
    dask scheduler address, e.g. ``tcp://10.0.0.5:8786`` (with ``--backend dask``; without it a
    local cluster of ``--jobs`` workers is started).
``--results DIR``
    Root of the results tree (default ``results``, or ``results/<model file name>`` for a
    study on a user's model); outputs go to ``DIR/<study name>/``.
``--fresh``
    Discard rows of an earlier, interrupted run instead of resuming it.
``--no-progress``
    No progress bar.
``--no-plots``
    Skip the PNG plots.

Exit status: 0 every point succeeded or lies outside the surface model's validity domain
(status invalid, one note line on stderr); 1 the study finished but some points failed, or
it stopped on a full disk or a lost permission (finished rows kept) (one summary
line on stderr; the messages are in points.csv); 2 wrong input, found before any point runs
(study file, model file, a design or process value, ``--results``, ``--scheduler``, another run
writing the same results); 130 interrupted (Ctrl-C, SIGTERM; rerun to resume).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} must be >= 1")
    return value


def add_run_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``run`` sub-command to an argparse ``subparsers`` object and return it."""
    parser = subparsers.add_parser(
        "run",
        help="run a study file (sweep, grid, optimiser, sensitivity)",
        description="Run or resume a study; results go to RESULTS/<study name>/.",
    )
    parser.add_argument(
        "study", type=Path, help="study file (TOML), e.g. studies/sweep-stiffness.toml"
    )
    parser.add_argument("--jobs", type=_positive_int, help="worker processes (default: all cores)")
    parser.add_argument(
        "--backend", choices=("loky", "dask"), default="loky", help="joblib backend"
    )
    parser.add_argument(
        "--scheduler", metavar="ADDRESS", help="dask scheduler, e.g. tcp://host:8786"
    )
    parser.add_argument(
        "--results",
        type=Path,
        help="results root (default results/, or results/<model file name>/ for a study on "
        "your own model)",
    )
    parser.add_argument("--fresh", action="store_true", help="ignore rows of an earlier run")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    parser.set_defaults(func=run_study_cli)
    return parser


def run_study_cli(args: argparse.Namespace) -> int:
    """Run the study of parsed ``ufmt run`` arguments; prints the headline; returns 0, or 1
    if some points failed (with a summary line on stderr).

    Raises
    ------
    StudyError
        A bad study file or argument (the caller prints its one-line message).
    """
    from ufmt.studies.load import load_study
    from ufmt.studies.outputs import read_meta
    from ufmt.studies.parallel import Execution
    from ufmt.studies.runner import default_results, run_study

    study = load_study(args.study)
    root = default_results(study) if args.results is None else Path(args.results)
    before = read_meta(root / study.name)  # a rerun that computes nothing leaves it as it was
    out_dir = run_study(
        study,
        Execution(jobs=args.jobs, backend=args.backend, scheduler=args.scheduler),
        results=args.results,
        progress=not args.no_progress,
        fresh=args.fresh,
        plots=not args.no_plots,
    )
    meta = read_meta(out_dir)
    run = meta["run"]
    print(f"{meta['study']}: {meta['headline']}")
    if before and meta == before:  # nothing computed: meta.json is the earlier run's
        print(
            f"{run['points_total']} points, every one reused from the run of {meta['started']};"
            f" nothing recomputed, every file as it was -> {out_dir}"
        )
    else:
        print(
            f"{run['points_total']} points ({run['points_new']} new, {run['points_reused']}"
            f" reused, {run['points_failed']} failed) in {run['wall_s']} s -> {out_dir}"
        )
    if run.get("points_invalid"):
        print(
            f"ufmt run: {run['points_invalid']} of {run['points_total']} points lie outside the"
            f" surface model's validity domain (status invalid; the limit is in"
            f" {out_dir / 'points.csv'}); left out of the results",
            file=sys.stderr,
        )
    if run["points_failed"]:
        print(
            f"ufmt run: {run['points_failed']} of {run['points_total']} points failed"
            f" (status and message in {out_dir / 'points.csv'})",
            file=sys.stderr,
        )
        return 1
    return 0
