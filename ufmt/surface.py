"""Machined surface from the relative tool-workpiece motion (paper eq. 4.1) and its metrics.

Tool path on the workpiece (eq. 4.1; workpiece frame, see :mod:`ufmt.dynamics.cutting`):
x = s_x + sigma R sin(phi), y = Y + R cos(phi), the slide position Y advancing by v/f per
revolution. A grid point (x, y) is met by the leading arc at phi_f = asin((x - s_x)/(sigma R))
when Y = y - R cos(phi_f), once per revolution in the neighbourhood of that slide position, and
keeps the lowest z_re of the passes over it ("tool interference", section 4.2):
z(x, y) = min over passes of z_re(phi, Y), z_re read from the response's
:class:`~ufmt.dynamics.response.ZreTable` (cubic in phi, linear in Y).

The tool of eq. 4.1 is a point (no kinematic marks): the passes over a point are the two
revolutions whose paths bracket it, each read at its own slide position (a time table holds
every revolution; a periodic table the steady state at that slide position). With
``nose_radius`` (off by default) the nose adds the kinematic marks, d^2 / (2 r_n) at normal
distance d from each bracketing path. The trailing arc (phi = pi - phi_f, at Y = y + R cos)
passes over the finished surface without cutting force; by default it does not re-cut: in
eq. 4.1's picture the middle of the plate, cut under the largest force, ends up highest (the
paper's Fig. 14), which a re-cutting trailing arc with the tool unloaded would erase.
``trailing_arc=True`` adds its passes to the minimum (back-cutting).

Grid: cell centres at most ``spacing`` apart (default ``DEFAULT_SPACING`` = 2 mm: 216 x 216
points, 1.9 mm, on the 0.41 m plate; counts are rounded up to fast FFT lengths); the PV is then
converged to better than 0.5 % (tests/test_surface.py).

Metrics (nm): PV = max - min over all points (as in the paper); PV and RMS with the best-fit
plane removed; band RMS = RMS of the plane-removed, Hann-windowed surface band-passed to spatial
wavelengths in the PSD1 (2.5-33 mm) and PSD2 (0.12-2.5 mm) bands of KDP optics (isotropic
spatial frequency). A grid of spacing h resolves wavelengths down to 2h only: a band reaching
below that is evaluated over its resolved part (PSD2 needs h <= 0.06 mm to be complete; with
the point tool of eq. 4.1 and 30 modes the surface has almost no content there).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.fft import next_fast_len

from ufmt.dynamics.cutting import Machine
from ufmt.dynamics.response import ZreTable

DEFAULT_SPACING = 2e-3
#: Spatial wavelength bands [m] of the KDP specifications.
BANDS = {"psd1": (2.5e-3, 33e-3), "psd2": (0.12e-3, 2.5e-3)}


@dataclass(frozen=True, eq=False)
class Surface:
    """Machined surface: x (Nx,), y (Ny,) cell centres [m] (workpiece frame), z (Ny, Nx) [m]."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray

    @property
    def spacing(self) -> tuple[float, float]:
        """Grid spacing (hx, hy) [m]."""
        return float(self.x[1] - self.x[0]), float(self.y[1] - self.y[0])


@lru_cache(maxsize=16)
def _grid(machine: Machine, spacing: float):
    """Cell centres and the two pass angles of every column (cached per machine and spacing)."""
    if not spacing > 0:
        raise ValueError(f"grid spacing must be > 0, got {spacing!r}")
    lx, ly = machine.workpiece_size
    # at most ``spacing`` apart; point counts rounded up to fast FFT lengths (for the PSD bands)
    nx, ny = (next_fast_len(max(int(np.ceil(v / spacing - 1e-9)), 4), real=True) for v in (lx, ly))
    x = (np.arange(nx) + 0.5) * (lx / nx) - lx / 2
    y = (np.arange(ny) + 0.5) * (ly / ny) - ly / 2
    s = machine.sense * (x - machine.offset_x) / machine.tool_radius
    lead = np.arcsin(s)
    phi = np.mod(np.stack([lead, np.pi - lead]), 2 * np.pi)  # (2, Nx): leading, trailing arc
    cos = np.cos(phi)
    return x, y, phi, cos


def machined_surface(
    table: ZreTable,
    machine: Machine,
    feed_per_rev: float,
    spacing: float = DEFAULT_SPACING,
    nose_radius: float | None = None,
    trailing_arc: bool = False,
) -> Surface:
    """The machined surface (eq. 4.1 with tool interference) on a grid of ``spacing`` [m].

    ``feed_per_rev`` [m] spaces the revolutions; ``nose_radius`` [m] turns on the kinematic
    marks; ``trailing_arc`` adds the trailing-arc passes to the minimum (back-cutting).
    Each point takes the lower of the two revolutions whose paths bracket it; a periodic
    (quasi-static) table gives each of them the steady state at its own slide position.
    """
    if not feed_per_rev > 0:
        raise ValueError(f"feed_per_rev must be > 0 [m], got {feed_per_rev!r}")
    if nose_radius is not None and not nose_radius > 0:
        raise ValueError(f"nose_radius must be > 0 [m], got {nose_radius!r}")
    x, y, phi, cos = _grid(machine, spacing)
    arcs = 2 if trailing_arc else 1
    phi, cos = phi[:arcs], cos[:arcs]
    cols = _columns(table.values, phi)
    turn = phi / (2 * np.pi)
    y_start = machine.cut_span[0]
    # revolutions since Y_start when the arc passes the point; the two bracketing revolutions
    rho = (y[:, None, None] - machine.tool_radius * cos - y_start) / feed_per_rev - turn
    k = np.floor(rho)
    frac = rho - k
    y_lo = y_start + feed_per_rev * (k + turn) - table.drift * turn
    z_lo = _gather(cols, *_locate(table.row_knots, cols.shape[0], y_lo))
    z_hi = _gather(cols, *_locate(table.row_knots, cols.shape[0], y_lo + feed_per_rev))
    if nose_radius is not None:
        d2 = (feed_per_rev * cos) ** 2 / (2 * nose_radius)
        z_lo += frac**2 * d2
        z_hi += (1 - frac) ** 2 * d2
    return Surface(x, y, np.minimum(z_lo, z_hi).min(axis=1))


