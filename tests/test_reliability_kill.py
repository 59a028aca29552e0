"""Reliability under kill -9: no worker outlives the main process (the files a kill leaves
are tested in test_files.py).

Oracle: the process table (/proc: a pid that is gone, or a zombie waiting to be reaped, has
ended), within a bound far below the life of an orphan (its 120 s task).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import joblib
import pytest
from synthetic import child_pids, process_running, still_running

HERE = Path(__file__).resolve()
REPO = HERE.parents[1]
ENDS_WITHIN_S = 30.0  # a liveness bound, far below what an orphan lives (its 120 s task)

pytestmark = pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs /proc")


def _python(code: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code)],
        cwd=REPO,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )


def _kill_and_wait_for(proc: subprocess.Popen, orphans: list[int]) -> list[int]:
    """kill -9 ``proc``; the ``orphans`` still alive after ENDS_WITHIN_S (killed then)."""
    proc.kill()
    proc.wait()
    left = still_running(orphans, ENDS_WITHIN_S)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    return left


# ---------------------------------------------------------------------------------------------
# workers die with the main process


def test_loky_workers_busy_in_a_point_end_when_the_main_process_is_killed():
    """The study pool's workers (``parallel_pool``, two loky workers) each busy in a 120 s
    task when the main process gets kill -9: every child of it ends."""
    proc = _python(
        """
        import time, joblib
        from ufmt.studies.parallel import Execution, parallel_pool
        with parallel_pool(Execution(jobs=2)) as parallel:
            for _ in parallel(joblib.delayed(time.sleep)(0.01) for _ in range(4)):
                pass
            print("ready", flush=True)
            for _ in parallel(joblib.delayed(time.sleep)(120) for _ in range(2)):
                pass
        """
    )
    assert proc.stdout.readline().strip() == "ready"
    time.sleep(1.0)  # the two long tasks reach the workers
    children = child_pids(proc.pid)
    assert len(children) >= 2, "no worker processes"
    assert _kill_and_wait_for(proc, children) == []


def test_the_watchdog_ends_a_process_whose_parent_died():
    """Where the kernel cannot signal a parent's death, ``watch_parent`` sees the parent
    change: a grandchild watching its parent ends when that parent gets kill -9."""
    grandchild = (
        "import os, time; from ufmt.studies.parallel import watch_parent;"
        " watch_parent(os.getppid(), 0.05); print('watching', flush=True); time.sleep(120)"
    )
    proc = _python(
        f"""
        import subprocess, sys, time
        child = subprocess.Popen([sys.executable, "-c", {grandchild!r}])
        print(child.pid, flush=True)
        time.sleep(120)
        """
    )
    pid = int(proc.stdout.readline())
    # the grandchild watches before the kill (a sleep here raced its import of ufmt on a
    # loaded machine: a parent killed first is never the one it watches)
    assert proc.stdout.readline().strip() == "watching"
    assert process_running(pid)
    assert _kill_and_wait_for(proc, [pid]) == []


@pytest.mark.slow
@pytest.mark.skipif(joblib.cpu_count() < 2, reason="--jobs 2 needs two cores")
def test_ufmt_run_workers_end_when_the_run_is_killed(tmp_path):
    """End to end: ``ufmt run --jobs 2`` killed with -9 mid-study leaves no process."""
    study = tmp_path / "orphans.toml"
    study.write_text(
        f'function = "{REPO / "tests" / "test_reliability.py"}:slow_line_pv"\n'
        'kind = "sweep"\n[[axis]]\nparameter = "rpm"\nrange = [200.0, 400.0]\nn = 60\n',
        encoding="utf-8",
    )
    results = tmp_path / "r"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    args = [sys.executable, "-m", "ufmt.cli", "run", str(study), "--jobs", "2"]
    args += ["--results", str(results), "--no-progress"]
    proc = subprocess.Popen(args, cwd=REPO, env=env, stderr=subprocess.DEVNULL)
    log = results / "orphans" / "points.csv"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and not (log.exists() and log.read_bytes().count(b"\n") > 3):
        time.sleep(0.05)
    children = child_pids(proc.pid)
    assert len(children) >= 2, "no worker processes"
    assert _kill_and_wait_for(proc, children) == []
