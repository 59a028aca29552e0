"""Natural frequencies and mode shapes of a model: the MSTMM eigen-solution end to end.

The Wittrick-Williams count of the model's exact dynamic stiffness (:mod:`ufmt.mstmm.wittrick`,
no mesh) counts the roots below any frequency and brackets each one; the MSTMM finds each
root in its bracket from det U_all(ω) = 0 and builds its shape from the null vector of U_all.
A counted root the MSTMM cannot find raises :class:`RootsLostError` (the CLI prints one line
naming the missing frequencies and exits non-zero). Where a hinge's stiffness depends on
frequency the count does not apply: :mod:`ufmt.mstmm.dependent` finds those roots per branch.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, replace

import numpy as np
from threadpoolctl import ThreadpoolController

from ufmt import limits
from ufmt.errors import UfmtError
from ufmt.kinds import frequency_dependent
from ufmt.model.load import as_model
from ufmt.model.schema import Model
from ufmt.mstmm.dependent import dependent_modes
from ufmt.mstmm.modes import ModeShapes, kinetic_terms, mode_shapes, shape_state_keys
from ufmt.mstmm.overall import State, TransferSystem, segment_designs
from ufmt.mstmm.roots import Roots, RootsLostError, bracketed_roots
from ufmt.mstmm.wittrick import Brackets, RootCounter

DEFAULT_FMAX_HZ = 1000.0
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True, eq=False, repr=False)
class ModalSolution:
    """Natural frequencies [Hz], shapes and bookkeeping of one eigen-solution.

    Attributes
    ----------
    frequencies_hz : (n,) natural frequencies [Hz], ascending (zero-frequency modes excluded).
    order : order of the overall transfer matrix U_all (0 for the assembled method).
    method : "mstmm" or "assembled".
    expected : modes counted in the same range (the Wittrick-Williams count for the MSTMM).
    rigid_body_modes : zero-frequency modes (counted, not listed).
    shapes : :class:`ufmt.mstmm.modes.ModeShapes` (unit modal mass), or None.
    seconds : wall time of the solution [s].
    model : the model it was solved for (``solve_modes`` keeps it; ``to_frame``, ``plot``,
        ``save`` use it when no model is passed).
    """

    frequencies_hz: np.ndarray
    order: int
    method: str
    expected: int  # modes counted in the same range
    rigid_body_modes: int
    shapes: ModeShapes | None
    seconds: float
    model: Model | None = None

    def _model(self, model):
        """``model`` (loaded if a path) or, if None, the model this solution was solved for."""
        return self.model if model is None else as_model(model)

    def __repr__(self) -> str:
        f = self.frequencies_hz
        span = f"{f[0]:.4g}-{f[-1]:.4g} Hz" if f.size else "none"
        return (
            f"ModalSolution(method={self.method!r}, order={self.order}, modes={f.size} "
            f"({span}), expected={self.expected}, rigid_body_modes={self.rigid_body_modes}, "
            f"shapes={'yes' if self.shapes is not None else 'no'}, seconds={self.seconds:.3g})"
        )

    def energy_shares(self, model=None) -> np.ndarray:
        """Kinetic-energy share (n_modes, n_bodies, 6) per body and direction; ``model`` a
        loaded model or its path (default: the one solved for)."""
        return energy_shares(self._model(model), self.shapes)

    def to_frame(self, model=None):
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
        model = self._model(model)
        if model is not None and self.shapes is not None:
            shares = self.energy_shares(model).reshape(self.frequencies_hz.size, -1)
            top = np.argmax(shares, axis=1)
            table["body"] = [model.bodies[i // 6].name for i in top]
            table["direction"] = [DIRECTIONS[i % 6] for i in top]
            table["energy_share"] = shares[np.arange(top.size), top]
        return table

    def plot(self, ax=None, model=None, mode: int | None = None, scale: float | None = None):
        """Natural frequency of each mode; given the model (loaded or its path), each mode's
        kinetic energy split over the bodies (which part of the machine moves in which mode).
        With ``mode``, a mode number (1-based, as the CLI and every table number modes), that
        mode's shape in 3-D instead (``scale``: displacement factor, default automatic).

        Returns
        -------
        matplotlib.figure.Figure

        Raises
        ------
        UfmtError
            ``mode`` outside 1..n (the modes solved), without ``model`` or without shapes.
        """
        model = self._model(model)
        if mode is None:
            from ufmt.plots.modes import plot_modal_solution

            return plot_modal_solution(self, model, ax=ax)
        from ufmt.plots.modes import plot_mode

        n = self.frequencies_hz.size
        if isinstance(mode, bool) or not isinstance(mode, int | np.integer):
            raise UfmtError(f"mode: {mode!r} is not a mode number 1..{n}")
        why = (
            "pass model=, the model the shapes belong to"
            if model is None
            else "solved without shapes"
            if self.shapes is None
            else f"{n} modes were solved"
            if not 1 <= mode <= n
            else ""
        )
        if why:
            raise UfmtError(f"mode {mode}: cannot draw it (1..{n}; {why})")
        line = describe(model, self.energy_shares(model), top=3)[mode - 1]
        return plot_mode(model, self.shapes, mode - 1, scale, line, ax=ax)

    def save(self, directory, model=None) -> list:
        """Write ``modes.csv`` (:meth:`to_frame`) and ``modes.png`` (:meth:`plot`) to
        ``directory``; returns the paths."""
        from pathlib import Path

        from ufmt import files
        from ufmt.plots import save_figure

        model = self._model(model)
        directory = Path(directory)
        table = self.to_frame(model)
        csv = files.write_with(
            directory / "modes.csv", lambda b: table.to_csv(b, index=False, float_format="%.10g")
        )
        return [csv, save_figure(self.plot(model=model), directory / "modes.png")]


def solve_modes(
    model,
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
    model : the validated model (:func:`ufmt.load_model`) or a model file's path.
    fmax_hz : upper end of the search [Hz] (default 1000 when ``count`` is not given).
    count : number of lowest nonzero modes to find (with ``fmax_hz``: at most that many
        below it).
    method : "mstmm", the only one here: roots det U_all(ω) = 0 (paper eq. 2.23) in the
        brackets of the Wittrick-Williams count and builds each shape from the null vector of
        U_all Z_all = 0 (eq. 2.15); :func:`ufmt.solvers.solve_modes` also takes the
        independent "assembled" mass-stiffness eigen-solution.
    shapes : False skips the mode shapes (frequencies only, faster).

    Returns
    -------
    ModalSolution
        ``frequencies_hz`` (n,) [Hz] ascending without the zero-frequency modes, ``order`` of
        U_all, ``expected`` (the Wittrick-Williams count in the range), ``rigid_body_modes``,
        ``shapes`` (unit-modal-mass :class:`~ufmt.mstmm.modes.ModeShapes`, or None), and
        ``seconds``; ``.to_frame(model)``, ``.plot(ax=None, model=None)``,
        ``.save(directory, model=None)``.

    Raises
    ------
    UfmtError
        A non-positive ``fmax_hz`` or ``count``, a method other than "mstmm", or more modes
        asked for than the model has.
    RootsLostError
        A counted root the MSTMM cannot find (the message names the missing frequencies).
    """
    model = as_model(model)
    with _blas_controller().limit(limits=1, user_api="blas"):
        return replace(_solve_modes(model, fmax_hz, count, method, shapes), model=model)