def _columns(values: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Table columns at angles phi (arcs, Nx), 4-point Lagrange in phi: (rows, arcs * Nx)."""
    rows, n3 = values.shape
    u = phi * ((n3 - 3) / (2 * np.pi))
    j0 = np.minimum(u.astype(int), n3 - 4)
    t = u - j0
    w = (
        -t * (t - 1) * (t - 2) / 6,
        (t + 1) * (t - 1) * (t - 2) / 2,
        -(t + 1) * t * (t - 2) / 2,
        (t + 1) * t * (t - 1) / 6,
    )
    cols = sum(values[:, j0 + i] * w[i] for i in range(4))
    return cols.reshape(rows, -1)


def _locate(row_knots, rows: int, slide: np.ndarray):
    """Flat indices into ``cols`` (rows, A) of the row below ``slide`` (Ny, arcs, Nx), weights."""
    rr = np.interp(slide, *row_knots)
    i0 = np.minimum(rr.astype(int), rows - 2)
    width = slide.shape[1] * slide.shape[2]
    flat = i0.reshape(slide.shape[0], width) * width + np.arange(width)
    return flat.reshape(slide.shape), rr - i0


def _gather(cols: np.ndarray, flat: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Linear interpolation between the located row and the next one: (Ny, arcs, Nx) [m]."""
    c = cols.ravel()
    lo = c[flat]
    return lo + weight * (c[flat + cols.shape[1]] - lo)


def steady_region(surface: Surface, machine: Machine, settle: float = 0.0) -> np.ndarray:
    """Points whose leading-arc pass has a constant chip pattern behind it: (Ny, Nx) bool.

    True where the pass happens while the leading arc crosses the whole workpiece width
    (:attr:`Machine.steady_span`), at least ``settle`` [m] of slide travel after that began.
    There the time-domain response has reached the periodic steady state.
    """
    y_a, y_b = machine.steady_span
    s = machine.sense * (surface.x - machine.offset_x) / machine.tool_radius
    slide = surface.y[:, None] - machine.tool_radius * np.sqrt(1 - s**2)[None, :]
    return (slide >= y_a + settle) & (slide <= y_b)


@lru_cache(maxsize=16)
def _spectral(nx: int, ny: int, hx: float, hy: float):
    """Hann window and the rfft2 weights of each band (cached per grid)."""
    win = np.outer(np.hanning(ny + 2)[1:-1], np.hanning(nx + 2)[1:-1])
    norm = 1.0 / (nx * ny * np.sqrt(np.mean(win**2)))
    fx = np.fft.rfftfreq(nx, hx)
    fy = np.fft.fftfreq(ny, hy)
    nu = np.hypot(fy[:, None], fx[None, :])
    half = np.full(fx.size, 2.0)  # rfft2 holds each +-fx pair once
    half[0] = 1.0
    if nx % 2 == 0:
        half[-1] = 1.0
    nyquist = 0.5 / max(hx, hy)
    masks = {}
    for name, (lam_min, lam_max) in BANDS.items():
        inside = (nu >= 1.0 / lam_max) & (nu <= min(1.0 / lam_min, nyquist))
        masks[name] = inside * half[None, :]
    return win, norm, masks


def surface_metrics(surface: Surface) -> dict[str, float]:
    """PV, PV and RMS with the best-fit plane removed, band RMS of PSD1 and PSD2 [nm].

    Keys: pv_nm, pv_tilt_removed_nm, rms_nm, psd1_rms_nm, psd2_rms_nm, grid_spacing_mm.
    """
    x, y, z = surface.x, surface.y, surface.z
    # cell-centred symmetric grid: 1, x and y are orthogonal, so the plane fit is three means
    xc, yc = x - x.mean(), y - y.mean()
    bx = (z @ xc).sum() / (y.size * (xc @ xc))
    by = (yc @ z).sum() / (x.size * (yc @ yc))
    flat = z - z.mean() - bx * xc[None, :] - by * yc[:, None]
    hx, hy = surface.spacing
    win, norm, masks = _spectral(x.size, y.size, hx, hy)
    power = np.abs(np.fft.rfft2(flat * win)) ** 2
    out = {
        "pv_nm": float(np.ptp(z)) * 1e9,
        "pv_tilt_removed_nm": float(np.ptp(flat)) * 1e9,
        "rms_nm": float(np.sqrt(np.mean(flat**2))) * 1e9,
    }
    for name, mask in masks.items():
        out[f"{name}_rms_nm"] = float(np.sqrt(np.sum(power * mask)) * norm) * 1e9
    out["grid_spacing_mm"] = max(hx, hy) * 1e3
    return out
