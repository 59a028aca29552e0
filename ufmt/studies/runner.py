"""Run a study: fan the points out over joblib workers, append rows as they finish, resume.

Execution model (one level of parallelism): the study's points are evaluated by the study
function in joblib workers, ``loky`` processes on this machine (default: one per core) or a
dask.distributed cluster through joblib's dask backend (``backend="dask"``; ``scheduler`` is
the address of a running scheduler, e.g. ``tcp://10.0.0.5:8786``; without one a local cluster
with ``jobs`` worker processes is started). Each worker's BLAS thread pools are limited to one
thread with threadpoolctl: the model's matrices are small (order 66), so threaded BLAS only adds
overhead (measured on the UFMT: 1.0 s per modal basis with one thread, 1.3-2.5 s with two), and
the cores are better used by evaluating points side by side.

Every finished point is appended to ``results/<study>/points.csv`` and flushed at once, so a
killed run loses only the points in flight. A rerun of the same study (same study file, model
file, function and physics code, checked by a fingerprint in ``meta.json``) reads the rows back,
evaluates only the missing points and ends with the same table; with anything changed it starts
afresh. A point whose function fails is a row with ``status = "error"`` and the message; a
rerun tries failed points again (a failure may have been transient; a deterministic one gives
the same row).
"""

from __future__ import annotations

import fcntl
import functools
import hashlib
import importlib
import importlib.util
import json
import math
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
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
from joblib.externals.loky.process_executor import TerminatedWorkerError
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from ufmt import evaluate_cache
from ufmt.errors import StudyError
from ufmt.evaluate import (
    PROCESS_PARAMETERS,
    code_sha256,
    model_file,
    resolve_model,
    source_sha256,
)
from ufmt.evaluate_cache import CacheWarning
from ufmt.model.schema import DesignParameter
from ufmt.studies import outputs
from ufmt.studies.spec import Study, load_study

BACKENDS = ("loky", "dask")
_SCHEDULER = re.compile(  # tcp://host:port, tls://..., ucx://..., host:port, inproc://...
    r"inproc://\S+|((tcp|tls|ucx)://)?(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):"
    r"(6553[0-5]|655[0-2][0-9]|65[0-4][0-9]{2}|6[0-4][0-9]{3}|[1-5][0-9]{4}|[1-9][0-9]{0,3})"
)


def _pool_lost() -> tuple[type[BaseException], ...]:
    """Errors of a lost pool (a killed worker or dask scheduler): the run stops, rows are
    kept."""
    lost = [TerminatedWorkerError, CancelledError, ConnectionError, TimeoutError]
    if "distributed" in sys.modules:
        from distributed.comm.core import CommClosedError

        lost.append(CommClosedError)
    return tuple(lost)


BLAS_THREADS = 1  # per worker (module docstring)
_BLAS_LIMITED_TASKS = 2  # per worker: before the first task and again once it loaded its libs


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


_tasks_done = 0


def evaluate_point(
    position: int,
    ref: str,
    design: Mapping[str, float],
    process: Mapping[str, float],
    model: str | None,
    parameters: Mapping[str, DesignParameter] | None = None,
) -> tuple[int, dict, float]:
    """Run the study function on one point in a worker: (position, record, seconds).

    ``parameters`` (the study file's own ``[design]`` declarations) is passed to the function
    as a keyword only when the study declares any. Never raises: an exception of the function
    becomes a record with status "error".
    """
    global _tasks_done
    if _tasks_done < _BLAS_LIMITED_TASKS:
        threadpool_limits(limits=BLAS_THREADS)
        _tasks_done += 1
    start = time.perf_counter()
    extra = {"parameters": dict(parameters)} if parameters else {}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CacheWarning)  # the main process reported it
            record = resolve_function(ref)(dict(design), dict(process), model, **extra)
        if not isinstance(record, Mapping):
            raise TypeError(f"returned {type(record).__name__}, not a dict")
        record = dict(record)
        record.setdefault("status", "ok")
        record.setdefault("message", "")
    except Exception as exc:  # a failing point is recorded, not fatal
        record = {"status": "error", "message": f"{type(exc).__name__}: {exc}"}
    return position, record, time.perf_counter() - start


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


@contextmanager
def parallel_pool(execution: Execution) -> Iterator[joblib.Parallel]:
    """A reusable joblib Parallel returning results as they finish (unordered)."""
    if execution.backend == "loky":
        n = execution.n_jobs
        with joblib.parallel_config(backend="loky", n_jobs=n, inner_max_num_threads=BLAS_THREADS):
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


