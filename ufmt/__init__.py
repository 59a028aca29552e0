"""ufmt: dynamics of ultra-precision fly-cutting machine tools (MSTMM).

Public entry points:

- ``ufmt.load_model(path=None)``: read and validate a model file (default: the packaged,
  calibrated UFMT, ``ufmt.packaged_path()``);
- ``ufmt.solve_modes(model, fmax_hz=None, count=None, method="mstmm")``: natural frequencies
  and mode shapes (:class:`ufmt.ModalSolution`: ``.to_frame()``, ``.plot()``, ``.save()``);
- ``ufmt.simulate(model, ufmt.Process(rpm, feed_mm_min, depth_um), ...)``: tool-tip response,
  machined surface and its PV;
- ``ufmt.evaluate(design, process, model=None)``: the study function (design, process) → PV;
  ``process`` is a ``ufmt.Process`` or a dict; returns a :class:`ufmt.EvaluationRecord`;
- ``ufmt.frf(model, direction="z", kind="receptance", output=None, input=None, ...)``:
  tool-workpiece or point-to-point FRF in any direction (:class:`ufmt.FrfResult`).

Every ``model`` argument takes a path or a loaded model; modes are numbered from 1.
"""

__version__ = "0.1.0"

# Imported eagerly: the functions ``simulate`` and ``evaluate`` share their names with their
# modules, and binding them here (after the submodules load) keeps ``ufmt.simulate`` the
# function whatever is imported later.
from ufmt.evaluate import EvaluationRecord, evaluate  # noqa: E402
from ufmt.machining.frf import FrfResult, frf  # noqa: E402
from ufmt.machining.process import Process  # noqa: E402
from ufmt.model.load import load_model, packaged_path  # noqa: E402
from ufmt.mstmm.solve import ModalSolution, solve_modes  # noqa: E402
from ufmt.simulate import simulate  # noqa: E402

__all__ = [
    "EvaluationRecord",
    "FrfResult",
    "ModalSolution",
    "Process",
    "evaluate",
    "frf",
    "load_model",
    "packaged_path",
    "simulate",
    "solve_modes",
]
