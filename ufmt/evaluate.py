"""The machine as a function: (design, process) -> machined-surface record.

:func:`evaluate` is what every study calls. It is pure (its result depends only on its
arguments, the model's content and the physics code), picklable (a module-level function
of plain dicts and a path) and never raises for a physics failure: the failure is recorded in
the returned record with ``status = "error"`` and a one-line ``message``. A caller's mistake
(an unknown parameter, a design value the model file could not hold) raises at once.

Design and process parameters, the reference process and the record's output names are
:mod:`ufmt.design`'s.

Caching: whole records are cached on disk as JSON files (:mod:`ufmt.evaluate_cache`), keyed
on the SHA-256 of the hinge values the design sets, the process, the model's content and the
physics code (:mod:`ufmt.fingerprint`). Within one process the modal basis of the last designs
is kept in memory, so a change of process on a known design reuses it.

:func:`evaluate_batch` evaluates several points at once, record for record as
:func:`evaluate`, with the modal bases of the new designs among them solved in one batch
(:func:`ufmt.solvers.solve_modes_batch`); a study's workers evaluate their chunks of points
so (:func:`evaluate_each`: per point the record or the exception).
"""

from __future__ import annotations

import functools
import math
import numbers
import os
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path

from ufmt import evaluate_cache
from ufmt.arguments import check_design
from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ, DEFAULT_SPACING
from ufmt.design import (
    ALWAYS_FINITE,
    FREQUENCIES,
    METRICS,
    N_FREQUENCIES,
    PROCESS_PARAMETERS,
    REFERENCE_PROCESS,
    SOURCE_METRICS,
    apply_design,
)
from ufmt.errors import ProcessError, StudyError, closest_name
from ufmt.fingerprint import code_sha256, file_sha256, model_sha256
from ufmt.kinds import frequency_dependent
from ufmt.machining.basis import ModalBasis
from ufmt.machining.lines import DEFAULT_LINE_SPACING
from ufmt.machining.modal import basis_at_slide, modal_basis, model_where_it_cuts
from ufmt.machining.process import Process, ProcessRangeWarning
from ufmt.machining.psd import BANDS, N_MIN_PERIODS
from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN
from ufmt.machining.validity import OutsideDomainError, check_case
from ufmt.model.load import load_model, packaged_path
from ufmt.model.machine import machine_of
from ufmt.model.schema import DesignParameter, Model
from ufmt.recent import Recent
from ufmt.simulate import simulate
from ufmt.solvers import solve_modes_batch

BASIS_CACHE = 4  # modal bases kept in memory per process (recent designs)


# ---------------------------------------------------------------------------------------------
# the model file


def model_file(model: str | os.PathLike | None) -> Path:
    """The model file to use: ``model`` or, if None, the packaged UFMT."""
    return packaged_path() if model is None else Path(model)


def resolve_model(model) -> tuple[Model, str]:
    """The model (path, loaded model or None = packaged) and its content hash (kept for the
    last few files in memory, keyed by their bytes).

    Raises
    ------
    ModelError
        The file cannot be read or is not a valid model.
    """
    if isinstance(model, Model):
        return model, _loaded_sha256(model)
    path = model_file(model)
    try:
        sha = file_sha256(path)
    except OSError:
        sha = ""  # load_model gives the one-line error
    return _load_model(str(path), sha)


@functools.lru_cache(maxsize=4)
def _loaded_sha256(model: Model) -> str:
    """The content hash of a loaded model (cached per object, which the cache keeps alive:
    models are frozen dataclasses with read-only arrays, and a design is a new object; the
    hash writes the whole model as TOML, ~5 ms for the packaged one)."""
    return model_sha256(model)


@functools.lru_cache(maxsize=4)
def _load_model(path: str, file_sha: str) -> tuple[Model, str]:
    """The model file at ``path`` (bytes ``file_sha``, which keys this cache) and its content
    hash."""
    model = load_model(path)
    return model, model_sha256(model)


# ---------------------------------------------------------------------------------------------
# the record