# ---------------------------------------------------------------------------------------------
# evaluating batches of points with resume


def point_key(group: str, values: Sequence[float]) -> str:
    """Identity of a point within a study: its group and the exact values of its parameters."""
    return json.dumps([group, [repr(float(v)) for v in values]])


class Evaluator:
    """Evaluates batches of points of one study, logging and reusing rows in ``points.csv``.

    Call :meth:`evaluate` with (group, point) pairs; each point maps parameters to values (the
    study's base is added). Rows come back in request order. A point already in the log (same
    group and parameter values) is reused, not recomputed.
    """

    def __init__(
        self,
        study: Study,
        out_dir: Path,
        baseline: Mapping[str, float],
        parallel: joblib.Parallel,
        progress: bool,
        planned: int | None = None,
    ):
        self.study = study
        self.parameters = list(study.parameters)
        self.baseline = dict(baseline)
        self.model = None if study.model is None else str(study.model)
        self._parallel = parallel
        self._log = outputs.PointLog(out_dir / outputs.POINTS, ["group", "index", *self.parameters])
        logged = {self._key(row["group"], row): row for row in self._log.read()}  # last wins
        self._rows = {k: row for k, row in logged.items() if row.get("status") != "error"}
        self._requested: dict[str, dict[str, int]] = {}
        self.points_new = 0
        self.points_reused = 0
        self.evaluation_s = 0.0
        self._bar = tqdm(
            total=planned or 0, desc=study.name, unit="pt", disable=not progress, dynamic_ncols=True
        )

    def _key(self, group: str, row: Mapping) -> str:
        return point_key(group, [row.get(p, math.nan) for p in self.parameters])

    def evaluate(self, items: Sequence[tuple[str, Mapping[str, float]]]) -> list[dict]:
        """Rows (inputs and outputs) of (group, point) pairs, in the order given."""
        rows, todo = [], {}
        for group, point in items:
            inputs = {**self.study.base, **{k: float(v) for k, v in point.items()}}
            row = {p: inputs.get(p, self.baseline.get(p, math.nan)) for p in self.parameters}
            key = self._key(group, row)
            requested = self._requested.setdefault(group, {})
            index = requested.setdefault(key, len(requested))
            rows.append(key)
            if key in self._rows:
                self._rows[key].update(group=group, index=index)
            elif key not in todo:
                todo[key] = ({"group": group, "index": index, **row}, inputs)
        self._bar.total = max(self._bar.total, self._bar.n + len(set(rows)))
        self._bar.update(len(set(rows)) - len(todo))
        self.points_reused += len(set(rows)) - len(todo)
        self._run(list(todo.items()))
        return [self._rows[key] for key in rows]

    def _run(self, todo: list) -> None:
        if not todo:
            return
        tasks = (
            joblib.delayed(evaluate_point)(
                position,
                self.study.function,
                {k: v for k, v in inputs.items() if k not in PROCESS_PARAMETERS},
                {k: v for k, v in inputs.items() if k in PROCESS_PARAMETERS},
                self.model,
                self.study.design,
            )
            for position, (_, (_, inputs)) in enumerate(todo)
        )
        try:
            for position, record, seconds in self._parallel(tasks):
                key, (row, _) = todo[position]
                outputs_ = {k: v for k, v in record.items() if k not in row}
                full = {**row, **outputs_}
                self._log.append(full)
                self._rows[key] = full
                self.points_new += 1
                self.evaluation_s += seconds
                self._bar.set_postfix_str(row["group"], refresh=False)
                self._bar.update(1)
        except _pool_lost() as exc:
            raise StudyError(
                f"{self.study.name}: the workers were lost ({type(exc).__name__}:"
                f" {' '.join(str(exc).split())[:200]}); {len(self._rows)} finished points are"
                " saved; rerun to resume"
            ) from None

    def values(self, group: str, points: Sequence[Mapping[str, float]], output="pv_nm"):
        """``output`` of each point as a float array (NaN where the point failed)."""
        rows = self.evaluate([(group, p) for p in points])
        return np.array([_number(r.get(output)) for r in rows])

    def table(self) -> pd.DataFrame:
        """Every row requested in this run, by group (in request order), then index."""
        keys = [k for requested in self._requested.values() for k in requested]
        return pd.DataFrame([self._rows[k] for k in keys], columns=self._log.columns)

    def complete(self) -> None:
        """Mark the progress bar finished (an optimiser may use less than its budget)."""
        self._bar.total = self._bar.n
        self._bar.refresh()

    def close(self) -> None:
        """Close the progress bar and the log."""
        self._bar.close()
        self._log.close()


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