def solve_modes_batch(
    models, *, count: int | None = None, fmax_hz: float | None = None, shapes: bool = True
) -> list[ModalSolution]:
    """:func:`solve_modes` of each design of ``models`` (loaded models or paths), in order.

    Designs of one structure (:meth:`ufmt.model.schema.Model.structure_key`) are counted and
    bracketed together: one Wittrick-Williams counter over their stack
    (:class:`ufmt.mstmm.wittrick.RootCounter`), every J evaluation one pass for all of them;
    each design's roots and shapes then come from its own Newton walks on det U_all. The BLAS
    thread limit is set once for the whole batch. Each result is the one :func:`solve_modes`
    returns for that design alone (to rounding; ``seconds``: its own share); a design with a
    frequency-dependent hinge is solved alone. Parameters and errors as :func:`solve_modes`
    (a lost root of any design raises for the batch).
    """
    models = [as_model(m) for m in models]
    _check(fmax_hz, count, "mstmm")
    with _blas_controller().limit(limits=1, user_api="blas"):
        groups: dict = {}  # designs of one structure are counted together
        out: list = [None] * len(models)
        for i, m in enumerate(models):
            if frequency_dependent(m):  # solved alone (ufmt.mstmm.dependent)
                out[i] = _solve_modes(m, fmax_hz, count, "mstmm", shapes)
            else:
                groups.setdefault(m.structure_key(), []).append(i)
        for members in groups.values():
            t0 = time.perf_counter()
            counter = RootCounter([models[i] for i in members])
            ranges = _search_ranges(counter, fmax_hz, count)
            systems = _segmented([models[i] for i in members], ranges)
            shared = (time.perf_counter() - t0) / len(members)  # the count's share
            for d, (i, brackets) in enumerate(zip(members, ranges, strict=True)):
                solution = _solution(counter, d, brackets, count, shapes, systems[d])
                out[i] = replace(solution, seconds=solution.seconds + shared)
        return out


