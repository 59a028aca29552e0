"""Line profiles of the machined surface for the PSD bands: the whole plate at a fine step.

The PSD bands (:mod:`ufmt.machining.psd`) are band RMS of the mean 1-D PSD of line profiles
along the feed (y) and across it (x); PSD2 (0.12-2.5 mm) needs steps <= 0.06 mm, which a whole
grid of a 410 mm plate cannot hold (~1.9e8 nodes). The bands read lines only, so only lines
are evaluated: along the feed the surface grid's columns (its x nodes) at ``line_spacing`` in
y, across it the grid's evenly spaced rows (its core y nodes) at ``line_spacing`` in x, as
many lines as the grid averages; (Nx + Ny) L / h points instead of (L / h)^2 (~1e7 on the
410 mm plate at 0.03 mm). Each point is the lower pass of the same terms as the grid's
(eq. 4.1, :func:`~ufmt.machining.surface.passes_on`). The lines span the clear aperture, as
the grid's bands (:func:`~ufmt.machining.psd.band_rms`): the plate less ``aperture_margin``
at every edge. Their axes are the nodes inside it of axes built as the grid's over the whole
plate (:func:`~ufmt.machining.surface.grid_axis`: nodes on the edges), and the lines run at
the grid's columns and rows inside it, so at the grid's own steps the lines are the grid's
columns and rows there.

Form: the grid's Legendre fit up to 2nd order over the clear aperture
(:func:`~ufmt.machining.surface.legendre_coefficients`) is removed as on the grid. On a column
(u fixed) its terms 1, u, v, P2(u) and u v are constant or linear in v, which the profile's own
linear detrend removes exactly, so only c5 P2(v) is subtracted; on a row only c3 P2(u). At the
grid's steps the band RMS thus equals :func:`~ufmt.machining.psd.band_rms` of the grid to
rounding.

The lines are evaluated in blocks of at most BLOCK_POINTS points (memory bounded whatever the
plate; every block of rows reads the same pass angles, so the response table's columns are
formed once per direction) and their PSDs averaged block by block.
"""

from __future__ import annotations

import numpy as np

from ufmt.machining.psd import BANDS, profile_psd, spectra_band_rms
from ufmt.machining.surface import (
    Surface,
    clear_aperture,
    grid_axis,
    legendre_coefficients,
    pass_angles,
    passes_on,
)
from ufmt.model.machine import Machine

#: Step [m] of the line profiles: Nyquist at 0.06 mm, half PSD2's shortest wavelength.
DEFAULT_LINE_SPACING = 0.03e-3
#: Points [-] of one block of line evaluation or of PSDs (~4 MB per float array).
BLOCK_POINTS = 2**19


