"""Run a study: check every input, lock its results directory, evaluate its points in
parallel (:mod:`ufmt.studies.parallel`) with the journal of earlier rows
(:mod:`ufmt.studies.journal`), let its kind analyse them (:mod:`ufmt.studies.kinds`) and draw
its figures.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path

import pandas as pd

from ufmt import evaluate_cache
from ufmt.errors import OutputError, RunFailed, StudyError
from ufmt.machining.process import ProcessRangeWarning
from ufmt.plots import mark_plate, save_figure
from ufmt.studies import outputs
from ufmt.studies.journal import (
    Evaluator,
    check_same_study,
    fingerprint,
    run_summary,
    set_aside,
    start_meta,
)
from ufmt.studies.kinds import KINDS, RESULT_TABLES
from ufmt.studies.load import load_study
from ufmt.studies.locking import locked, sigterm_interrupts
from ufmt.studies.parallel import (
    Execution,
    parallel_pool,
    resolve_function,
    stop_local_workers,
    within_cores,
)
from ufmt.studies.spec import Study, StudyKind

DEFAULT_EXECUTION = Execution()  # loky workers on this machine, one per core


def run_study(
    study: Study | str | Path,
    execution: Execution = DEFAULT_EXECUTION,
    results: str | Path | None = None,
    progress: bool = True,
    fresh: bool = False,
    plots: bool = True,
) -> Path:
    """Run (or resume) a study; returns its results directory ``<results>/<name>/``.

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
        Root of the results tree; ``README.md`` there is regenerated. None:
        :func:`default_results`.
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
    execution = within_cores(execution)
    resolve_function(study.function)
    evaluate_cache.directory()  # an unusable cache: one warning here, not one per worker
    identity = fingerprint(study)
    out_dir = default_results(study) / study.name if results is None else Path(results) / study.name
    with locked(out_dir), sigterm_interrupts():
        try:
            return _run_locked(study, execution, out_dir, identity, progress, fresh, plots)
        except OSError as exc:  # a full disk, a permission lost mid-run
            raise _failed(study, out_dir, exc) from None


def _failed(study: Study, out_dir: Path, exc: OSError) -> RunFailed:
    """The one-line error of a run stopped by ``exc``; meta.json records "failed" with the
    reason where it still can be written."""
    where = getattr(exc, "filename", None)
    reason = str(exc) if isinstance(exc, OutputError) else f"{where}: {exc.strerror or exc}"
    meta = outputs.read_meta(out_dir)
    if meta:
        meta.update(status="failed", reason=reason, stopped=outputs.now())
        try:
            outputs.write_json(meta, out_dir / outputs.META)
        except OSError:
            pass  # the disk is still full: the reason is in the error line
    rows = out_dir / outputs.POINTS
    return RunFailed(
        f"{study.name}: stopped: {reason}; the finished rows are kept in {rows}; rerun to resume"
    )


def default_results(study: Study) -> Path:
    """Results root of a study: ``results/`` on the packaged model, ``results/<model file
    name>/`` on a user's model (so its outputs and index stay apart from the packaged ones)."""
    return Path("results") if study.model is None else Path("results") / Path(study.model).stem


def _run_locked(study, execution, out_dir, identity, progress, fresh, plots) -> Path:
    """The run, holding the lock on ``out_dir``: reuse or discard earlier results, evaluate,
    write points.csv, meta.json, the figures and the results index."""
    kind = KINDS[study.kind]
    previous = outputs.read_meta(out_dir)
    check_same_study(study, out_dir, previous, identity, fresh)
    reuse = not fresh and previous.get("fingerprint") == identity["fingerprint"]
    if not reuse:  # the earlier rows are set aside as points.<fingerprint>.csv, never deleted
        set_aside(out_dir, previous, (*RESULT_TABLES, outputs.META, *previous.get("plots", [])))
    meta = start_meta(study, identity)
    for message in meta["warnings"]:  # process values outside Table 1, as simulate warns
        warnings.warn(message, ProcessRangeWarning, stacklevel=2)
    if reuse and previous.get("plots"):
        meta["plots"] = previous["plots"]  # kept on disk; listed until replaced
    try:
        outputs.write_json(meta, out_dir / outputs.META)
    except OSError as exc:  # nothing has run yet: a plain input error
        raise StudyError(f"--results: {exc}") from None
    start = time.perf_counter()
    evaluator, headline, table = _evaluate(study, kind, execution, out_dir, progress, meta)
    outputs.write_table(table, out_dir / outputs.POINTS)
    run = run_summary(execution, table, evaluator, time.perf_counter() - start)
    meta.update(status="complete", headline=headline, run=run)
    meta = outputs.settled_meta(meta, previous)
    outputs.write_json(meta, out_dir / outputs.META)
    if plots and run["points_failed"] + run["points_invalid"] < run["points_total"]:
        figures = kind.figures(out_dir)
        if kind.simulated_figures is not None:
            figures.update(kind.simulated_figures(study, out_dir))
        for fig in figures.values():
            mark_plate(fig, meta.get("plate_mm"))
        meta["plots"] = [save_figure(fig, out_dir / name).name for name, fig in figures.items()]
        outputs.write_json(meta, out_dir / outputs.META)
    elif plots:
        warnings.warn(f"{study.name}: no plots: no point succeeded (see points.csv)", stacklevel=2)
    outputs.write_index(out_dir.parent)
    return out_dir


def _evaluate(
    study: Study, kind: StudyKind, execution: Execution, out_dir: Path, progress: bool, meta
) -> tuple[Evaluator, str, pd.DataFrame]:
    """Evaluate the study's points as its kind's analysis requests them: (evaluator,
    headline, table of every requested row). Any interruption (an error, Ctrl-C, SIGTERM)
    records ``meta.json`` as interrupted, stops the local workers and propagates."""
    baseline = study.baseline
    try:
        with parallel_pool(execution) as parallel:
            planned = kind.planned_points(study)
            evaluator = Evaluator(
                study, out_dir, baseline, parallel, progress, planned, execution.n_jobs
            )
            try:
                headline = kind.analyse(study, evaluator, baseline, out_dir)
                evaluator.complete()
                table = evaluator.table()
            finally:
                evaluator.close()
    except BaseException as exc:
        stop_local_workers(execution)
        if not isinstance(exc, OSError):  # a failure is recorded by run_study
            meta.update(status="interrupted", stopped=outputs.now())
            outputs.write_json(meta, out_dir / outputs.META)
        raise
    return evaluator, headline, table
