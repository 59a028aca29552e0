"""Study throughput: new-design points per second of a stiffness sweep on 2 workers, with the
workers' chunks evaluated as one batch (``ufmt.evaluate_batch``) and point by point.

Every point is a new design (the head's angular air-bearing stiffness changes), so each costs
a full modal basis (every mode below the default cutoff), a periodic response and a surface:
the expensive case. Each measurement is a fresh process (``python bench_studies.py --child``)
that runs a warm-up sweep on other designs (starting the workers, importing the physics) and
then the timed sweep, with the disk cache off (``UFMT_CACHE_DIR=""``), a fresh results
directory and the C heap's thresholds of :mod:`ufmt.allocator` (as environment variables, so
that another revision's processes get them too). The variants run interleaved, round after
round, and each reports its best round (the machine is shared). ``--against DIR`` adds a
checkout of another revision (e.g. main), run by the same harness on its own code, and prints
the ratio. Target: >= 4x the new-design points per second of the code before batching (main),
at equal jobs.

``--synthetic`` times instead a stand-in function that burns 20 ms of CPU per point without
the physics, with --jobs 1 and 2: the runner's own overhead and its parallel speed-up (target
>= 1.7x on 2 cores).

Run: ``python benchmarks/bench_studies.py [--points N] [--rounds R] [--against DIR]
[--synthetic]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
REPO = HERE.parents[1]
SYNTHETIC_SECONDS = 0.02  # CPU time per point of the stand-in [s]
TARGET_SPEEDUP = 1.7  # jobs 2 / jobs 1, synthetic
TARGET_AGAINST = 4.0  # batched / the other revision, new designs per second
JOBS = 2
# glibc's heap thresholds as ufmt.allocator sets them in ufmt's own processes, given to every
# variant's processes (the other revision's too: its best, not its defaults)
HEAP = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(256 << 20)}

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


def evaluate_one_by_one(design, process, model=None, **kwargs):
    """``ufmt.evaluate`` under another name: the runner then evaluates its chunks point by
    point (only ``ufmt.evaluate`` itself has a batched form)."""
    from ufmt.evaluate import evaluate

    return evaluate(design, process, model, **kwargs)


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


def child(function: str, jobs: int, points: int) -> None:
    """One measurement in this process: a warm-up sweep on other designs, then the timed one;
    prints the timed run's seconds."""
    with tempfile.TemporaryDirectory() as tmp:
        _time_run(function, jobs, 2 * jobs, 0.3, 0.35, Path(tmp))  # warm-up: other designs
        print(_time_run(function, jobs, points, 0.5, 5.0, Path(tmp)))


def measure(repo: Path, function: str, jobs: int, points: int) -> float:
    """Points per second of one child process running ``repo``'s code."""
    env = {**os.environ, "UFMT_CACHE_DIR": "", "PYTHONPATH": str(repo), **HEAP}
    command = [sys.executable, str(HERE), "--child", function, str(jobs), str(points)]
    done = subprocess.run(command, cwd=repo, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"bench child failed ({repo}, {function}):\n{done.stderr[-2000:]}")
    return points / float(done.stdout.split()[-1])


def compare(points: int, rounds: int, against: Path | None) -> dict[str, float]:
    """Best points per second of each variant over ``rounds`` interleaved rounds."""
    variants = {
        "batched": (REPO, "ufmt.evaluate:evaluate"),
        "one by one": (REPO, f"{HERE}:evaluate_one_by_one"),
    }
    if against is not None:
        variants[f"{against}"] = (against, "ufmt.evaluate:evaluate")
    best = dict.fromkeys(variants, 0.0)
    for k in range(rounds):
        for label, (repo, function) in variants.items():
            rate = measure(repo, function, JOBS, points)
            best[label] = max(best[label], rate)
            print(f"  round {k + 1}: {label:>12}: {rate:.2f} new-design points/s", flush=True)
    return best


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=24, help="points per timed run")
    parser.add_argument("--rounds", type=int, default=2, help="interleaved rounds")
    parser.add_argument("--against", type=Path, help="checkout of another revision to compare")
    parser.add_argument("--synthetic", action="store_true", help="stand-in function, no physics")
    parser.add_argument("--child", nargs=3, metavar=("FUNCTION", "JOBS", "POINTS"))
    args = parser.parse_args(argv)
    if args.child:
        function, jobs, points = args.child
        child(function, int(jobs), int(points))
    elif args.synthetic:
        _synthetic(args.points)
    else:
        _throughput(args)


def _throughput(args: argparse.Namespace) -> None:
    print(
        f"study sweep throughput (ufmt.evaluate, a new design per point, full basis; {JOBS}"
        f" workers; {args.points} points per run; disk cache off; {os.cpu_count()} cores;"
        f" best of {args.rounds} interleaved rounds)"
    )
    best = compare(args.points, args.rounds, args.against)
    batched, single = best["batched"], best["one by one"]
    print(f"  batched {batched:.2f} points/s, one by one {single:.2f}: {batched / single:.2f}x")
    if args.against is not None:
        other = best[f"{args.against}"]
        ratio = batched / other
        verdict = "meets" if ratio >= TARGET_AGAINST else "MISSES"
        print(f"  batched / {args.against}: {ratio:.2f}x ({verdict} target >= {TARGET_AGAINST}x)")


def _synthetic(points: int) -> None:
    print(f"study sweep throughput (synthetic 20 ms/point function; {os.cpu_count()} cores)")
    function = f"{HERE}:synthetic_pv"
    rates = {jobs: measure(REPO, function, jobs, points) for jobs in (1, 2)}
    for jobs, rate in rates.items():
        print(f"  jobs {jobs}: {rate:.1f} points/s")
    speedup = rates[2] / rates[1]
    verdict = "meets" if speedup >= TARGET_SPEEDUP else "MISSES"
    print(f"  speed-up jobs 2 / jobs 1: {speedup:.2f}x ({verdict} target >= {TARGET_SPEEDUP}x)")


if __name__ == "__main__":
    main()
