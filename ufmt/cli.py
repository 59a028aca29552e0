"""Command-line interface: ``ufmt modes | simulate | frf | calibrate | plot-mode | run``.

User errors (bad model, study or argument) print one line on stderr and exit with status 2;
no traceback. ``--json`` output is exactly one JSON object on stdout.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings

from threadpoolctl import threadpool_limits

from ufmt.errors import UfmtError


def load(path: str | None):
    """The model at ``path``, or the packaged UFMT."""
    from ufmt.model.load import load_model, packaged_path

    return load_model(path or packaged_path())


def positive(kind):
    """argparse type: a number of ``kind`` that must be > 0."""

    def parse(text):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{text} must be > 0")
        return value

    return parse


def cmd_modes(args) -> int:
    """Natural frequencies (and dominant bodies/directions) of a model."""
    from ufmt.mstmm.solve import describe, solve_modes

    model = load(args.model)
    sol = solve_modes(model, args.fmax, args.count, args.method, shapes=args.method == "mstmm")
    lines = describe(model, sol.energy_shares(model)) if sol.shapes is not None else []
    if args.json:
        out = {
            "model": model.name,
            "source": model.source,
            "method": sol.method,
            "order": sol.order,
            "frequencies_hz": [float(f) for f in sol.frequencies_hz],
            "count": int(sol.frequencies_hz.size),
            "expected_count": sol.expected,
            "rigid_body_modes": sol.rigid_body_modes,
            "dominant": lines,
            "seconds": round(sol.seconds, 4),
        }
        print(json.dumps(out))
        return 0
    print(f"{model.name}: {sol.frequencies_hz.size} modes ({sol.method}", end="")
    print(f", U_all order {sol.order})" if sol.order else ")")
    if sol.rigid_body_modes:
        print(f"  + {sol.rigid_body_modes} zero-frequency (rigid-body) modes")
    print(f"{'mode':>5} {'f [Hz]':>14}  dominant body and direction (kinetic energy)")
    for i, f in enumerate(sol.frequencies_hz):
        desc = lines[i] if lines else ""
        print(f"{i + 1:>5} {f:>14.6f}  {desc}")
    if sol.expected != sol.frequencies_hz.size:
        print(
            f"warning: the assembled model counts {sol.expected} modes in this range",
            file=sys.stderr,
        )
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="ufmt", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("modes", help="natural frequencies and mode descriptions")
    p.add_argument("model", nargs="?", help="model TOML (default: packaged UFMT)")
    p.add_argument("--fmax", type=positive(float), help="upper frequency [Hz] (default 1000)")
    p.add_argument("--count", type=positive(int), help="number of modes")
    p.add_argument("--method", choices=["mstmm", "assembled"], default="mstmm")
    p.add_argument("--json", action="store_true", help="one JSON object on stdout")
    p.set_defaults(func=cmd_modes)
    # the other modules add their own sub-parsers (imported here: they import this module)
    from ufmt.commands import register as register_model_commands
    from ufmt.dynamics.cli import register as register_dynamics_commands
    from ufmt.studies.cli import add_run_parser

    for register in (register_model_commands, register_dynamics_commands, add_run_parser):
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
    with warnings.catch_warnings():
        warnings.showwarning = _warning_line
        return _main(argv)


def _main(argv) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "run":  # the study runner limits BLAS threads per worker itself
            return int(args.func(args) or 0)
        # the matrices are small (order ~100): BLAS threads would only add contention
        with threadpool_limits(limits=1, user_api="blas"):
            return int(args.func(args) or 0)
    except UfmtError as exc:
        print(f"ufmt {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"ufmt {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