# ---------------------------------------------------------------------------------------------
# a whole study


def fingerprint(study: Study) -> dict[str, str]:
    """Hashes that decide whether earlier rows of this study can be reused.

    They cover what changes results and nothing else: the parsed study file (not its comments
    or layout), the model's content (not its path or comments), the study function (its name,
    or the syntax tree of a ``file.py`` function) and the physics code's syntax trees. The
    same study in another clone or directory has the same fingerprint.
    """
    module, _, attribute = study.function.rpartition(":")
    function = f"{source_sha256(module)}:{attribute}" if module.endswith(".py") else study.function
    _, model_sha = resolve_model(model_file(study.model))
    parts = {
        "study_sha256": study.content_sha256,
        "function_sha256": hashlib.sha256(function.encode()).hexdigest(),
        "model_sha256": model_sha,
        "code_sha256": code_sha256(),
    }
    parts["fingerprint"] = hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
    return parts


def planned_points(study: Study) -> int | None:
    """Number of points the study will request (sweeps, grids, sensitivity: exact; optimisers:
    their evaluation budget, an upper bound), or None if unknown."""
    from ufmt.studies import optimise

    if study.kind in ("sweep", "grid"):
        return sum(math.prod(len(a.values) for a in g.axes) for g in study.groups)
    if study.kind == "sensitivity":
        from ufmt.studies.sensitivity import sample_count

        return sample_count(study)
    return optimise.budget(study)


def _analyse(study: Study, evaluator: Evaluator, baseline: dict, out_dir: Path) -> str:
    """Evaluate the study's points (or run its optimiser) and return the headline finding."""
    if study.kind in ("sweep", "grid"):
        evaluator.evaluate([(g.name, p) for g in study.groups for p in g.points(baseline)])
        return outputs.sweep_headline(evaluator.table(), study, baseline)
    if study.kind == "sensitivity":
        from ufmt.studies.sensitivity import run_sensitivity

        return run_sensitivity(study, evaluator, baseline, out_dir)
    from ufmt.studies import optimise

    if study.kind == "optimise-process":
        return optimise.run_optimise_process(study, evaluator, baseline, out_dir)
    return optimise.run_optimise_design(study, evaluator, baseline, out_dir)


def run_study(
    study: Study | str | Path,
    execution: Execution = Execution(),
    results: str | Path = "results",
    progress: bool = True,
    fresh: bool = False,
    plots: bool = True,
) -> Path:
    """Run (or resume) a study; returns its results directory ``results/<name>/``.

    Every input is checked before any point runs (the study file, its model, every design
    and process value it can set). The directory is locked while the run writes it: a second
    run of a study into the same directory stops at once with one line. SIGTERM (like
    Ctrl-C) stops the workers, keeps the finished rows and leaves ``meta.json`` with status
    "interrupted"; a rerun resumes.

    Parameters
    ----------
    study
        A parsed study or the path of a study file.
    execution
        Workers, backend and scheduler.
    results
        Root of the results tree; ``README.md`` there is regenerated.
    progress
        Show a tqdm progress bar on stderr.
    fresh
        Ignore rows of an earlier run.
    plots
        Draw the study's PNG plots.

    Raises
    ------
    StudyError
        A bad study, model, argument or results directory, another run holding the lock, or
        a lost worker pool (finished rows are kept).
    KeyboardInterrupt
        Ctrl-C or SIGTERM (finished rows are kept).
    """
    if not isinstance(study, Study):
        study = load_study(study)
    resolve_function(study.function)
    evaluate_cache.directory()  # an unusable cache: one warning here, not one per worker
    identity = fingerprint(study)
    out_dir = Path(results) / study.name
    with _locked(out_dir), _sigterm_interrupts():
        return _run_locked(study, execution, out_dir, identity, progress, fresh, plots)


