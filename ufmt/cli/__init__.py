"""Command-line interface: ``ufmt modes | simulate | frf | surface | compare | calibrate |
validate | plot-mode | run | report``; ``ufmt --version``; bare ``ufmt`` prints the help.

Exit status: 0 success; 1 ``ufmt run`` finished but some points failed (a summary line on
stderr; each failure's message is in points.csv); 2 a user error (bad model, study, argument or
results directory; another run holding the results) as one line on stderr, no traceback;
130 interrupted (Ctrl-C or SIGTERM; finished study rows are kept). ``--json`` output is exactly
one strict JSON object on stdout.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

from ufmt import __version__
from ufmt.errors import UfmtError
from ufmt.limits import MAX_MODE_FREQUENCY_HZ

DESCRIPTION = (
    "Dynamics of ultra-precision fly-cutting machine tools: natural frequencies and mode "
    "shapes (MSTMM), cutting response and machined-surface PV, validation against the paper, "
    "parameter studies and an HTML report. MODEL defaults to the packaged, calibrated UFMT."
)


def build_parser() -> argparse.ArgumentParser:
    """The full parser: every sub-command registers its arguments (their modules, and the
    defaults their help shows, load here, not when ``ufmt.cli`` is imported)."""
    from ufmt.cli.calibration import register as register_calibration
    from ufmt.cli.common import positive
    from ufmt.cli.machining import register as register_machining
    from ufmt.cli.measured import register as register_measured
    from ufmt.cli.modes import cmd_modes
    from ufmt.cli.report import register as register_report
    from ufmt.cli.studies import add_run_parser
    from ufmt.limits import MAX_MODE_COUNT

    parser = _Parser(prog="ufmt", description=DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"ufmt {__version__}")
    sub = parser.add_subparsers(dest="command", title="commands")
    p = sub.add_parser("modes", help="natural frequencies and mode descriptions")
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    p.add_argument(
        "--fmax",
        type=positive(float, at_most=MAX_MODE_FREQUENCY_HZ),
        help="upper frequency [Hz] (default 1000, at most 20000)",
    )
    p.add_argument(
        "--count",
        type=positive(int, at_most=MAX_MODE_COUNT),
        help=f"number of modes (at most {MAX_MODE_COUNT})",
    )
    p.add_argument("--method", choices=["mstmm", "assembled"], default="mstmm")
    p.add_argument(
        "--zeta",
        type=positive(float, below=1.0),
        help="structural damping ratio of the damped modes (default: the model's "
        "machine.modal_damping_ratio, else 0.01); the hinge dampers add to it",
    )
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_modes)
    registers = (register_calibration, register_machining, register_measured, add_run_parser)
    for register in (*registers, register_report):
        register(sub)
    return parser


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error (no usage dump) and exit status 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _warning_line(message, category, filename, lineno, file=None, line=None):
    """Warnings (e.g. a process outside Table 1) as one line on stderr, without source."""
    print(f"warning: {message}", file=sys.stderr)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["--version"]:  # as argparse's version action, without building the parser
        print(f"ufmt {__version__}")
        raise SystemExit(0)
    from ufmt.allocator import retain_freed_memory
    from ufmt.cli.environment import matplotlib_config_dir

    matplotlib_config_dir()
    retain_freed_memory()
    with warnings.catch_warnings():
        warnings.showwarning = _warning_line
        return _main(argv)


def _main(argv) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:  # bare `ufmt`: the help, not an error
        parser.print_help()
        return 0
    import numpy as np  # here, not at the top: `ufmt --version` and `--help` stay instant
    from threadpoolctl import threadpool_limits

    try:
        if args.command == "run":  # the study runner limits BLAS threads per worker itself
            return int(args.func(args) or 0)
        # the matrices are small (order ~100): BLAS threads would only add contention
        with threadpool_limits(limits=1, user_api="blas"):
            return int(args.func(args) or 0)
    except UfmtError as exc:  # RunFailed: exit 1 (a study's finished rows are kept)
        print(f"ufmt {args.command}: error: {exc}", file=sys.stderr)
        return getattr(exc, "exit_status", 2)
    except BrokenPipeError:
        # the reader closed stdout (e.g. `ufmt modes | head`): stop quietly, as SIGPIPE would
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as exc:  # a file the command reads or writes (outputs: OutputError, above)
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"ufmt {args.command}: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"ufmt {args.command}: interrupted (finished results are kept)", file=sys.stderr)
        return 130
    except (MemoryError, RecursionError, np.linalg.LinAlgError) as exc:
        # a last guard: the input checks should have refused what causes these
        reason = " ".join(str(exc).split())[:200] or "out of memory"
        given = getattr(args, "model", None) or getattr(args, "study", None)
        where = f"{given}: " if given else "the packaged model: "
        print(
            f"ufmt {args.command}: error: {where}{type(exc).__name__}: {reason} (input too"
            " large or too extreme for the solver; budgets in ufmt.limits)",
            file=sys.stderr,
        )
        return 2
