"""Natural frequencies and mode shapes of a model: the MSTMM eigen-solution end to end.

The assembled mass-stiffness model of the same file counts and brackets the roots; the MSTMM
finds each one from det U_all(ω) = 0 and builds its shape from the null vector of U_all.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from ufmt.assembled import assembled_modes
from ufmt.errors import UfmtError
from ufmt.model.schema import Model
from ufmt.mstmm.modes import ModeShapes, kinetic_terms, mode_shapes
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.roots import natural_frequencies

DEFAULT_FMAX_HZ = 1000.0
BRACKETING_ELEMENTS = 8  # beam elements of the assembled model that only counts and brackets
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True, eq=False, repr=False)
class ModalSolution:
    """Natural frequencies [Hz], shapes and bookkeeping of one eigen-solution.

    Attributes
    ----------
    frequencies_hz : (n,) natural frequencies [Hz], ascending (zero-frequency modes excluded).
    order : order of the overall transfer matrix U_all (0 for the assembled method).
    method : "mstmm" or "assembled".
    expected : modes the assembled model counts in the same range.
    rigid_body_modes : zero-frequency modes (counted, not listed).
    shapes : :class:`ufmt.mstmm.modes.ModeShapes` (unit modal mass), or None.
    seconds : wall time of the solution [s].
    """

    frequencies_hz: np.ndarray
    order: int
    method: str
    expected: int  # modes the assembled model counts in the same range
    rigid_body_modes: int
    shapes: ModeShapes | None
    seconds: float

    def __repr__(self) -> str:
        f = self.frequencies_hz
        span = f"{f[0]:.4g}-{f[-1]:.4g} Hz" if f.size else "none"
        return (
            f"ModalSolution(method={self.method!r}, order={self.order}, modes={f.size} "
            f"({span}), expected={self.expected}, rigid_body_modes={self.rigid_body_modes}, "
            f"shapes={'yes' if self.shapes is not None else 'no'}, seconds={self.seconds:.3g})"
        )

    def energy_shares(self, model: Model) -> np.ndarray:
        """Kinetic-energy share (n_modes, n_bodies, 6) per body and direction."""
        return energy_shares(model, self.shapes)

    def to_frame(self, model: Model | None = None):
        """One row per mode: ``mode``, ``frequency_hz`` and, given the model the shapes belong
        to, the dominant ``body``, ``direction`` and its ``energy_share`` (of kinetic energy).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        table = pd.DataFrame(
            {
                "mode": np.arange(1, self.frequencies_hz.size + 1),
                "frequency_hz": self.frequencies_hz,
            }
        )
        if model is not None and self.shapes is not None:
            shares = self.energy_shares(model).reshape(self.frequencies_hz.size, -1)
            top = np.argmax(shares, axis=1)
            table["body"] = [model.bodies[i // 6].name for i in top]
            table["direction"] = [DIRECTIONS[i % 6] for i in top]
            table["energy_share"] = shares[np.arange(top.size), top]
        return table

    def plot(self, ax=None, model: Model | None = None):
        """Natural frequency of each mode; given the model, each mode's kinetic energy split
        over the bodies (which part of the machine moves in which mode).

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ufmt.plots.modes import plot_modal_solution

        return plot_modal_solution(self, model, ax=ax)

    def save(self, directory, model: Model | None = None) -> list:
        """Write ``modes.csv`` (:meth:`to_frame`) and ``modes.png`` (:meth:`plot`) to
        ``directory``; returns the paths."""
        from pathlib import Path

        from ufmt.plots import save_figure

        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        csv = directory / "modes.csv"
        self.to_frame(model).to_csv(csv, index=False, float_format="%.10g")
        return [csv, save_figure(self.plot(model=model), directory / "modes.png")]


def _range(fmax_hz, count, estimates) -> float:
    """Upper frequency of the search [Hz] from --fmax and/or --count."""
    if count is None:
        return DEFAULT_FMAX_HZ if fmax_hz is None else float(fmax_hz)
    if count < 1:
        raise UfmtError(f"--count: {count} must be >= 1")
    if estimates.size < count:
        if fmax_hz is not None:
            return float(fmax_hz)
        raise UfmtError(
            f"--count: the model has only {estimates.size} nonzero modes; ask for fewer"
        )
    top = estimates[count - 1]
    upper = top * (1 + 1e-6) if count == estimates.size else np.sqrt(top * estimates[count])
    return min(float(fmax_hz), upper) if fmax_hz is not None else float(upper)


def solve_modes(
    model: Model,
    fmax_hz: float | None = None,
    count: int | None = None,
    method: str = "mstmm",
    shapes: bool = True,
) -> ModalSolution:
    """Natural frequencies (and shapes) below ``fmax_hz`` or the first ``count`` modes.

    BLAS runs single-threaded here: the matrices are small (order ~100), where threads only
    add contention.

    Parameters
    ----------
    model : the validated model (:func:`ufmt.load_model`).
    fmax_hz : upper end of the search [Hz] (default 1000 when ``count`` is not given).
    count : number of lowest nonzero modes to find (with ``fmax_hz``: at most that many
        below it).
    method : "mstmm" (default) roots det U_all(ω) = 0 (paper eq. 2.23) and builds each shape
        from the null vector of U_all Z_all = 0 (eq. 2.15); "assembled" is the independent
        mass-stiffness eigen-solution, for cross-checks (frequencies only).
    shapes : False skips the mode shapes (frequencies only, faster).

    Returns
    -------
    ModalSolution
        ``frequencies_hz`` (n,) [Hz] ascending without the zero-frequency modes, ``order`` of
        U_all, ``expected`` (the assembled model's count in the range), ``rigid_body_modes``,
        ``shapes`` (unit-modal-mass :class:`~ufmt.mstmm.modes.ModeShapes`, or None), and
        ``seconds``; ``.to_frame(model)``, ``.plot(ax=None, model=None)``,
        ``.save(directory, model=None)``.

    Raises
    ------
    UfmtError
        A non-positive ``fmax_hz`` or ``count``, an unknown method, or more modes asked for
        than the model has.
    """
    with threadpool_limits(limits=1, user_api="blas"):
        return _solve_modes(model, fmax_hz, count, method, shapes)


def _solve_modes(model, fmax_hz, count, method, shapes) -> ModalSolution:
    if fmax_hz is not None and not (np.isfinite(fmax_hz) and fmax_hz > 0):
        raise UfmtError(f"--fmax: {fmax_hz} must be a positive number of Hz")
    if method not in ("mstmm", "assembled"):
        raise UfmtError(f"--method: {method!r} is not one of 'mstmm', 'assembled'")
    t0 = time.perf_counter()
    guess_fmax = (DEFAULT_FMAX_HZ if fmax_hz is None else fmax_hz) if count is None else None
    asm = assembled_modes(
        model,
        fmax_hz=_pad(guess_fmax),
        count=None if count is None else count + 1,
        elements_per_beam=None if method == "assembled" else BRACKETING_ELEMENTS,
    )
    est = np.asarray(asm.frequencies_hz)
    fmax = _range(fmax_hz, count, est)
    if method == "assembled":
        f = est[est <= fmax]
        return ModalSolution(
            f, 0, "assembled", f.size, asm.rigid_body_modes, None, time.perf_counter() - t0
        )
    system = TransferSystem(model)
    roots = natural_frequencies(system, fmax, est)
    f = roots.frequencies_hz
    if count is not None:
        f = f[:count]
    modes = mode_shapes(system, f) if shapes and f.size else None
    return ModalSolution(
        f,
        system.order,
        "mstmm",
        min(roots.expected, count or roots.expected),
        asm.rigid_body_modes,
        modes,
        time.perf_counter() - t0,
    )


def _pad(fmax_hz):
    """Assembled estimates a little beyond f_max so roots near the limit are bracketed."""
    return None if fmax_hz is None else 1.05 * fmax_hz


def energy_shares(model: Model, shapes: ModeShapes) -> np.ndarray:
    """Kinetic energy per body and direction [share of the mode's total] (n, bodies, 6)."""
    out = kinetic_terms(model, shapes.rigid, shapes.beams)
    total = out.sum(axis=(1, 2), keepdims=True)
    total[total == 0] = 1.0
    return out / total


def describe(model: Model, shares: np.ndarray, top: int = 2) -> list[str]:
    """One line per mode: the dominant bodies and directions, e.g. 'bed rz 41%, head z 20%'."""
    names = [b.name for b in model.bodies]
    lines = []
    for s in shares:
        # ties (mirror-symmetric bodies) broken by body order, not by rounding noise
        rounded = np.round(s.ravel(), 6)
        flat = np.lexsort((np.arange(rounded.size), -rounded))[:top]
        parts = [f"{names[i // 6]} {DIRECTIONS[i % 6]} {100 * s.ravel()[i]:.0f}%" for i in flat]
        lines.append(", ".join(parts))
    return lines
