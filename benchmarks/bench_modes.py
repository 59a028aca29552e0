"""Benchmark: every mode below 1 kHz of the 13-body, 18-hinge, two-beam UFMT prior model.

MSTMM (including its own coarse assembled count and bracketing) against the assembled LAPACK
eigen-solution with a converged beam mesh. Target (issue 2): ratio <= 5, no missed roots.
"""

import statistics
import time

import numpy as np

from ufmt.assembled import assembled_modes
from ufmt.model.load import load_model, packaged_path
from ufmt.mstmm.solve import solve_modes

FMAX_HZ = 1000.0
REPEATS = 7


def median_seconds(fn) -> float:
    times = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    model = load_model(packaged_path("ufmt-prior.toml"))
    asm = assembled_modes(model, fmax_hz=FMAX_HZ)
    mst = solve_modes(model, fmax_hz=FMAX_HZ, shapes=False)
    f_a = np.asarray(asm.frequencies_hz)
    f_a = f_a[f_a <= FMAX_HZ]
    missed = f_a.size - mst.frequencies_hz.size
    worst = np.max(np.abs(mst.frequencies_hz / f_a - 1)) if missed == 0 else float("nan")
    t_asm = median_seconds(lambda: assembled_modes(model, fmax_hz=FMAX_HZ))
    t_mst = median_seconds(lambda: solve_modes(model, fmax_hz=FMAX_HZ, shapes=False))
    print(
        f"modes below {FMAX_HZ:.0f} Hz: {mst.frequencies_hz.size} (assembled {f_a.size}, "
        f"missed {missed}); U_all order {mst.order}; max |MSTMM/assembled - 1| = {worst:.1e}"
    )
    print(f"assembled eigen-solution: {1e3 * t_asm:8.1f} ms (median of {REPEATS})")
    print(f"MSTMM all roots:          {1e3 * t_mst:8.1f} ms (median of {REPEATS})")
    print(f"ratio MSTMM / assembled:  {t_mst / t_asm:8.2f}  (target <= 5)")


if __name__ == "__main__":
    main()
