"""Parallel execution of a study's points: the worker function, the joblib pools (loky
processes or a dask.distributed cluster) and what a lost pool looks like.

One level of parallelism: the study's points are evaluated by the study function in joblib
workers, ``loky`` processes on this machine (default: one per core) or a dask.distributed
cluster through joblib's dask backend (``backend="dask"``; ``scheduler`` is the address of a
running scheduler, e.g. ``tcp://10.0.0.5:8786``; without one a local cluster with ``jobs``
worker processes is started). A task is a chunk of several points (:func:`chunk_size`), not
one point; ``ufmt.evaluate`` evaluates a chunk as one batch
(:func:`ufmt.evaluate.evaluate_each`: the new designs' modes in one solve). Each worker's
BLAS thread pools are limited to one thread with threadpoolctl: the model's matrices are small
(order ~70), so threaded BLAS only adds overhead (docs/benchmarks.md), and the cores are
better used by evaluating points side by side.

A loky worker ends when the main process dies, even by kill -9 (which runs no clean-up): on
Linux the kernel sends it SIGTERM (``prctl(PR_SET_PDEATHSIG)``, set by the worker initializer
:func:`exit_with_parent`); elsewhere a watchdog thread in the worker sees its parent change
(:func:`watch_parent`). Without either, an orphaned worker would finish its point and then wait
for loky's idle timeout (300 s). The kernel's signal follows the thread that started the
worker: a pool first used from a thread that then ends loses its workers (the run stops as a
lost pool, rows kept); ufmt starts its pools from the main thread.

The workers import this module only (the worker function is pickled by reference), so it
stays free of the study kinds and their plots.
"""

from __future__ import annotations

import ctypes
import dataclasses
import functools
import hashlib
import importlib
import importlib.util
import os
import re
import signal
import sys
import threading
import time
import warnings
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import CancelledError
from contextlib import contextmanager
from dataclasses import dataclass

import joblib
from joblib.externals.loky.process_executor import TerminatedWorkerError
from threadpoolctl import threadpool_limits

from ufmt.allocator import retain_freed_memory
from ufmt.errors import StudyError
from ufmt.evaluate_cache import CacheWarning, issued, not_shown
from ufmt.machining.validity import OutsideDomainError
from ufmt.model.schema import DesignParameter

BACKENDS = ("loky", "dask")
_SCHEDULER = re.compile(  # tcp://host:port, tls://..., ucx://..., host:port, inproc://...
    r"inproc://\S+|((tcp|tls|ucx)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):"
    r"(6553[0-5]|655[0-2][0-9]|65[0-4][0-9]{2}|6[0-4][0-9]{3}|[1-5][0-9]{4}|[1-9][0-9]{0,3})"
)
BLAS_THREADS = 1  # per worker (module docstring)
_BLAS_LIMITED_TASKS = 2  # per worker: before the first task and again once it loaded its libs
_PR_SET_PDEATHSIG = 1  # prctl option, <linux/prctl.h>
PARENT_POLL_S = 0.5  # [s] the watchdog's period where the kernel cannot signal a parent's death


def pool_lost_errors() -> tuple[type[BaseException], ...]:
    """Errors of a lost pool (a killed worker or dask scheduler): the run stops, rows are
    kept."""
    lost = [TerminatedWorkerError, CancelledError, ConnectionError, TimeoutError]
    if "distributed" in sys.modules:
        from distributed.comm.core import CommClosedError

        lost.append(CommClosedError)
    return tuple(lost)


# ---------------------------------------------------------------------------------------------
# the study function, called in the workers


@functools.cache
def resolve_function(ref: str):
    """The callable named by ``"module:attribute"`` or ``"/path/file.py:attribute"``.

    Raises
    ------
    StudyError
        The module or attribute cannot be imported.
    """
    module_name, _, attribute = ref.rpartition(":")
    try:
        if module_name.endswith(".py"):
            digest = hashlib.sha256(module_name.encode()).hexdigest()[:16]
            name = f"_ufmt_study_function_{digest}"
            spec = importlib.util.spec_from_file_location(name, module_name)
            if spec is None or spec.loader is None:
                raise ImportError(f"cannot load {module_name}")
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module  # lets the module's own functions pickle by reference
            spec.loader.exec_module(module)
        else:
            module = importlib.import_module(module_name)
        function = getattr(module, attribute)
    except (ImportError, OSError, AttributeError) as exc:
        raise StudyError(f"function {ref!r}: cannot import: {exc}") from None
    if not callable(function):
        raise StudyError(f"function {ref!r}: not callable")
    return function


