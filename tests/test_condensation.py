"""The condensed count's building blocks: the Schur complement C(ω) of the inner coordinates
against the one of the independently assembled nodal K(ω), its independence of the call it is
formed in (bitwise), the per-structure cache of the nodal springs, and the bisection's cuts."""

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
from test_wittrick import beam_and_tilting_block, packaged_designs, spring_chain

from ufmt.model.load import load_model, model_from_dict
from ufmt.mstmm import nodal
from ufmt.mstmm.wittrick import RootCounter, _cuts

MODELS = {
    "packaged": lambda: packaged_designs(2),
    "block": lambda: [
        model_from_dict(beam_and_tilting_block()),
        model_from_dict(beam_and_tilting_block()).with_hinge("s1", stiffness=[3e7] * 3),
    ],
    "mixed": lambda: [load_model(Path(__file__).parent / "models" / "good_mixed.toml")],
}


def pairs(counter: RootCounter, n: int = 70):
    """``n`` (ω [rad/s], design) pairs, designs interleaved, ω at least 1e-3 (relative) from
    every pole of the inner structure (the Schur complement's poles)."""
    omega = 2 * np.pi * np.geomspace(5.0, 5000.0, n)
    design = np.arange(n) % len(counter.models)
    poles = np.sqrt(counter.stack.poles[design])
    keep = np.all(np.abs(poles - omega[:, None]) > 1e-3 * omega[:, None], axis=1)
    return omega[keep], design[keep]


@pytest.mark.parametrize("which", MODELS)
def test_complement_is_the_schur_complement_of_the_assembled_k(which):
    """Oracle: K_OO - K_OI K_II⁻¹ K_IO from the whole nodal K(ω) (each beam's own exact
    stiffness assembled densely, :meth:`NodalStiffness.matrix`), at 70 frequencies of
    interleaved designs (several blocks of CHUNK): the condensation's products, the scattered
    beam terms and the mass term form the same matrix."""
    counter = RootCounter(MODELS[which]())
    omega, design = pairs(counter)
    assert omega.size > 2 * nodal.CHUNK
    got, inner_negative, _ = counter.stack.complement(omega, design)
    for d, model_nodal in enumerate(counter.nodals):
        c = model_nodal.condensation
        at = np.flatnonzero(design == d)
        k = model_nodal.matrix(omega[at])
        kii = k[:, c.inner[:, None], c.inner]
        kio = k[:, c.inner[:, None], c.outer]
        koo = k[:, c.outer[:, None], c.outer]
        expected = koo - np.swapaxes(kio, 1, 2) @ np.linalg.solve(kii, kio)
        scale = np.abs(k).max(axis=(1, 2))[:, None, None]
        np.testing.assert_allclose(got[at] / scale, expected / scale, rtol=0, atol=1e-9)
        negative = [np.count_nonzero(sla.eigvalsh(m) < 0) for m in kii]
        np.testing.assert_array_equal(inner_negative[at], negative)


@pytest.mark.parametrize("which", ["packaged", "block"])
def test_a_frequencys_complement_does_not_depend_on_its_call_to_the_last_bit(which):
    """Oracle: the same (design, ω) alone. C(ω) of every pair of a call of 70 interleaved
    pairs is bitwise the C of that pair evaluated alone (one row: BLAS would take another
    path for a product over the whole batch); with and without mass coupling."""
    counter = RootCounter(MODELS[which]())
    omega, design = pairs(counter)
    together = counter.stack.complement(omega, design)
    for i in range(omega.size):
        alone = counter.stack.complement(omega[i : i + 1], design[i : i + 1])
        for a, b in zip(alone, together, strict=True):
            np.testing.assert_array_equal(a[0], b[i])


def test_a_new_design_of_a_cached_structure_gets_its_own_springs():
    """Oracle: the eigenvalues of the changed chain's (K, M). The structure (layout, basis,
    springs' rows, mass) is built once and shared; a design with other stiffness values gets
    its own K(0), and without beams its linearised estimates are its frequencies."""
    model, _ = spring_chain()
    k, m = np.array([4e6, 2.5e6, 1e6]), np.array([12.0, 7.0, 3.0])
    changed = model.with_hinge("k1", stiffness=[5e6, 0.0, 0.0])
    k[1] = 5e6
    stiffness = np.diag(k + np.r_[k[1:], 0.0]) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    exact = np.sqrt(sla.eigh(stiffness, np.diag(m), eigvals_only=True)) / (2 * np.pi)
    assert nodal._structure(model) is nodal._structure(changed)  # one structure
    estimates = RootCounter(changed).nodal.estimates() / (2 * np.pi)
    np.testing.assert_allclose(estimates, exact, rtol=1e-9)


def test_cuts_split_intervals_into_parts_of_equal_ratio():
    """Oracle: geometric division. One level is the geometric middle sqrt(lo hi) exactly; two
    levels give three ascending points with four equal ratios (hi/lo)^(1/4)."""
    lo, hi = np.array([1.0, 250.0, 3e3]), np.array([2.0, 251.0, 4.5e3])
    np.testing.assert_array_equal(_cuts(lo, hi, 1)[:, 0], np.sqrt(lo * hi))
    ends = np.c_[lo, _cuts(lo, hi, 2), hi]
    ratios = ends[:, 1:] / ends[:, :-1]
    np.testing.assert_allclose(ratios, np.repeat((hi / lo) ** 0.25, 4).reshape(3, 4), rtol=1e-14)


@pytest.mark.parametrize("value", [-5e6, np.nan])
def test_a_design_with_a_negative_or_nan_spring_is_refused_and_leaves_the_structure_alone(value):
    """A negative or NaN stiffness shares its structure key with valid designs (the key tells
    only rigid and released directions apart), so solving it first must not fix which springs
    the structure has. Oracle: the chain's exact frequencies (its 3x3 (K, M) eigenvalues)."""
    from ufmt.errors import ModelError
    from ufmt.mstmm.solve import solve_modes

    good, exact = spring_chain()
    bad = good.with_hinge("k1", stiffness=[value, 0.0, 0.0])
    with pytest.raises(ModelError, match="hinge 'k1': stiffness"):
        solve_modes(bad, fmax_hz=3000)
    found = solve_modes(good, fmax_hz=3000).frequencies_hz
    np.testing.assert_allclose(found, exact, rtol=1e-10)
