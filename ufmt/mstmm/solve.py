"""Natural frequencies and mode shapes of a model: the MSTMM eigen-solution end to end.

The assembled mass-stiffness model of the same file counts and brackets the roots; the MSTMM
finds each one from det U_all(ω) = 0 and builds its shape from the null vector of U_all.
A root the assembled model counts but the MSTMM cannot find raises :class:`RootsLostError`
(the CLI prints one line naming the missing frequencies and exits non-zero).
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import hashlib
import pickle
import time
from dataclasses import dataclass

import numpy as np
from threadpoolctl import ThreadpoolController

from ufmt.assembled import assembled_modes
from ufmt.errors import UfmtError
from ufmt.model.schema import Model
from ufmt.mstmm.bodies import rules_of
from ufmt.mstmm.modes import ModeShapes, kinetic_terms, mode_shapes, shape_state_keys
from ufmt.mstmm.overall import State, TransferSystem
from ufmt.mstmm.roots import RootsLostError, continued_roots, natural_frequencies

DEFAULT_FMAX_HZ = 1000.0
# beam elements of the assembled model that only counts and brackets; the finer meshes are
# tried in turn only when a counted root was not found (estimates too far from the roots)
BRACKETING_MESHES = (8, 24, 64)
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

        from ufmt import files
        from ufmt.plots import save_figure

        directory = Path(directory)
        table = self.to_frame(model)
        csv = files.write_with(
            directory / "modes.csv", lambda b: table.to_csv(b, index=False, float_format="%.10g")
        )
        return [csv, save_figure(self.plot(model=model), directory / "modes.png")]


def _range(fmax_hz, count, estimates) -> float:
    """Upper frequency of the search [Hz] from --fmax and/or --count."""
    if count is None:
        return DEFAULT_FMAX_HZ if fmax_hz is None else float(fmax_hz)
    if count < 1:
        raise UfmtError(f"number of modes: {count} must be >= 1")
    if estimates.size < count:
        if fmax_hz is not None:
            return float(fmax_hz)
        raise UfmtError(
            f"number of modes: {count} asked for, but the model has only {estimates.size} "
            "nonzero modes; ask for fewer"
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
    with _blas_controller().limit(limits=1, user_api="blas"):
        return _solve_modes(model, fmax_hz, count, method, shapes)


@functools.cache
def _blas_controller() -> ThreadpoolController:
    """The loaded BLAS libraries, found once: a new ``threadpool_limits`` scans every loaded
    shared library (~3 ms, a few per cent of a solve)."""
    return ThreadpoolController()


@contextlib.contextmanager
def continuation(key):
    """Within this block, ``solve_modes(model, count=n)`` starts from the roots of the last
    design solved under the same ``key`` (a sweep of one model file over hinge stiffnesses).

    A design that differs from the last one only in hinge stiffness values (same masses, same
    released and rigid directions), each scaled by s_i, has K_new between min(1, s_i) K_old
    and max(1, s_i) K_old, so by Courant-Fischer its k-th natural frequency lies in
    [f_k √min(1, s_i), f_k √max(1, s_i)] around the last design's k-th one. When those
    brackets of the n + 1 lowest roots do not overlap, each holds exactly its own roots:
    Newton tracks them from the last design with no assembled solve, each certified inside
    its bracket as usual (contracting steps, right multiplicity), and det U_all must change
    sign between them as their multiplicities say. Otherwise (large steps, a split repeated
    root) the assembled estimates are used as usual.
    """
    token = _CONTINUATION.set(key)
    try:
        yield
    finally:
        _CONTINUATION.reset(token)


_CONTINUATION: contextvars.ContextVar = contextvars.ContextVar("continuation", default=None)
# continuation key -> (masses, hinge pattern, hinge stiffness, roots [Hz], rigid-body modes)
_LAST_ROOTS: dict = {}
LAST_ROOTS_KEPT = 8
MAX_TRACKED_SHIFT = 1.05  # continuation only when no root can move by more than this factor


def _hinge_pattern(model: Model) -> tuple:
    """Which hinge directions are released, elastic or rigid: the topology of U_all."""
    return tuple(tuple(np.sign(h.stiffness6) * np.isfinite(h.stiffness6)) for h in model.hinges)


def _masses(model: Model) -> str:
    """Digest of every body (mass, inertia, beam data): the mass matrix of the design."""
    return hashlib.sha256(pickle.dumps(model.bodies)).hexdigest()


def _stiffness_bounds(model: Model, stiffness_before) -> tuple[float, float]:
    """(min(1, s_i), max(1, s_i)) over the finite nonzero hinge stiffness ratios s_i."""
    now = np.concatenate([h.stiffness6 for h in model.hinges])
    before = np.concatenate(stiffness_before)
    elastic = np.isfinite(now) & (now > 0)
    ratio = now[elastic] / before[elastic]
    return min(1.0, float(ratio.min(initial=1.0))), max(1.0, float(ratio.max(initial=1.0)))


def _continued(model, count, shapes, t0) -> ModalSolution | None:
    """The first ``count`` modes tracked from the last design's roots, or None (see
    :func:`continuation`)."""
    key = _CONTINUATION.get()
    last = _LAST_ROOTS.get(key) if key is not None else None
    if (
        last is None
        or last[0] != _masses(model)
        or last[1] != _hinge_pattern(model)
        or last[3].size < count + 1
    ):
        return None
    low, high = _stiffness_bounds(model, last[2])
    if high / low > MAX_TRACKED_SHIFT**2:  # Newton from so far away: not worth trying
        return None
    start = last[3][: count + 1]
    system = TransferSystem(model)
    roots = continued_roots(system, start, start * np.sqrt(low), start * np.sqrt(high))
    if roots is None:
        return None
    f, z = roots.frequencies_hz[:count], roots.null_vectors[:count]
    modes = mode_shapes(system, f, z) if shapes else None
    _remember(key, model, roots.frequencies_hz, last[4])
    return ModalSolution(f, system.order, "mstmm", count, last[4], modes, time.perf_counter() - t0)


def _remember(key, model, roots_hz, rigid_body_modes) -> None:
    _LAST_ROOTS.pop(key, None)
    stiffness = [h.stiffness6.copy() for h in model.hinges]
    entry = (_masses(model), _hinge_pattern(model), stiffness, np.array(roots_hz))
    _LAST_ROOTS[key] = (*entry, rigid_body_modes)
    while len(_LAST_ROOTS) > LAST_ROOTS_KEPT:
        del _LAST_ROOTS[next(iter(_LAST_ROOTS))]


def _solve_modes(model, fmax_hz, count, method, shapes) -> ModalSolution:
    if fmax_hz is not None and not (np.isfinite(fmax_hz) and fmax_hz > 0):
        raise UfmtError(f"--fmax: {fmax_hz} must be a positive number of Hz")
    if method not in ("mstmm", "assembled"):
        raise UfmtError(f"--method: {method!r} is not one of 'mstmm', 'assembled'")
    t0 = time.perf_counter()
    tracking = method == "mstmm" and fmax_hz is None and count is not None and count >= 1
    tracking = tracking and _CONTINUATION.get() is not None
    if tracking and (solution := _continued(model, count, shapes, t0)) is not None:
        return solution
    guess_fmax = (DEFAULT_FMAX_HZ if fmax_hz is None else fmax_hz) if count is None else None
    system = TransferSystem(model) if method == "mstmm" else None
    for elements in BRACKETING_MESHES:  # a finer mesh only if a root was not found
        asm = assembled_modes(
            model,
            fmax_hz=_pad(guess_fmax),
            count=None if count is None else count + 1,
            elements_per_beam=None if method == "assembled" else elements,
            shapes=False,
        )
        est = np.asarray(asm.frequencies_hz)
        fmax = _range(fmax_hz, count, est)
        if tracking and est.size > count:  # the next design tracks count + 1 roots
            fmax = float(est[count]) * (1 + 1e-6)
        if method == "assembled":
            f = est[est <= fmax]
            return ModalSolution(
                f, 0, "assembled", f.size, asm.rigid_body_modes, None, time.perf_counter() - t0
            )
        keys = shape_state_keys(system) if shapes else ()
        roots = natural_frequencies(system, fmax, est, state_keys=keys)
        if roots.missing_hz.size == 0 or not _distributed(model):
            break
    if roots.missing_hz.size:
        raise RootsLostError(
            f"{model.source}: the MSTMM found {roots.frequencies_hz.size} of the "
            f"{roots.expected} natural frequencies the assembled model counts below "
            f"{fmax:.6g} Hz; missing near "
            + ", ".join(f"{x:.6g}" for x in roots.missing_hz)
            + " Hz"
        )
    f, z = roots.frequencies_hz[:count], roots.null_vectors[:count]
    states = None if roots.states is None else _first(roots.states, f.size)
    modes = mode_shapes(system, f, z, states) if shapes and f.size else None
    if tracking:
        _remember(_CONTINUATION.get(), model, roots.frequencies_hz, asm.rigid_body_modes)
    return ModalSolution(
        f,
        system.order,
        "mstmm",
        min(roots.expected, count or roots.expected),
        asm.rigid_body_modes,
        modes,
        time.perf_counter() - t0,
    )


def _first(states: dict, count: int) -> dict:
    """The state maps at the first ``count`` roots."""
    return {key: State(m.cols, m.arr[:count]) for key, m in states.items()}


def _distributed(model: Model) -> bool:
    """Whether a body has distributed mass (a beam): then a finer assembled mesh can bring
    an estimate the MSTMM missed."""
    return any(rules_of(b).distributed for b in model.bodies)


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