@dataclass(frozen=True, eq=False, repr=False)
class EvaluationRecord(Mapping):
    """What :func:`evaluate` returns: one (design, process) point and its outcome.

    A read-only mapping of the record's names (the design parameters, ``rpm``,
    ``feed_mm_min``, ``depth_um``, the metrics, ``f1_hz`` .., ``status``, ``message``) to
    values, in that order, so ``record["pv_nm"]`` and ``dict(record)`` work as with a dict and
    two records are equal when their items are; ``.to_dict()`` is that dict (the form the
    studies and the cache keep), ``.to_frame()`` one row. ``status`` and ``message`` are also
    attributes.
    """

    values: dict

    def __getitem__(self, key):
        return self.values[key]

    def __iter__(self):
        return iter(self.values)

    def __len__(self) -> int:
        return len(self.values)

    def __eq__(self, other) -> bool:
        return isinstance(other, Mapping) and dict(self.values) == dict(other.items())

    __hash__ = None  # a mutable-looking mapping: no hash, as a dict

    @property
    def status(self) -> str:
        """The outcome: "ok" or "error"."""
        return self.values["status"]

    @property
    def message(self) -> str:
        """Warnings or the error, one line (empty if none)."""
        return self.values["message"]

    def __repr__(self) -> str:
        pv = self.values.get("pv_nm", math.nan)
        process = ", ".join(f"{k}={self.values[k]:g}" for k in PROCESS_PARAMETERS)
        tail = f", message={self.message!r}" if self.message else ""
        return f"EvaluationRecord({process}: pv_nm={pv:.4g}, status={self.status!r}{tail})"

    def to_dict(self) -> dict:
        """The record as a plain dict (a copy)."""
        return dict(self.values)

    def to_frame(self):
        """The record as a one-row pandas DataFrame (units in the column names)."""
        import pandas as pd

        return pd.DataFrame([self.values])

    def plot(self, ax=None):
        """The record's surface heights [nm] as bars: the total PV, the interferometer's PV
        and RMS, and the PV of each error source alone (unresolved ones left out).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ufmt.plots import new_axes

        fig, ax = new_axes(ax)
        names = [k for k, v in self.values.items() if k.endswith("_nm") and math.isfinite(v)]
        ax.barh(names[::-1], [self.values[k] for k in names[::-1]], color="0.5")
        ax.set_xlabel("[nm]")
        process = ", ".join(f"{k} {self.values[k]:g}" for k in PROCESS_PARAMETERS)
        ax.set_title(f"{process}: {self.status}", fontsize="medium")
        return fig

    def save(self, directory) -> list:
        """Write ``record.json`` (strict JSON, null for NaN), ``record.csv``
        (:meth:`to_frame`) and ``record.png`` (:meth:`plot`) to ``directory``; returns the
        paths."""
        from ufmt import files
        from ufmt.jsonout import dumps_strict
        from ufmt.plots import save_figure

        directory = Path(directory)
        table = self.to_frame()
        return [
            files.write_text(directory / "record.json", dumps_strict(self.values) + "\n"),
            files.write_with(
                directory / "record.csv",
                lambda b: table.to_csv(b, index=False, float_format="%.10g"),
            ),
            save_figure(self.plot(), directory / "record.png"),
        ]


# ---------------------------------------------------------------------------------------------
# evaluation


def evaluate(
    design: Mapping[str, float],
    process,
    model: str | os.PathLike | Model | None = None,
    *,
    parameters: Mapping[str, DesignParameter] | None = None,
) -> EvaluationRecord:
    """Surface metrics and natural frequencies of one design under one cutting process.

    Parameters
    ----------
    design
        Design parameters (:mod:`ufmt.design`: stiffnesses, ``machine.<key>``) -> value [SI];
        missing ones keep the model's calibrated values; None or {} is the model as it is.
        The design comes first and the model third (or ``model=``), :mod:`ufmt.arguments`.
    process
        A :class:`ufmt.Process` or a mapping of ``rpm`` [rev/min], ``feed_mm_min`` [mm/min],
        ``depth_um`` [um]; missing ones take the reference case (300 rpm, 15 mm/min, 4 um).
    model
        Model file or loaded :class:`~ufmt.model.schema.Model`; None for the packaged UFMT.
    parameters
        Design parameters declared outside the model (a study file's ``[design]`` table).

    Returns
    -------
    EvaluationRecord
        A read-only mapping (``.to_dict()`` the plain dict): the inputs, then ``pv_nm``,
        ``pv_aperture_nm`` (clear aperture), ``pv_tilt_removed_nm``,
        ``pv_measured_nm`` and ``rms_measured_nm`` (as the interferometer reports them,
        :mod:`ufmt.machining.instruments`), ``rms_nm``, ``psd1_rms_nm``, ``psd2_rms_nm`` [nm]
        (surface of paper eq. 4.1; NaN where a band is not resolved), ``force_peak_n`` [N],
        ``pv_<source>_nm`` [nm] for each error source of :mod:`ufmt.machining.sources` alone,
        ``waviness_rms_nm`` [nm], ``zre_peak_nm`` [nm] (z_re average peak) and
        ``tip_acc_measured_mm_s2`` [mm/s^2] (as the accelerometer chain reports it),
        ``pv_dynamic_nm``, ``pv_dynamic_steady_nm`` and ``edge_runout_nm`` [nm] (the
        cutting-force vibration's surface alone: whole plate, steady cut, what the entry and
        exit strips add, :func:`ufmt.machining.surface.dynamic_metrics`), ``f1_hz`` ..
        ``f6_hz`` (first natural frequencies [Hz]), ``status`` ("ok" or "error") and ``message``
        (warnings or the error, one line; empty if none). On error the metrics are NaN.

    Raises
    ------
    StudyError
        An unknown design or process parameter name, a design value that is not a number (a
        boolean, text), or a model where the design is due (a caller's mistake, not physics).
    ProcessError
        A process value that is not a real number (None, a string, a bool).
    OutsideDomainError
        A cut outside the surface model's validity domain
        (:mod:`ufmt.machining.validity`); a study records it as ``invalid``.
    ModelError
        A model file that cannot be loaded, or a design value it could not hold (negative,
        NaN, outside the loader's ``LIMITS``).
    """
    return _finish(_case(design, process, model, parameters))


def evaluate_batch(
    designs: Sequence[Mapping[str, float]],
    processes,
    model: str | os.PathLike | Model | None = None,
    *,
    parameters: Mapping[str, DesignParameter] | None = None,
) -> list[EvaluationRecord]:
    """:func:`evaluate` of several points at once: ``[evaluate(d, p, model) for d, p in
    zip(designs, processes)]``, record for record, with the modal bases of the new designs
    solved in one batch (:func:`ufmt.solvers.solve_modes_batch`).

    ``processes`` is one process for every design or a sequence of them (one per design).
    Raises what :func:`evaluate` would raise for the first point that fails, after every point
    has been evaluated (:func:`evaluate_each` keeps each point's outcome instead).
    """
    outcomes = evaluate_each(designs, processes, model, parameters=parameters)
    for outcome in outcomes:
        if isinstance(outcome, Exception):
            raise outcome
    return outcomes


def evaluate_each(
    designs: Sequence[Mapping[str, float]],
    processes,
    model: str | os.PathLike | Model | None = None,
    *,
    parameters: Mapping[str, DesignParameter] | None = None,
) -> list[EvaluationRecord | Exception]:
    """Per point, what :func:`evaluate` returns or the exception it raises (a caller's
    mistake, a cut outside the validity domain), the points' modal bases solved as in
    :func:`evaluate_batch`: the form a study's worker needs (one point's mistake is that
    point's row)."""
    if isinstance(processes, Mapping) or (
        is_dataclass(processes) and not isinstance(processes, type)
    ):
        processes = [processes] * len(designs)
    if len(processes) != len(designs):
        raise StudyError(f"evaluate_batch: {len(designs)} designs but {len(processes)} processes")
    cases: list[_Case | Exception] = []
    for design, process in zip(designs, processes, strict=True):
        try:
            cases.append(_case(design, process, model, parameters))
        except Exception as exc:  # this point's own outcome
            cases.append(exc)
    bases = _batch_bases([c for c in cases if isinstance(c, _Case) and c.needs_basis])
    return [c if isinstance(c, Exception) else _finish(c, bases.get(c.basis_key)) for c in cases]


@dataclass
class _Case:
    """One point on its way through :func:`evaluate`: the record's inputs, the designed model
    and process, and either its cached outputs, the failure met before the physics, or the
    keys the physics run needs."""

    record: dict
    model: Model
    process: dict
    basis_key: tuple = ()
    key: dict | None = None
    outputs: dict | None = None
    failure: Exception | None = None

    @property
    def needs_basis(self) -> bool:
        """Whether the physics must run (no cached record, no earlier failure)."""
        return self.outputs is None and self.failure is None


def _case(design, process, model, parameters) -> _Case:
    """A point's inputs checked, its designed model and its cached outputs, if any.

    Raises the caller's mistakes (StudyError, ProcessError, ModelError) and
    OutsideDomainError; any other failure is kept in the case and recorded by :func:`_finish`.
    """
    design = check_design(design)
    process = _process_mapping(process)
    _check_process_names(process)
    base, base_sha = resolve_model(model)
    design_items = tuple(sorted(design.items()))
    designed = apply_design(base, dict(design_items), parameters)
    process_full = {**REFERENCE_PROCESS, **{k: _process_value(k, v) for k, v in process.items()}}
    case = _Case({**dict(design_items), **process_full}, designed, process_full)
    try:
        _check_domain(designed, process_full)  # before the cache and the modal basis
        changes = _hinge_changes(base, designed)
        case.basis_key = (base_sha, changes)
        case.key = {
            "model_sha256": base_sha,
            "code_sha256": code_sha256(),
            "hinges": [[name, [repr(v) for v in values]] for name, values in changes],
            "machine": _machine_changes(base, designed),
            "process": {k: repr(v) for k, v in process_full.items()},
        }
        case.outputs = evaluate_cache.load(case.key, METRICS + FREQUENCIES, physical)
    except OutsideDomainError:
        raise  # not a failure: the cut is outside what the surface model describes
    except Exception as exc:  # any physics failure becomes a recorded error
        case.failure = exc
    return case


def _finish(case: _Case, basis: ModalBasis | None = None) -> EvaluationRecord:
    """The record of ``case``: its cached outputs, or the physics run (on ``basis`` if given,
    else the design's own modal basis) and stored in the cache; a failure as status "error"."""
    record = dict(case.record)
    try:
        if case.failure is not None:
            raise case.failure
        outputs = case.outputs
        if outputs is None:
            outputs = _physics(case.model, case.process, case.basis_key, basis)
            evaluate_cache.store(case.key, outputs)
        outputs = dict(outputs)
        message = outputs.pop("message")
        record.update(outputs, status="ok", message=message)
    except OutsideDomainError:
        raise
    except Exception as exc:  # any physics failure becomes a recorded error
        record.update(dict.fromkeys(METRICS + FREQUENCIES, math.nan))
        record.update(status="error", message=_one_line(f"{type(exc).__name__}: {exc}"))
    return EvaluationRecord(record)


def _check_process_names(process: Mapping) -> None:
    """Raise StudyError for a process parameter name that is not one of PROCESS_PARAMETERS."""
    for name in process:
        if name not in PROCESS_PARAMETERS:
            close = closest_name(name, PROCESS_PARAMETERS)
            hint = f"did you mean {close!r}?" if close else ", ".join(PROCESS_PARAMETERS)
            raise StudyError(f"evaluate: unknown process parameter {name!r} ({hint})")


def physical(name: str, value: float) -> bool:
    """Whether ``value`` is a possible value of output ``name``: never infinite; finite where
    :data:`ALWAYS_FINITE`; a frequency [Hz] > 0; a PV, RMS or force >= 0 (a cache record
    outside these is recomputed)."""
    if math.isnan(value):
        return name not in ALWAYS_FINITE
    if not math.isfinite(value):
        return False
    return value > 0.0 if name in FREQUENCIES else value >= 0.0


def _process_mapping(process) -> dict:
    """A process given as a mapping or a dataclass (``ufmt.Process``) as a dict."""
    if is_dataclass(process) and not isinstance(process, type):
        return {f.name: getattr(process, f.name) for f in fields(process)}
    if not isinstance(process, Mapping):
        raise StudyError(
            f"evaluate: process must be a ufmt.Process or a mapping, not {type(process).__name__}"
        )
    return dict(process)


def _check_domain(model: Model, process: Mapping[str, float]) -> None:
    """Raise OutsideDomainError for a case outside the surface model's validity domain at the
    default grid and aperture (:func:`ufmt.machining.validity.check_case`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ProcessRangeWarning)  # recorded by the physics run
        case = Process(**process)
    check_case(case, machine_of(model), DEFAULT_SPACING, DEFAULT_APERTURE_MARGIN)


def _process_value(name: str, value) -> float:
    """A process value as a float; anything but a real number (None, a string, a bool)
    raises ProcessError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ProcessError(
            f"evaluate: process {name!r}: {value!r} is not a number ({type(value).__name__})"
        )
    return float(value)


def _number(value) -> float:
    """A metric as a float; None (a source switched off, a band not resolved) as NaN."""
    return math.nan if value is None else float(value)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _physics(model: Model, process: Mapping[str, float], basis_key, basis=None) -> dict:
    """Metrics [nm], frequencies [Hz] and warnings of one case on ``basis`` (None: the
    design's own, :func:`_modal_basis`); raises on any failure."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        basis = _modal_basis(model, basis_key, basis)
        lines = study_line_spacing(model)
        result = simulate(model, Process(**process), basis=basis, line_spacing=lines)
    by_source = {f"pv_{k}_nm": v for k, v in result.pv_by_source_nm.items()}
    outputs = {
        name: _number(by_source.get(name) if name in SOURCE_METRICS else result.metrics[name])
        for name in METRICS
    }
    frequencies = list(basis.omega[:N_FREQUENCIES] / (2.0 * math.pi))
    frequencies += [math.nan] * (N_FREQUENCIES - len(frequencies))
    outputs.update(zip(FREQUENCIES, map(float, frequencies), strict=True))
    outputs["message"] = _one_line("; ".join(dict.fromkeys(str(w.message) for w in caught)))
    return outputs


def study_line_spacing(model: Model) -> float | None:
    """The step [m] of the PSD line profiles the study function reads: the lines
    (:mod:`ufmt.machining.lines`: PSD1 free of the display grid's aliasing, PSD2 resolved) on a
    plate that holds PSD1 (N_MIN_PERIODS of its longest wavelength along both sides), None
    (the grid's rows and columns) on a smaller plate such as the paper's, where PSD1 is not
    resolved and the lines would more than double the cost of every point
    (docs/benchmarks.md)."""
    machine = machine_of(model)
    longest = BANDS["psd1"][1] * N_MIN_PERIODS
    return DEFAULT_LINE_SPACING if min(machine.workpiece_size) >= longest else None


def _hinge_changes(base: Model, model: Model) -> tuple:
    """The hinges whose stiffness ``model`` changed from ``base``: a design's identity (a
    design that restates calibrated values is the calibrated design)."""
    if model is base:
        return ()
    return tuple(
        (new.name, tuple(float(v) for v in new.stiffness6))
        for new, old in zip(model.hinges, base.hinges, strict=True)
        if tuple(new.stiffness6) != tuple(old.stiffness6)
    )


def _machine_changes(base: Model, model: Model) -> dict[str, str]:
    """The ``[machine]`` values ``model`` changed from ``base`` (repr of each), a design's
    identity beside its hinges (the modal basis does not depend on them)."""
    if model.machine is base.machine:
        return {}
    old, new = base.machine.table, model.machine.table
    return {k: repr(v) for k, v in new.items() if old.get(k) != v}


_BASES = Recent(BASIS_CACHE)  # (model_sha, hinge changes) -> ModalBasis


def _modal_basis(model, key, solved=None):
    """The default modal basis of ``model`` (every mode below the default cutoff,
    :mod:`ufmt.defaults`): ``solved`` if given (a batch's), else the memo's or a new one; kept
    for the last BASIS_CACHE designs so that process changes on a known design reuse it."""
    return _BASES.get(key, (lambda: solved) if solved is not None else (lambda: modal_basis(model)))


def _batch_bases(cases: Sequence[_Case]) -> dict:
    """Modal bases of the distinct designs of ``cases`` that are not kept in memory, their
    modes solved in one call (:func:`ufmt.solvers.solve_modes_batch`), by basis key: the steps
    of :func:`ufmt.machining.modal.modal_basis` at the default cutoff, with the solve batched.

    Left out, so that its point builds its basis on its own inside the physics run (which then
    records the failure or the warnings in that point's record, as :func:`evaluate` does): a
    design whose basis fails or warns, and every design if the batch solve fails or warns.
    """
    models = {}
    for case in cases:
        if frequency_dependent(case.model):  # its own basis (ufmt.machining.film_basis)
            continue
        if case.basis_key not in _BASES and case.basis_key not in models:
            models[case.basis_key] = case.model
    if len(models) < 2:
        return {}  # nothing to batch
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            slides = {key: model_where_it_cuts(model) for key, model in models.items()}
            solutions = solve_modes_batch(
                [moved for _, moved in slides.values()], fmax_hz=DEFAULT_BASIS_CUTOFF_HZ
            )
    except Exception:  # each point solves its own design and records its own failure
        return {}
    if caught:
        return {}
    bases = {}
    for (key, model), solution in zip(models.items(), solutions, strict=True):
        slide_y, moved = slides[key]
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                basis = basis_at_slide(model, moved, slide_y, solution)
            except Exception:
                continue
        if not caught:
            bases[key] = basis
    return bases
