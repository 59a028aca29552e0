"""The vocabulary of the study function ``evaluate(design, process)``: the design parameters and
the hinge values they set, the process parameters and their reference case, and the names of
the record's outputs.

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

A model with a ``[machine]`` table also takes ``machine.<key>``, any optional number of that
table (``machine.force_scale``, ``machine.straightness_m``, ...; the list and the bands are
:data:`ufmt.model.machine.OPTIONAL_FIELDS`, so a key added there is a parameter at once), and
``machine.workpiece_size[i]`` (i = 0, 1: the plate's x and y side [m]). A value is checked by
the ``[machine]`` reader (its band, the plate inside the tool circle).

Process parameters: ``rpm`` [rev/min], ``feed_mm_min`` [mm/min], ``depth_um`` [um]; a missing
one takes the paper's reference case (300 rpm, 15 mm/min, 4 um; Table 4).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from ufmt.defaults import REFERENCE_PROCESS
from ufmt.errors import ModelError, StudyError, closest_name
from ufmt.machining.sources import SOURCES
from ufmt.model.design import (
    MACHINE_PAIRS,
    MACHINE_PREFIX,
    design_target,
    machine_target,
    parameter_value,
)
from ufmt.model.hinges import check_hinge_values
from ufmt.model.machine import OPTIONAL_FIELDS, read_machine
from ufmt.model.schema import DesignParameter, Model

PROCESS_PARAMETERS = tuple(REFERENCE_PROCESS)

N_FREQUENCIES = 6  # natural frequencies reported in each record
#: PV [nm] of the surface with one error source alone (ufmt.machining.sources.SOURCES).
SOURCE_METRICS = tuple(f"pv_{source}_nm" for source in SOURCES)
#: The record's metrics in order, each with whether the physics always gives it as a finite
#: number (the others may be NaN: a band not resolved, a source switched off).
_METRICS_FINITE = (
    ("pv_nm", True),
    ("pv_aperture_nm", True),
    ("pv_tilt_removed_nm", True),
    ("pv_measured_nm", True),
    ("rms_measured_nm", True),
    ("rms_nm", True),
    ("psd1_rms_nm", False),
    ("psd2_rms_nm", False),
    ("force_peak_n", True),
    *((name, False) for name in SOURCE_METRICS),
    ("waviness_rms_nm", False),
    ("zre_peak_nm", False),
    ("tip_acc_measured_mm_s2", False),
    # pv_dynamic_nm, the dynamic surface's whole-plate PV, is the dynamic source's (above)
    ("pv_dynamic_steady_nm", False),
    ("edge_runout_nm", False),
)
METRICS = tuple(name for name, _ in _METRICS_FINITE)
#: Metrics the physics always gives as a finite number.
ALWAYS_FINITE = tuple(name for name, finite in _METRICS_FINITE if finite)
FREQUENCIES = tuple(f"f{i}_hz" for i in range(1, N_FREQUENCIES + 1))


def machine_parameters() -> tuple[str, ...]:
    """Every ``machine.`` parameter name (optional numbers, then pair components)."""
    pairs = tuple(f"{MACHINE_PREFIX}{k}[{i}]" for k in MACHINE_PAIRS for i in (0, 1))
    return (*(f"{MACHINE_PREFIX}{k}" for k in OPTIONAL_FIELDS), *pairs)


def design_parameters(
    model: Model, extra: Mapping[str, DesignParameter] | None = None
) -> dict[str, DesignParameter]:
    """The named design parameters of ``model`` (its ``[design]`` table) and ``extra`` ones
    (a study file's ``[design]``, which take precedence)."""
    return {**model.design, **(extra or {})}


def parameter_names(model: Model, extra: Mapping[str, DesignParameter] | None = None) -> tuple:
    """Every named parameter (design, machine, then process); hinge overrides follow their
    pattern."""
    machine = machine_parameters() if model.machine is not None else ()
    return (*design_parameters(model, extra), *machine, *PROCESS_PARAMETERS)


def unknown_design_parameter(
    name: str, model: Model, extra: Mapping[str, DesignParameter] | None = None
) -> str | None:
    """Why ``name`` is not a design parameter of ``model`` (with a did-you-mean), or None."""
    parameters = design_parameters(model, extra)
    if name.startswith(MACHINE_PREFIX) and name not in parameters:
        return _unknown_machine_parameter(name, model)
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


def _unknown_machine_parameter(name: str, model: Model) -> str | None:
    """Why ``name`` (``machine.``...) is not a parameter of ``model``, or None."""
    if model.machine is None:
        return f"parameter {name!r}: model {model.source} has no [machine] table"
    if machine_target(name) is None:
        choices = machine_parameters()
        close = closest_name(name, choices, cutoff=0.5)
        hint = f"did you mean {close!r}?" if close else f"machine parameters: {', '.join(choices)}"
        return f"unknown parameter {name!r} ({hint})"
    return None


def _apply_machine(model: Model, design: Mapping[str, float]) -> Model:
    """A copy of ``model`` with the ``machine.`` values of ``design`` set (checked by the
    ``[machine]`` reader: bands, plate inside the tool circle)."""
    table = dict(model.machine.table)
    for name, value in design.items():
        key, index = machine_target(name)
        if index is None:
            table[key] = float(value)
        else:
            pair = list(table.get(key, getattr(model.machine, key)))
            pair[index] = float(value)
            table[key] = pair
    try:
        machine = read_machine(table, model.source)
    except ModelError as exc:
        raise ModelError(f"design parameters {', '.join(design)}: {exc}") from None
    return replace(model, machine=machine)


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
    machine = {}
    for name, value in design.items():
        problem = unknown_design_parameter(name, model, parameters)
        if problem:
            raise StudyError(problem)
        if name.startswith(MACHINE_PREFIX) and name not in declared:
            machine[name] = value
            continue
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
    return _apply_machine(model, machine) if machine else model


def design_value(
    model: Model, name: str, parameters: Mapping[str, DesignParameter] | None = None
) -> float:
    """The value of design parameter ``name`` in ``model``: the mean of its components [SI]
    (a ``machine.`` parameter: the ``[machine]`` value)."""
    return parameter_value(model, name, design_parameters(model, parameters))
