"""The machine as a function: (design, process) -> machined-surface record (issue 5).

:func:`evaluate` is what every study calls. It is pure (its result depends only on its
arguments, the model's content and the physics code), picklable (a module-level function
of plain dicts and a path) and never raises for a physics failure: the failure is recorded in
the returned record with ``status = "error"`` and a one-line ``message``. A caller's mistake
(an unknown parameter, a design value the model file could not hold) raises at once.

Design parameters are declared by name in the model file's ``[design]`` table (or a study
file's, passed as ``parameters``): ``[design.<name>]`` with ``hinge``, ``field``
(``stiffness`` [N/m] or ``rotational_stiffness`` [N m/rad]) and ``components`` (0, 1, 2 = x,
y, z). The packaged UFMT declares (``h31`` = fly-cutting-head air bearing, ``h25`` = spindle
air bearing; spindle axis = global z):

* ``head_radial_stiffness_N_m``: h31 ``stiffness[0]`` and ``[1]`` (x and y) [N/m];
* ``head_axial_stiffness_N_m``: h31 ``stiffness[2]`` (z) [N/m];
* ``head_angular_stiffness_Nm_rad``: h31 ``rotational_stiffness[0]`` and ``[1]`` [N m/rad]
  (about z the bearing stays released);
* ``spindle_radial_stiffness_N_m``, ``spindle_axial_stiffness_N_m``,
  ``spindle_angular_stiffness_Nm_rad``: the same components of h25.

Any model also takes ``hinge.<name>.stiffness[i]`` and ``hinge.<name>.rotational_stiffness[i]``:
one component (i = 0, 1, 2 for x, y, z) of any hinge. Every value is checked with the model
loader's rules (:func:`ufmt.model.load.check_hinge_values`: >= 0, inf = rigid, within
``LIMITS``).

Process parameters: ``rpm`` [rev/min], ``feed_mm_min`` [mm/min], ``depth_um`` [um]; a missing
one takes the paper's reference case (300 rpm, 15 mm/min, 4 um; Table 4).

Caching: whole records are cached on disk as JSON files (:mod:`ufmt.evaluate_cache`), keyed
on the SHA-256 of the hinge values the design sets, the process, the model's content and the
physics code. Within one process the modal basis of the last designs is kept in memory, so a
change of process on a known design reuses it.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import re
import warnings
from collections.abc import Mapping
from dataclasses import fields, is_dataclass
from pathlib import Path

import numpy as np

from ufmt import evaluate_cache
from ufmt.errors import StudyError, closest_name
from ufmt.machining.sources import SOURCES
from ufmt.model.hinges import check_hinge_values
from ufmt.model.load import packaged_path
from ufmt.model.schema import DesignParameter, Model
from ufmt.recent import Recent

N_MODES = 30  # modes in the modal basis (paper section 3.2 uses the first 30)
N_FREQUENCIES = 6  # natural frequencies reported in each record
BASIS_CACHE = 4  # modal bases kept in memory per process (recent designs)

REFERENCE_PROCESS = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
PROCESS_PARAMETERS = tuple(REFERENCE_PROCESS)
#: PV [nm] of the surface with one error source alone (ufmt.machining.sources.SOURCES).
SOURCE_METRICS = tuple(f"pv_{source}_nm" for source in SOURCES)
METRICS = (
    "pv_nm",
    "pv_aperture_nm",
    "pv_tilt_removed_nm",
    "rms_nm",
    "psd1_rms_nm",
    "psd2_rms_nm",
    "force_peak_n",
    *SOURCE_METRICS,
)
FREQUENCIES = tuple(f"f{i}_hz" for i in range(1, N_FREQUENCIES + 1))
OUTPUTS = METRICS + FREQUENCIES + ("status", "message")

_HINGE_PARAMETER = re.compile(
    r"hinge\.(?P<hinge>[^.\[\]]+)\.(?P<field>stiffness|rotational_stiffness)\[(?P<index>[012])\]"
)
_PACKAGE = Path(__file__).resolve().parent
_NOT_PHYSICS = ("studies", "plots", "cli", "calibration")


# ---------------------------------------------------------------------------------------------
# parameters


def design_parameters(
    model: Model, extra: Mapping[str, DesignParameter] | None = None
) -> dict[str, DesignParameter]:
    """The named design parameters of ``model`` (its ``[design]`` table) and ``extra`` ones
    (a study file's ``[design]``, which take precedence)."""
    return {**model.design, **(extra or {})}


def parameter_names(model: Model, extra: Mapping[str, DesignParameter] | None = None) -> tuple:
    """Every named parameter (design then process); hinge overrides follow their pattern."""
    return (*design_parameters(model, extra), *PROCESS_PARAMETERS)


def design_target(
    name: str, parameters: Mapping[str, DesignParameter]
) -> tuple[str, str, tuple[int, ...]]:
    """(hinge, field, components) that design parameter ``name`` sets.

    Raises
    ------
    KeyError
        ``name`` is neither a declared design parameter nor ``hinge.<name>.<field>[i]``.
    """
    if name in parameters:
        p = parameters[name]
        return p.hinge, p.field, p.components
    match = _HINGE_PARAMETER.fullmatch(name)
    if match is None:
        raise KeyError(name)
    return match["hinge"], match["field"], (int(match["index"]),)


def unknown_design_parameter(
    name: str, model: Model, extra: Mapping[str, DesignParameter] | None = None
) -> str | None:
    """Why ``name`` is not a design parameter of ``model`` (with a did-you-mean), or None."""
    parameters = design_parameters(model, extra)
    try:
        hinge, _, _ = design_target(name, parameters)
    except KeyError:
        close = closest_name(name, parameter_names(model, extra), cutoff=0.5)
        hint = f"did you mean {close!r}?" if close else f"declared: {', '.join(parameters)}"
        return (
            f"unknown parameter {name!r} ({hint}; or hinge.<name>.stiffness[i]; declare others "
            "in a [design] table)"
        )
    hinges = [h.name for h in model.hinges]
    if hinge not in hinges:
        close = closest_name(hinge, hinges)
        hint = f"did you mean {close!r}?" if close else f"hinges: {', '.join(hinges)}"
        return f"parameter {name!r}: model {model.source} has no hinge {hinge!r} ({hint})"
    return None


def apply_design(
    model: Model,
    design: Mapping[str, float],
    parameters: Mapping[str, DesignParameter] | None = None,
) -> Model:
    """A copy of ``model`` with the hinge stiffnesses of ``design`` [N/m, N m/rad] set.

    A parameter over several components (radial: x and y; angular: about x and y) is their
    arithmetic mean: setting it scales the components in proportion, so the calibrated
    anisotropy is kept and the calibrated value gives back the calibrated model. Components
    whose mean is 0 or infinite are all set to the value. ``parameters`` adds declarations to
    the model's own (:func:`design_parameters`).

    Raises
    ------
    StudyError
        An unknown parameter or hinge name.
    ModelError
        A value the model file could not hold (negative, NaN, outside ``LIMITS``), in the
        loader's one-line message.
    """
    declared = design_parameters(model, parameters)
    changes: dict[str, dict[str, np.ndarray]] = {}
    for name, value in design.items():
        problem = unknown_design_parameter(name, model, parameters)
        if problem:
            raise StudyError(problem)
        hinge, field, components = design_target(name, declared)
        fields_ = changes.setdefault(hinge, {})
        current = fields_.setdefault(field, np.array(getattr(model.hinge(hinge), field)))
        old = current[list(components)]
        mean = old.mean()
        value = float(value)
        scaled = old * (value / mean) if np.isfinite(mean) and mean > 0 else value
        current[list(components)] = scaled
        check_hinge_values(model, hinge, field, current, f"design parameter {name} = {value!r}")
    for hinge, fields_ in changes.items():
        model = model.with_hinge(hinge, **fields_)
    return model


def design_value(
    model: Model, name: str, parameters: Mapping[str, DesignParameter] | None = None
) -> float:
    """The value of design parameter ``name`` in ``model``: the mean of its components [SI]."""
    hinge, field, components = design_target(name, design_parameters(model, parameters))
    return float(np.mean(getattr(model.hinge(hinge), field)[list(components)]))


# ---------------------------------------------------------------------------------------------
# model file and code identity


def model_file(model: str | os.PathLike | None) -> Path:
    """The model file to use: ``model`` or, if None, the packaged UFMT."""
    return packaged_path() if model is None else Path(model)


def cutting_travel_mm(model: str | os.PathLike | None = None) -> float:
    """Slide travel of one finishing pass [mm]: workpiece length along y + 2 R, from the first
    touch of the tool circle to its exit (``Machine.cut_span`` of the model's ``[machine]``)."""
    from ufmt.model.load import load_model
    from ufmt.model.machine import machine_of

    low, high = machine_of(load_model(model_file(model))).cut_span
    return (high - low) * 1e3


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 hex digest of a file's bytes."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def model_sha256(model: Model) -> str:
    """SHA-256 of a model's content (its canonical TOML): comments, layout and the file's
    location do not change it."""
    from ufmt.model.write import model_to_toml

    return hashlib.sha256(model_to_toml(model).encode()).hexdigest()


def source_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a Python file's syntax tree: comments and formatting do not change it (a
    file that does not parse is hashed by its bytes)."""
    import ast

    text = Path(path).read_bytes()
    try:
        return hashlib.sha256(ast.dump(ast.parse(text)).encode()).hexdigest()
    except (SyntaxError, ValueError):
        return hashlib.sha256(text).hexdigest()


@functools.cache
def code_sha256() -> str:
    """SHA-256 over the physics source (syntax trees of every ``ufmt/**/*.py`` outside
    studies, plots, cli and calibration), keyed by their paths inside the package."""
    digest = hashlib.sha256()
    for path in sorted(_PACKAGE.rglob("*.py")):
        relative = path.relative_to(_PACKAGE)
        if relative.parts[0] in _NOT_PHYSICS:
            continue
        digest.update(relative.as_posix().encode())
        digest.update(source_sha256(path).encode())
    return digest.hexdigest()


# ---------------------------------------------------------------------------------------------
# evaluation


def evaluate(
    design: Mapping[str, float],
    process,
    model: str | os.PathLike | Model | None = None,
    *,
    parameters: Mapping[str, DesignParameter] | None = None,
) -> dict:
    """Surface metrics and natural frequencies of one design under one cutting process.

    Parameters
    ----------
    design
        Design parameters (module docstring) -> value [N/m or N m/rad]; missing ones keep the
        model's calibrated values.
    process
        A :class:`ufmt.Process` or a mapping of ``rpm`` [rev/min], ``feed_mm_min`` [mm/min],
        ``depth_um`` [um]; missing ones take the reference case (300 rpm, 15 mm/min, 4 um).
    model
        Model file or loaded :class:`~ufmt.model.schema.Model`; None for the packaged UFMT.
    parameters
        Design parameters declared outside the model (a study file's ``[design]`` table).

    Returns
    -------
    dict
        The inputs, then ``pv_nm``, ``pv_aperture_nm`` (clear aperture), ``pv_tilt_removed_nm``,
        ``rms_nm``, ``psd1_rms_nm``, ``psd2_rms_nm`` [nm] (surface of paper eq. 4.1; NaN where a
        band is not resolved), ``force_peak_n`` [N], ``pv_<source>_nm`` [nm] for each error
        source of :mod:`ufmt.machining.sources` alone, ``f1_hz`` .. ``f6_hz`` (first natural
        frequencies [Hz]), ``status`` ("ok" or "error") and ``message`` (warnings or the error,
        one line; empty if none). On error the metrics are NaN.

    Raises
    ------
    StudyError
        An unknown design or process parameter name (a caller's mistake, not physics).
    ModelError
        A model file that cannot be loaded, or a design value it could not hold (negative,
        NaN, outside the loader's ``LIMITS``).
    """
    process = _process_mapping(process)
    for name in process:
        if name not in PROCESS_PARAMETERS:
            close = closest_name(name, PROCESS_PARAMETERS)
            hint = f"did you mean {close!r}?" if close else ", ".join(PROCESS_PARAMETERS)
            raise StudyError(f"evaluate: unknown process parameter {name!r} ({hint})")
    base, base_sha = resolve_model(model)
    design_items = tuple(sorted((k, float(v)) for k, v in design.items()))
    designed = apply_design(base, dict(design_items), parameters)
    process_full = {**REFERENCE_PROCESS, **{k: float(v) for k, v in process.items()}}
    record: dict = {**dict(design_items), **process_full}
    try:
        changes = _hinge_changes(base, designed)
        key = {
            "model_sha256": base_sha,
            "code_sha256": code_sha256(),
            "hinges": [[name, [repr(v) for v in values]] for name, values in changes],
            "process": {k: repr(v) for k, v in process_full.items()},
        }
        outputs = evaluate_cache.load(key, METRICS + FREQUENCIES)
        if outputs is None:
            outputs = _physics(designed, process_full, (base_sha, changes))
            evaluate_cache.store(key, outputs)
        message = outputs.pop("message")
        record.update(outputs, status="ok", message=message)
    except Exception as exc:  # any physics failure becomes a recorded error
        record.update(dict.fromkeys(METRICS + FREQUENCIES, math.nan))
        record.update(status="error", message=_one_line(f"{type(exc).__name__}: {exc}"))
    return record


def _process_mapping(process) -> dict:
    """A process given as a mapping or a dataclass (``ufmt.Process``) as a dict."""
    if is_dataclass(process) and not isinstance(process, type):
        return {f.name: getattr(process, f.name) for f in fields(process)}
    if not isinstance(process, Mapping):
        raise StudyError(
            f"evaluate: process must be a ufmt.Process or a mapping, not {type(process).__name__}"
        )
    return dict(process)


def _number(value) -> float:
    """A metric as a float; None (a source switched off, a band not resolved) as NaN."""
    return math.nan if value is None else float(value)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def resolve_model(model) -> tuple[Model, str]:
    """The model (path, loaded model or None = packaged) and its content hash (kept for the
    last few files in memory, keyed by their bytes).

    Raises
    ------
    ModelError
        The file cannot be read or is not a valid model.
    """
    if isinstance(model, Model):
        return model, model_sha256(model)
    path = model_file(model)
    try:
        sha = file_sha256(path)
    except OSError:
        sha = ""  # load_model gives the one-line error
    return _load_model(str(path), sha)


@functools.lru_cache(maxsize=4)
def _load_model(path: str, file_sha: str) -> tuple[Model, str]:
    """The model file at ``path`` (bytes ``file_sha``, which keys this cache) and its content
    hash."""
    from ufmt.model.load import load_model

    model = load_model(path)
    return model, model_sha256(model)


def _physics(model: Model, process: Mapping[str, float], basis_key) -> dict:
    """Metrics [nm], frequencies [Hz] and warnings of one case; raises on any failure."""
    from ufmt.machining.process import Process
    from ufmt.simulate import simulate

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        basis = _modal_basis(model, basis_key)
        result = simulate(model, Process(**process), basis=basis)
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


_BASES = Recent(BASIS_CACHE)  # (model_sha, hinge changes) -> ModalBasis


def _modal_basis(model, key):
    """Modal basis (first N_MODES modes) of ``model``, kept for the last BASIS_CACHE designs so
    that process changes on a known design reuse it."""
    from ufmt.machining.modal import modal_basis

    return _BASES.get(key, lambda: modal_basis(model, N_MODES))
