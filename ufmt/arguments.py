"""The public functions' arguments, checked one way everywhere (``ufmt.simulate``,
``ufmt.evaluate``, ``ufmt.frf``, ``ufmt.solve_modes``).

One order: the model comes first in ``simulate(model, process)``, ``frf(model, ...)`` and
``solve_modes(model, ...)``; ``evaluate(design, process, model=None)`` takes the design first and
the model as its third argument or keyword. A model passed where a design or process is due
(or the reverse) is refused with a message that names the order. Every ``model`` takes a path,
a loaded model or None (the packaged UFMT); every ``process`` a :class:`ufmt.Process` or a
mapping of ``rpm``, ``feed_mm_min``, ``depth_um`` (missing ones: the reference case). A
boolean or text where a number is due is refused, never converted.
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Mapping

from ufmt import limits
from ufmt.defaults import REFERENCE_PROCESS
from ufmt.errors import ProcessError, StudyError, closest_name
from ufmt.machining.process import Process
from ufmt.model.schema import Model


def is_model(value) -> bool:
    """Whether ``value`` is what a ``model`` argument takes (a loaded model or a path)."""
    return isinstance(value, Model | str | os.PathLike)


def is_process(value) -> bool:
    """Whether ``value`` is what a ``process`` argument takes."""
    return isinstance(value, Process | Mapping)


def as_process(process, caller: str) -> Process:
    """``process`` (a :class:`Process` or a mapping; missing names from the reference case) as
    a :class:`Process`; an unknown name or a value that is not a number raises
    :class:`~ufmt.errors.ProcessError`."""
    if isinstance(process, Process):
        return process
    if not isinstance(process, Mapping):
        raise ProcessError(
            f"{caller}: process must be a ufmt.Process or a mapping of "
            f"{', '.join(REFERENCE_PROCESS)}, not {type(process).__name__}"
        )
    for name in process:
        if name not in REFERENCE_PROCESS:
            close = closest_name(name, REFERENCE_PROCESS)
            hint = f"did you mean {close!r}?" if close else ", ".join(REFERENCE_PROCESS)
            raise ProcessError(f"{caller}: unknown process parameter {name!r} ({hint})")
    return Process(**{**REFERENCE_PROCESS, **process})


def simulate_inputs(model, process) -> tuple:
    """``(model, process)`` of ``simulate``, refusing the two in the other order."""
    if is_process(model) and (process is None or is_model(process)):
        raise ProcessError(
            "simulate(model, process): the model comes first (a path, a loaded model or None),"
            f" got a process {type(model).__name__} as the model"
        )
    return model, as_process(process, "simulate")


def check_design(design, caller: str = "evaluate") -> dict:
    """``design`` (a mapping of parameter -> number; None: no change) as a dict of floats; a
    model in its place, a boolean or text value raise :class:`~ufmt.errors.StudyError`."""
    if design is None:
        return {}
    if is_model(design):
        raise StudyError(
            f"{caller}(design, process, model=None): the design comes first (a mapping of"
            f" parameter -> value, or None), got a model ({type(design).__name__}); pass the"
            " model as the third argument or model=..."
        )
    if not isinstance(design, Mapping):
        raise StudyError(
            f"{caller}: design must be a mapping of parameter -> value or None, not"
            f" {type(design).__name__}"
        )
    return {name: _design_value(caller, name, value) for name, value in design.items()}


def _design_value(caller: str, name, value) -> float:
    """One design value as a float; a boolean, text or other non-number raises (its range is
    the design parameter's own check, :mod:`ufmt.design`)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise StudyError(
            f"{caller}: design parameter {limits.shown(name)}: {limits.shown(value)} is not a"
            " number"
        )
    return float(value)
