"""The dynamic surface's PV whole, in the steady cut and the edge run-out (oracles: synthetic
z_re terms of known shape on the packaged machine's passes, the steady span's closed form, the
surface of the dynamic source alone as ``simulate`` reports it)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import ufmt
from ufmt.defaults import DEFAULT_SPACING
from ufmt.machining.surface import DYNAMIC_METRICS, dynamic_metrics, surface_passes
from ufmt.model.machine import machine_of, read_machine

FEED = 50e-6  # [m/rev], the reference cut's


@pytest.fixture(scope="module")
def machine(packaged):
    return machine_of(packaged)


@pytest.fixture(scope="module")
def passes(machine):
    return surface_passes(machine, FEED, DEFAULT_SPACING)


def periodic_term(passes):
    """A steady z_re: 20 nm cos(5 phi) + 3 nm, the same every revolution (both passes)."""
    z = 20e-9 * np.cos(5 * passes.phi) + 3e-9
    return np.broadcast_to(z, passes.slide.shape)


def test_a_steady_periodic_zre_has_equal_whole_and_steady_pv_up_to_the_grid(passes, machine):
    """Every column's value is on every row, and some rows are steady throughout: the whole
    PV is the term's range over the grid's pass angles, the steady PV its range over the
    columns off the side edges, so they differ by at most the term's change over one grid
    step (20 nm 5 |sin(5 phi)| |dphi/dx| h_x at the edge)."""
    term = periodic_term(passes)
    m = dynamic_metrics(passes, term, machine)
    z = 20 * np.cos(5 * passes.phi[0]) + 3
    assert m["pv_dynamic_nm"] == pytest.approx(z.max() - z.min(), rel=1e-12)
    assert m["pv_dynamic_steady_nm"] == pytest.approx(np.ptp(z[1:-1]), rel=1e-12)
    step = np.max(np.abs(np.diff(z)))
    assert 0 <= m["edge_runout_nm"] <= step


@pytest.mark.parametrize("edge", ["entry", "exit"])
def test_an_edge_spike_is_run_out_not_steady_pv(passes, machine, edge):
    """A 100 nm dip on the passes outside the steady span (slide before its start or after
    its end): the whole-plate PV sees it (range of the steady term + 100 nm, as the dip lies
    below the term's minimum), the steady PV does not."""
    y_a, y_b = machine.steady_span
    term = periodic_term(passes)
    outside = passes.slide < y_a if edge == "entry" else passes.slide > y_b
    assert outside.any()
    spiked = term - 100e-9 * outside
    plain = dynamic_metrics(passes, term, machine)
    m = dynamic_metrics(passes, spiked, machine)
    assert m["pv_dynamic_steady_nm"] == pytest.approx(plain["pv_dynamic_steady_nm"], rel=1e-12)
    assert m["pv_dynamic_nm"] == pytest.approx(plain["pv_dynamic_nm"] + 100.0, rel=1e-9)
    assert m["edge_runout_nm"] == pytest.approx(plain["edge_runout_nm"] + 100.0, rel=1e-9)


def test_the_steady_points_are_those_of_the_steady_span(passes, machine):
    """Passes.steady against the closed form: the leading arc passes a point (x, y) at slide
    y - R cos(phi(x)), and its two bracketing revolutions lie within one feed of it; so a
    point off the side edges whose pass is two feeds inside the steady span is steady, one
    two feeds outside it is not, and no point on a side edge x = +-lx/2 is."""
    y_a, y_b = machine.steady_span
    steady = passes.steady(machine)
    r = machine.tool_radius
    s = machine.sense * (passes.x - machine.offset_x) / r
    lead = r * np.sqrt(1 - s**2)
    slide = passes.y[:, None] - lead[None, :]  # the leading arc's pass at this point
    inner = (slide >= y_a + 2 * FEED) & (slide <= y_b - 2 * FEED)
    outer = (slide >= y_a - 2 * FEED) & (slide <= y_b + 2 * FEED)
    sides = np.abs(passes.x) == machine.workpiece_size[0] / 2
    assert sides.sum() == 2 and not steady[:, sides].any()
    assert np.all(steady[:, ~sides][inner[:, ~sides]]) and not np.any(steady[~outer])


def test_simulate_reports_the_dynamic_metrics_of_the_dynamic_source_alone(packaged):
    """pv_dynamic_nm is the PV of the dynamic source alone (pv_by_source_nm) and, with that
    source alone, the plate's pv_nm; the run-out is the difference of the two PVs; the keys
    reach the JSON and are null where the source is off."""
    process = ufmt.Process(300, 15, 4)
    options = {"n_modes": 30, "n_phi": 1024}
    full = ufmt.simulate(packaged, process, **options)
    alone = ufmt.simulate(packaged, process, sources=("dynamic",), **options)
    m = full.metrics
    assert m["pv_dynamic_nm"] == pytest.approx(full.pv_by_source_nm["dynamic"], rel=1e-12)
    assert alone.metrics["pv_dynamic_nm"] == pytest.approx(alone.metrics["pv_nm"], rel=1e-12)
    assert m["edge_runout_nm"] == pytest.approx(
        m["pv_dynamic_nm"] - m["pv_dynamic_steady_nm"], rel=1e-12
    )
    assert 0 < m["pv_dynamic_steady_nm"] <= m["pv_dynamic_nm"]
    d = full.to_dict()
    assert all(d[k] == m[k] for k in DYNAMIC_METRICS)
    off = ufmt.simulate(packaged, process, sources=("feed_marks",), **options).to_dict()
    assert all(off[k] is None for k in DYNAMIC_METRICS)


def test_nan_when_no_point_is_steady():
    """A plate shorter along the feed than the arc's sweep across its width, R (1 - cos
    phi_max) (here 60 mm radius over a 100 mm width: 26.8 mm against 20 mm), is never crossed
    whole: no steady point, the steady PV is NaN, the whole PV is still the term's range."""
    from synthetic import SMALL

    machine = read_machine({**SMALL, "workpiece_size": [0.1, 0.02]})
    y_a, y_b = machine.steady_span
    assert y_a > y_b  # the closed form: the span is empty
    passes = surface_passes(machine, FEED, 1e-3)
    m = dynamic_metrics(passes, periodic_term(passes), machine)
    assert math.isnan(m["pv_dynamic_steady_nm"]) and math.isnan(m["edge_runout_nm"])
    z = 20 * np.cos(5 * passes.phi[0]) + 3
    assert m["pv_dynamic_nm"] == pytest.approx(z.max() - z.min(), rel=1e-12)