#: Study functions with a batched form, by (module, name): a function of (designs,
#: processes, model) giving per point the record or the exception the function would give.
BATCHED = {("ufmt.evaluate", "evaluate"): "ufmt.evaluate:evaluate_each"}
MAX_CHUNK = 32  # points per task at most (a task's points are lost if the run is killed)
CHUNKS_PER_WORKER = 4  # tasks per worker at least, while chunks stay under MAX_CHUNK

_tasks_done = 0


def chunk_size(points: int, jobs: int) -> int:
    """Points per task for ``points`` points on ``jobs`` workers: each worker gets about
    CHUNKS_PER_WORKER tasks (the load stays balanced), none over MAX_CHUNK points."""
    return max(1, min(MAX_CHUNK, -(-points // (CHUNKS_PER_WORKER * jobs))))


def evaluate_chunk(
    positions: Sequence[int],
    ref: str,
    points: Sequence[tuple[Mapping[str, float], Mapping[str, float]]],
    model: str | None,
    parameters: Mapping[str, DesignParameter] | None = None,
) -> list[tuple[int, dict, float, list[str]]]:
    """Run the study function on a chunk of (design, process) points in a worker: per point
    (position, record, seconds, cache warnings) (seconds: the chunk's time shared equally;
    the main process reports each cache warning once).

    A function in :data:`BATCHED` (``ufmt.evaluate``) evaluates the chunk in one call of its
    batched form, any other point by point. ``parameters`` (the study file's own ``[design]``
    declarations) is passed to the function as a keyword only when the study declares any.
    Never raises: an exception of the function becomes that point's record with status
    "error" ("invalid" outside the validity domain).
    """
    global _tasks_done
    if _tasks_done < _BLAS_LIMITED_TASKS:
        threadpool_limits(limits=BLAS_THREADS)
        _tasks_done += 1
    start = time.perf_counter()
    extra = {"parameters": dict(parameters)} if parameters else {}
    before = issued()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CacheWarning)
        records = _records(ref, points, model, extra)
    notes = [str(w.message) for w in caught if issubclass(w.category, CacheWarning)]
    not_shown(set(notes) - before)  # one job: this is the main process; its journal shows them
    seconds = (time.perf_counter() - start) / max(len(points), 1)
    return [
        (position, record, seconds, notes if i == 0 else [])
        for i, (position, record) in enumerate(zip(positions, records, strict=True))
    ]


def _records(ref: str, points, model, extra) -> list[dict]:
    """The study function's record of each point (:func:`evaluate_chunk`)."""
    try:
        function = resolve_function(ref)
    except StudyError as exc:  # every point's record says why
        return [_record(functools.partial(_given, exc)) for _ in points]
    name = (getattr(function, "__module__", None), getattr(function, "__name__", None))
    batched = BATCHED.get(name)
    if batched is not None and len(points) > 1:
        designs, processes = [dict(d) for d, _ in points], [dict(p) for _, p in points]
        try:
            outcomes = resolve_function(batched)(designs, processes, model, **extra)
        except Exception:  # not a point's outcome: each point runs on its own below
            outcomes = None
        if outcomes is not None:
            return [_record(functools.partial(_given, outcome)) for outcome in outcomes]
    return [
        _record(functools.partial(function, dict(design), dict(process), model, **extra))
        for design, process in points
    ]


def _given(outcome):
    """``outcome``: a record, or an exception raised as the function would have raised it."""
    if isinstance(outcome, BaseException):
        raise outcome
    return outcome


def _record(call) -> dict:
    """The record ``call()`` returns for one point; an exception becomes status "error"."""
    try:
        record = call()
        if not isinstance(record, Mapping):
            raise TypeError(f"returned {type(record).__name__}, not a dict")
        record = dict(record)
        record.setdefault("status", "ok")
        record.setdefault("message", "")
    except OutsideDomainError as exc:  # outside the surface model's validity domain
        record = {"status": "invalid", "message": str(exc)}
    except Exception as exc:  # a failing point is recorded, not fatal
        record = {"status": "error", "message": f"{type(exc).__name__}: {exc}"}
    return record


# ---------------------------------------------------------------------------------------------
# workers that die with the main process


def start_worker(parent: int) -> None:
    """Worker initializer of the study pool: the heap kept for reuse
    (:func:`ufmt.allocator.retain_freed_memory`: each design reuses the last one's pages) and
    the worker tied to the main process (:func:`exit_with_parent`). Only in the pool's own
    workers: a caller's process (``--jobs 1``, a user's dask workers) keeps its heap."""
    retain_freed_memory()
    exit_with_parent(parent)


def exit_with_parent(parent: int) -> None:
    """Worker initializer: end this process with SIGTERM when process ``parent`` (the main
    process that started it) dies, by the kernel's parent-death signal on Linux, else by
    :func:`watch_parent`. A parent already gone before the signal was armed ends it now."""
    if not _arm_parent_death_signal():
        watch_parent(parent)
    if os.getppid() != parent:
        os.kill(os.getpid(), signal.SIGTERM)


def _arm_parent_death_signal() -> bool:
    """``prctl(PR_SET_PDEATHSIG, SIGTERM)``; False where there is no such call."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def watch_parent(parent: int, period: float = PARENT_POLL_S) -> threading.Thread:
    """A daemon thread sending SIGTERM to this process once its parent is no longer
    ``parent`` (an orphan is adopted by another process), checked every ``period`` [s]."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(period)
        os.kill(os.getpid(), signal.SIGTERM)

    thread = threading.Thread(target=watch, name="ufmt-parent-watchdog", daemon=True)
    thread.start()
    return thread


# ---------------------------------------------------------------------------------------------
# parallel pools


@dataclass(frozen=True)
class Execution:
    """How to evaluate: ``jobs`` workers on ``backend`` (loky | dask) at ``scheduler``."""

    jobs: int | None = None
    backend: str = "loky"
    scheduler: str | None = None

    def __post_init__(self):
        if self.backend not in BACKENDS:
            raise StudyError(f"--backend: unknown backend {self.backend!r} (loky or dask)")
        if self.jobs is not None and self.jobs < 1:
            raise StudyError(f"--jobs: {self.jobs} must be >= 1")
        if self.scheduler is not None and self.backend != "dask":
            raise StudyError("--scheduler: needs --backend dask")
        if self.scheduler is not None and not _SCHEDULER.fullmatch(self.scheduler):
            raise StudyError(
                f"--scheduler: {self.scheduler!r} is not a scheduler address"
                " (tcp://HOST:PORT, tls://HOST:PORT or HOST:PORT, port 1-65535)"
            )

    @property
    def n_jobs(self) -> int:
        """Number of workers (default: every core joblib sees)."""
        return self.jobs or joblib.cpu_count()


def within_cores(execution: Execution) -> Execution:
    """``execution`` with its local workers capped at the cores available (joblib's count:
    CPU affinity and cgroup quota included); a larger ``jobs`` gives one warning. A remote
    dask scheduler's cluster is not capped."""
    cores = joblib.cpu_count()
    if execution.jobs is None or execution.jobs <= cores or execution.scheduler is not None:
        return execution
    warnings.warn(
        f"--jobs {execution.jobs}: only {cores} cores are available; using {cores} workers",
        stacklevel=3,
    )
    return dataclasses.replace(execution, jobs=cores)


@contextmanager
def parallel_pool(execution: Execution) -> Iterator[joblib.Parallel]:
    """A reusable joblib Parallel returning results as they finish (unordered)."""
    if execution.backend == "loky":
        n = execution.n_jobs
        config = joblib.parallel_config(
            backend="loky",
            n_jobs=n,
            inner_max_num_threads=BLAS_THREADS,
            initializer=start_worker,
            initargs=(os.getpid(),),
        )
        with config:
            with joblib.Parallel(return_as="generator_unordered") as parallel:
                yield parallel
        return
    from dask.distributed import Client, LocalCluster

    cluster = None
    try:
        if execution.scheduler is None:
            cluster = LocalCluster(
                n_workers=execution.n_jobs, threads_per_worker=1, dashboard_address=None
            )
        client = Client(execution.scheduler or cluster, timeout=10)
    except (OSError, TimeoutError, ValueError) as exc:
        reason = " ".join(str(exc).split())[:200]
        raise StudyError(f"--scheduler {execution.scheduler}: cannot connect: {reason}") from None
    try:
        with joblib.parallel_config(backend="dask"):
            with joblib.Parallel(n_jobs=-1, return_as="generator_unordered") as parallel:
                yield parallel
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def stop_local_workers(execution: Execution) -> None:
    """Kill the loky worker processes (they would otherwise outlive an interrupted run)."""
    if execution.backend != "loky":
        return
    from joblib.externals.loky import get_reusable_executor

    get_reusable_executor().shutdown(wait=False, kill_workers=True)
