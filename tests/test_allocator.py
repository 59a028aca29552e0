"""The CLI's and the study workers' heap thresholds (ufmt.allocator): a design's solve reuses
the last design's pages. Oracle: the kernel's count of minor page faults (getrusage), a
property of the process, not a clock; the default process is the control."""

import subprocess
import sys

import pytest

FAULTS_PER_DESIGN = """
import resource, sys
from ufmt.allocator import retain_freed_memory
if sys.argv[1] == "retain" and not retain_freed_memory():
    sys.exit(print("no glibc mallopt here"))
from ufmt.design import apply_design, design_value
from ufmt.model.load import load_model
from ufmt.mstmm.solve import solve_modes
model = load_model(None)
value = design_value(model, "head_radial_stiffness_N_m")
designs = [apply_design(model, {"head_radial_stiffness_N_m": value * (1 + 1e-4) ** i})
           for i in range(1, 6)]
for d in designs[:2]:  # the first solves fill the caches and the heap
    solve_modes(d, fmax_hz=5000)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for d in designs[2:]:
    solve_modes(d, fmax_hz=5000)
print((resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 3)
"""


def _faults_per_design(mode: str) -> float:
    run = subprocess.run(
        [sys.executable, "-c", FAULTS_PER_DESIGN, mode], capture_output=True, text=True, check=True
    )
    if "no glibc" in run.stdout:
        pytest.skip(run.stdout.strip())
    return float(run.stdout.split()[-1])


def test_a_new_designs_solve_reuses_the_last_ones_pages():
    retained, default = _faults_per_design("retain"), _faults_per_design("default")
    assert default > 500  # the control: glibc's defaults fault a full basis's arrays in again
    assert retained < default / 20


def heap_retained(design, process, model=None):
    """Study function: pv_nm 1 where this process keeps freed heap (ufmt.allocator), else 0."""
    from ufmt.allocator import retain_freed_memory

    return {"pv_nm": float(retain_freed_memory.cache_info().currsize)}


RUN_IN_A_LIBRARY_CALLER = """
import sys
from pathlib import Path
import pandas as pd
from ufmt.allocator import retain_freed_memory
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study
study, results = Path(sys.argv[1]), Path(sys.argv[2])
for jobs in (1, 2):
    out = run_study(study, Execution(jobs=jobs), results=results / str(jobs), progress=False,
                    plots=False)
    print(jobs, pd.read_csv(out / "points.csv")["pv_nm"].tolist(),
          retain_freed_memory.cache_info().currsize)
"""


def test_only_the_pools_own_workers_change_their_heap(tmp_path):
    """A library caller's process keeps glibc's defaults (``--jobs 1`` runs the points there);
    the study pool's workers take the thresholds. Oracle: whether each process called it."""
    study = tmp_path / "heap.toml"
    study.write_text(
        f'function = "{__file__}:heap_retained"\nkind = "sweep"\n'
        '[[axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\nn = 4\n',
        encoding="utf-8",
    )
    run = subprocess.run(
        [sys.executable, "-c", RUN_IN_A_LIBRARY_CALLER, str(study), str(tmp_path / "r")],
        capture_output=True,
        text=True,
        check=True,
    )
    lines = run.stdout.splitlines()
    assert lines == ["1 [0.0, 0.0, 0.0, 0.0] 0", "2 [1.0, 1.0, 1.0, 1.0] 0"]
