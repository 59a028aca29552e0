"""``ufmt modes``: natural frequencies, the dominant body and direction of each mode and (MSTMM)
the damped natural frequencies and damping ratios with ζ and the hinge dampers."""

from __future__ import annotations

import sys

from ufmt.cli.common import load
from ufmt.errors import UfmtError
from ufmt.jsonout import dumps_strict


def cmd_modes(args) -> int:
    """Natural frequencies (and dominant bodies/directions, damped modes) of a model."""
    from ufmt.machining.damped_frequencies import damped_frequencies
    from ufmt.mstmm.solve import describe
    from ufmt.solvers import solve_modes

    model = load(args.model)
    sol = solve_modes(model, args.fmax, args.count, args.method, shapes=args.method == "mstmm")
    lines = describe(model, sol.energy_shares(model)) if sol.shapes is not None else []
    damped = None
    if sol.shapes is not None and sol.frequencies_hz.size:
        try:
            damped = damped_frequencies(model, count=sol.frequencies_hz.size, zeta=args.zeta)
        except UfmtError as exc:  # e.g. coalescing poles: the undamped modes still stand
            print(f"warning: no damped modes: {exc}", file=sys.stderr)
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
        } | _damped_json(damped)
        print(dumps_strict(out))
        return 0
    print(f"{model.name}: {sol.frequencies_hz.size} modes ({sol.method}", end="")
    print(f", U_all order {sol.order})" if sol.order else ")")
    if sol.rigid_body_modes:
        count = sol.rigid_body_modes
        print(f"  + {count} zero-frequency (rigid-body) mode{'' if count == 1 else 's'}")
    paired = damped is not None and damped.damped_hz.size == sol.frequencies_hz.size
    extra = f" {'f_d [Hz]':>14} {'zeta [%]':>8}" if paired else ""
    print(f"{'mode':>5} {'f [Hz]':>14}{extra}  dominant body and direction (kinetic energy)")
    for i, f in enumerate(sol.frequencies_hz):
        desc = lines[i] if lines else ""
        cols = (
            f" {damped.damped_hz[i]:>14.6f} {100 * damped.damping_ratio[i]:>8.3f}" if paired else ""
        )
        print(f"{i + 1:>5} {f:>14.6f}{cols}  {desc}")
    if damped is not None:
        _print_damped(damped, paired)
    if sol.expected != sol.frequencies_hz.size:
        print(
            f"warning: {sol.expected} modes are counted in this range",
            file=sys.stderr,
        )
    return 0


def _damped_json(damped) -> dict:
    """The damped modes' keys of ``ufmt modes --json`` (null without them: the assembled
    method, or damped modal equations that are defective)."""
    if damped is None:
        return dict.fromkeys(
            ("damped_frequencies_hz", "damping_ratios", "structural_damping_ratio", "hinge_dampers")
        )
    return {
        "damped_frequencies_hz": [float(f) for f in damped.damped_hz],
        "damping_ratios": [float(z) for z in damped.damping_ratio],
        "structural_damping_ratio": damped.zeta,
        "hinge_dampers": damped.hinge_dampers,
    }


def _print_damped(damped, paired: bool) -> None:
    """The damping the f_d and zeta columns hold (and the damped modes if not one per mode)."""
    kind = "complex modes with the hinge dampers" if damped.hinge_dampers else "no hinge dampers"
    print(f"f_d, zeta: damped modes, structural zeta {damped.zeta:g} ({kind})")
    if not paired:
        for i, (f, z) in enumerate(zip(damped.damped_hz, damped.damping_ratio, strict=True)):
            print(f"  damped mode {i + 1}: f_d {f:.6f} Hz, zeta {100 * z:.3f} %")
