"""Benchmark: the real workload, the full modal basis (every mode to 5 kHz: 68 on the packaged
UFMT) of a new design, MSTMM against the best assembled baseline at equal accuracy; and the
cost growth of both with the model's size.

* MSTMM: ``solve_modes(design, fmax_hz=5000)`` with shapes (Wittrick-Williams count and
  brackets, Newton roots to 1e-12, no mesh anywhere).
* Baseline: assembled build (mesh, K, M, exact condensation of the massless dofs) plus its
  best eigen-solver call with eigenvectors, at the coarsest beam mesh whose every frequency
  of the basis is within the target (1e-5, 1e-6) of the MSTMM's, or the finest mesh tried
  (printed; then the ratio is a bound: the baseline would cost more). Solvers tried:
  ``scipy.linalg.eigh(K, M, subset_by_index)``, sparse shift-invert Lanczos
  (``scipy.sparse.linalg.eigsh(K, k, M, sigma=0)``) and the package's singular-value
  solver (``assembled_modes``). The assembled frequencies converge from above to the
  MSTMM's at the linear elements' O(h²) rate (printed), so the MSTMM values are the mesh
  limit and "equal accuracy" is set by the target.
* A new design per call on both sides (the head's radial air-bearing stiffness changes by
  1e-4 each call: the structure caches are shared, as in a study, the stiffness is new).
* The C heap's thresholds raised as in the CLI (:mod:`ufmt.allocator`), for both sides.
* One BLAS thread on both sides (threadpoolctl), calls interleaved in one run (medians of
  CPU time, ``time.process_time``: both sides run on one thread, and on a shared machine
  wall time mostly measures the wait for a core); each round a block of MSTMM_BLOCK new
  designs for the MSTMM (as a study solves them, one after the other) and one call of each
  baseline (see :func:`interleaved`).
* Secondary line: the same for the first 30 modes (the former default basis).
* Batches: the full basis of new designs per design, ``solve_modes_batch`` over batches of 8
  and 32 designs of one structure against ``solve_modes`` one by one, interleaved (target
  <= 25 ms per design inside a batch).
* Growth: synthetic chains of 10-80 rigid bodies with a beam every fifth link and a spring
  closing a loop every tenth body; MSTMM and assembled (its automatic mesh, default rtol)
  time for the 20 lowest modes against size, printed as a table.
Target: MSTMM <= 0.1x the best baseline at equal accuracy on the full basis. Printed, never
asserted.
"""

import statistics
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_limits

from ufmt.allocator import retain_freed_memory
from ufmt.assembled import assemble, assembled_modes, reduced_matrices
from ufmt.design import apply_design, design_value
from ufmt.model.load import load_model, model_from_dict
from ufmt.mstmm.solve import solve_modes, solve_modes_batch

FMAX_HZ = 5000.0
SECONDARY_MODES = 30
TARGETS = (1e-5, 1e-6)
MESHES = (4, 8, 16, 32, 64, 120, 180, 240)
SLOWEST_TRIED_S = 15.0  # a solver is not tried on finer meshes once one call takes this long
ROUNDS = 3
MSTMM_BLOCK = 8  # MSTMM calls (new designs) in a row per round: see interleaved
PARAMETER = "head_radial_stiffness_N_m"
CHAIN_SIZES = (10, 20, 40, 80)
PITCH = 0.2  # [m] between a chain's bodies (0.35 m made the 80-body chain 28 m long)
CHAIN_MODES = 20
CHAIN_MESHES = (2, 4, 8, 16, 32)
CHAIN_TARGET = 1e-6
BATCH_SIZES = (8, 32)
BATCH_TARGET_MS = 25.0


def designs(model):
    """An endless supply of new designs of one structure (stiffness up by 1e-4 each)."""
    value, i = design_value(model, PARAMETER), 0
    while True:
        i += 1
        yield apply_design(model, {PARAMETER: value * (1 + 1e-4) ** i})


