"""The periodic path evaluated a block at a time (the z_re table's rows and its kernels'
harmonics, the recurrence's modes), which bounds the memory of a large plate, against the same
evaluation in one block.

Oracle: the blocks are independent (each table row's spectrum and inverse transform, each
harmonic's kernel, each mode's recurrence), so every number must be equal whatever the block
size: one row, harmonic or mode at a time against all at once, to the rounding of the library
kernels a one-row or one-mode product or transform takes (1e-12 of the table's and 1e-13 of
the state's largest value; the metrics [nm] to 1e-12 relative).
"""

from importlib import resources

import numpy as np
import pytest
from synthetic import SMALL, synthetic_basis

import ufmt
from ufmt.machining import periodic_path, recurrence
from ufmt.machining.damping import damped_modes
from ufmt.machining.process import Process
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model

PROCESS = Process(300, 15, 4)
PACKAGED = str(resources.files("ufmt") / "data" / "ufmt.toml")


def _packaged():
    """The packaged UFMT (complex modes: its hinge dampers), coarse enough to be quick."""
    return ufmt.simulate(PACKAGED, PROCESS, n_phi=2048, line_spacing=2e-4)


def _synthetic():
    """A synthetic machine on a 20 mm plate (real modes, proportional damping)."""
    model = Model("syn", (), (), machine=read_machine({**SMALL, "workpiece_size": [0.02] * 2}))
    basis = synthetic_basis(n=6)
    return ufmt.simulate(
        model, PROCESS, basis=basis, static_correction=False, n_phi=1024, line_spacing=1e-4
    )


def _in_blocks(monkeypatch, size: int, simulate):
    """``simulate()`` with every block of ``size`` bytes and its table's values."""
    monkeypatch.setattr(periodic_path, "SPECTRA_BLOCK_BYTES", size)
    monkeypatch.setattr(periodic_path, "MODE_BLOCK_BYTES", size)
    monkeypatch.setattr(recurrence, "MODE_BLOCK_BYTES", size)
    periodic_path._periodic_kernels.cache_clear()  # the kernels are formed in blocks too
    result = simulate()
    return result, result.response.table.values


@pytest.mark.parametrize("simulate", [_packaged, _synthetic])
def test_blocks_of_one_equal_one_block(monkeypatch, simulate):
    whole, whole_values = _in_blocks(monkeypatch, 2**62, simulate)
    result, values = _in_blocks(monkeypatch, 1, simulate)
    table = result.response.table
    geo = table.parts[0]
    modes = damped_modes(geo.basis, np.array(table.zeta))
    assert (modes is not None) == (simulate is _packaged)  # both recurrences are covered
    assert values.shape == (table.row_y.size, geo.n_phi + 3) and np.abs(values).max() > 0
    scale = np.abs(whole_values).max()
    np.testing.assert_allclose(values, whole_values, rtol=0, atol=1e-12 * scale)
    numbers = {k: v for k, v in whole.metrics.items() if isinstance(v, float)}
    assert len(numbers) > 20 and set(numbers) <= set(result.metrics)
    for key, value in numbers.items():
        np.testing.assert_allclose(result.metrics[key], value, rtol=1e-12, err_msg=key)


def test_from_rest_by_mode_equals_all_modes(monkeypatch):
    omega = 2 * np.pi * np.array([30.0, 400.0, 1200.0, 3000.0])
    zeta = np.array([0.05, 0.02, 0.3, 0.05])
    rec = recurrence.pole_recurrence(-zeta * omega + 1j * omega * np.sqrt(1 - zeta**2), 1e-4, 60)
    force = np.random.default_rng(1).normal(size=(4, 41)) * (1 + 0.5j)
    monkeypatch.setattr(recurrence, "MODE_BLOCK_BYTES", 2**62)
    whole = rec.from_rest(force)
    tol = 1e-13 * np.abs(whole).max()
    monkeypatch.setattr(recurrence, "MODE_BLOCK_BYTES", 1)
    np.testing.assert_allclose(rec.from_rest(force), whole, rtol=0, atol=tol)
    for i in range(4):  # one mode's recurrence is the subset's
        one = rec.subset(slice(i, i + 1)).from_rest(force[i : i + 1])
        np.testing.assert_allclose(one, whole[i : i + 1], rtol=0, atol=tol)