def line_axes(
    grid: Surface, line_spacing: float, aperture_margin: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """The fine axes x (across the feed) and y (along it) [m] of the line profiles over
    ``grid``'s clear aperture (``aperture_margin`` [m] off every edge), at most
    ``line_spacing`` [m] apart: the nodes of the whole extent's fine axes inside it."""
    if not (np.isfinite(line_spacing) and line_spacing > 0):
        raise ValueError(f"line_spacing must be a finite number > 0 [m], got {line_spacing!r}")
    y = grid.y[grid.core_rows]
    fine_x = grid_axis(grid.x[0], grid.x[-1], line_spacing)
    fine_y = grid_axis(y[0], y[-1], line_spacing)
    return (
        fine_x[clear_aperture(fine_x, aperture_margin)],
        fine_y[clear_aperture(fine_y, aperture_margin)],
    )


def line_spectra(
    machine: Machine,
    feed_per_rev: float,
    grid: Surface,
    heights,
    line_spacing: float = DEFAULT_LINE_SPACING,
    trailing_arc: bool = False,
    aperture_margin: float = 0.0,
) -> dict[str, tuple[int, float, np.ndarray, np.ndarray]]:
    """The mean PSD of the line profiles in each direction of
    :data:`~ufmt.machining.psd.DIRECTIONS` over the clear aperture: (points per line, step
    [m], frequency [1/m], PSD [m^2 m]).

    ``grid``: the surface on the grid (its columns, rows and form fit); ``heights(passes)``:
    the terms of that surface (heights at both passes) on any
    :class:`~ufmt.machining.surface.Passes`; ``feed_per_rev`` [m] and ``trailing_arc`` as
    the grid's passes; ``line_spacing`` [m] the step along the lines; ``aperture_margin`` [m]
    the clear aperture's edge exclusion (:func:`~ufmt.machining.psd.band_rms`'s).
    """
    x, y = grid.x, grid.y[grid.core_rows]
    in_x, in_y = clear_aperture(x, aperture_margin), clear_aperture(y, aperture_margin)
    x, y = x[in_x], y[in_y]
    coef = legendre_coefficients(x, y, grid.z[grid.core_rows][np.ix_(in_y, in_x)])
    fine_x, fine_y = line_axes(grid, line_spacing, aperture_margin)
    hx, hy = fine_x[1] - fine_x[0], fine_y[1] - fine_y[0]

    def along():  # the grid's columns; of the fit only c5 P2(v) is not a line in v
        z = lines_surface(machine, feed_per_rev, x, fine_y, heights, trailing_arc)
        z -= coef[5] * _p2(fine_y, y)[:, None]
        return mean_psd(z, hy, axis=0)

    def across():  # the grid's rows; of the fit only c3 P2(u) is not a line in u
        z = lines_surface(machine, feed_per_rev, fine_x, y, heights, trailing_arc)
        z -= coef[3] * _p2(fine_x, x)[None, :]
        return mean_psd(z, hx, axis=1)

    return {"along": (fine_y.size, hy, *along()), "across": (fine_x.size, hx, *across())}


def line_band_rms(spectra: dict, bands=tuple(BANDS)) -> dict[str, float]:
    """Band RMS [nm] of :func:`line_spectra` (keys as :func:`~ufmt.machining.psd.band_rms`)."""
    profiles = {d: (n, h, lambda f=f, p=p: (f, p)) for d, (n, h, f, p) in spectra.items()}
    return spectra_band_rms(profiles, bands)


def lines_surface(
    machine: Machine, feed_per_rev: float, x: np.ndarray, y: np.ndarray, heights, trailing_arc
) -> np.ndarray:
    """The surface (Ny, Nx) [m] of the terms ``heights(passes)`` at the points of columns x
    (Nx,) and rows y (Ny,) [m], the lower pass everywhere, a block of rows at a time."""
    angles = pass_angles(machine, x)
    z = np.empty((y.size, x.size))
    step = max(1, BLOCK_POINTS // x.size)
    for i in range(0, y.size, step):
        passes = passes_on(machine, feed_per_rev, x, y[i : i + step], None, trailing_arc, angles)
        z[i : i + step] = passes.lower(heights(passes)).z
    return z


def mean_psd(z: np.ndarray, spacing: float, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~ufmt.machining.psd.profile_psd` of the lines of ``z`` along ``axis``,
    ``spacing`` [m], a block of lines at a time: frequency [1/m] and the mean PSD."""
    lines = np.moveaxis(z, axis, -1)
    count, n = lines.shape
    step = max(1, BLOCK_POINTS // n)
    total = 0.0
    for i in range(0, count, step):
        frequency, psd = profile_psd(lines[i : i + step], spacing)
        total = total + psd * min(step, count - i)
    return frequency, total / count


def _p2(fine: np.ndarray, coarse: np.ndarray) -> np.ndarray:
    """P2(u) = 1.5 u^2 - 0.5 at ``fine`` [m], u scaled to [-1, 1] over ``coarse``'s ends."""
    u = (2 * fine - coarse[0] - coarse[-1]) / (coarse[-1] - coarse[0])
    return 1.5 * u**2 - 0.5
