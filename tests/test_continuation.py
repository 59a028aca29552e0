"""Continuation over a sweep: roots tracked from the neighbouring design agree with a full
solve, and an untracked root makes the tracking give up (never a silent loss)."""

import numpy as np
import pytest
from synthetic import axisymmetric_chain

from ufmt.assembled import assembled_modes
from ufmt.model.load import load_model, model_from_dict, packaged_path
from ufmt.mstmm import solve as solve_module
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.roots import continued_roots
from ufmt.mstmm.solve import continuation, solve_modes


@pytest.mark.parametrize(
    ("steps", "count", "counted_solves"),
    [
        ((1.0, 1.002, 1.004, 1.006), 12, 1),
        ((1.0, 1.02, 1.04, 1.06), 12, 1),
        ((1.0, 1.5, 2.25), 12, 3),
        ((1.0, 1.01, 1.02), 30, 1),  # the brackets of modes 30 and 31 overlap: one block
    ],
)
def test_sweep_with_continuation_equals_independent_solves(
    monkeypatch, steps, count, counted_solves
):
    """Stiffness sweeps of the packaged model: oracle = each design solved on its own (with
    the Wittrick-Williams brackets). In small steps only the first design needs the count;
    in 50 % steps the Courant-Fischer brackets of the 10.2 and 10.4 Hz modes overlap, so
    every design takes the counted path, with the same result."""
    base = load_model(packaged_path("ufmt-prior.toml"))
    hinge = base.hinges[0]
    designs = [base.with_hinge(hinge.name, stiffness=hinge.stiffness6[:3] * s) for s in steps]
    independent = [solve_modes(m, count=count) for m in designs]
    calls = []
    real = solve_module.RootCounter
    monkeypatch.setattr(solve_module, "RootCounter", lambda m: calls.append(1) or real(m))
    with continuation(("sweep", steps, count)):
        tracked = [solve_modes(m, count=count) for m in designs]
    assert len(calls) == counted_solves
    for a, b in zip(independent, tracked, strict=True):
        np.testing.assert_allclose(b.frequencies_hz, a.frequencies_hz, rtol=1e-10)
        for name, motion in a.shapes.rigid.items():  # unit modal mass, up to sign
            scale = np.abs(motion).max()
            np.testing.assert_allclose(
                np.abs(b.shapes.rigid[name]), np.abs(motion), rtol=0, atol=1e-8 * scale
            )


def test_tracking_gives_up_when_a_root_is_not_tracked():
    """Start values that skip a simple root (oracle: the exact assembled model of a rigid
    chain): the det sign pattern breaks, so no result instead of a lost root."""
    model = model_from_dict(axisymmetric_chain(2))
    exact = assembled_modes(model).frequencies_hz
    simple = np.flatnonzero(
        (np.diff(exact, prepend=0) > 1e-9 * exact) & (np.diff(exact, append=np.inf) > 1e-9 * exact)
    )
    skip = simple[simple < exact.size - 1][0]
    assert continued_roots(TransferSystem(model), exact, exact, exact) is not None
    missed = np.delete(exact, skip)
    assert continued_roots(TransferSystem(model), missed, missed, missed) is None


@pytest.mark.parametrize(("hinge", "kind"), [(9, "rotational_stiffness"), (16, "stiffness")])
def test_tracked_roots_that_cross_stay_tracked(monkeypatch, hinge, kind):
    """A sweep of the prior model in 3 % steps up then down (oracle: each design solved on
    its own): roots of several clusters share one block and cross, and each cluster keeps
    its own root (a root another cluster only lies near is not given up to it), so only the
    first design needs the count."""
    base = load_model(packaged_path("ufmt-prior.toml"))
    h = base.hinges[hinge]
    v = np.array(getattr(h, kind), dtype=float)
    elastic = np.isfinite(v) & (v > 0)
    steps = np.cumprod([1.0] + [1.03] * 5 + [0.97] * 3)
    designs = [base.with_hinge(h.name, **{kind: np.where(elastic, v * s, v)}) for s in steps]
    independent = [solve_modes(m, count=40, shapes=False).frequencies_hz for m in designs]
    calls = []
    real = solve_module.RootCounter
    monkeypatch.setattr(solve_module, "RootCounter", lambda m: calls.append(1) or real(m))
    with continuation(("crossing", hinge, kind)):
        tracked = [solve_modes(m, count=40, shapes=False).frequencies_hz for m in designs]
    assert len(calls) == 1
    for a, b in zip(independent, tracked, strict=True):
        np.testing.assert_allclose(b, a, rtol=1e-10)