def eigh_dense(model, elements: int, count: int) -> np.ndarray:
    """Build + eigh(K, M) for the ``count`` lowest nonzero modes [Hz] (shapes computed)."""
    k, m, zero = reduced_matrices(assemble(model, elements_per_beam=elements))
    w2, _ = sla.eigh(k, m, subset_by_index=[zero, zero + count - 1])
    return np.sqrt(np.abs(w2)) / (2 * np.pi)


def eigsh_sparse(model, elements: int, count: int) -> np.ndarray:
    """Build + sparse shift-invert Lanczos about σ = 0 (shapes computed); the zero modes,
    if any, come first."""
    k, m, zero = reduced_matrices(assemble(model, elements_per_beam=elements))
    w2, _ = spla.eigsh(sp.csc_array(k), k=zero + count, M=sp.csc_array(m), sigma=-1.0)
    return np.sqrt(np.abs(np.sort(w2)[zero:])) / (2 * np.pi)


def svd_assembled(model, elements: int, count: int) -> np.ndarray:
    """The package's assembled solver (singular values), shapes included."""
    return assembled_modes(model, count=count, elements_per_beam=elements).frequencies_hz


SOLVERS = {
    "eigh(K, M)": eigh_dense,
    "eigsh(K, M, σ=0)": eigsh_sparse,
    "assembled_modes (SVD)": svd_assembled,
}


def interleaved(calls: dict, rounds: int = ROUNDS, block: dict | None = None) -> dict:
    """Median CPU time [s] per call of each callable, the callables taking turns for
    ``rounds`` rounds, each turn a block of ``block[name]`` calls (default 1) timed one by
    one: a solver that takes milliseconds runs a few designs in a row, as a study does, not
    each one straight after a baseline call that took hundreds of milliseconds and evicted
    its working set from the caches (both sides still see the same machine load)."""
    times: dict = {name: [] for name in calls}
    for _ in range(rounds):
        for name, fn in calls.items():
            for _ in range((block or {}).get(name, 1)):
                t0 = time.process_time()
                fn()
                times[name].append(time.process_time() - t0)
    return {name: statistics.median(t) for name, t in times.items()}


def mesh_errors(model, reference: np.ndarray) -> dict:
    """{solver: {elements: per-mode relative errors}} against the MSTMM's frequencies, each
    solver refined until it reaches the finest target or a call gets too slow."""
    out: dict = {}
    for name, solver in SOLVERS.items():
        out[name] = {}
        for elements in MESHES:
            t0 = time.perf_counter()
            f = solver(model, elements, reference.size)
            out[name][elements] = np.abs(f / reference - 1)
            worst = [err.max() for err in out[name].values()]
            if worst[-1] <= min(TARGETS) or time.perf_counter() - t0 > SLOWEST_TRIED_S:
                break
            if len(worst) > 1 and worst[-1] > worst[-2]:  # refining makes it worse (rounding)
                break
    return out


def baselines(errors: dict, count: int, target: float) -> list:
    """(solver, elements, reached): per solver that reaches ``target`` on the first ``count``
    modes, its coarsest such mesh; if none does, the most accurate solver and mesh tried
    (the bound: reaching the target would cost it more)."""
    reached, closest = [], []
    for name, by_mesh in errors.items():
        ok = [e for e, err in by_mesh.items() if err[:count].max() <= target]
        if ok:
            reached.append((name, ok[0], True))
        for e, err in by_mesh.items():
            closest.append((err[:count].max(), name, e))
    if reached:
        return reached
    _, name, elements = min(closest)
    return [(name, elements, False)]


