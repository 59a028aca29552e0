"""ufmt: dynamics of ultra-precision fly-cutting machine tools (MSTMM).

Public entry points:

- ``ufmt.load_model(path=None)``: read and validate a model file (default: the packaged,
  calibrated UFMT, ``ufmt.packaged_path()``);
- ``ufmt.solve_modes(model, fmax_hz=None, count=None, method="mstmm")``: natural frequencies
  and mode shapes (:class:`ufmt.ModalSolution`: ``.to_frame()``, ``.plot()``, ``.save()``);
- ``ufmt.simulate(model, ufmt.Process(rpm, feed_mm_min, depth_um), ...)``: tool-tip response,
  machined surface and its PV; ``process`` a ``ufmt.Process`` or a dict, as ``evaluate``;
- ``ufmt.evaluate(design, process, model=None)``: the study function (design, process) → PV;
  the design first (None: the model as it is), the model third or ``model=``; ``process`` is a
  ``ufmt.Process`` or a dict; returns a :class:`ufmt.EvaluationRecord`;
  ``ufmt.evaluate_batch(designs, processes, model=None)`` the same for many points at once;
- ``ufmt.frf(model, direction="z", kind="receptance", output=None, input=None, ...)``:
  tool-workpiece or point-to-point FRF in any direction (:class:`ufmt.FrfResult`);
- ``ufmt.read_surface(path, feed_direction="y", ...)``: a measured height map (MetroPro, x3p,
  SDF, xyz, ufmt's exports) through the instrument pipeline
  (:class:`ufmt.measured.analysis.MeasuredSurface`);
- ``ufmt.read_modal_test(path, unit=None)``: a modal test (CSV or universal file) with its
  sensors (positions [m]), frequencies, damping ratios and shapes (docs/modal-test.md).

Every ``model`` argument takes a path, a loaded model or None (the packaged UFMT); a model
in another argument's place is refused with the order (:mod:`ufmt.arguments`); every request
is bounded before it allocates (:mod:`ufmt.limits`); modes are numbered from 1.
"""

import sys
import types

__version__ = "0.1.0"

# The public names load their modules on first use (PEP 562): ``import ufmt`` and
# ``ufmt --version`` stay instant, and a command pays only for the stages it runs.
_PUBLIC = {
    "EvaluationRecord": "ufmt.evaluate",
    "FrfResult": "ufmt.machining.frf",
    "ModalSolution": "ufmt.mstmm.solve",
    "Process": "ufmt.machining.process",
    "evaluate": "ufmt.evaluate",
    "evaluate_batch": "ufmt.evaluate",
    "frf": "ufmt.machining.frf",
    "load_model": "ufmt.model.load",
    "packaged_path": "ufmt.model.load",
    "read_modal_test": "ufmt.calibration.modal_test",
    "read_surface": "ufmt.measured.analysis",
    "simulate": "ufmt.simulate",
    "solve_modes": "ufmt.solvers",
}
__all__ = sorted(_PUBLIC)


def __getattr__(name: str):
    """The public function or class ``name``, imported from its module when first asked for
    and bound here."""
    if name not in _PUBLIC:
        raise AttributeError(f"module 'ufmt' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(_PUBLIC[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_PUBLIC])


class _Package(types.ModuleType):
    """The package module: ``simulate`` and ``evaluate`` share their names with their modules,
    and importing ``ufmt.simulate`` binds the module on the package; the function is bound
    instead, so ``ufmt.simulate`` is the function whatever is imported when."""

    def __setattr__(self, name, value):
        if name in _PUBLIC and isinstance(value, types.ModuleType) and hasattr(value, name):
            value = getattr(value, name)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
