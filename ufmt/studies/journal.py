"""The journal of a study run: the rows of ``points.csv`` reused on a rerun, the fingerprint that
decides whether they may be, and the ``meta.json`` of the run.

The workers evaluate chunks of points (:func:`ufmt.studies.parallel.chunk_size`: a few per
worker, at most MAX_CHUNK points each); every point of a finished chunk is appended to
``results/<study>/points.csv`` and flushed at once, so a killed run loses only the chunks in
flight. A rerun of the same study (same study file, model file, function and physics code,
checked by a fingerprint in ``meta.json``) reads the rows back, evaluates only the missing
points and ends with the same table; with anything changed it starts afresh. A point whose
function fails is a row with ``status = "error"`` and the message; a rerun tries failed points
again (a failure may have been transient; a deterministic one gives the same row). A point
outside the surface model's validity domain (:mod:`ufmt.machining.validity`) is a row with
``status = "invalid"`` and the limit it breaks; it is deterministic, so it is reused, and the
kinds leave it out of optima and fits like a failed point (its outputs are empty).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path

import joblib
import numpy as np
import pandas as pd
from tqdm import tqdm

from ufmt import evaluate_cache
from ufmt.design import PROCESS_PARAMETERS
from ufmt.errors import ModelError, StudyError
from ufmt.evaluate import model_file, resolve_model
from ufmt.fingerprint import code_sha256, source_sha256
from ufmt.studies import outputs
from ufmt.studies.parallel import chunk_size, evaluate_chunk, pool_lost_errors
from ufmt.studies.ranges import process_warnings
from ufmt.studies.spec import Study

# ---------------------------------------------------------------------------------------------
# points.csv: evaluating batches of points with resume


def point_key(group: str, values: Sequence[float]) -> str:
    """Identity of a point within a study: its group and the exact values of its parameters."""
    return json.dumps([group, [repr(float(v)) for v in values]])


class Evaluator:
    """Evaluates batches of points of one study, logging and reusing rows in ``points.csv``.

    Call :meth:`evaluate` with (group, point) pairs; each point maps parameters to values (the
    study's base is added). Rows come back in request order. The new points of a call go to
    the ``jobs`` workers of ``parallel`` in chunks (:meth:`_run`). A point already in the log
    (same group and parameter values) is reused, not recomputed; ``points_reused`` counts only
    rows logged before this run (a point requested twice in one run is computed once and
    counted once, as new).

    The progress bar counts requests against ``planned`` (the kind's exact count or its
    optimiser's budget, an upper bound), which stays the bar's total: a search that stops
    early ends short of it and says so, rather than moving the total during the run.
    """

    def __init__(
        self,
        study: Study,
        out_dir: Path,
        baseline: Mapping[str, float],
        parallel: joblib.Parallel,
        progress: bool,
        planned: int | None = None,
        jobs: int = 1,
        log: str = outputs.POINTS,
    ):
        self.study = study
        self.out_dir = Path(out_dir)
        self.parameters = list(study.parameters)
        self.baseline = dict(baseline)
        self.model = None if study.model is None else str(study.model)
        self._parallel = parallel
        self._jobs = jobs
        self._log = outputs.PointLog(self.out_dir / log, ["group", "index", *self.parameters])
        logged = {self._key(row["group"], row): row for row in self._log.read()}  # last wins
        self._rows = {k: row for k, row in logged.items() if row.get("status") != "error"}
        self._earlier = frozenset(self._rows)  # rows this run may reuse
        self._requested: dict[str, dict[str, int]] = {}
        self.points_new = 0
        self.points_reused = 0
        self.evaluation_s = 0.0
        self._bar = tqdm(
            total=planned or 0, desc=study.name, unit="pt", disable=not progress, dynamic_ncols=True
        )

    def sibling(self, log: str, planned: int) -> Evaluator:
        """An evaluator of the same study and workers that logs to ``log`` (a table beside
        points.csv, resumed like it), with its own progress bar of ``planned`` points: points
        that are not the study's own (the band samples of its decisions), kept out of
        points.csv."""
        progress = not self._bar.disable
        return Evaluator(
            self.study,
            self.out_dir,
            self.baseline,
            self._parallel,
            progress,
            planned,
            self._jobs,
            log,
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
            if key not in requested and key in self._earlier:
                self.points_reused += 1
            index = requested.setdefault(key, len(requested))
            rows.append(key)
            if key in self._rows:
                self._rows[key].update(group=group, index=index)
            elif key not in todo:
                todo[key] = ({"group": group, "index": index, **row}, inputs)
        if self._bar.n + len(set(rows)) > self._bar.total:  # only if a kind under-plans
            self._bar.total = self._bar.n + len(set(rows))
            self._bar.set_description_str(f"{self.study.name} (more points than planned)")
        self._bar.update(len(set(rows)) - len(todo))
        self._run(list(todo.items()))
        return [self._rows[key] for key in rows]

    def _run(self, todo: list) -> None:
        """Evaluate the ``todo`` points in chunks (:func:`~ufmt.studies.parallel.chunk_size`),
        appending each point's row to the log as its chunk finishes: a killed run loses only
        the chunks in flight."""
        if not todo:
            return
        size = chunk_size(len(todo), self._jobs)
        tasks = (
            joblib.delayed(evaluate_chunk)(
                range(start, min(start + size, len(todo))),
                self.study.function,
                [_design_and_process(inputs) for _, (_, inputs) in todo[start : start + size]],
                self.model,
                self.study.design,
            )
            for start in range(0, len(todo), size)
        )
        try:
            for chunk in self._parallel(tasks):
                for position, record, seconds, notes in chunk:
                    self._record(todo[position], record, seconds, notes)
        except pool_lost_errors() as exc:
            raise StudyError(
                f"{self.study.name}: the workers were lost ({type(exc).__name__}:"
                f" {' '.join(str(exc).split())[:200]}); {len(self._rows)} finished points are"
                " saved; rerun to resume"
            ) from None

    def _record(self, item, record: Mapping, seconds: float, notes: Sequence[str]) -> None:
        """Log the row of one finished point (``item``: its key and (row, inputs))."""
        for note in notes:  # a worker's cache failure, reported once
            evaluate_cache.warn_once(note)
        key, (row, _) = item
        full = {**row, **{k: v for k, v in record.items() if k not in row}}
        self._log.append(full)
        self._rows[key] = full
        self.points_new += 1
        self.evaluation_s += seconds
        self._bar.set_postfix_str(row["group"], refresh=False)
        self._bar.update(1)

    def values(self, group: str, points: Sequence[Mapping[str, float]], output="pv_nm"):
        """``output`` of each point as a float array (NaN where the point failed)."""
        rows = self.evaluate([(group, p) for p in points])
        return np.array([_number(r.get(output)) for r in rows])

    def table(self) -> pd.DataFrame:
        """Every row requested in this run, by group (in request order), then index."""
        keys = [k for requested in self._requested.values() for k in requested]
        return pd.DataFrame([self._rows[k] for k in keys], columns=self._log.columns)

    def complete(self) -> None:
        """Mark the progress bar finished; an optimiser that used less than its budget says
        so (the total stays the budget)."""
        if self._bar.n < self._bar.total:
            self._bar.set_postfix_str(
                f"finished: {self._bar.n} of at most {self._bar.total} planned", refresh=False
            )
        self._bar.refresh()

    def close(self) -> None:
        """Close the progress bar and the log."""
        self._bar.close()
        self._log.close()


def _design_and_process(inputs: Mapping[str, float]) -> tuple[dict, dict]:
    """A point's inputs split into the design and the process (PROCESS_PARAMETERS)."""
    design = {k: v for k, v in inputs.items() if k not in PROCESS_PARAMETERS}
    return design, {k: v for k, v in inputs.items() if k in PROCESS_PARAMETERS}


def _number(value) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


# ---------------------------------------------------------------------------------------------
# fingerprint and meta.json


def fingerprint(study: Study) -> dict[str, str]:
    """Hashes that decide whether earlier rows of this study can be reused.

    They cover what changes results and nothing else: the parsed study file (not its comments,
    layout or ``description``: :data:`NOT_RESULTS`), the model's content (not its path or
    comments), the study function (its name, or the syntax tree of a ``file.py`` function)
    and the physics code's syntax trees. The same study in another clone or directory has the
    same fingerprint.
    """
    module, _, attribute = study.function.rpartition(":")
    function = f"{source_sha256(module)}:{attribute}" if module.endswith(".py") else study.function
    _, model_sha = resolve_model(model_file(study.model))
    parts = {
        "study_sha256": results_sha256(study),
        "function_sha256": hashlib.sha256(function.encode()).hexdigest(),
        "model_sha256": model_sha,
        "code_sha256": code_sha256(),
    }
    parts["fingerprint"] = hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
    return parts


#: Study-file fields that do not change any result (editing them keeps the rows).
NOT_RESULTS = ("description",)


def results_sha256(study: Study) -> str:
    """SHA-256 of the study file's parsed content without :data:`NOT_RESULTS` (comments and
    layout never count)."""
    data = {k: v for k, v in tomllib.loads(study.text).items() if k not in NOT_RESULTS}
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def set_aside(out_dir: Path, previous: Mapping, others: Sequence[str]) -> Path | None:
    """Move the rows of an earlier run that cannot be reused to ``points.<fingerprint>.csv``
    (never deleted) and remove the files derived from them (``others``: tables, meta.json,
    plots); returns where the rows went (None: there were none)."""
    points = out_dir / outputs.POINTS
    kept = None
    if points.is_file():
        tag = str(previous.get("fingerprint") or "previous")[:16]
        kept = out_dir / f"points.{tag}.csv"
        os.replace(points, kept)
    for name in others:
        if isinstance(name, str) and Path(name).name == name:  # never outside out_dir
            (out_dir / name).unlink(missing_ok=True)
    return kept


def check_same_study(study: Study, out_dir: Path, previous: Mapping, identity, fresh) -> None:
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


def start_meta(study: Study, identity: Mapping[str, str]) -> dict:
    """The ``meta.json`` of a run that starts: the study, its inputs and their hashes
    (``identity``: :func:`fingerprint`), package versions and the git revision."""
    baseline = study.baseline
    return {
        "study": study.name,
        "kind": study.kind,
        "description": study.description,
        "study_file": str(study.path),
        "study_text": study.text,
        "function": study.function,
        "model": "packaged" if study.model is None else str(study.model),
        **identity,
        "baseline": baseline,
        "plate_mm": plate_mm(study, baseline),
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
        "warnings": process_warnings(study),
        "status": "running",
        "started": outputs.now(),
        "versions": outputs.package_versions(),
        "git": outputs.git_revision(Path(__file__).resolve().parent),
    }


def plate_mm(study: Study, baseline: Mapping[str, float]) -> list[float] | None:
    """The plate [mm] (x, y) every point of the study cuts: ``machine.workpiece_size[i]`` of
    its ``[base]`` where set, else the model's; None for a model without ``[machine]`` or
    one that cannot be read (its run then fails with the model's own error)."""
    try:
        model, _ = resolve_model(study.model)
    except (ModelError, OSError):
        return None
    size = model.machine.workpiece_size if model.machine is not None else (None, None)
    plate = [baseline.get(f"machine.workpiece_size[{i}]", size[i]) for i in (0, 1)]
    return None if None in plate else [round(1e3 * float(v), 6) for v in plate]


def run_summary(execution, table: pd.DataFrame, evaluator: Evaluator, wall: float) -> dict:
    """The ``run`` entry of a finished run's ``meta.json``: workers, points, times [s]."""
    status = table.get("status", pd.Series(dtype=str))
    ok = int((status == "ok").sum())
    invalid = int((status == "invalid").sum())
    return {
        "jobs": execution.n_jobs,
        "backend": execution.backend,
        "scheduler": execution.scheduler,
        "wall_s": round(wall, 3),
        "points_total": len(table),
        "points_new": evaluator.points_new,
        "points_reused": evaluator.points_reused,
        "points_failed": len(table) - ok - invalid,
        "points_invalid": invalid,
        "evaluation_s": round(evaluator.evaluation_s, 3),
        "points_per_s": round(evaluator.points_new / wall, 3) if wall > 0 else None,
    }
