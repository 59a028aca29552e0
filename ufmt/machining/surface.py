"""Machined surface from the relative tool-workpiece motion (paper eq. 4.1) and its metrics.

Tool path on the workpiece (eq. 4.1; workpiece frame, see :mod:`ufmt.machining.cutting`):
x = s_x + sigma R sin(phi), y = Y + R cos(phi), the slide position Y advancing by v/f per
revolution. A grid point (x, y) is met by the leading arc at phi_f = asin((x - s_x)/(sigma R))
when Y = y - R cos(phi_f), once per revolution in the neighbourhood of that slide position, and
keeps the lowest z_re of the passes over it ("tool interference", section 4.2):
z(x, y) = min over passes of z_re(phi, Y), z_re read from the response's
:class:`~ufmt.machining.response.ZreTable` (cubic in phi, linear in Y).

The tool of eq. 4.1 is a point (no kinematic marks): the passes over a point are the two
revolutions whose paths bracket it, each read at its own slide position (a time table holds
every revolution; a periodic table the steady state at that slide position). With
``nose_radius`` (off by default) the nose adds the kinematic marks, d^2 / (2 r_n) at normal
distance d from each bracketing path. The trailing arc (phi = pi - phi_f, at Y = y + R cos)
passes over the finished surface without cutting force; by default it does not re-cut: in
eq. 4.1's picture the middle of the plate, cut under the largest force, ends up highest (the
paper's Fig. 14), which a re-cutting trailing arc with the tool unloaded would erase.
``trailing_arc=True`` adds its passes to the minimum (back-cutting).

Grid: nodes on the plate's edges, at most ``spacing`` apart (default 1 mm in x, 2 mm in y:
432 x 216 nodes on the 0.41 m plate; counts rounded up to fast FFT lengths), plus rows 8 times
denser within 6 mm of the entry and exit edges (y = -+ly/2), where the first and last
revolutions of the cut leave mm-wide features that can set the PV. On the UFMT prior model the
PV is then within ~1 % of a grid four times finer (tests/test_surface.py checks 1 % on a
synthetic basis).

Metrics (nm): PV = max - min over all points (as in the paper); PV with the best-fit plane
removed; RMS with that plane removed; band RMS = RMS of the plane-removed, Hann-windowed
surface band-passed to spatial wavelengths in the PSD1 (2.5-33 mm) and PSD2 (0.12-2.5 mm)
bands of KDP optics (isotropic spatial frequency). The plane, the RMS and the bands use the
evenly spaced rows. A grid resolves wavelengths down to twice its coarser step only: a band
reaching below that is evaluated over its resolved part (4-33 mm for PSD1 at the default;
PSD2 is unresolved and reads 0: it needs steps <= 0.06 mm, and with the point tool of eq. 4.1
and 30 modes the surface has almost no content there).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.fft import next_fast_len

from ufmt.machining.response import ZreTable
from ufmt.model.machine import Machine

#: Grid spacing (x, y) [m]: x finer, as the x-profile of a pass carries the vibration of the
#: highest modes (down to ~6 mm wavelength at 200 rpm and 700 Hz); y coarser, as the surface
#: changes slowly with the slide away from the entry and exit edges (refined separately).
DEFAULT_SPACING = (1e-3, 2e-3)
#: Width [m] of the bands along the entry and exit edges (y = -+ly/2) refined for the PV, and
#: the refinement of their rows: the cut's first and last revolutions leave mm-wide features.
EDGE_BAND = 6e-3
EDGE_REFINE = 8
#: Spatial wavelength bands [m] of the KDP specifications.
BANDS = {"psd1": (2.5e-3, 33e-3), "psd2": (0.12e-3, 2.5e-3)}


@dataclass(frozen=True, eq=False)
class Surface:
    """Machined surface: x (Nx,), y (Ny,) grid [m] (workpiece frame), z (Ny, Nx) [m].

    core (Ny,) marks the rows of the evenly spaced grid (all rows if None); the others are the
    refined rows along the entry and exit edges, used by the PV only.
    """

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    core: np.ndarray | None = None

    @property
    def core_rows(self) -> np.ndarray:
        """Boolean mask (Ny,) of the evenly spaced rows."""
        return np.ones(self.y.size, bool) if self.core is None else self.core

    @property
    def spacing(self) -> tuple[float, float]:
        """Spacing (hx, hy) [m] of the evenly spaced grid."""
        y = self.y[self.core_rows]
        return float(self.x[1] - self.x[0]), float(y[1] - y[0])


@lru_cache(maxsize=16)
def _grid(machine: Machine, spacing):
    """Grid, core rows and the two pass angles of every column (cached per machine, spacing)."""
    hx, hy = np.broadcast_to(np.asarray(spacing, dtype=float), (2,))
    if not (hx > 0 and hy > 0):
        raise ValueError(f"grid spacing must be > 0, got {spacing!r}")
    lx, ly = machine.workpiece_size
    # nodes on the plate edges, at most ``spacing`` apart; counts rounded up to fast FFT lengths
    nx, ny = (
        next_fast_len(int(np.ceil(v / h - 1e-9)) + 1, real=True) for v, h in ((lx, hx), (ly, hy))
    )
    x = np.linspace(-lx / 2, lx / 2, nx)
    core_y = np.linspace(-ly / 2, ly / 2, ny)
    fine = (core_y[1] - core_y[0]) / EDGE_REFINE
    offsets = np.arange(1, int(min(EDGE_BAND, ly / 4) / fine) + 1) * fine
    band = np.concatenate([-ly / 2 + offsets, ly / 2 - offsets])
    gap = np.abs(band[:, None] - core_y[None, :]).min(axis=1)
    y = np.concatenate([core_y, band[gap > fine / 2]])
    order = np.argsort(y)
    y, core = y[order], (np.arange(y.size) < ny)[order]
    s = machine.sense * (x - machine.offset_x) / machine.tool_radius
    lead = np.arcsin(np.clip(s, -1.0, 1.0))
    phi = np.mod(np.stack([lead, np.pi - lead]), 2 * np.pi)  # (2, Nx): leading, trailing arc
    cos = np.cos(phi)
    return x, y, core, phi, cos


def machined_surface(
    table: ZreTable,
    machine: Machine,
    feed_per_rev: float,
    spacing=DEFAULT_SPACING,
    nose_radius: float | None = None,
    trailing_arc: bool = False,
) -> Surface:
    """The machined surface (eq. 4.1 with tool interference) on a grid of ``spacing`` [m].

    ``spacing``: one step or (x, y) steps [m], the largest allowed.

    ``feed_per_rev`` [m] spaces the revolutions; ``nose_radius`` [m] turns on the kinematic
    marks; ``trailing_arc`` adds the trailing-arc passes to the minimum (back-cutting).
    Each point takes the lower of the two revolutions whose paths bracket it; a periodic
    (quasi-static) table gives each of them the steady state at its own slide position.
    """
    if not feed_per_rev > 0:
        raise ValueError(f"feed_per_rev must be > 0 [m], got {feed_per_rev!r}")
    if nose_radius is not None and not nose_radius > 0:
        raise ValueError(f"nose_radius must be > 0 [m], got {nose_radius!r}")
    spacing = tuple(np.broadcast_to(np.asarray(spacing, dtype=float), (2,)).tolist())
    x, y, core, phi, cos = _grid(machine, spacing)
    arcs = 2 if trailing_arc else 1
    phi, cos = phi[:arcs], cos[:arcs]
    cols = _columns(table.values, phi)
    turn = phi / (2 * np.pi)
    y_start = machine.cut_span[0]
    # revolutions since Y_start when the arc passes the point; the two bracketing revolutions
    rho = (y[:, None, None] - machine.tool_radius * cos - y_start) / feed_per_rev - turn
    k = np.floor(rho)
    y_lo = y_start + feed_per_rev * (k + turn) - table.drift * turn
    columns = np.arange(cols.shape[1]).reshape(arcs, -1)
    z_lo = _lookup(cols, table.row_knots, y_lo, columns)
    z_hi = _lookup(cols, table.row_knots, y_lo + feed_per_rev, columns)
    if nose_radius is not None:
        frac = rho - k
        d2 = (feed_per_rev * cos) ** 2 / (2 * nose_radius)
        z_lo += frac**2 * d2
        z_hi += (1 - frac) ** 2 * d2
    z = np.minimum(z_lo, z_hi)
    return Surface(x, y, z.min(axis=1) if arcs > 1 else z[:, 0], core)


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


def _lookup(cols: np.ndarray, row_knots, slide: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``cols`` (rows, C) linearly interpolated in rows at slide positions [m], in ``columns``.

    The fractional row of a slide position comes from the table's knots (see ZreTable);
    the column indices ``columns`` broadcast against ``slide``.
    """
    start, step, u = row_knots
    rows, width = cols.shape
    t = np.clip((slide - start) / step, 0.0, u.size - 1.0)
    k = np.minimum(t.astype(np.intp), u.size - 2)
    rr = u[k] + (t - k) * (u[k + 1] - u[k])
    i0 = np.minimum(rr.astype(np.intp), rows - 2)
    flat = i0 * width + columns
    c = cols.ravel()
    lo = c[flat]
    return lo + (rr - i0) * (c[flat + width] - lo)


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
    core = surface.core_rows
    x, y, z = surface.x, surface.y[core], surface.z[core]
    # evenly spaced symmetric grid: 1, x and y are orthogonal, so the plane fit is three means
    xc, yc = x - x.mean(), y - y.mean()
    bx = (z @ xc).sum() / (y.size * (xc @ xc))
    by = (yc @ z).sum() / (x.size * (yc @ yc))
    plane = z.mean() + bx * (surface.x - x.mean())[None, :] + by * (surface.y - y.mean())[:, None]
    flat = z - plane[core]
    hx, hy = surface.spacing
    win, norm, masks = _spectral(x.size, y.size, hx, hy)
    power = np.abs(np.fft.rfft2(flat * win)) ** 2
    out = {
        "pv_nm": float(np.ptp(surface.z)) * 1e9,
        "pv_tilt_removed_nm": float(np.ptp(surface.z - plane)) * 1e9,
        "rms_nm": float(np.sqrt(np.mean(flat**2))) * 1e9,
    }
    for name, mask in masks.items():
        out[f"{name}_rms_nm"] = float(np.sqrt(np.sum(power * mask)) * norm) * 1e9
    out["grid_spacing_mm"] = max(hx, hy) * 1e3
    return out
