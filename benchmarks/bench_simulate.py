"""Benchmark: evaluation cost on the packaged UFMT.

1. ``ufmt.evaluate``, a new process (rpm, feed, depth) on a known design: periodic response
   of both force parts + surfaces of every source + metrics; target <= 5 ms;
2. ``ufmt.evaluate``, a new design (head radial stiffness): modal basis (MSTMM, 30 modes) +
   static correction + the above; target <= 50 ms;
3. of a new design, all but the modal solve (static correction, cut geometry, response and
   surfaces: a precomputed basis), and the static correction alone (:func:`residual_flexibility`);
4. the periodic record window's state of a new design at the reference cut and at the
   doubled sampling of the accelerometer's Richardson step (A active samples of N, n complex
   modes): :func:`periodic_coordinates` (O(n A)) side by side with the sum of the force with
   the periodic impulse response it replaced (O(n A^2), the same numbers); printed, no target;
5. the accelerometer's Richardson step of a new design (the record window at twice the
   samples): :func:`record_tip_acceleration` (the tool tip's z acceleration alone) side by side
   with the whole periodic response it replaced (every body's motion, the static correction,
   the force; the same peak to 1e-12); printed, no target;
6. a whole-workpiece time-domain simulation at the reference process; target <= 3 s;
7. peak memory (VmHWM, the resident-set high-water mark of its own address space) of a fresh
   sweep worker that evaluates a few designs and processes; target <= 250 MiB.

CPU time of this process (``time.process_time``; the machine is shared, wall time would count
the other sessions), medians; BLAS single-threaded (small matrices); evaluation cache off.
"""

import os
import statistics
import subprocess
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits

os.environ["UFMT_CACHE_DIR"] = ""  # every evaluation computes (the cache would answer)

import ufmt  # noqa: E402
from ufmt.machining.cut_geometry import cut_geometry  # noqa: E402
from ufmt.machining.cutting import DEFAULT_COEFFICIENTS, FORCE_PARTS  # noqa: E402
from ufmt.machining.damping import damped_modes  # noqa: E402
from ufmt.machining.instruments import AccelerometerChain, accelerometer_peak  # noqa: E402
from ufmt.machining.modal import modal_basis  # noqa: E402
from ufmt.machining.periodic_path import (  # noqa: E402
    periodic_coordinates,
    periodic_response,
    record_tip_acceleration,
)
from ufmt.machining.process import Process  # noqa: E402
from ufmt.machining.recurrence import DEFAULT_ZETA, modal_damping, pole_recurrence  # noqa: E402
from ufmt.machining.static import residual_flexibility  # noqa: E402
from ufmt.model.load import load_model, packaged_path  # noqa: E402
from ufmt.model.machine import machine_of  # noqa: E402
from ufmt.simulate import simulate  # noqa: E402

REFERENCE = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
DESIGN = "head_radial_stiffness_N_m"
WORKER_DESIGNS = 6  # designs x 2 processes in the memory measurement

WORKER = f"""
import os
import numpy as np
os.environ["UFMT_CACHE_DIR"] = ""
import ufmt
rng = np.random.default_rng(1)
for i in range({WORKER_DESIGNS}):
    design = {{"{DESIGN}": 10 ** rng.uniform(8.0, 8.6)}}
    for rpm in (250.0, 350.0):
        assert ufmt.evaluate(design, {{"rpm": rpm}})["status"] == "ok"
print(open("/proc/self/status").read().split("VmHWM:")[1].split()[0])  # peak RSS [KiB]
"""


def median_ms(fn, repeats) -> float:
    times = []
    for i in range(repeats):
        t0 = time.process_time()
        fn(i)
        times.append(time.process_time() - t0)
    return 1e3 * statistics.median(times)


