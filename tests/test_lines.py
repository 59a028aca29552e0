"""The PSD bands on line profiles (ufmt.machining.lines) against the whole grid.

Oracle: at the grid's own steps the line profiles are the grid's columns and rows, so their
bands equal band_rms of the grid (an independent path: the whole grid, the full Legendre fit,
every profile at once) to rounding; finer lines converge under halving of the step.
"""

import math
import subprocess
import sys

import numpy as np
import pytest
from synthetic import MACHINE, SMALL, synthetic_basis

import ufmt
from ufmt.errors import ProcessError
from ufmt.machining.lines import line_axes, lines_surface
from ufmt.machining.process import Process
from ufmt.machining.psd import band_rms
from ufmt.machining.sources import MODEL, SCALLOP, acting_sources, check_sources
from ufmt.machining.validity import OutsideDomainError
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model

PROCESS = Process(300, 15, 4)
BAND_KEYS = [f"{b}_rms{d}_nm" for b in ("psd1", "psd2") for d in ("", "_along", "_across")]
#: Plates (x, y) [m] and the grid's (square) step [m]: one resolves PSD1, the other PSD2 (over
#: the clear aperture: the plate less MARGIN at every edge).
CASES = [((0.11, 0.11), 1e-3), ((0.010, 0.011), 0.05e-3)]
#: Clear-aperture edge exclusion [m] of every run.
MARGIN = 1e-3
#: Samples per revolution of every run (the default follows the grid step: costly here).
N_PHI = 2048


def model_of(size):
    """The synthetic machine on a plate of ``size`` [m]."""
    return Model("syn", (), (), machine=read_machine({**SMALL, "workpiece_size": list(size)}))


def run(size, process=PROCESS, **options):
    """ufmt.simulate of the synthetic basis (no static correction) on a plate of ``size``."""
    basis = synthetic_basis(n=6)
    options = {
        "basis": basis,
        "static_correction": False,
        "n_phi": N_PHI,
        "aperture_margin": MARGIN,
        **options,
    }
    return ufmt.simulate(model_of(size), process, **options)


@pytest.mark.parametrize("size, step", CASES)
@pytest.mark.parametrize("method", ["periodic", "time"])
def test_lines_at_the_grid_step_are_the_grid_rows_and_columns(size, step, method):
    grid = run(size, spacing=step, line_spacing=None, method=method)
    expected = band_rms(grid.smooth_surface, aperture_margin=MARGIN)
    assert any(np.isfinite(expected[k]) and expected[k] > 0 for k in BAND_KEYS)
    lines = run(size, spacing=step, line_spacing=step, method=method).metrics
    for key in BAND_KEYS:
        np.testing.assert_allclose(grid.metrics[key], expected[key], rtol=1e-12, equal_nan=True)
        np.testing.assert_allclose(lines[key], expected[key], rtol=1e-9, equal_nan=True)
    assert lines["psd_line_spacing_mm"] == pytest.approx(step * 1e3)


def test_lines_surface_equals_the_grid_at_its_nodes():
    """The lines' heights at the grid's nodes are the grid's heights (evaluated a block of rows
    at a time, every block reading the same pass angles)."""
    size, step = CASES[1]
    result = run(size, spacing=step, line_spacing=None)
    grid, machine = result.smooth_surface, result.machine
    sources = acting_sources(check_sources(result.sources), machine)
    smooth = [s for s in sources if s.enters not in (SCALLOP, MODEL)]  # no model: no bodies

    def heights(passes):
        return [s.heights(passes, result.response.table, machine, PROCESS, {}) for s in smooth]

    fine_x, fine_y = line_axes(grid, step)
    core_y = grid.y[grid.core_rows]
    np.testing.assert_array_equal(fine_x, grid.x)
    np.testing.assert_array_equal(fine_y, core_y)
    z = lines_surface(machine, PROCESS.feed_per_rev_m, grid.x, core_y, heights, False)
    np.testing.assert_allclose(z, grid.z[grid.core_rows], rtol=0, atol=1e-12 * np.ptp(z))


def test_psd2_converges_under_halving_of_the_line_step():
    """The PSD2 band RMS on the whole plate at 0.03, 0.015 and 0.0075 mm (8 mm/min, 300 rpm,
    as the packaged model's reference cut): the second halving changes it less than the first,
    and by < 1 % (the default reads within 2 %). Not every surface converges as fast: at
    15 mm/min this plate's reading wanders by +-15 % down to 0.01 mm (docs/ufmt-model.md)."""
    size, process = CASES[1][0], Process(300, 8, 5)
    psd2 = [
        run(size, line_spacing=h, process=process).metrics["psd2_rms_nm"]
        for h in (0.03e-3, 0.015e-3, 0.0075e-3)
    ]
    assert all(math.isfinite(v) and v > 0 for v in psd2)
    first, second = abs(psd2[1] - psd2[0]), abs(psd2[2] - psd2[1])
    assert second < first < 0.02 * psd2[2]
    assert second < 0.01 * psd2[2]


@pytest.mark.parametrize("bad", [0.0, -1e-5, math.nan, math.inf])
def test_a_bad_line_step_is_refused(bad):
    with pytest.raises(OutsideDomainError, match="line_spacing"):
        run(CASES[1][0], line_spacing=bad)


def test_too_many_line_points_are_refused_before_any_work():
    with pytest.raises(ProcessError, match="line-profile points; at most"):
        run((0.1, 0.1), line_spacing=1e-8)


def test_cli_refuses_a_line_step_too_fine_for_the_plate_in_one_line():
    done = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", "simulate", "--line-spacing", "1e-5", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and "line-profile points; at most" in done.stderr


@pytest.mark.slow
def test_a_410_mm_plate_reports_finite_psd1_and_psd2():
    """The contract: the whole 410 mm aperture resolves both bands in both directions."""
    model = Model("syn", (), (), machine=read_machine(MACHINE))
    metrics = ufmt.simulate(
        model, PROCESS, basis=synthetic_basis(n=6), static_correction=False
    ).metrics
    assert all(math.isfinite(metrics[key]) and metrics[key] > 0 for key in BAND_KEYS)
