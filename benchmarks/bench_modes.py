"""Benchmark: 30 modes with shapes of the packaged UFMT model, MSTMM against the assembled
model at equal accuracy and equal BLAS threads.

* MSTMM: ``solve_modes(model, count=30)`` (its Wittrick-Williams count and brackets,
  Newton roots to 1e-12, inverse-iteration shapes on every body).
* Baseline: assembled build (mesh, K, M, exact condensation of the massless dofs) plus an
  eigen-solver, eigenvectors included, at the coarsest beam mesh whose 30 frequencies are
  within the target of the MSTMM's (found by convergence over the mesh, printed). Three
  solver calls are tried and the fastest that reaches the target is the baseline:
  ``scipy.linalg.eigh(K, M, subset_by_index=...)``; the same on the shift-inverted pencil
  ``eigh(M, K + σM)`` (largest 1/(λ + σ), σ = (2π·1 Hz)²), which keeps the relative accuracy
  of the low modes that eigh(K, M) loses to eps·λ_max on fine meshes; and the package's
  singular-value solver (``assembled_modes``).
* The assembled frequencies converge to the MSTMM's at the beam elements' O(h²) rate
  (printed: error × elements² is flat), i.e. the MSTMM values are the mesh limit; the MSTMM
  roots themselves are converged to 1e-12, so "equal accuracy" is set by the target.
* Both sides run with one BLAS thread (threadpoolctl), timed in the same run, interleaved
  (one call of each in turn, REPEATS rounds, medians): the machine is shared, so both sides
  see the same load.
* Sweeps: 30 modes of consecutive designs (head radial air-bearing stiffness in 1 % steps
  and in the 1.47x steps of studies/sweep-stiffness.toml) with and without continuation
  (``ufmt.mstmm.solve.continuation``); ``ufmt.evaluate`` of new designs (no disk cache) and
  the share of its modal solve.
Targets: MSTMM / (build + eigen-solver) <= 2 at equal accuracy, stretch <= 1 with
continuation in a sweep; new-design evaluate <= 50 ms. Printed, never asserted.
"""

import importlib
import os
import statistics
import time

import numpy as np
import scipy.linalg as sla
from threadpoolctl import threadpool_limits

from ufmt.assembled import assemble, assembled_modes, reduced_matrices
from ufmt.model.load import load_model, packaged_path
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.reduced import ConstantParts
from ufmt.mstmm.solve import continuation, solve_modes

MODES = 30
REPEATS = 9
TARGETS = (1e-5, 1e-6, 1e-7)
MESHES = (2, 3, 4, 5, 6, 8, 10, 12, 15, 20, 25, 30, 40, 48, 64)
SHIFT = (2 * np.pi) ** 2  # σ [rad²/s²] of the shift-inverted pencil
SWEEP_PARAMETER = "head_radial_stiffness_N_m"
SWEEP_STEPS = {"1 % steps": 1.01, "1.47x steps": 100 ** (1 / 12)}
SWEEP_DESIGNS = 12


def interleaved_medians(calls: dict) -> dict:
    """Median wall time [s] of each callable, called in turn for REPEATS rounds."""
    times: dict = {name: [] for name in calls}
    for _ in range(REPEATS):
        for name, fn in calls.items():
            t0 = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - t0)
    return {name: statistics.median(t) for name, t in times.items()}


def eigh_direct(model, elements: int) -> np.ndarray:
    """Assembled build + eigh(K, M): the 30 lowest nonzero modes [Hz] (shapes computed)."""
    k, m, zero = reduced_matrices(assemble(model, elements_per_beam=elements))
    w2, _ = sla.eigh(k, m, subset_by_index=[zero, zero + MODES - 1])
    return np.sqrt(np.abs(w2)) / (2 * np.pi)


def eigh_inverted(model, elements: int) -> np.ndarray:
    """Assembled build + eigh(M, K + σM): the largest 1/(λ + σ) are the lowest λ."""
    k, m, zero = reduced_matrices(assemble(model, elements_per_beam=elements))
    n = k.shape[0]
    mu, _ = sla.eigh(m, k + SHIFT * m, subset_by_index=[n - zero - MODES, n - zero - 1])
    return np.sqrt(np.abs(1.0 / mu[::-1] - SHIFT)) / (2 * np.pi)


def svd_modes(model, elements: int) -> np.ndarray:
    """The package's assembled solver (singular values of the mass-scaled deformation)."""
    return assembled_modes(model, count=MODES, elements_per_beam=elements).frequencies_hz


SOLVERS = {
    "eigh(K, M)": eigh_direct,
    "eigh(M, K + σM)": eigh_inverted,
    "assembled_modes (SVD)": svd_modes,
}