def compare(model, count: int | None, label: str, errors: dict) -> None:
    """Interleaved timing of the MSTMM and each baseline on new designs; prints ratios."""
    supply = designs(model)
    n = count or next(iter(next(iter(errors.values())).values())).size
    mstmm = (
        (lambda: solve_modes(next(supply), fmax_hz=FMAX_HZ))
        if count is None
        else (lambda: solve_modes(next(supply), count=count))
    )
    calls = {"mstmm": mstmm}
    chosen = {target: baselines(errors, n, target) for target in TARGETS}
    for name, elements, _ in {c for cs in chosen.values() for c in cs}:
        calls[(name, elements)] = lambda s=SOLVERS[name], e=elements: s(next(supply), e, n)
    seconds = interleaved(calls, block={"mstmm": MSTMM_BLOCK})
    print(f"{label}: MSTMM {1e3 * seconds['mstmm']:8.1f} ms CPU per new design (median)")
    for target in TARGETS:
        best = min(chosen[target], key=lambda c: seconds[c[:2]])
        for name, elements, reached in chosen[target]:
            worst = errors[name][elements][:n].max()
            note = "" if reached else f"  (not reached: the most accurate tried, {worst:.1e})"
            ms = 1e3 * seconds[(name, elements)]
            print(f"  {target:.0e}: {name:22s} {elements:4d} el/beam {ms:9.1f} ms{note}")
        bound = "" if best[2] else " (bound: the baseline has not reached the target)"
        print(
            f"  {target:.0e}: ratio MSTMM / best baseline ({best[0]}, {best[1]} el/beam) = "
            f"{seconds['mstmm'] / seconds[best[:2]]:.3f}{bound}"
        )


def batches(model) -> None:
    """Milliseconds per new design (full basis with shapes): one by one, and inside batches
    of BATCH_SIZES designs; the designs are made before the clock starts."""
    supply = designs(model)
    times: dict = {size: [] for size in ("one by one", *BATCH_SIZES)}
    for _ in range(ROUNDS):
        for size in times:
            stack = [next(supply) for _ in range(8 if size == "one by one" else size)]
            t0 = time.process_time()
            if size == "one by one":
                [solve_modes(d, fmax_hz=FMAX_HZ) for d in stack]
            else:
                solve_modes_batch(stack, fmax_hz=FMAX_HZ)
            times[size].append((time.process_time() - t0) / len(stack))
    print(f"designs in batches, full basis to {FMAX_HZ:g} Hz with shapes (CPU, {ROUNDS} rounds):")
    for size, seconds in times.items():
        label = size if isinstance(size, str) else f"batch of {size}"
        ms = 1e3 * statistics.median(seconds)
        target = f"(target <= {BATCH_TARGET_MS:g} ms in a batch)"
        print(f"  {label:12s} {ms:8.1f} ms per design {target}")


def chain_model(bodies: int) -> dict:
    """A chain of ``bodies`` rigid bodies along x on springs, a beam every fifth link
    (rigidly held by its neighbours), a spring from body i to body i + 2 every tenth body
    (a closed loop), grounded at both ends; links PITCH [m] apart, so 80 bodies stay inside
    the 20 m a model file may span."""
    rng = np.random.default_rng(bodies)
    spring = {"stiffness": [5e7] * 3, "rotational_stiffness": [5e5] * 3}
    rigid = {"stiffness": [float("inf")] * 3, "rotational_stiffness": [float("inf")] * 3}
    steel = {"density": 7850.0, "youngs_modulus": 2.1e11, "shear_modulus": 8.1e10}
    body, hinge, x = [], [], 0.0
    for i in range(bodies):
        mass, j = rng.uniform(2.0, 20.0), rng.uniform(0.01, 0.1)
        inertia = np.diag([j, j * rng.uniform(0.6, 1.0), j * rng.uniform(0.6, 1.0)])
        body.append(
            {"name": f"b{i}", "kind": "rigid", "mass": mass, "center_of_mass": [x, 0.0, 0.0]}
            | {"inertia": inertia.tolist()}
        )
        previous = "ground" if i == 0 else f"b{i - 1}"
        if i % 5 == 4:  # a beam between the previous body and this one
            name = f"beam{i}"
            body.append(
                {
                    "name": name,
                    "kind": "beam",
                    "start": [x - 0.6 * PITCH, 0, 0],
                    "end": [x - 0.1 * PITCH, 0, 0],
                }
                | steel
                | {"diameter": 0.04}
            )
            hinge.append(
                {"name": f"h{i}a", "between": [previous, name], "at": [x - 0.6 * PITCH, 0, 0]}
                | rigid
            )
            hinge.append(
                {"name": f"h{i}b", "between": [name, f"b{i}"], "at": [x - 0.1 * PITCH, 0, 0]}
                | rigid
            )
        else:
            hinge.append(
                {"name": f"h{i}", "between": [previous, f"b{i}"], "at": [x - 0.3 * PITCH, 0, 0]}
                | spring
            )
        if i % 10 == 9:  # a loop: body i - 2 to body i
            hinge.append(
                {"name": f"loop{i}", "between": [f"b{i - 2}", f"b{i}"], "at": [x - PITCH, 0.1, 0]}
                | spring
            )
        x += PITCH
    hinge.append({"name": "end", "between": [f"b{bodies - 1}", "ground"], "at": [x, 0, 0]} | spring)
    return {"name": f"chain{bodies}", "body": body, "hinge": hinge}


