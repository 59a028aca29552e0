"""The Newton iteration's U_all, placed straight into the reduced layout (ufmt.mstmm.overall
.place, ufmt.mstmm.reduced.ConstantParts), against U_all assembled in full and cut (oracle:
the dense matrix of the same walk; the Schur-complement property of the elimination)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic import axisymmetric_chain

from ufmt.model.load import load_model, model_from_dict, packaged_path
from ufmt.mstmm.overall import TransferSystem, assemble, place
from ufmt.mstmm.reduced import ConstantParts


def _model(name: str):
    if name == "chain":
        return model_from_dict(axisymmetric_chain(1))
    return load_model(packaged_path(name))


@pytest.mark.parametrize("name", ["ufmt.toml", "chain"])
def test_placed_matrix_is_the_assembled_one_cut_to_the_reduced_layout_bitwise(name):
    """Oracle: U_all assembled densely and gathered to the reduction's rows and columns. The
    placement moves the same numbers, so it must agree to the last bit, at every ω of a
    batch (the reduction found, as Newton finds it, from three of them)."""
    system = TransferSystem(_model(name), fmax_hz=3000.0)
    omega = 2 * np.pi * np.geomspace(20.0, 3000.0, 9)
    omega = np.concatenate([omega, omega * (1 + 1e-7), [0.61 * omega[0]]])
    blocks, _ = system.equation_blocks(omega)
    dense = assemble(blocks, system.size)
    at = [0, 9, -1]
    assert np.array_equal(assemble(blocks, system.size, at), dense[at])
    reduction = ConstantParts.of(dense[at])
    placed = place(blocks, *reduction.placement(), reduction.arranged_shape)
    assert placed.shape == (omega.size, *reduction.arranged_shape)
    assert np.array_equal(placed, reduction.arrange(dense))


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
    s = reduction.reduce(reduction.arrange(u))
    ratio = np.linalg.det(u) / np.linalg.det(s)
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-12)