def main() -> None:
    model = load_model(packaged_path("ufmt-prior.toml"))
    with threadpool_limits(limits=1, user_api="blas"):
        mst = solve_modes(model, count=MODES)
        f = mst.frequencies_hz
        errors = {
            name: {e: float(np.max(np.abs(fn(model, e) / f - 1))) for e in MESHES}
            for name, fn in SOLVERS.items()
        }
        candidates = {
            target: [
                (name, mesh)
                for name in SOLVERS
                if (mesh := next((e for e in MESHES if errors[name][e] <= target), None))
            ]
            for target in TARGETS
        }
        calls = {"mstmm": lambda: solve_modes(model, count=MODES)}
        for name, mesh in sorted({c for cs in candidates.values() for c in cs}):
            calls[(name, mesh)] = lambda fn=SOLVERS[name], e=mesh: fn(model, e)
        seconds = interleaved_medians(calls)
    system = TransferSystem(model, fmax_hz=float(f[-1]))
    u = system.evaluate(2 * np.pi * f[[0, 0, -1]] * np.array([1.0, 1.0 + 1e-7, 1.0]))
    newton_order = ConstantParts.of(u).order
    print(
        f"{MODES} modes with shapes, packaged model, 1 BLAS thread on both sides; "
        f"U_all order {mst.order}, {system.size} with {len(system.segments)} segments, "
        f"{newton_order} after its ω-independent parts are eliminated (the Newton matrix); "
        f"{mst.frequencies_hz.size}/{mst.expected} roots"
    )
    print("assembled vs MSTMM, max |f/f_MSTMM - 1| by elements per beam (x elements² for SVD):")
    print("   el  " + "  ".join(f"{name:>21s}" for name in SOLVERS) + "   error x el²")
    for e in MESHES:
        row = "  ".join(f"{errors[name][e]:21.2e}" for name in SOLVERS)
        print(f"  {e:3d}  {row}   {errors['assembled_modes (SVD)'][e] * e**2:9.2e}")
    t_mst = seconds["mstmm"]
    print(f"MSTMM solve_modes(count={MODES}): {1e3 * t_mst:7.1f} ms (median)")
    best_by_target = {}
    for target in TARGETS:
        print(f"accuracy {target:.0e}:")
        for name, mesh in candidates[target]:
            t = seconds[(name, mesh)]
            print(f"  build + {name:21s} at {mesh:2d} el/beam {1e3 * t:7.1f} ms")
        if not candidates[target]:
            print("  no assembled solver reaches it on the meshes tried")
            continue
        name, mesh = min(candidates[target], key=lambda c: seconds[c])
        best_by_target[target] = seconds[(name, mesh)]
        print(
            f"  ratio MSTMM / best baseline ({name}, {mesh} el/beam) = "
            f"{t_mst / best_by_target[target]:5.2f} (target <= 2)"
        )
    sweeps(model, best_by_target)


def sweep_ms(model, step: float, tracked: bool) -> float:
    """Mean time per design [ms] of 30 modes with shapes over a stiffness sweep."""
    from ufmt.design import apply_design, design_value

    value = design_value(model, SWEEP_PARAMETER)
    designs = [
        apply_design(model, {SWEEP_PARAMETER: value * step**i}) for i in range(SWEEP_DESIGNS)
    ]
    t0 = time.perf_counter()
    with continuation(("bench", step, time.perf_counter()) if tracked else None):
        for design in designs:
            solve_modes(design, count=MODES)
    return 1e3 * (time.perf_counter() - t0) / len(designs)


def evaluate_ms(step: float) -> tuple[float, float]:
    """Median ``ufmt.evaluate`` time [ms] of new designs and the share of its modal solve
    (median ``solve_modes(count=30)`` of other new designs over it; no profiler running)."""
    from ufmt.design import apply_design, design_value

    ev = importlib.import_module("ufmt.evaluate")
    os.environ["UFMT_CACHE_DIR"] = ""  # no disk cache: every design is computed
    base, _ = ev.resolve_model(None)
    value = design_value(base, SWEEP_PARAMETER)
    ev.evaluate({}, {})  # warm up: model, tables, imports
    evaluate_s, modal_s = [], []
    for i in range(1, SWEEP_DESIGNS + 1):
        t0 = time.perf_counter()
        ev.evaluate({SWEEP_PARAMETER: value * step**i}, {})
        evaluate_s.append(time.perf_counter() - t0)
        design = apply_design(base, {SWEEP_PARAMETER: value * step ** (i + 0.5)})
        t0 = time.perf_counter()
        solve_modes(design, count=MODES)
        modal_s.append(time.perf_counter() - t0)
    median = statistics.median(evaluate_s)
    return 1e3 * median, statistics.median(modal_s) / median


def sweeps(model, baselines: dict) -> None:
    """Per-design times of sweeps, against the best baseline [s] at each accuracy."""
    print(f"sweep of {SWEEP_DESIGNS} designs ({SWEEP_PARAMETER}), 30 modes with shapes:")
    with threadpool_limits(limits=1, user_api="blas"):
        for label, step in SWEEP_STEPS.items():
            plain, tracked = sweep_ms(model, step, False), sweep_ms(model, step, True)
            print(f"  {label:11s}: {plain:6.1f} ms per design, with continuation {tracked:6.1f} ms")
            for target, seconds in baselines.items():
                print(
                    f"    ratio (with continuation) to the best baseline at {target:.0e}: "
                    f"{tracked / (1e3 * seconds):5.2f} (stretch target <= 1)"
                )
        ms, share = evaluate_ms(SWEEP_STEPS["1.47x steps"])
    print(f"ufmt.evaluate, new design: {ms:6.1f} ms median (target <= 50), modal solve {share:.0%}")


if __name__ == "__main__":
    main()
