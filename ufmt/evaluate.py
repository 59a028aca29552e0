"""The machine as a function: (design, process) -> machined-surface record (issue 5).

:func:`evaluate` is what every study calls. It is pure (its result depends only on its
arguments, the model file's content and the physics code), picklable (a module-level function
of plain dicts and a path) and never raises for a physics failure: the failure is recorded in
the returned record with ``status = "error"`` and a one-line ``message``.

Design parameters (units in the names) map onto hinges of the packaged UFMT model
(``h31`` = fly-cutting-head air bearing, ``h25`` = spindle air bearing; spindle axis = global z):

* ``head_radial_stiffness_N_m``: h31 ``stiffness[0]`` and ``[1]`` (x and y) [N/m];
* ``head_axial_stiffness_N_m``: h31 ``stiffness[2]`` (z) [N/m];
* ``head_angular_stiffness_Nm_rad``: h31 ``rotational_stiffness[0]`` and ``[1]`` [N m/rad]
  (about z the bearing stays released);
* ``spindle_radial_stiffness_N_m``, ``spindle_axial_stiffness_N_m``,
  ``spindle_angular_stiffness_Nm_rad``: the same components of h25;
* ``hinge.<name>.stiffness[i]`` and ``hinge.<name>.rotational_stiffness[i]``: one component
  (i = 0, 1, 2 for x, y, z) of any hinge.

Process parameters: ``rpm`` [rev/min], ``feed_mm_min`` [mm/min], ``depth_um`` [um]; a missing
one takes the paper's reference case (300 rpm, 15 mm/min, 4 um; Table 4).

Caching: whole records are cached on disk with :class:`joblib.Memory`, keyed on the design, the
process, the SHA-256 of the model file and of the physics source code (every ``ufmt`` module
outside ``ufmt.studies`` and ``ufmt.plots``). The directory is ``$UFMT_CACHE_DIR`` if set (set
it to the empty string to switch the disk cache off), else ``$XDG_CACHE_HOME/ufmt`` or
``~/.cache/ufmt``. Failed evaluations are not cached. Within one process the modal basis of
the last designs is kept in memory, so a change of process on a known design reuses it.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import re
import threading
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ufmt.errors import StudyError
from ufmt.model.load import packaged_path

HEAD_HINGE = "h31"
SPINDLE_HINGE = "h25"
N_MODES = 30  # modes in the modal basis (paper section 3.2 uses the first 30)
N_FREQUENCIES = 6  # natural frequencies reported in each record
BASIS_CACHE = 4  # modal bases kept in memory per process (recent designs)

# name -> (hinge, field, components set to the value)
DESIGN_PARAMETERS: dict[str, tuple[str, str, tuple[int, ...]]] = {
    "head_radial_stiffness_N_m": (HEAD_HINGE, "stiffness", (0, 1)),
    "head_axial_stiffness_N_m": (HEAD_HINGE, "stiffness", (2,)),
    "head_angular_stiffness_Nm_rad": (HEAD_HINGE, "rotational_stiffness", (0, 1)),
    "spindle_radial_stiffness_N_m": (SPINDLE_HINGE, "stiffness", (0, 1)),
    "spindle_axial_stiffness_N_m": (SPINDLE_HINGE, "stiffness", (2,)),
    "spindle_angular_stiffness_Nm_rad": (SPINDLE_HINGE, "rotational_stiffness", (0, 1)),
}
REFERENCE_PROCESS = {"rpm": 300.0, "feed_mm_min": 15.0, "depth_um": 4.0}
PROCESS_PARAMETERS = tuple(REFERENCE_PROCESS)
METRICS = ("pv_nm", "pv_tilt_removed_nm", "rms_nm", "psd1_rms_nm", "psd2_rms_nm")
FREQUENCIES = tuple(f"f{i}_hz" for i in range(1, N_FREQUENCIES + 1))
OUTPUTS = METRICS + FREQUENCIES + ("status", "message")

_HINGE_PARAMETER = re.compile(
    r"hinge\.(?P<hinge>[^.\[\]]+)\.(?P<field>stiffness|rotational_stiffness)\[(?P<index>[012])\]"
)
_PACKAGE = Path(__file__).resolve().parent
_NOT_PHYSICS = ("studies", "plots", "cli", "calibration")


# ---------------------------------------------------------------------------------------------
# parameters


def parameter_names() -> tuple[str, ...]:
    """Every named parameter (design then process); hinge overrides follow their pattern."""
    return (*DESIGN_PARAMETERS, *PROCESS_PARAMETERS)


def design_target(name: str) -> tuple[str, str, tuple[int, ...]]:
    """(hinge, field, components) that design parameter ``name`` sets.

    Raises
    ------
    KeyError
        ``name`` is neither a named design parameter nor ``hinge.<name>.<field>[i]``.
    """
    if name in DESIGN_PARAMETERS:
        return DESIGN_PARAMETERS[name]
    match = _HINGE_PARAMETER.fullmatch(name)
    if match is None:
        raise KeyError(name)
    return match["hinge"], match["field"], (int(match["index"]),)


def is_design_parameter(name: str) -> bool:
    """True for a named design parameter or a ``hinge.<name>.<field>[i]`` override."""
    try:
        design_target(name)
    except KeyError:
        return False
    return True


def is_parameter(name: str) -> bool:
    """True for any design or process parameter."""
    return name in PROCESS_PARAMETERS or is_design_parameter(name)


def apply_design(model, design: Mapping[str, float]):
    """A copy of ``model`` with the hinge stiffnesses of ``design`` [N/m, N m/rad] set.

    A parameter over several components (radial: x and y; angular: about x and y) is their
    arithmetic mean: setting it scales the components in proportion, so the calibrated
    anisotropy is kept and the calibrated value gives back the calibrated model. Components
    whose mean is 0 or infinite are all set to the value.

    Raises
    ------
    KeyError
        An unknown parameter or hinge name.
    """
    changes: dict[str, dict[str, np.ndarray]] = {}
    for name, value in design.items():
        hinge, field, components = design_target(name)
        fields = changes.setdefault(hinge, {})
        current = fields.setdefault(field, np.array(getattr(model.hinge(hinge), field)))
        old = current[list(components)]
        mean = old.mean()
        scaled = old * (float(value) / mean) if np.isfinite(mean) and mean > 0 else float(value)
        current[list(components)] = scaled
    for hinge, fields in changes.items():
        model = model.with_hinge(hinge, **fields)
    return model


def design_value(model, name: str) -> float:
    """The value of design parameter ``name`` in ``model``: the mean of its components [SI]."""
    hinge, field, components = design_target(name)
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


@functools.cache
def code_sha256() -> str:
    """SHA-256 over the physics source: every ``ufmt/**/*.py`` outside studies and plots."""
    digest = hashlib.sha256()
    for path in sorted(_PACKAGE.rglob("*.py")):
        relative = path.relative_to(_PACKAGE)
        if relative.parts[0] in _NOT_PHYSICS:
            continue
        digest.update(str(relative).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


# ---------------------------------------------------------------------------------------------
# evaluation


def evaluate(
    design: Mapping[str, float],
    process: Mapping[str, float],
    model: str | os.PathLike | None = None,
) -> dict:
    """Surface metrics and natural frequencies of one design under one cutting process.

    Parameters
    ----------
    design
        Design parameters (module docstring) -> value [N/m or N m/rad]; missing ones keep the
        model's calibrated values.
    process
        ``rpm`` [rev/min], ``feed_mm_min`` [mm/min], ``depth_um`` [um]; missing ones take the
        reference case (300 rpm, 15 mm/min, 4 um).
    model
        Model file; None for the packaged, calibrated UFMT.

    Returns
    -------
    dict
        The inputs, then ``pv_nm``, ``pv_tilt_removed_nm``, ``rms_nm``, ``psd1_rms_nm``,
        ``psd2_rms_nm`` [nm] (surface of paper eq. 4.1), ``f1_hz`` .. ``f6_hz`` (first natural
        frequencies [Hz]), ``status`` ("ok" or "error") and ``message`` (warnings or the error,
        one line; empty if none). On error the metrics are NaN.

    Raises
    ------
    StudyError
        An unknown design or process parameter name (a caller's mistake, not physics).
    """
    for name in design:
        if not is_design_parameter(name):
            raise StudyError(f"evaluate: unknown design parameter {name!r}")
    for name in process:
        if name not in PROCESS_PARAMETERS:
            raise StudyError(f"evaluate: unknown process parameter {name!r}")
    design_items = tuple(sorted((k, float(v)) for k, v in design.items()))
    process_full = {**REFERENCE_PROCESS, **{k: float(v) for k, v in process.items()}}
    record: dict = {**dict(design_items), **process_full}
    try:
        path = model_file(model)
        outputs = _cached_physics()(
            design_items, tuple(process_full.items()), file_sha256(path), code_sha256(), str(path)
        )
        message = outputs.pop("message")
        record.update(outputs, status="ok", message=message)
    except Exception as exc:  # any physics failure becomes a recorded error
        record.update(dict.fromkeys(METRICS + FREQUENCIES, math.nan))
        record.update(status="error", message=_one_line(f"{type(exc).__name__}: {exc}"))
    return record


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _cache_location() -> str | None:
    configured = os.environ.get("UFMT_CACHE_DIR")
    if configured is not None:
        return configured or None
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return str(Path(base) / "ufmt")


def _cached_physics():
    return _memory_cached(_cache_location())


@functools.cache
def _memory_cached(location: str | None):
    import joblib

    memory = joblib.Memory(location, verbose=0)
    return memory.cache(_physics, ignore=["path"])


def _physics(design_items, process_items, model_sha, code_sha, path) -> dict:
    """Metrics [nm] and frequencies [Hz] of one case; raises on any failure (not cached)."""
    from ufmt.machining.process import Process
    from ufmt.simulate import simulate

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        base = _base_model(path, model_sha)
        model = apply_design(base, dict(design_items))
        basis = _modal_basis(model, (model_sha, _hinge_changes(base, model)))
        result = simulate(model, Process(**dict(process_items)), basis=basis)
    outputs = {name: float(result.metrics[name]) for name in METRICS}
    frequencies = list(basis.omega[:N_FREQUENCIES] / (2.0 * math.pi))
    frequencies += [math.nan] * (N_FREQUENCIES - len(frequencies))
    outputs.update(zip(FREQUENCIES, map(float, frequencies), strict=True))
    outputs["message"] = _one_line("; ".join(dict.fromkeys(str(w.message) for w in caught)))
    return outputs


@functools.lru_cache(maxsize=4)
def _base_model(path: str, model_sha: str):
    """The model file at ``path`` (content ``model_sha``, which keys the cache)."""
    from ufmt.model.load import load_model

    return load_model(path)


def _hinge_changes(base, model) -> tuple:
    """The hinges whose stiffness ``model`` changed from ``base``: a design's identity (a
    design that restates calibrated values is the calibrated design)."""
    return tuple(
        (new.name, tuple(new.stiffness6))
        for new, old in zip(model.hinges, base.hinges, strict=True)
        if tuple(new.stiffness6) != tuple(old.stiffness6)
    )


_BASES: dict = {}  # (model_sha, hinge changes) -> ModalBasis, least recently used first
_BASES_LOCK = threading.Lock()  # dask workers may evaluate in threads


def _modal_basis(model, key):
    """Modal basis (first N_MODES modes) of ``model``, kept for the last BASIS_CACHE designs so
    that process changes on a known design reuse it."""
    from ufmt.machining.modal import modal_basis

    with _BASES_LOCK:
        basis = _BASES.pop(key, None)
    if basis is None:
        basis = modal_basis(model, N_MODES)
    with _BASES_LOCK:
        _BASES[key] = basis
        while len(_BASES) > BASIS_CACHE:
            del _BASES[next(iter(_BASES))]
    return basis
