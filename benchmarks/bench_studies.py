"""Study throughput: points per second of a stiffness sweep with --jobs 1 and --jobs 2.

Every point is a new design (the head's angular air-bearing stiffness changes), so each costs
a modal basis, a periodic response and a surface: the expensive case. The disk cache is off
(``UFMT_CACHE_DIR=""``), each run writes to a fresh results directory, and a warm-up run on
other designs first starts the workers and imports the physics, so the timed runs measure
steady throughput. Target: speed-up >= 1.7x on 2 cores.

``--synthetic`` times a stand-in function that burns the same CPU time per point without
the physics, to separate the runner's overhead from the model's cost.

Run: ``python benchmarks/bench_studies.py [--points N] [--synthetic]``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

SYNTHETIC_SECONDS = 0.02  # CPU time per point of the stand-in [s], the evaluate target
TARGET_SPEEDUP = 1.7

STUDY = """\
kind = "sweep"
name = "{name}"
function = "{function}"
[base]
rpm = 300.0
feed_mm_min = 15.0
depth_um = 4.0
[[axis]]
parameter = "head_angular_stiffness_Nm_rad"
{source} = [{low}, {high}]
n = {n}
spacing = "log"
"""


def synthetic_pv(design, process, model=None):
    """Stand-in study function: SYNTHETIC_SECONDS of single-threaded numpy work."""
    rng = np.random.default_rng(int(design["head_angular_stiffness_Nm_rad"]) % 2**32)
    a = rng.standard_normal((64, 64))
    end = time.process_time() + SYNTHETIC_SECONDS
    while time.process_time() < end:
        a = np.tanh(a @ a.T / 64.0)
    return {"pv_nm": float(np.abs(a).sum())}


def _time_run(function: str, jobs: int, n: int, low: float, high: float, root: Path) -> float:
    """Wall time [s] of one sweep over ``n`` designs, stiffness ``low``-``high`` x calibrated
    (x 1e6 N m/rad for the synthetic function, which needs no model)."""
    from ufmt.studies.load import parse_study
    from ufmt.studies.parallel import Execution
    from ufmt.studies.runner import run_study

    name = f"bench-j{jobs}-{low:g}"
    path = root / f"{name}.toml"
    synthetic = function.endswith(":synthetic_pv")
    source, scale = ("range", 1e6) if synthetic else ("scale", 1.0)
    text = STUDY.format(
        name=name, function=function, source=source, low=low * scale, high=high * scale, n=n
    )
    study = parse_study(text, path)
    start = time.perf_counter()
    run_study(study, Execution(jobs=jobs), results=root / "results", progress=False, plots=False)
    return time.perf_counter() - start


def bench(points: int, synthetic: bool) -> dict[int, float]:
    """Points per second for jobs 1 and 2 (after a warm-up run per setting)."""
    function = f"{Path(__file__).resolve()}:synthetic_pv" if synthetic else "ufmt.evaluate:evaluate"
    rates = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for jobs in (1, 2):
            _time_run(function, jobs, 4 * jobs, 0.3, 0.35, root)  # warm-up: other designs
            seconds = _time_run(function, jobs, points, 0.5, 5.0, root)
            rates[jobs] = points / seconds
            print(f"  jobs {jobs}: {points} points in {seconds:.2f} s = {rates[jobs]:.1f} points/s")
    return rates


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=60, help="points per timed run")
    parser.add_argument("--synthetic", action="store_true", help="stand-in function, no physics")
    args = parser.parse_args(argv)
    previous = os.environ.get("UFMT_CACHE_DIR")
    os.environ["UFMT_CACHE_DIR"] = ""  # no disk cache, inherited by the workers started below
    try:
        _report(args)
    finally:
        if previous is None:
            del os.environ["UFMT_CACHE_DIR"]
        else:
            os.environ["UFMT_CACHE_DIR"] = previous


def _report(args: argparse.Namespace) -> None:
    what = (
        "synthetic 20 ms/point function"
        if args.synthetic
        else "ufmt.evaluate, new design per point"
    )
    print(f"study sweep throughput ({what}; disk cache off; {os.cpu_count()} cores)")
    rates = bench(args.points, args.synthetic)
    speedup = rates[2] / rates[1]
    verdict = "meets" if speedup >= TARGET_SPEEDUP else "MISSES"
    print(f"  speed-up jobs 2 / jobs 1: {speedup:.2f}x ({verdict} target >= {TARGET_SPEEDUP}x)")


if __name__ == "__main__":
    main()
