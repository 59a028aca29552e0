"""Side by side: the cost of ``ufmt.evaluate`` in two checkouts of ufmt, interleaved.

    python benchmarks/compare_checkouts.py BEFORE_DIR AFTER_DIR [--designs 9]

One worker process per checkout (its own ``PYTHONPATH``, one BLAS thread, the evaluation cache
off), each given the same work in turn, the order alternating: per step a new design of the
packaged UFMT at the reference cut (``eval``: modal basis and all), the machining part of a new
design on a basis solved outside the clock (``sim``: ``simulate``), and a new process on the
calibrated design (``proc``). Prints the medians of ``time.process_time`` [ms] of each kind in
each checkout, their ratio, and the largest relative difference of the reported
tip_acc_measured_mm_s2 and pv_nm between the two (the checkouts should agree to rounding).
"""

import argparse
import os
import statistics
import subprocess
import sys

WORKER = """
import importlib, os, sys, time
os.environ["UFMT_CACHE_DIR"] = ""
from threadpoolctl import threadpool_limits
threadpool_limits(1)
from ufmt.design import apply_design
from ufmt.evaluate import evaluate
from ufmt.machining.modal import modal_basis
from ufmt.machining.process import Process
from ufmt.model.load import load_model, packaged_path
simulation = importlib.import_module("ufmt.simulate")
model = load_model(packaged_path())
name = "head_angular_stiffness_Nm_rad"
nominal = model.hinge(model.design[name].hinge).rotational_stiffness[0]
reference = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
evaluate({name: 0.8 * nominal}, reference, model)  # imports and machine-only caches
evaluate({}, reference, model)  # the calibrated design's basis
for line in sys.stdin:
    kind, i = line.split()
    i = int(i)
    if kind == "eval":
        t0 = time.process_time()
        metrics = evaluate({name: nominal * (1 + 0.013 * i)}, reference, model)
    elif kind == "sim":
        design = apply_design(model, {name: nominal * (1.5 + 0.013 * i)})
        basis = modal_basis(design)
        t0 = time.process_time()
        metrics = simulation.simulate(design, Process(**reference), basis=basis).metrics
    else:
        process = {"rpm": 200 + 15 * i, "feed_mm_min": 5 + i, "depth_um": 2 + 0.5 * i}
        t0 = time.process_time()
        metrics = evaluate({}, process, model)
    ms = 1e3 * (time.process_time() - t0)
    print(ms, metrics["tip_acc_measured_mm_s2"], metrics["pv_nm"], flush=True)
"""
KINDS = ("eval", "sim", "proc")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--designs", type=int, default=9)
    args = parser.parse_args()
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    workers = {
        root: subprocess.Popen(
            [sys.executable, "-c", WORKER],
            cwd=root,
            env={**env, "PYTHONPATH": root},
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        for root in (args.before, args.after)
    }
    times = {(root, kind): [] for root in workers for kind in KINDS}
    values = {(root, kind): [] for root in workers for kind in KINDS}
    for i in range(args.designs):
        for kind in KINDS:
            for root in list(workers)[:: 1 if i % 2 == 0 else -1]:
                worker = workers[root]
                worker.stdin.write(f"{kind} {i}\n")
                worker.stdin.flush()
                ms, acc, pv = map(float, worker.stdout.readline().split())
                times[(root, kind)].append(ms)
                values[(root, kind)].append((acc, pv))
    for worker in workers.values():
        worker.stdin.close()
        worker.wait()
    for kind in KINDS:
        before, after = (statistics.median(times[(root, kind)]) for root in workers)
        pairs = zip(values[(args.before, kind)], values[(args.after, kind)], strict=True)
        moved = max(abs(a - b) / abs(a) for x, y in pairs for a, b in zip(x, y, strict=True))
        print(
            f"{kind:4s}: {before:7.1f} ms before, {after:7.1f} ms after ({before / after:.2f}x); "
            f"largest relative difference of the metrics {moved:.1e}"
        )


if __name__ == "__main__":
    main()
