"""Natural frequencies of a model whose hinge stiffness depends on frequency (a hinge kind whose
Wittrick-Williams count does not apply, e.g. :mod:`ufmt.kinds.aerostatic_hinge`).

The undamped modes of such a model are the roots of det(K(ω) - ω² M) = 0 (paper eq. 2.23 with
the hinge transfer matrices of eq. 2.13 at k'(ω)), K(ω) from the hinges' storage stiffness
k'(ω) = Re k*(ω); the loss Im k* damps the response (:mod:`ufmt.machining.frf`), not the
modes. The count at one stiffness cannot count these roots (K moves with ω), so each root is
found on its branch:

* the model *frozen* at f: every hinge a constant spring at k'(2 pi f); its j-th natural
  frequency f_j(f) comes from the certified constant-stiffness solver;
* k0 <= k'(ω) <= k_inf and no natural frequency falls when a stiffness rises (Rayleigh), so
  f_j(static) <= f_j(f) <= f_j(high) for every f: the j-th root, f = f_j(f), lies in
  [f_j(static), f_j(high)], where h_j(f) = f - f_j(f) goes from <= 0 to >= 0;
* Illinois false position on h_j, all branches at once (each step one batch of frozen designs,
  counted together by :func:`ufmt.mstmm.solve.solve_modes_batch`).

One root per branch is found: should k'(ω) rise so steeply that f_j(f) crossed the line f more
than once, a branch could hold more. Mode j's shape is the frozen model's j-th at the root (U_all
there is the model's own with the hinges at k'(ω), :class:`ufmt.mstmm.overall.TransferSystem`),
unit modal mass.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ufmt.kinds import hinge_kind_of
from ufmt.model.schema import Hinge, Model, frozen_array
from ufmt.mstmm.modes import ModeShapes
from ufmt.mstmm.overall import TransferSystem

RTOL = 1e-12  # relative tolerance on a root [-] (the constant solver's own is ~1e-13)
MAX_STEPS = 200  # false-position steps per branch before giving up


def _spring(hinge: Hinge, stiffness6: np.ndarray) -> Hinge:
    """``hinge`` as a constant spring hinge of stiffness ``stiffness6`` (6,)."""
    k = np.asarray(stiffness6, dtype=float)
    return replace(
        hinge,
        kind="spring",
        extra={},
        stiffness=frozen_array(k[:3]),
        rotational_stiffness=frozen_array(k[3:]),
    )


def frozen(model: Model, hz: float) -> Model:
    """``model`` with every hinge a constant spring at its storage stiffness k'(2 pi hz)."""
    w = np.array([2 * np.pi * hz])
    springs = (_spring(h, hinge_kind_of(h).storage_stiffness6(h, w)[0]) for h in model.hinges)
    return replace(model, hinges=tuple(springs))


def bounding(model: Model, upper: bool) -> Model:
    """``model`` with every hinge at the constant stiffness bounding k'(ω) from below (the
    static k0) or, with ``upper``, from above (k_inf)."""
    return replace(
        model,
        hinges=tuple(_spring(h, hinge_kind_of(h).bounds6(h)[int(upper)]) for h in model.hinges),
    )


def dependent_modes(model: Model, top, count, shapes: bool, solve_batch: Callable) -> tuple:
    """(frequencies [Hz], order of U_all, zero-frequency modes, shapes or None) of a
    frequency-dependent ``model``: its roots below ``top`` [Hz] (None: no limit) or its
    first ``count`` (``solve_batch``: :func:`ufmt.mstmm.solve.solve_modes_batch`)."""
    (lower,) = solve_batch([bounding(model, False)], count=count, fmax_hz=top, shapes=False)
    n = lower.frequencies_hz.size
    f = np.zeros(0)
    if n:
        (upper,) = solve_batch([bounding(model, True)], count=n, shapes=False)
        f = branch_roots(model, lower.frequencies_hz, upper.frequencies_hz, solve_batch)
        f = f[f <= top] if top is not None else f
    order = TransferSystem(model).order
    modes = _shapes(model, f, order, solve_batch) if shapes and f.size else None
    return f, order, lower.rigid_body_modes, modes


def _shapes(model: Model, f: np.ndarray, order: int, solve_batch: Callable) -> ModeShapes:
    """Mode j's shape from the model frozen at its root f_j (U_all there is the model's own),
    stacked; ``z_all``: the boundary unknowns of U_all (order columns, no segment states)."""
    solved = solve_batch([frozen(model, float(x)) for x in f], count=f.size, shapes=True)
    picked = [s.shapes for s in solved]
    j = np.arange(f.size)

    def stack(get):
        return np.stack([get(s)[k] for k, s in zip(j, picked, strict=True)])

    first = picked[0]
    return ModeShapes(
        f,
        stack(lambda s: s.z_all[:, :order]),
        {k: stack(lambda s, k=k: s.rigid[k]) for k in first.rigid},
        {k: stack(lambda s, k=k: s.virtual[k]) for k in first.virtual},
        {k: (p, w, stack(lambda s, k=k: s.beams[k][2])) for k, (p, w, _) in first.beams.items()},
        stack(lambda s: s.modal_mass),
        first.centers,
    )


def branch_roots(model: Model, lo, hi, solve_batch: Callable) -> np.ndarray:
    """The root of each branch j in [lo_j, hi_j] [Hz] (Illinois false position on
    h_j(f) = f - f_j(frozen at f)), ascending."""
    a, b = np.array(lo, dtype=float), np.array(hi, dtype=float)
    fa, fb = _h(model, a, solve_batch), _h(model, b, solve_batch)
    root = np.where(fa >= 0.0, a, np.where(fb <= 0.0, b, np.nan))
    for _ in range(MAX_STEPS):
        act = np.flatnonzero(np.isnan(root))
        if not act.size:
            return np.sort(root)
        x = b[act] - fb[act] * (b[act] - a[act]) / (fb[act] - fa[act])
        fx = _h(model, x, solve_batch, act)
        done = (np.abs(fx) <= RTOL * x) | (np.abs(b[act] - a[act]) <= RTOL * x)
        root[act[done]] = x[done]
        flip = fx * fb[act] < 0.0  # the root now lies between b and x: a <- b
        a[act[flip]], fa[act[flip]] = b[act[flip]], fb[act[flip]]
        fa[act[~flip]] *= 0.5  # Illinois: halve the stale end's value
        b[act], fb[act] = x, fx
    raise RuntimeError(f"{model.source}: a frequency-dependent root did not converge")


def _h(model: Model, hz: np.ndarray, solve_batch: Callable, branch=None) -> np.ndarray:
    """h_j(f) = f - f_j(frozen at f) [Hz] of branches ``branch`` (default 0..n-1) at ``hz``."""
    branch = np.arange(hz.size) if branch is None else np.asarray(branch)
    designs = [frozen(model, float(x)) for x in hz]
    solved = solve_batch(designs, count=int(branch.max()) + 1, shapes=False)
    return hz - np.array([s.frequencies_hz[j] for s, j in zip(solved, branch, strict=True)])