def _run_locked(study, execution, out_dir, identity, progress, fresh, plots) -> Path:
    baseline = study.baseline
    previous = outputs.read_meta(out_dir)
    _check_same_study(study, out_dir, previous, identity, fresh)
    reuse = not fresh and previous.get("fingerprint") == identity["fingerprint"]
    if not reuse:
        for name in (*outputs.TABLES, outputs.META, *previous.get("plots", [])):
            (out_dir / name).unlink(missing_ok=True)
    meta = {
        "study": study.name,
        "kind": study.kind,
        "description": study.description,
        "study_file": str(study.path),
        "study_text": study.text,
        "function": study.function,
        "model": "packaged" if study.model is None else str(study.model),
        **identity,
        "baseline": baseline,
        "parameters": list(study.parameters),
        "groups": [
            {"name": g.name, "axes": [{"parameter": a.parameter, "log": a.log} for a in g.axes]}
            for g in study.groups
        ],
        "bounds": [
            {"parameter": b.parameter, "range": list(b.resolved(baseline)), "log": b.log}
            for b in study.bounds
        ],
        "options": study.options,
        "status": "running",
        "started": outputs.now(),
        "versions": outputs.package_versions(),
        "git": outputs.git_revision(Path(__file__).resolve().parent),
    }
    if reuse and previous.get("plots"):
        meta["plots"] = previous["plots"]  # kept on disk; listed until replaced
    outputs.write_json(meta, out_dir / outputs.META)
    start = time.perf_counter()
    try:
        with parallel_pool(execution) as parallel:
            evaluator = Evaluator(
                study, out_dir, baseline, parallel, progress, planned_points(study)
            )
            try:
                headline = _analyse(study, evaluator, baseline, out_dir)
                evaluator.complete()
                table = evaluator.table()
            finally:
                evaluator.close()
    except BaseException:
        meta.update(status="interrupted", stopped=outputs.now())
        outputs.write_json(meta, out_dir / outputs.META)
        _stop_local_workers(execution)
        raise
    outputs.write_table(table, out_dir / outputs.POINTS)
    wall = time.perf_counter() - start
    ok = int((table.get("status", pd.Series(dtype=str)) == "ok").sum())
    meta.update(
        status="complete",
        headline=headline,
        run={
            "jobs": execution.n_jobs,
            "backend": execution.backend,
            "scheduler": execution.scheduler,
            "wall_s": round(wall, 3),
            "points_total": len(table),
            "points_new": evaluator.points_new,
            "points_reused": evaluator.points_reused,
            "points_failed": len(table) - ok,
            "evaluation_s": round(evaluator.evaluation_s, 3),
            "points_per_s": round(evaluator.points_new / wall, 3) if wall > 0 else None,
        },
    )
    outputs.write_json(meta, out_dir / outputs.META)
    if plots and ok:
        from ufmt.plots.studies import plot_study

        meta["plots"] = [p.name for p in plot_study(out_dir)]
        outputs.write_json(meta, out_dir / outputs.META)
    elif plots:
        warnings.warn(f"{study.name}: no plots: every point failed (see points.csv)", stacklevel=2)
    outputs.write_index(out_dir.parent)
    return out_dir


def _check_same_study(study: Study, out_dir: Path, previous: Mapping, identity, fresh) -> None:
    """Refuse a results directory that holds another study file's results under the same
    name (a changed study file, same name, is a new run of the same study)."""
    if fresh or not previous or previous.get("study_sha256") == identity["study_sha256"]:
        return
    other = Path(str(previous.get("study_file", ""))).name
    if other and other != study.path.name:
        raise StudyError(
            f"{study.path}: field 'name': {out_dir} holds the results of another study file"
            f" with the name {study.name!r} ({other}); give this study its own name, use"
            " --results, or --fresh to replace them"
        )


LOCK = ".lock"


@contextmanager
def _locked(out_dir: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``out_dir/.lock`` (created with ``out_dir``) for the run.

    Raises
    ------
    StudyError
        The directory cannot be created or written, or another run holds the lock.
    """
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        handle = (out_dir / LOCK).open("a+", encoding="utf-8")
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise StudyError(f"--results: cannot write {out_dir}: {reason}") from None
    with handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.seek(0)
            holder = handle.read().strip() or "?"
            raise StudyError(
                f"{out_dir}: another ufmt run (pid {holder}) is writing these results; wait for"
                " it to finish (its rows are then reused) or use --results"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"{os.getpid()}\n")
        handle.flush()
        try:
            yield
        finally:
            handle.seek(0)
            handle.truncate()
            fcntl.flock(handle, fcntl.LOCK_UN)


@contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """Turn SIGTERM into KeyboardInterrupt while running (main thread only), so a terminated
    run stops its workers and records itself as interrupted, like Ctrl-C."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _stop_local_workers(execution: Execution) -> None:
    """Kill the loky worker processes (they would otherwise outlive an interrupted run)."""
    if execution.backend != "loky":
        return
    from joblib.externals.loky import get_reusable_executor

    get_reusable_executor().shutdown(wait=False, kill_workers=True)
