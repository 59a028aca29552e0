"""``solve_modes`` by either eigen-solver: the MSTMM (:mod:`ufmt.mstmm`, the default) or the
independent assembled mass-stiffness model (:mod:`ufmt.assembled`, for cross-checks). The two
packages import nothing from each other; this module is the one place that knows both."""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path

from ufmt.errors import UfmtError
from ufmt.model.load import as_model
from ufmt.model.schema import Model
from ufmt.mstmm.solve import DEFAULT_FMAX_HZ, ModalSolution
from ufmt.mstmm.solve import solve_modes as mstmm_modes

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
    model = as_model(model)
    if method not in METHODS:
        raise UfmtError(f"--method: {method!r} is not one of 'mstmm', 'assembled'")
    if method == "mstmm":
        return mstmm_modes(model, fmax_hz, count, shapes=shapes)
    if fmax_hz is not None and not (fmax_hz > 0 and fmax_hz < float("inf")):
        raise UfmtError(f"--fmax: {fmax_hz} must be a positive number of Hz")
    if count is not None and count < 1:
        raise UfmtError(f"number of modes: {count} must be >= 1")
    from ufmt.assembled import assembled_modes

    t0 = time.perf_counter()
    fmax = DEFAULT_FMAX_HZ if fmax_hz is None and count is None else fmax_hz
    found = assembled_modes(model, fmax_hz=fmax, count=count, shapes=False)
    f = found.frequencies_hz
    seconds = time.perf_counter() - t0
    return ModalSolution(f, 0, "assembled", f.size, found.rigid_body_modes, None, seconds)


def solve_modes_batch(
    models: Sequence[Model],
    *,
    count: int | None = None,
    fmax_hz: float | None = None,
    shapes: bool = True,
) -> list[ModalSolution]:
    """MSTMM modes of several designs of one structure, one by one: ``[solve_modes(m,
    fmax_hz, count, shapes=shapes) for m in models]`` (parameters and each result as
    :func:`ufmt.mstmm.solve.solve_modes`)."""
    return [mstmm_modes(model, fmax_hz, count, shapes=shapes) for model in models]
