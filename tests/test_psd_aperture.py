"""The PSD bands over the clear aperture (the plate less ``aperture_margin`` at every edge, as
the interferometer's PV), on the grid and on the line profiles.

Oracles: invariance, the bands over the clear aperture do not change when the surface changes
outside it (a feature 100 times the interior's in the entry, exit and side strips: the bands
do not see it, to rounding), while the same feature moves them when the aperture takes it in
(margin 0); and two independent paths, the grid's band_rms (the whole clear-aperture grid, its
full Legendre fit) and the line profiles at the grid's own step (each line alone, only the P2
terms of the fit removed), which read the same profiles and so agree to 1e-9.
"""

import numpy as np
from synthetic import SMALL

from ufmt.machining.lines import line_band_rms, line_spectra
from ufmt.machining.process import Process
from ufmt.machining.psd import band_rms
from ufmt.machining.surface import Surface
from ufmt.model.machine import read_machine

STEP = 0.05e-3  # [m]
#: Nodes across and along: fast FFT lengths, so the lines' axes at STEP are the grid's.
NX, NY = 256, 288
MARGIN = 1e-3  # [m]
PROCESS = Process(300, 15, 4)
X = np.linspace(-(NX - 1) * STEP / 2, (NX - 1) * STEP / 2, NX)
Y = np.linspace(-(NY - 1) * STEP / 2, (NY - 1) * STEP / 2, NY)
MACHINE = read_machine({**SMALL, "workpiece_size": [X[-1] - X[0], Y[-1] - Y[0]]})


def interior(x, y):
    """PSD2 content everywhere [m]: 1 nm at 0.5 mm across the feed, 0.8 mm along it."""
    return 1e-9 * (np.sin(2 * np.pi * x / 0.5e-3) + np.cos(2 * np.pi * y / 0.8e-3 + 0.3))


def edge(x, y):
    """A 0.3 mm ripple of 100 nm on the strips outside the clear aperture only [m]."""
    outside = (np.abs(x) > X[-1] - MARGIN + 1e-9) | (np.abs(y) > Y[-1] - MARGIN + 1e-9)
    return np.where(outside, 1e-7 * np.sin(2 * np.pi * (x + y) / 0.3e-3), 0.0)


def grid(f) -> Surface:
    return Surface(X, Y, f(X[None, :], Y[:, None]))


def lines(f, margin: float) -> dict[str, float]:
    """The bands of ``f`` on the line profiles at the grid's step over the clear aperture."""

    def heights(passes):  # one term, the same at both passes
        return [f(passes.x[None, :], passes.y[:, None])[:, None, :]]

    spectra = line_spectra(
        MACHINE, PROCESS.feed_per_rev_m, grid(f), heights, STEP, aperture_margin=margin
    )
    return line_band_rms(spectra)


def both(x, y):
    return interior(x, y) + edge(x, y)


KEYS = ("psd2_rms_along_nm", "psd2_rms_across_nm")


def test_the_bands_do_not_see_the_edge_strips():
    assert np.abs(edge(X[None, :], Y[:, None])).max() > 50e-9  # [m]: 50x the interior
    clean = band_rms(grid(interior), aperture_margin=MARGIN)
    edged = band_rms(grid(both), aperture_margin=MARGIN)
    whole = band_rms(grid(both), aperture_margin=0.0)
    for key in KEYS:
        assert clean[key] > 0.1  # [nm]: the interior's content is resolved
        np.testing.assert_allclose(edged[key], clean[key], rtol=1e-12)
        assert whole[key] > 3 * clean[key]  # the same strips inside the aperture dominate


def test_lines_and_grid_agree_over_the_clear_aperture():
    for f in (interior, both):
        on_grid = band_rms(grid(f), aperture_margin=MARGIN)
        on_lines = lines(f, MARGIN)
        for key in KEYS:
            np.testing.assert_allclose(on_lines[key], on_grid[key], rtol=1e-9)
    np.testing.assert_allclose(lines(both, MARGIN)["psd2_rms_nm"], on_grid["psd2_rms_nm"])
    wide = lines(both, 0.0)
    for key in KEYS:
        np.testing.assert_allclose(
            wide[key], band_rms(grid(both), aperture_margin=0.0)[key], rtol=1e-9
        )
