"""The periodic path's z_re table read where the surface reads it: from the few
samples the stencils touch, by the periodic impulse response, it equals the whole table
computed by the harmonics (an independent evaluation) read at the same angles."""

import dataclasses

import numpy as np
import pytest
from synthetic import SMALL, random_residual, synthetic_basis

from ufmt.machining.cut_geometry import cut_geometry
from ufmt.machining.periodic_path import periodic_response
from ufmt.machining.process import Process
from ufmt.machining.response import ZreTable
from ufmt.machining.surface import surface_grid
from ufmt.model.machine import read_machine


@pytest.mark.parametrize("residual", [None, random_residual()])
@pytest.mark.parametrize("n_phi", [64, 512])
def test_columns_from_few_samples_equal_the_whole_table_read_there(residual, n_phi):
    m = read_machine(SMALL)
    basis = synthetic_basis(n=5)
    geos = [
        cut_geometry(basis, m, n_phi=n_phi, table_rows=40, part=part, residual=residual)
        for part in ("area", "edge")
    ]
    table = periodic_response(geos, Process(260, 11, 5)).table
    whole = ZreTable(table.values, table.row_y, table.drift, table.row_knots)
    # both arcs of a surface grid, and angles anywhere on the circle
    phi = np.concatenate(
        [surface_grid(m, (2e-3, 2e-3))[3].ravel(), np.linspace(0, 2 * np.pi, 37)[:-1]]
    )
    expected = whole.columns(phi)
    assert np.abs(expected).max() > 0
    np.testing.assert_allclose(
        table.columns_from_samples(phi), expected, rtol=0, atol=1e-12 * np.abs(expected).max()
    )
    # columns() of a fresh table picks by cost (here the samples); the same numbers
    fresh = dataclasses.replace(table)
    np.testing.assert_allclose(
        fresh.columns(phi), expected, rtol=0, atol=1e-12 * np.abs(expected).max()
    )