def _segmented(models: list[Model], ranges: list[Brackets]) -> list[TransferSystem]:
    """The transfer systems of designs of one structure, segmented for their search ranges
    together (:func:`ufmt.mstmm.overall.segment_designs`: each as alone, bitwise)."""
    systems = [TransferSystem(m) for m in models]
    tops: dict = {}  # designs with the same upper frequency are segmented in one pass
    for system, brackets in zip(systems, ranges, strict=True):
        tops.setdefault(brackets.below_hz, []).append(system)
    for top, group in tops.items():
        segment_designs(group, top)
    return systems


@functools.cache
def _blas_controller() -> ThreadpoolController:
    """The loaded BLAS libraries, found once: a new ``threadpool_limits`` scans every loaded
    shared library, a cost of the order of a small solve's."""
    return ThreadpoolController()


def _check(fmax_hz, count, method) -> None:
    """UfmtError for a bad ``fmax_hz``, ``count`` or ``method`` (see :func:`solve_modes`)."""
    if fmax_hz is not None:
        limits.number("fmax_hz", fmax_hz, 0.0, limits.MAX_FREQUENCY_HZ)
        if not fmax_hz > 0:
            raise UfmtError(f"fmax_hz: {fmax_hz} must be > 0 [Hz]")
    if method != "mstmm":
        raise UfmtError(
            f"method: {method!r}: this is the MSTMM solver; ufmt.solve_modes takes 'assembled'"
        )
    if count is not None:
        limits.count("count", count, 1, limits.MAX_MODE_COUNT)


def _solve_modes(model, fmax_hz, count, method, shapes) -> ModalSolution:
    _check(fmax_hz, count, method)
    t0 = time.perf_counter()
    if frequency_dependent(model):  # the count does not apply: ufmt.mstmm.dependent
        top = DEFAULT_FMAX_HZ if fmax_hz is None and count is None else fmax_hz
        f, order, rigid, modes = dependent_modes(model, top, count, shapes, solve_modes_batch)
        seconds = time.perf_counter() - t0
        return ModalSolution(f, order, "mstmm", f.size, rigid, modes, seconds)
    counter = RootCounter(model)
    (brackets,) = _search_ranges(counter, fmax_hz, count)
    if count is None and brackets.total > limits.MAX_MODE_COUNT:  # counted, not yet solved
        raise UfmtError(
            f"{model.source}: {brackets.total:,} modes below fmax_hz = {brackets.below_hz:g}"
            f" Hz; at most {limits.MAX_MODE_COUNT:,} per request (lower fmax_hz or give count)"
        )
    solution = _solution(counter, 0, brackets, count, shapes)
    return replace(solution, seconds=time.perf_counter() - t0)


def certified_roots(model, fmax_hz: float, state_keys=()) -> tuple[TransferSystem, Roots]:
    """(the transfer system, every root below ``fmax_hz`` [Hz] with its null vectors): the
    path :func:`solve_modes` takes (Wittrick-Williams brackets, Newton, bisection on the
    count where Newton cannot certify), before any root is required or a shape built."""
    model = as_model(model)
    _check(fmax_hz, None, "mstmm")
    if frequency_dependent(model):
        raise UfmtError(f"{model.source}: a hinge's stiffness depends on frequency: no count")
    counter = RootCounter(model)
    (brackets,) = _search_ranges(counter, fmax_hz, None)
    system = TransferSystem(model)
    with _blas_controller().limit(limits=1, user_api="blas"):
        return system, _roots(counter, 0, brackets, system, state_keys)


