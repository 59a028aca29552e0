"""MSTMM against the independently assembled mass-stiffness model of the same file."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from strategies import random_model, rigid_models

from ufmt.assembled import assembled_modes
from ufmt.model.load import model_from_dict
from ufmt.mstmm.solve import certified_roots
from ufmt.mstmm.topology import build_topology


def compare(model, rtol):
    asm = assembled_modes(model)
    est = np.asarray(asm.frequencies_hz)
    fmax = float(est.max()) * 1.001
    _, roots = certified_roots(model, fmax)
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


def beam_loop_model(seed: int) -> dict:
    """Random rigid tree with a round and a rectangular beam closing a loop through a hub."""
    data = random_model(seed, n_bodies=3, n_loops=1, ground_loops=0)
    rng = np.random.default_rng(seed)
    p0, p1, p2 = rng.uniform(-0.5, 0.5, (3, 3))
    common = {"density": 7850.0, "youngs_modulus": 2.1e11, "shear_modulus": 8.1e10}
    data["body"] += [
        {
            "name": "shaft",
            "kind": "beam",
            "start": p0.tolist(),
            "end": p1.tolist(),
            "diameter": 0.08,
            **common,
        },
        {
            "name": "plate",
            "kind": "beam",
            "start": p1.tolist(),
            "end": p2.tolist(),
            "area": 4e-3,
            "second_moment_y": 2e-6,
            "second_moment_z": 5e-6,
            "polar_moment": 7e-6,
            "torsion_constant": 4e-6,
            **common,
        },
        {"name": "hub", "kind": "virtual"},
    ]
    k = {"stiffness": [5e7, 6e7, 7e7], "rotational_stiffness": [2e6, 3e6, 4e6]}
    data["hinge"] += [
        {"name": "s0", "between": ["b0", "shaft"], "at": p0.tolist(), **k},
        {"name": "s1", "between": ["shaft", "hub"], "at": p1.tolist(), **k},
        {"name": "s2", "between": ["hub", "plate"], "at": p1.tolist(), **k},
        {"name": "s3", "between": ["plate", "b2"], "at": p2.tolist(), **k},
        {"name": "s4", "between": ["hub", "ground"], "at": p1.tolist(), **k},
    ]
    return data


def test_beams_inside_loops_converge_to_mstmm():
    """Two beams in a closed loop: the assembled model (consistent mass, an upper bound mode by
    mode) converges to the MSTMM roots from above, its error falling at least 4x per halving
    of the element length (h² for axial/torsion, h⁴ for bending)."""
    model = model_from_dict(beam_loop_model(3))
    fmax = 600.0
    coarse = np.asarray(assembled_modes(model, fmax_hz=fmax, elements_per_beam=16).frequencies_hz)
    fine = np.asarray(assembled_modes(model, fmax_hz=fmax, elements_per_beam=32).frequencies_hz)
    _, roots = certified_roots(model, fmax)
    f = roots.frequencies_hz
    # the assembled roots are upper bounds: each one below fmax has its MSTMM root below it
    assert np.sum(fine <= fmax) <= f.size <= fine.size
    fine = fine[: f.size]
    err_coarse = coarse[: f.size] / f - 1
    err_fine = fine / f - 1
    assert np.all(err_fine > -1e-10)  # upper bounds
    assert np.all(err_fine < 1e-4)
    significant = err_fine > 1e-9
    assert np.all(err_coarse[significant] / err_fine[significant] > 3.5)
