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

import functools
import hashlib
import importlib
import importlib.util
import json
import math
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
from joblib.externals.loky.process_executor import TerminatedWorkerError
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from ufmt.errors import ModelError, StudyError
from ufmt.evaluate import (
    PROCESS_PARAMETERS,
    REFERENCE_PROCESS,
    code_sha256,
    design_value,
    file_sha256,
    model_file,
)
from ufmt.studies import outputs
from ufmt.studies.spec import Study, load_study

BACKENDS = ("loky", "dask")
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
) -> tuple[int, dict, float]:
    """Run the study function on one point in a worker: (position, record, seconds).

    Never raises: an exception of the function becomes a record with status "error".
    """
    global _tasks_done
    if _tasks_done < _BLAS_LIMITED_TASKS:
        threadpool_limits(limits=BLAS_THREADS)
        _tasks_done += 1
    start = time.perf_counter()
    try:
        record = resolve_function(ref)(dict(design), dict(process), model)
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
    except OSError as exc:
        raise StudyError(f"--scheduler {execution.scheduler}: cannot connect: {exc}") from None
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
            total=0, desc=study.name, unit="pt", disable=not progress, dynamic_ncols=True
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
        self._bar.total += len(set(rows))
        self._bar.update(len(set(rows)) - len(todo))
        self.points_reused += len(set(rows)) - len(todo)
        self._run(list(todo.items()))
        return [self._rows[key] for key in rows]

    def _run(self, todo: list) -> None:
        if not todo:
            return
        self._bar.set_postfix_str(todo[0][1][0]["group"], refresh=False)
        tasks = (
            joblib.delayed(evaluate_point)(
                position,
                self.study.function,
                {k: v for k, v in inputs.items() if k not in PROCESS_PARAMETERS},
                {k: v for k, v in inputs.items() if k in PROCESS_PARAMETERS},
                self.model,
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
                self._bar.update(1)
        except TerminatedWorkerError as exc:
            raise StudyError(
                f"{self.study.name}: a worker died ({' '.join(str(exc).split())[:200]});"
                f" {len(self._rows)} finished points are saved; rerun to resume"
            ) from None

    def values(self, group: str, points: Sequence[Mapping[str, float]], output="pv_nm"):
        """``output`` of each point as a float array (NaN where the point failed)."""
        rows = self.evaluate([(group, p) for p in points])
        return np.array([_number(r.get(output)) for r in rows])

    def table(self) -> pd.DataFrame:
        """Every row requested in this run, by group (in request order), then index."""
        keys = [k for requested in self._requested.values() for k in requested]
        return pd.DataFrame([self._rows[k] for k in keys], columns=self._log.columns)

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


def resolve_baseline(study: Study) -> dict[str, float]:
    """Value of every study parameter when it is not varied: base, else reference process,
    else the model's calibrated design (NaN if the model cannot supply it and nothing needs it).

    Raises
    ------
    StudyError
        A relative range (``scale``) whose calibrated value is unavailable, or a hinge the
        model does not have.
    """
    baseline = {}
    missing = []
    for name in study.parameters:
        if name in study.base:
            baseline[name] = study.base[name]
        elif name in PROCESS_PARAMETERS:
            baseline[name] = REFERENCE_PROCESS[name]
        else:
            missing.append(name)
    if not missing:
        return baseline
    from ufmt.model.load import load_model

    path = model_file(study.model)
    try:
        model = load_model(path)
    except ModelError as exc:
        needed = [n for n in missing if n in study.relative_parameters]
        if needed:
            raise StudyError(
                f"{study.path}: field '{needed[0]}': a scale needs the calibrated value: {exc}"
            ) from None
        return {**baseline, **dict.fromkeys(missing, math.nan)}
    for name in missing:
        try:
            baseline[name] = design_value(model, name)
        except KeyError as exc:
            raise StudyError(f"{study.path}: parameter {name!r}: {exc.args[0]}") from None
    return baseline


def fingerprint(study: Study) -> dict[str, str]:
    """Hashes that decide whether earlier rows of this study can be reused."""
    path = model_file(study.model)
    model_sha = file_sha256(path) if path.exists() else "missing"
    module = study.function.rpartition(":")[0]
    function_sha = file_sha256(module) if module.endswith(".py") else study.function
    parts = {
        "study_sha256": hashlib.sha256(study.text.encode()).hexdigest(),
        "function": study.function,
        "function_sha256": hashlib.sha256(function_sha.encode()).hexdigest(),
        "model": str(path),
        "model_sha256": model_sha,
        "code_sha256": code_sha256(),
    }
    parts["fingerprint"] = hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
    return parts


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
    """
    if not isinstance(study, Study):
        study = load_study(study)
    resolve_function(study.function)
    baseline = resolve_baseline(study)
    identity = fingerprint(study)
    results = Path(results)
    out_dir = results / study.name
    out_dir.mkdir(parents=True, exist_ok=True)
    previous = outputs.read_meta(out_dir)
    if fresh or previous.get("fingerprint") != identity["fingerprint"]:
        for name in (*outputs.TABLES, outputs.META, *previous.get("plots", [])):
            (out_dir / name).unlink(missing_ok=True)
    meta = {
        "study": study.name,
        "kind": study.kind,
        "description": study.description,
        "study_file": str(study.path),
        "study_text": study.text,
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
    outputs.write_json(meta, out_dir / outputs.META)
    start = time.perf_counter()
    with parallel_pool(execution) as parallel:
        evaluator = Evaluator(study, out_dir, baseline, parallel, progress)
        try:
            headline = _analyse(study, evaluator, baseline, out_dir)
            table = evaluator.table()
        finally:
            evaluator.close()
    outputs.write_table(table, out_dir / outputs.POINTS)
    wall = time.perf_counter() - start
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
            "points_failed": int((table.get("status", pd.Series()) != "ok").sum()),
            "evaluation_s": round(evaluator.evaluation_s, 3),
            "points_per_s": round(evaluator.points_new / wall, 3) if wall > 0 else None,
        },
    )
    outputs.write_json(meta, out_dir / outputs.META)
    if plots:
        from ufmt.plots.studies import plot_study

        meta["plots"] = [p.name for p in plot_study(out_dir)]
        outputs.write_json(meta, out_dir / outputs.META)
    outputs.write_index(results)
    return out_dir
