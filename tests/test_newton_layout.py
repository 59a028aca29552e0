"""The Newton iteration's S', mapped from U_all's nonzero entries (ufmt.mstmm.reduced
.SparseReduction), against U_all assembled in full, cut and reduced densely (oracle: the
dense matrices of the same walk; the Schur-complement property of the elimination)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic import axisymmetric_chain

from ufmt.model.load import load_model, model_from_dict, packaged_path
from ufmt.mstmm.dense_reduction import arranged, left_right, null_vectors, reduced
from ufmt.mstmm.overall import TransferSystem, assemble, block_layout
from ufmt.mstmm.reduced import ConstantParts, SparseReduction


def _model(name: str):
    if name == "chain":
        return model_from_dict(axisymmetric_chain(1))
    return load_model(packaged_path(name))


@pytest.mark.parametrize("name", ["ufmt.toml", "chain"])
def test_sparse_map_gives_the_reduction_of_the_assembled_matrix(name):
    """Oracle: U_all assembled densely, cut to the reduction's rows and columns and reduced
    densely (ConstantParts.reduce). The entries the map takes are every nonzero of the cut
    U_all at every ω of a batch (the structural zeros found, as Newton finds them, from
    three of them); S' and the pivot rows' products from them agree with the dense ones to
    rounding, and S' has no nonzero outside the map's pattern."""
    system = TransferSystem(_model(name), fmax_hz=3000.0)
    omega = 2 * np.pi * np.geomspace(20.0, 3000.0, 9)
    omega = np.concatenate([omega, omega * (1 + 1e-7), [0.61 * omega[0]]])
    blocks, _ = system.equation_blocks(omega)
    dense = assemble(blocks, system.size)
    at = [0, 9, -1]
    assert np.array_equal(assemble(blocks, system.size, at), dense[at])
    reduction = ConstantParts.of(dense[at])
    sparse = SparseReduction.of(reduction, block_layout(blocks))
    values = sparse.values(blocks)
    cut = arranged(reduction, dense)
    rows, columns = reduction.placement()
    taken = np.zeros(reduction.arranged_shape, dtype=bool)
    for k, i, j in sparse.plan.gather:
        r0 = sum(b.arr.shape[1] for b in blocks[:k])
        taken[rows[r0 + i], columns[blocks[k].cols[j]]] = True
    assert np.count_nonzero(taken) == values.shape[1]
    assert not np.any(cut[:, ~taken])  # every nonzero is taken
    s_dense = reduced(reduction, dense)
    s_sparse = sparse.pattern.dense(sparse.s_values(values))
    # both sum the terms of S' = L A R in different orders: within rounding of their sizes
    left, right = left_right(reduction)
    terms = np.abs(left) @ np.abs(cut) @ np.abs(right)
    assert np.all(np.abs(s_sparse - s_dense) <= 1e-14 * terms)
    z = np.random.default_rng(0).standard_normal((omega.size, reduction.order, 2))
    expected = null_vectors(reduction, dense, z)
    np.testing.assert_allclose(
        sparse.null_vectors(values, z), expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max()
    )


def _synthetic(omega: float) -> np.ndarray:
    """A 6 x 6 U(ω) whose column 0 is constant; of the three rows touching it, rows 0 and 1
    differ by a factor 2 in every ω-dependent entry and row 1 is the pivot (largest scaled
    entry), so step 1 leaves the o rows (0, 2) with row 0 constant: S's first o row is
    eliminated, its second kept."""
    w = omega
    return np.array(
        [
            [1.0, w, 3.0, w**2, 0.0, 0.0],
            [2.0, 2 * w, 5.0, 2 * w**2, 0.0, 0.0],
            [0.1, 1.0, w, 0.0, 0.0, 1.0],
            [0.0, np.sin(w), w, 1.0, w**3, 0.0],
            [0.0, 1.0, w**2, np.cos(w), 2.0, w],
            [0.0, w, 1.0, 3.0, w, 1.0],
        ]
    )


def test_reduction_whose_first_o_row_becomes_constant_keeps_det_up_to_a_constant():
    """Oracle: det U / det S' is one constant over ω (Schur complement). This matrix makes
    reduce combine only the kept o rows of step 1, here not the first (a branch no packaged
    model reaches)."""
    omega = np.array([0.7, 1.3, 2.9, 4.1])
    u = np.array([_synthetic(w) for w in omega])
    reduction = ConstantParts.of(np.array([_synthetic(w) for w in (1.1, 1.1 * (1 + 1e-7), 0.67)]))
    assert reduction.row_combine.shape[0] == 2  # two o rows ...
    assert reduction.kept.size == 4 and reduction.kept[0] == 1  # ... the first not kept
    s = reduced(reduction, u)
    ratio = np.linalg.det(u) / np.linalg.det(s)
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-12)


@pytest.mark.parametrize("threshold", [0.0, 1e-11])
def test_rounding_size_multipliers_taken_as_zeros_change_nothing_but_rounding(
    monkeypatch, threshold
):
    """Oracle: the same solve with G's and C's rounding-size multipliers kept (threshold 0)
    or dropped up to 100 times the default. Frequencies agree to 1e-13 and every mode
    shape's U_all null vector to 1e-9 of its size: the default sits where the choice does
    not matter."""
    import ufmt.mstmm.reduced as reduced_module
    from ufmt.mstmm.solve import solve_modes

    model = load_model(packaged_path("ufmt.toml"))
    default = solve_modes(model, fmax_hz=5000.0)
    monkeypatch.setattr(reduced_module, "ROUNDING_MULTIPLIER", threshold)
    reduced_module._PLANS.clear()
    other = solve_modes(model, fmax_hz=5000.0)
    reduced_module._PLANS.clear()
    np.testing.assert_allclose(other.frequencies_hz, default.frequencies_hz, rtol=1e-13, atol=0)
    a, b = default.shapes.z_all, other.shapes.z_all
    sign = np.sign(np.sum(a * b, axis=1))[:, None]  # a shape's sign is a convention
    scale = np.linalg.norm(a, axis=1)[:, None]
    assert np.all(np.abs(a - sign * b) <= 1e-9 * scale)
