"""MSTMM against the independently assembled mass-stiffness model of the same file."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from strategies import random_model, rigid_models

from ufmt.assembled import assembled_modes
from ufmt.model.load import model_from_dict
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.roots import natural_frequencies
from ufmt.mstmm.topology import build_topology


def compare(model, rtol):
    asm = assembled_modes(model)
    est = np.asarray(asm.frequencies_hz)
    fmax = float(est.max()) * 1.001
    roots = natural_frequencies(TransferSystem(model), fmax, est)
    assert roots.frequencies_hz.size == est.size
    assert np.allclose(roots.frequencies_hz, est, rtol=rtol, atol=0)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rigid_models())
def test_random_rigid_trees_and_loops(data):
    compare(model_from_dict(data), 1e-7)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(rigid_models(special=True))
def test_random_models_with_released_and_rigid_directions(data):
    compare(model_from_dict(data), 1e-7)


def test_order_counts_cuts_and_ground_loops():
    """Order = 6 per root + 12 per body-body cut + 6 per cut at ground (no free tips)."""
    data = random_model(7, n_bodies=4, n_loops=3, ground_loops=2)
    topo = build_topology(model_from_dict(data))
    assert topo.order_size == 6 + 12 * 3 + 6 * 2 + 6 * len(topo.free_tip_columns)