def _roots(counter: RootCounter, design: int, brackets: Brackets, system, state_keys) -> Roots:
    """The roots of design ``design`` of ``counter`` in its certified ``brackets``."""

    def refine(lo_hz, hi_hz):
        return counter.refine(lo_hz, hi_hz, design=design)

    return bracketed_roots(system, brackets, refine, state_keys=state_keys)


def _solution(counter: RootCounter, design: int, brackets: Brackets, count, shapes, system=None):
    """The ModalSolution of design ``design`` of ``counter`` from its brackets (``seconds``
    of this part only); ``system``: its TransferSystem if made."""
    t0 = time.perf_counter()
    model = counter.models[design]
    system = TransferSystem(model) if system is None else system
    keys = shape_state_keys(system) if shapes else ()
    roots = _roots(counter, design, brackets, system, keys)
    if roots.missing_hz.size:
        raise RootsLostError(
            f"{model.source}: the MSTMM found {roots.frequencies_hz.size} of the "
            f"{roots.expected} natural frequencies counted below {brackets.below_hz:.6g} Hz "
            "(Wittrick-Williams); missing near "  # known to the brackets' START_RTOL
            + ", ".join(f"{x:.5g}" for x in roots.missing_hz)
            + " Hz"
        )
    f, z = roots.frequencies_hz[:count], roots.null_vectors[:count]
    states = None if roots.states is None else _first(roots.states, f.size)
    modes = mode_shapes(system, f, z, states) if shapes and f.size else None
    expected = min(roots.expected, count or roots.expected)
    rigid = int(counter.zero_modes[design])
    seconds = time.perf_counter() - t0
    solution = ModalSolution(f, system.order, "mstmm", expected, rigid, modes, seconds)
    return solution


def _search_ranges(counter: RootCounter, fmax_hz, count) -> list[Brackets]:
    """Certified brackets of the roots to find, per design of ``counter``: all below
    ``fmax_hz`` (default 1000 Hz), or the first ``count`` and at most those below
    ``fmax_hz``; the upper frequency lies between the last wanted root and the next one."""
    n = len(counter.models)
    if count is None:
        found = counter.brackets(DEFAULT_FMAX_HZ if fmax_hz is None else float(fmax_hz))
        return [found] if n == 1 else found
    wanted = count
    limited = np.zeros(n, dtype=bool)  # fewer than wanted below fmax_hz: all of those
    if fmax_hz is not None:
        limited = counter.below(np.full(n, float(fmax_hz)), np.arange(n)) < wanted
    top = np.full(n, np.nan if fmax_hz is None else float(fmax_hz))
    if not limited.all():
        upper = counter.upper_for(wanted, DEFAULT_FMAX_HZ if fmax_hz is None else float(fmax_hz))
        top[~limited] = upper[~limited] * (1 + 1e-9)
    first = np.where(limited, np.iinfo(int).max, wanted)
    found = counter.brackets(top, first=first)
    found = [found] if n == 1 else found
    return [b if limited[d] else _first_brackets(b, wanted) for d, b in enumerate(found)]


def _first_brackets(found: Brackets, wanted: int) -> Brackets:
    """The brackets of the first ``wanted`` roots, the upper frequency half-way
    (geometrically) between the last of them and the next bracket."""
    last = int(np.searchsorted(np.cumsum(found.multiplicity), wanted))  # holds root `wanted`
    top = found.hi_hz[last]
    if last + 1 < found.lo_hz.size:
        top = np.sqrt(top * found.lo_hz[last + 1])
    keep = slice(0, last + 1)
    start = None if found.start_hz is None else found.start_hz[keep]
    return Brackets(
        found.lo_hz[keep], found.hi_hz[keep], found.multiplicity[keep], float(top), start
    )


def _first(states: dict, count: int) -> dict:
    """The state maps at the first ``count`` roots."""
    return {key: State(m.cols, m.arr[:count]) for key, m in states.items()}


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
