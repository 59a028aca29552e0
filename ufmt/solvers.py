"""``solve_modes`` by either eigen-solver: the MSTMM (:mod:`ufmt.mstmm`, the default) or the
independent assembled mass-stiffness model (:mod:`ufmt.assembled`, for cross-checks). The two
packages import nothing from each other; this module is the one place that knows both."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from ufmt import limits
from ufmt.errors import UfmtError
from ufmt.kinds import frequency_dependent
from ufmt.model.load import as_model
from ufmt.model.schema import Model
from ufmt.mstmm.dependent import dependent_modes
from ufmt.mstmm.solve import DEFAULT_FMAX_HZ, ModalSolution
from ufmt.mstmm.solve import solve_modes as mstmm_modes
from ufmt.mstmm.solve import solve_modes_batch as mstmm_modes_batch

METHODS = ("mstmm", "assembled")


def solve_modes(
    model: Model | str | Path | None,
    fmax_hz: float | None = None,
    count: int | None = None,
    method: str = "mstmm",
    shapes: bool = True,
) -> ModalSolution:
    """Natural frequencies (and shapes) below ``fmax_hz`` or the first ``count`` modes.

    ``method`` "mstmm" (default): :func:`ufmt.mstmm.solve.solve_modes` (exact beams, mode
    shapes); "assembled": the assembled model on its automatic mesh (frequencies only,
    ``order`` 0, ``expected`` the number it finds). Other parameters and the result as
    :func:`ufmt.mstmm.solve.solve_modes`; ``model`` is a loaded model or a path (None: the
    packaged UFMT).
    """
    if method not in METHODS:
        raise UfmtError(f"method: {method!r} is not one of 'mstmm', 'assembled'")
    if fmax_hz is not None:  # the budget (ufmt.limits) before the model is even loaded
        limits.number("fmax_hz", fmax_hz, 0.0, limits.MAX_FREQUENCY_HZ)
    if count is not None:
        limits.count("count", count, 1, limits.MAX_MODE_COUNT)
    model = as_model(model)
    if method == "mstmm":
        return mstmm_modes(model, fmax_hz, count, shapes=shapes)
    if fmax_hz is not None and not fmax_hz > 0:
        raise UfmtError(f"fmax_hz: {fmax_hz} must be > 0 [Hz]")
    t0 = time.perf_counter()
    fmax = DEFAULT_FMAX_HZ if fmax_hz is None and count is None else fmax_hz
    if frequency_dependent(model):  # per branch, each step an assembled solve
        f, _, rigid, _ = dependent_modes(model, fmax, count, False, _assembled_batch)
        seconds = time.perf_counter() - t0
        return ModalSolution(f, 0, "assembled", f.size, rigid, None, seconds, model)
    (solution,) = _assembled_batch([model], count=count, fmax_hz=fmax)
    return replace(solution, seconds=time.perf_counter() - t0)


def _assembled_batch(models, *, count=None, fmax_hz=None, shapes=False) -> list[ModalSolution]:
    """The assembled model's frequencies of each of ``models`` (constant stiffness), in the
    call shape of :func:`ufmt.mstmm.solve.solve_modes_batch` (``shapes`` is ignored)."""
    from ufmt.assembled import assembled_modes

    out = []
    for model in models:
        found = assembled_modes(model, fmax_hz=fmax_hz, count=count, shapes=False)
        f = found.frequencies_hz
        out.append(
            ModalSolution(f, 0, "assembled", f.size, found.rigid_body_modes, None, 0.0, model)
        )
    return out


def solve_modes_batch(
    models: Sequence[Model | str | Path],
    *,
    count: int | None = None,
    fmax_hz: float | None = None,
    shapes: bool = True,
) -> list[ModalSolution]:
    """MSTMM modes of several designs (of one structure, e.g. a study's points), one result
    per design in order, each equal to :func:`solve_modes` of that design alone: see
    :func:`ufmt.mstmm.solve.solve_modes_batch`."""
    return mstmm_modes_batch(models, count=count, fmax_hz=fmax_hz, shapes=shapes)