def impulse_sum(recurrence, force, active):
    """The baseline (the formula periodic_coordinates replaced): over the run of A active
    samples, the force summed with the periodic impulse response as one (n, A, A) tensor
    product; after it, the free decay."""
    n = active.size
    first = int(np.flatnonzero(active & ~np.roll(active, 1))[0])
    a = int(np.count_nonzero(active))
    run = (first + np.arange(a)) % n
    lags, pairs = np.unique(
        np.mod(np.subtract.outer(np.arange(a), np.arange(a)), n), return_inverse=True
    )
    f = force[:, run]
    inside = np.einsum("sjm,sm->sj", recurrence.impulse(lags)[:, pairs.reshape(a, a)], f)
    after = recurrence.e * inside[:, -1] + recurrence.b1 * f[:, -1]
    x = np.empty(force.shape, complex)
    x[:, :a] = inside
    np.multiply(recurrence.powers[:, : n - a], after[:, None], out=x[:, a:])
    return np.roll(x, first, axis=1)


def periodic_state_ms(model, reference, repeats=5) -> list[tuple[int, int, int, float, float]]:
    """(A, N, n, ms O(n A), ms O(n A^2)) of a new design's record window at the reference cut
    and at twice its sampling, the two timed alternately; asserts equal results."""
    h31 = model.hinge("h31")
    design = model.with_hinge("h31", stiffness=h31.stiffness * 1.37)
    basis = modal_basis(design)
    modes = damped_modes(basis, DEFAULT_ZETA)
    machine = machine_of(design)
    n_phi = simulate(design, reference, basis=basis).samples_per_rev
    rows = []
    for n in (n_phi, 2 * n_phi):
        geo = cut_geometry(basis, machine, n_phi=n, table_rows=8)
        rec = pole_recurrence(modes.poles, 1 / (reference.spindle_hz * n), n)
        rng = np.random.default_rng(n)
        force = np.where(geo.active, rng.normal(size=(modes.poles.size, n)), 0.0)
        fast, slow = [], []
        for _ in range(repeats):
            for fn, times in ((periodic_coordinates, fast), (impulse_sum, slow)):
                t0 = time.process_time()
                z = fn(rec, force, geo.active)
                times.append(time.process_time() - t0)
            scale = np.abs(z).max()
            assert np.abs(periodic_coordinates(rec, force, geo.active) - z).max() < 1e-12 * scale
        a = int(np.count_nonzero(geo.active))
        ms = (1e3 * statistics.median(fast), 1e3 * statistics.median(slow))
        rows.append((a, n, modes.poles.size, *ms))
    return rows


def step_peak(basis, machine, n, zeta, process, residual, alone: bool) -> float:
    """The accelerometer's peak [m/s^2] of the periodic record at n samples per revolution:
    of the tool tip's z acceleration alone, or of the whole periodic response (``residual``
    its static correction)."""
    geos = [
        cut_geometry(basis, machine, DEFAULT_COEFFICIENTS, n, 8, part, residual)
        for part in FORCE_PARTS
    ]
    if alone:
        t, acc = record_tip_acceleration(geos, process, zeta, machine.force_scale)
    else:
        response = periodic_response(geos, process, zeta, machine.force_scale)
        t, acc = response.t, response.tip_acc[:, 2]
    return accelerometer_peak(t, acc, 1, AccelerometerChain.of(machine))


def accelerometer_step_ms(designs, bases, reference) -> tuple[int, float, float]:
    """(N, ms record alone, ms whole response) of the Richardson step's fine record of each
    new design (every mode below the cutoff, as the run keeps them), the two timed
    alternately, each on its own uncached geometries; asserts equal peaks."""
    alone, whole = [], []
    for i, (design, basis) in enumerate(zip(designs, bases, strict=True)):
        result = simulate(design, reference, basis=basis)  # the run: modes and caches as then
        assert result.n_modes == basis.n_modes
        machine, n = result.machine, 2 * result.samples_per_rev
        zeta = modal_damping(machine.modal_damping_ratio, basis.n_modes)
        residual = residual_flexibility(design, basis, machine)
        peaks = []
        order = ((True, None, alone), (False, residual, whole))
        for record_alone, res, times in order if i % 2 == 0 else order[::-1]:
            t0 = time.process_time()
            peaks.append(step_peak(basis, machine, n, zeta, reference, res, record_alone))
            times.append(time.process_time() - t0)
        assert abs(peaks[0] - peaks[1]) <= 1e-12 * abs(peaks[0])
    return n, 1e3 * statistics.median(alone), 1e3 * statistics.median(whole)