def coarsest_mesh(model, reference: np.ndarray) -> int:
    """Fewest elements per beam (of CHAIN_MESHES) with the assembled frequencies within
    CHAIN_TARGET of the MSTMM's, or the finest."""
    for elements in CHAIN_MESHES:
        f = assembled_modes(model, count=reference.size, elements_per_beam=elements, shapes=False)
        if np.max(np.abs(f.frequencies_hz / reference - 1)) <= CHAIN_TARGET:
            return elements
    return CHAIN_MESHES[-1]


def growth() -> None:
    """MSTMM and assembled time for CHAIN_MODES modes against the chain's size, the assembled
    model at its coarsest mesh within CHAIN_TARGET."""
    print(
        f"cost growth, {CHAIN_MODES} lowest modes with shapes, chains with beams and loops; "
        f"assembled (SVD) at the coarsest mesh within {CHAIN_TARGET:.0e} of the MSTMM:"
    )
    print("  bodies  beams  loops  U_all order  MSTMM [ms]  el/beam  dofs  assembled [ms]")
    for n in CHAIN_SIZES:
        model = model_from_dict(chain_model(n))
        beams = sum(b.kind == "beam" for b in model.bodies)
        mst = solve_modes(model, count=CHAIN_MODES)
        elements = coarsest_mesh(model, mst.frequencies_hz)
        calls = {
            "mstmm": lambda m=model: solve_modes(m, count=CHAIN_MODES),
            "assembled": lambda m=model, e=elements: assembled_modes(
                m, count=CHAIN_MODES, elements_per_beam=e
            ),
        }
        seconds = interleaved(calls)
        dofs = assemble(model, elements_per_beam=elements).K.shape[0]
        print(
            f"  {n:6d}  {beams:5d}  {n // 10:5d}  {mst.order:11d}  {1e3 * seconds['mstmm']:10.1f}"
            f"  {elements:7d}  {dofs:4d}  {1e3 * seconds['assembled']:14.1f}"
        )


def main() -> None:
    retain_freed_memory()  # as the CLI and the study workers run; both sides share it
    model = load_model()
    with threadpool_limits(limits=1, user_api="blas"):
        reference = solve_modes(model, fmax_hz=FMAX_HZ)
        f = reference.frequencies_hz
        print(
            f"full basis: every mode to {FMAX_HZ:g} Hz of the packaged model, {f.size} modes "
            f"({f.size}/{reference.expected} counted), 1 BLAS thread on both sides"
        )
        errors = mesh_errors(model, f)
        print("assembled vs MSTMM, max |f/f_MSTMM - 1| over the basis by elements per beam:")
        for name, by_mesh in errors.items():
            row = "  ".join(f"{e}: {err.max():.1e}" for e, err in by_mesh.items())
            rate = [err.max() * e**2 for e, err in by_mesh.items()]
            print(f"  {name:22s} {row}   (error x el² {rate[0]:.2g} -> {rate[-1]:.2g})")
        compare(model, None, f"full basis ({f.size} modes)", errors)
        compare(model, SECONDARY_MODES, f"secondary: first {SECONDARY_MODES} modes", errors)
        batches(model)
        growth()


if __name__ == "__main__":
    main()
