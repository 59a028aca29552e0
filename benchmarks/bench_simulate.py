"""Benchmark (issues 4, 8, 9): PV evaluation cost on the packaged UFMT.

1. a new design: modal basis (MSTMM, 30 modes) + static correction + periodic response of both
   force parts + surfaces of every source; target <= 50 ms (issue 9);
2. a new process on a known design: periodic response + surfaces; target <= 5 ms;
3. the static correction alone (assembled static solve of one design);
4. a whole-workpiece time-domain simulation at the reference process; target <= 3 s.
Medians; BLAS single-threaded (small matrices).
"""

import statistics
import time

import numpy as np
from threadpoolctl import threadpool_limits

from ufmt.machining.modal import modal_basis
from ufmt.machining.process import Process
from ufmt.machining.static import residual_flexibility
from ufmt.model.load import load_model, packaged_path
from ufmt.model.machine import machine_of
from ufmt.simulate import simulate


def median_ms(fn, repeats) -> float:
    times = []
    for i in range(repeats):
        t0 = time.perf_counter()
        fn(i)
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main() -> None:
    model = load_model(packaged_path())
    h31 = model.hinge("h31")
    rng = np.random.default_rng(0)
    reference = Process(300.0, 15.0, 4.0)

    def new_design(i):
        factor = 10 ** rng.uniform(-0.3, 0.3)
        m = model.with_hinge("h31", stiffness=h31.stiffness * factor)
        simulate(m, reference, basis=modal_basis(m))

    basis = modal_basis(model)
    simulate(model, reference, basis=basis)  # geometry set-up of this basis

    def new_process(i):
        p = Process(rng.uniform(200, 400), rng.uniform(4, 16), rng.uniform(2, 8))
        simulate(model, p, basis=basis)

    with threadpool_limits(limits=1, user_api="blas"):
        t_design = median_ms(new_design, 7)
        t_process = median_ms(new_process, 41)
        t_static = median_ms(lambda i: residual_flexibility(model, basis, machine_of(model)), 7)
        t0 = time.perf_counter()
        simulate(model, reference, basis=basis, method="time")
        t_time = time.perf_counter() - t0
    print(f"new design (modes + response + surface): {t_design:9.1f} ms median  (target <= 50)")
    print(f"new process on a known design:           {t_process:9.1f} ms median  (target <= 5)")
    print(f"static correction of one design:         {t_static:9.1f} ms median")
    print(f"whole workpiece, time domain:            {t_time:9.2f} s          (target <= 3)")


if __name__ == "__main__":
    main()