def measure() -> dict[str, float]:
    """The figures of this benchmark (ms, s, MiB)."""
    model = load_model(packaged_path())
    rng = np.random.default_rng(0)
    ufmt.evaluate({}, REFERENCE)  # the calibrated design's basis and geometry

    def new_process(i):
        process = {
            "rpm": rng.uniform(200, 400),
            "feed_mm_min": rng.uniform(4, 16),
            "depth_um": rng.uniform(2, 8),
        }
        assert ufmt.evaluate({}, process)["status"] == "ok"

    def new_design(i):
        assert ufmt.evaluate({DESIGN: 10 ** rng.uniform(8.0, 8.6)}, REFERENCE)["status"] == "ok"

    machine = machine_of(model)
    basis = modal_basis(model)
    h31 = model.hinge("h31")

    def static(i):
        design = model.with_hinge("h31", stiffness=h31.stiffness * 10 ** rng.uniform(-0.3, 0.3))
        residual_flexibility(design, basis, machine)

    designs = [
        model.with_hinge("h31", stiffness=h31.stiffness * 10 ** rng.uniform(-0.3, 0.3))
        for _ in range(9)
    ]
    bases = [modal_basis(d) for d in designs]  # the engine's part, outside the clock
    reference = Process(**REFERENCE)

    def machining(i):  # static correction, geometry, response and surfaces of a new design
        simulate(designs[i], reference, basis=bases[i])

    with threadpool_limits(limits=1, user_api="blas"):
        out = {
            "process_ms": median_ms(new_process, 61),
            "design_ms": median_ms(new_design, 9),
            "static_ms": median_ms(static, 21),
            "machining_ms": median_ms(machining, len(designs)),
        }
        out["periodic_state"] = periodic_state_ms(model, reference)
        out["accelerometer_step"] = accelerometer_step_ms(designs, bases, reference)
        out["time_s"] = 1e-3 * median_ms(
            lambda i: simulate(model, reference, basis=basis, method="time"), 3
        )
    worker = subprocess.run(
        [sys.executable, "-c", WORKER], capture_output=True, text=True, check=True
    )
    out["worker_mib"] = int(worker.stdout.split()[-1]) / 1024
    return out


def main() -> None:
    m = measure()
    print(f"evaluate, new process on a known design: {m['process_ms']:8.2f} ms CPU  (target <= 5)")
    print(f"evaluate, new design (modes + all):      {m['design_ms']:8.1f} ms CPU  (target <= 50)")
    print(f"  of it all but the modal solve:         {m['machining_ms']:8.1f} ms CPU")
    print(f"  static correction of a new design:     {m['static_ms']:8.2f} ms CPU")
    for a, n, modes, fast, slow in m["periodic_state"]:
        print(
            f"periodic_coordinates at A = {a} active samples of N = {n}, {modes} modes: "
            f"{fast:.2f} ms CPU; the impulse sum O(n A^2): {slow:.1f} ms ({slow / fast:.0f}x)"
        )
    n, alone, whole = m["accelerometer_step"]
    print(
        f"accelerometer step's record at N = {n}, new design: {alone:.1f} ms CPU; "
        f"the whole periodic response: {whole:.1f} ms ({whole / alone:.1f}x)"
    )
    print(f"whole workpiece, time domain:            {m['time_s']:8.2f} s  CPU  (target <= 3)")
    print(
        f"sweep worker peak memory ({WORKER_DESIGNS} designs x 2):  "
        f"{m['worker_mib']:8.0f} MiB      (target <= 250)"
    )


if __name__ == "__main__":
    main()
