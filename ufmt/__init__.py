"""ufmt: dynamics of ultra-precision fly-cutting machine tools (MSTMM).

Public entry points (imported lazily, so ``import ufmt`` stays cheap):

- ``ufmt.load_model(path)``: read and validate a model file;
- ``ufmt.solve_modes(model, fmax_hz=None, count=None, method="mstmm")``: natural frequencies
  and mode shapes;
- ``ufmt.simulate(model, process, ...)``: tool-tip response, machined surface and its PV;
- ``ufmt.evaluate(design, process, model=None)``: the study function (design, process) → PV.
"""

from importlib import import_module

__version__ = "0.1.0"

_EXPORTS = {
    "load_model": "ufmt.model.load",
    "solve_modes": "ufmt.mstmm.solve",
    "simulate": "ufmt.simulate",
    "evaluate": "ufmt.evaluate",
    "Process": "ufmt.dynamics.process",
}


def __getattr__(name):
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'ufmt' has no attribute {name!r}")


__all__ = list(_EXPORTS)
