"""The complex modes' defectiveness check (oracle: the Jordan form of a critically damped
mode, q'' + 2 w q' + w^2 q = f, whose first-order matrix [[0, 1], [-w^2, -2 w]] has the double
pole -w with one eigenvector, against the same mode lightly damped)."""

import numpy as np
import pytest

from ufmt.errors import UfmtError
from ufmt.machining.basis import ModalBasis
from ufmt.machining.damping import damped_modes


def one_mode(hinge: float) -> ModalBasis:
    """One mode at 2 rad/s of unit modal mass whose hinge damping adds ``hinge`` [1/s]."""
    shape = np.ones((1, 6))
    return ModalBasis(
        omega=np.array([2.0]),
        modal_mass=np.array([1.0]),
        body_shapes={"head": shape, "slider": shape},
        body_centers={"head": [0.0, 0.0, 0.0], "slider": [0.0, 0.0, 0.0]},
        hinge_damping=np.array([[hinge]]),
    )


def test_a_critically_damped_mode_is_reported_defective():
    with pytest.raises(UfmtError, match="defective"):
        damped_modes(one_mode(3.0), 0.25)  # D = 2 0.25 2 + 3 = 4 = 2 w


def test_a_lightly_damped_mode_has_its_conjugate_pole():
    modes = damped_modes(one_mode(0.1), 0.25)  # D = 1.1: zeta 0.275
    zeta = 1.1 / 4
    expected = -zeta * 2.0 + 2.0j * np.sqrt(1 - zeta**2)
    np.testing.assert_allclose(modes.poles, [expected], rtol=1e-14)
