"""``ufmt modes``: natural frequencies and the dominant body and direction of each mode."""

from __future__ import annotations

import sys

from ufmt.cli.common import load
from ufmt.jsonout import dumps_strict


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
        print(dumps_strict(out))
        return 0
    print(f"{model.name}: {sol.frequencies_hz.size} modes ({sol.method}", end="")
    print(f", U_all order {sol.order})" if sol.order else ")")
    if sol.rigid_body_modes:
        count = sol.rigid_body_modes
        print(f"  + {count} zero-frequency (rigid-body) mode{'' if count == 1 else 's'}")
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
