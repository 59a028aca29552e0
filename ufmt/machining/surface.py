"""Machined surface from the relative tool-workpiece motion (paper eq. 4.1) and its metrics.

Tool path on the workpiece (eq. 4.1; workpiece frame, see :mod:`ufmt.machining.cutting`):
x = s_x + sigma R sin(phi), y = Y + R cos(phi), the slide position Y advancing by v/f per
revolution. A grid point (x, y) is met by the leading arc at phi_f = asin((x - s_x)/(sigma R))
when Y = y - R cos(phi_f), once per revolution in the neighbourhood of that slide position, and
keeps the lowest z_re of the passes over it ("tool interference", section 4.2):
z(x, y) = min over passes of z_re(phi, Y), z_re read from the response's
:class:`~ufmt.machining.response.ZreTable` (cubic in phi, linear in Y).

The passes over a point are the two revolutions whose paths bracket it, each read at its own
slide position (a time table holds every revolution; a periodic table the steady state at
that slide position). With ``nose_radius`` the round nose adds the feed marks, d^2 / (2 r_n) at
normal distance d from each bracketing path (scallop (v/f)^2 cos^2(phi) / (8 r_n) between
them); the geometric error sources (:mod:`ufmt.machining.sources`) add their z(phi, Y) at each
pass. The trailing arc (phi = pi - phi_f, at Y = y + R cos) passes over the finished surface
without cutting force; by default it does not re-cut (``trailing_arc=True`` adds its passes to
the minimum: back-cutting).

Grid: nodes on the plate's edges, at most ``spacing`` apart (default 1 mm in x, 1.25 mm in y:
432 x 330 nodes on the 0.41 m plate, counts rounded up to fast FFT lengths; 1.25 mm samples
PSD1's shortest wavelength), plus rows 8 times denser within 6 mm of the entry and exit edges
(y = -+ly/2), where the first and last revolutions of the cut leave mm-wide features that can
set the PV. ``window`` evaluates an evenly spaced patch instead (the PSD2 patch).

Metrics [nm] (:func:`surface_metrics`): PV = max - min over all points (as in the paper); PV
and RMS with the best-fit plane removed; PV and RMS over the clear aperture (the plate less
``DEFAULT_APERTURE_MARGIN`` = 5 mm at every edge); form = PV of the 2nd-order part of a
least-squares Legendre fit up to 2nd order (power, astigmatism, twist), waviness = what that
fit leaves (PV, RMS). The plane, the fits and the RMS use the evenly spaced rows. The PSD bands
(PSD1, PSD2: band RMS of 1-D PSDs of the waviness along and across the feed) are
:mod:`ufmt.machining.psd`'s, read on line profiles at 0.03 mm over the whole plate
(:mod:`ufmt.machining.lines`, which evaluates the same passes on other axes: :func:`passes_on`);
a patch (``DEFAULT_PSD2_PATCH`` = 20 mm square at 0.05 mm, ``ufmt.simulate(...,
psd2_patch=...)``), as a shop measures PSD2 on sub-apertures, is the superseded alternative.

Dynamic metrics [nm] (:func:`dynamic_metrics`): the PV of the cutting-force vibration's
surface alone over the whole plate (the paper's definition, eq. 4.1) and over the steady cut
(:meth:`Passes.steady`: the chip pattern repeats every revolution, off the side edges where
each revolution's force steps), and the edge run-out, what the edges add.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
import scipy.fft

from ufmt.defaults import DEFAULT_SPACING
from ufmt.machining.periodic_path import PeriodicZreTable
from ufmt.machining.response import ZreTable
from ufmt.model.machine import Machine

#: Grid spacing (x, y) [m]: x finer, as the x-profile of a pass carries the vibration of the
#: highest modes (down to ~6 mm wavelength at 200 rpm and 700 Hz); y coarser, as the surface
#: changes slowly with the slide away from the entry and exit edges (refined separately).
#: Clear-aperture edge exclusion [m] of the aperture metrics (docs/ufmt-model.md).
DEFAULT_APERTURE_MARGIN = 5e-3
#: Grid step [m] and side [m] of the patch that resolves PSD2 (``psd2_patch`` option).
PSD2_PATCH_SPACING = 0.05e-3
DEFAULT_PSD2_PATCH = 20e-3
#: Width [m] of the bands along the entry and exit edges (y = -+ly/2) refined for the PV, and
#: the refinement of their rows: the cut's first and last revolutions leave mm-wide features.
EDGE_BAND = 6e-3
EDGE_REFINE = 8


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

    @cached_property
    def spacing(self) -> tuple[float, float]:
        """Spacing (hx, hy) [m] of the evenly spaced grid."""
        y = self.y[self.core_rows]
        return float(self.x[1] - self.x[0]), float(y[1] - y[0])


@lru_cache(maxsize=16)
def surface_grid(machine: Machine, spacing, window=None):
    """Grid, core rows and the two pass angles of every column (cached per machine, spacing).

    ``window`` ((x0, x1), (y0, y1)) [m]: a patch of the plate instead of the whole plate
    (evenly spaced, no refined edge bands).
    """
    hx, hy = np.broadcast_to(np.asarray(spacing, dtype=float), (2,))
    if not (hx > 0 and hy > 0):
        raise ValueError(f"grid spacing must be > 0, got {spacing!r}")
    lx, ly = machine.workpiece_size
    if window is None:
        (x0, x1), (y0, y1) = (-lx / 2, lx / 2), (-ly / 2, ly / 2)
    else:
        (x0, x1), (y0, y1) = window
        if not (-lx / 2 <= x0 < x1 <= lx / 2 and -ly / 2 <= y0 < y1 <= ly / 2):
            raise ValueError(f"window {window!r} must lie inside the plate")
    x, core_y = grid_axis(x0, x1, hx), grid_axis(y0, y1, hy)
    ny = core_y.size
    y, core = core_y, np.ones(ny, bool)
    if window is None:
        fine = (core_y[1] - core_y[0]) / EDGE_REFINE
        offsets = np.arange(1, int(min(EDGE_BAND, ly / 4) / fine) + 1) * fine
        band = np.concatenate([-ly / 2 + offsets, ly / 2 - offsets])
        gap = np.abs(band[:, None] - core_y[None, :]).min(axis=1)
        y = np.concatenate([core_y, band[gap > fine / 2]])
        order = np.argsort(y)
        y, core = y[order], (np.arange(y.size) < ny)[order]
    return x, y, core, *pass_angles(machine, x)


def grid_axis(start: float, stop: float, step: float) -> np.ndarray:
    """Evenly spaced nodes [m] from ``start`` to ``stop`` (both included), at most ``step``
    [m] apart, their count rounded up to a fast FFT length."""
    n = scipy.fft.next_fast_len(int(np.ceil((stop - start) / step - 1e-9)) + 1, real=True)
    return np.linspace(start, stop, n)


def clear_aperture(axis: np.ndarray, margin: float) -> np.ndarray:
    """Mask of the nodes of ``axis`` [m] at least ``margin`` [m] inside its ends: the clear
    aperture's along that axis (the interferometer's, :mod:`ufmt.machining.instruments`)."""
    half = (axis[-1] - axis[0]) / 2 - margin
    if not half > 0:
        raise ValueError(f"aperture_margin {margin!r} m leaves no clear aperture")
    return np.abs(axis - (axis[-1] + axis[0]) / 2) <= half + 1e-12


def pass_angles(machine: Machine, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The leading and trailing arcs' angles phi (2, Nx) [rad] over the columns x (Nx,) [m]
    and their cosines."""
    s = machine.sense * (x - machine.offset_x) / machine.tool_radius
    lead = np.arcsin(np.clip(s, -1.0, 1.0))
    phi = np.mod(np.stack([lead, np.pi - lead]), 2 * np.pi)  # (2, Nx): leading, trailing arc
    return phi, np.cos(phi)


@dataclass(frozen=True, eq=False)
class Passes:
    """The two passes of every arc over every grid point (the bracketing revolutions).

    x (Nx,), y (Ny,) grid [m] and core (Ny,) its evenly spaced rows (see :class:`Surface`);
    phi (arcs, Nx) [rad] the pass angle of each column, cos its cosine; frac (Ny, arcs, Nx)
    how far the point lies from the earlier pass's path towards the later one (0..1, in
    revolutions); slide (2, Ny, arcs, Nx) [m] the slide positions of the earlier and the later
    pass (``feed_per_rev`` further). Every term of the surface is an array of heights (earlier,
    later) broadcasting to ``slide``; :meth:`lower` takes the lower pass (tool interference).
    """

    x: np.ndarray
    y: np.ndarray
    core: np.ndarray
    phi: np.ndarray
    cos: np.ndarray
    frac: np.ndarray
    slide: np.ndarray
    feed_per_rev: float

    def dynamic(self, table: ZreTable | PeriodicZreTable, machine: Machine) -> np.ndarray:
        """z_re of ``table`` [m] at both passes (cubic in phi, linear in the table's rows)."""
        arcs = self.phi.shape[0]
        pairs = _table_pairs(table, self.phi.tobytes(), arcs)
        slide = self.slide - table.drift * (self.phi / (2 * np.pi)) if table.drift else self.slide
        columns = np.arange(self.phi.size).reshape(arcs, -1)
        return _lookup(pairs, table.row_knots, slide, columns)

    def geometric(self, geometric) -> np.ndarray:
        """Heights [m] of a geometric z(phi, Y) (:func:`~ufmt.machining.sources.geometric_z`)."""
        return geometric(self.phi, self.slide)

    def feed_marks(self, nose_radius: float) -> np.ndarray:
        """Nose scallops [m]: d^2 / (2 r_n) at normal distance d from each pass's path,
        ``nose_radius`` r_n [m]."""
        if not nose_radius > 0:
            raise ValueError(f"nose_radius must be > 0 [m], got {nose_radius!r}")
        d2 = (self.feed_per_rev * self.cos) ** 2 / (2 * nose_radius)
        return np.stack([self.frac, 1 - self.frac]) ** 2 * d2

    def lower(self, terms) -> Surface:
        """The surface of the summed ``terms`` (heights at both passes): the lower pass
        everywhere."""
        terms = list(terms)
        z = self._lower_pass(sum(terms[1:], terms[0]) if terms else np.zeros(()))
        z = np.broadcast_to(z, self.frac.shape)
        return Surface(self.x, self.y, z.min(axis=1) if z.shape[1] > 1 else z[:, 0], self.core)

    def pv_each(self, terms) -> list[float]:
        """PV [m] of the surface of each of ``terms`` alone (its :meth:`lower`)."""
        pv = []
        for z in terms:
            # the lower arc (a term of phi alone is the same on every row)
            z = np.min(self._lower_pass(z), axis=-2)
            pv.append(float(z.max() - z.min()))
        return pv

    def steady(self, machine: Machine) -> np.ndarray:
        """Points (Ny, Nx) of the steady cut: both of their leading-arc passes ran while the arc
        crossed the whole plate (:attr:`Machine.steady_span`: the chip pattern behind them
        repeats every revolution; the others form the entry and exit strips), off the plate's
        side edges x = +-lx/2, where every revolution's force steps on and off (there eq. 4.1
        reads the sampled step itself, a value of the discretisation; the real step is spread
        over the nose's engaged edge, ~0.2 mm, less than a grid step)."""
        y_a, y_b = machine.steady_span
        slide = self.slide[:, :, 0, :]
        periodic = np.all((slide >= y_a) & (slide <= y_b), axis=0)
        return periodic & (np.abs(self.x) < machine.workpiece_size[0] / 2)[None, :]

    def _lower_pass(self, z):
        """The lower of a term's heights at the two passes (stacked on its first axis); a term
        without that axis is the same at both passes and is returned as is."""
        return np.minimum(z[0], z[1]) if np.ndim(z) == self.slide.ndim else z


def surface_passes(
    machine: Machine,
    feed_per_rev: float,
    spacing=DEFAULT_SPACING,
    trailing_arc: bool = False,
    window=None,
) -> Passes:
    """The passes over the grid of ``spacing`` [m], the surface's terms' common frame.

    ``spacing``: one step or (x, y) steps [m], the largest allowed. ``feed_per_rev`` [m]
    spaces the revolutions; ``trailing_arc`` adds the trailing-arc passes (back-cutting);
    ``window`` ((x0, x1), (y0, y1)) [m] evaluates a patch only. Each point takes the lower of
    the two revolutions whose paths bracket it (:meth:`Passes.lower`); a periodic
    (quasi-static) table gives each of them the steady state at its own slide position. Every
    surface of one grid and feed (the total, each error source alone) shares one.
    """
    spacing = tuple(np.broadcast_to(np.asarray(spacing, dtype=float), (2,)).tolist())
    if window is not None:
        window = tuple(tuple(float(v) for v in w) for w in window)
    x, y, core, phi, cos = surface_grid(machine, spacing, window)
    return passes_on(machine, feed_per_rev, x, y, core, trailing_arc, (phi, cos))


def passes_on(
    machine: Machine,
    feed_per_rev: float,
    x: np.ndarray,
    y: np.ndarray,
    core: np.ndarray | None = None,
    trailing_arc: bool = False,
    angles: tuple[np.ndarray, np.ndarray] | None = None,
) -> Passes:
    """The passes over the points of columns x (Nx,) and rows y (Ny,) [m] (any axes: a grid
    or line profiles), ``core`` the evenly spaced rows (None: all), ``angles`` the columns'
    :func:`pass_angles` when known (:func:`surface_passes`)."""
    if not feed_per_rev > 0:
        raise ValueError(f"feed_per_rev must be > 0 [m], got {feed_per_rev!r}")
    if core is None:
        core = np.ones(y.size, bool)
    phi, cos = pass_angles(machine, x) if angles is None else angles
    arcs = 2 if trailing_arc else 1
    phi, cos = phi[:arcs], cos[:arcs]
    turn = phi / (2 * np.pi)
    y_start = machine.cut_span[0]
    # revolutions since Y_start when the arc passes the point; the two bracketing revolutions
    rho = (y[:, None, None] - machine.tool_radius * cos - y_start) / feed_per_rev - turn
    k = np.floor(rho)
    slide = y_start + feed_per_rev * (k + turn)  # slide position of the earlier pass
    slide = np.stack([slide, slide + feed_per_rev])
    return Passes(x, y, core, phi, cos, rho - k, slide, feed_per_rev)


@lru_cache(maxsize=2)  # one simulation reads its table on the grid's and the lines' columns
def _table_pairs(table, phi: bytes, arcs: int) -> np.ndarray:
    """The table's columns at the pass angles ``phi`` ((arcs, Nx) [rad] as float64 bytes;
    ``table.columns``), each row with the next one as its imaginary part: (rows - 1,
    arcs * Nx) complex, so that a lookup is one gather of both (cached per table, angles)."""
    cols = table.columns(np.frombuffer(phi).reshape(arcs, -1))
    pairs = cols[:-1] + 1j * cols[1:]
    pairs.setflags(write=False)
    return pairs


def _lookup(pairs: np.ndarray, row_knots, slide: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Table columns linearly interpolated in rows at slide positions [m], in ``columns``.

    ``pairs`` (rows - 1, C): each row's columns plus i times the next row's
    (:func:`_table_pairs`).
    The fractional row of a slide position comes from the table's knots (see ZreTable);
    the column indices ``columns`` broadcast against ``slide``.
    """
    start, step, u = row_knots
    width = pairs.shape[1]
    t = np.clip((slide - start) / step, 0.0, u.size - 1.0)
    k = np.minimum(t.astype(np.intp), u.size - 2)
    rr = u[k] + (t - k) * (u[k + 1] - u[k])
    i0 = np.minimum(rr.astype(np.intp), pairs.shape[0] - 1)
    both = pairs.ravel()[i0 * width + columns]  # one gather: this row and the next
    lo = both.real
    return lo + (rr - i0) * (both.imag - lo)


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


@dataclass(frozen=True)
class _GridFit:
    """Process-independent parts of the plane and Legendre fits on an evenly spaced grid.

    xc (Nx,), yc (Ny,) the coordinates less their means [m] and xx, yy their sums of squares
    [m^2]; fu (6, Nx), gv (6, Ny) the factors of the six Legendre terms (each f(u) g(v)) and
    normal (6, 6) their normal equations.
    """

    xc: np.ndarray
    yc: np.ndarray
    xx: float
    yy: float
    fu: np.ndarray
    gv: np.ndarray
    normal: np.ndarray


def _grid_fit(x: np.ndarray, y: np.ndarray) -> _GridFit:
    """The :class:`_GridFit` of the grid x (Nx,), y (Ny,) [m] (cached per grid)."""
    return _grid_fit_of(x.tobytes(), y.tobytes())


@lru_cache(maxsize=16)
def _grid_fit_of(x_bytes: bytes, y_bytes: bytes) -> _GridFit:
    """The :class:`_GridFit` of grid axes x, y [m] (float64 bytes); cached, read-only."""
    x, y = np.frombuffer(x_bytes), np.frombuffer(y_bytes)
    xc, yc = x - x.mean(), y - y.mean()
    u = (2 * x - x[0] - x[-1]) / (x[-1] - x[0])
    v = (2 * y - y[0] - y[-1]) / (y[-1] - y[0])
    one_u, one_v = np.ones_like(u), np.ones_like(v)
    fu = np.stack([one_u, u, one_u, 1.5 * u**2 - 0.5, u, one_u])  # (6, Nx)
    gv = np.stack([one_v, one_v, v, one_v, v, 1.5 * v**2 - 0.5])  # (6, Ny)
    normal = (fu @ fu.T) * (gv @ gv.T)
    for a in (xc, yc, fu, gv, normal):
        a.setflags(write=False)
    return _GridFit(xc, yc, float(xc @ xc), float(yc @ yc), fu, gv, normal)


def _plane(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Best-fit plane of z (Ny, Nx) on an evenly spaced grid (three means: 1, x, y orthogonal)."""
    g = _grid_fit(x, y)
    bx = (z @ g.xc).sum() / (y.size * g.xx)
    by = (g.yc @ z).sum() / (x.size * g.yy)
    return z.mean() + bx * g.xc[None, :] + by * g.yc[:, None]


def legendre_fit(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares fit of Legendre polynomials up to 2nd order in (x, y) over the grid.

    Returns (fit, form): the whole fit (piston, tilt, 2nd order) and its 2nd-order part
    (P2(u), u v, P2(v) with u, v the coordinates scaled to [-1, 1]), both (Ny, Nx). Every term
    is a product f(u) g(v), so the normal equations are sums over u and v separately.
    """
    g = _grid_fit(x, y)
    coef = legendre_coefficients(x, y, z)
    fit = (g.gv.T * coef) @ g.fu
    form = (g.gv[3:].T * coef[3:]) @ g.fu[3:]
    return fit, form


def legendre_coefficients(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Coefficients (6,) of :func:`legendre_fit` [z unit], of 1, u, v, P2(u), u v, P2(v)."""
    g = _grid_fit(x, y)
    return np.linalg.solve(g.normal, ((g.gv @ z) * g.fu).sum(axis=1))


#: Keys of :func:`dynamic_metrics` [nm].
DYNAMIC_METRICS = ("pv_dynamic_nm", "pv_dynamic_steady_nm", "edge_runout_nm")


def dynamic_metrics(passes: Passes, term, machine: Machine) -> dict[str, float]:
    """PV [nm] of the surface of one term alone (the cutting-force vibration's z_re at both
    passes, :meth:`Passes.dynamic`), eq. 4.1: ``pv_dynamic_nm`` over the whole plate (the
    paper's definition), ``pv_dynamic_steady_nm`` over the steady cut (:meth:`Passes.steady`;
    NaN if no point is steady) and ``edge_runout_nm``, what the entry and exit strips add."""
    z = passes.lower([term]).z
    steady = z[np.broadcast_to(passes.steady(machine), z.shape)]
    whole = _pv(z) * 1e9
    inside = _pv(steady) * 1e9 if steady.size else float("nan")
    return dict(zip(DYNAMIC_METRICS, (whole, inside, whole - inside), strict=True))


def _pv(z: np.ndarray) -> float:
    """Peak to valley of z [its unit] (np.ptp without its dispatch)."""
    return float(z.max() - z.min())


def _rms(z: np.ndarray) -> float:
    """Root mean square of z [its unit]."""
    return float(np.sqrt(np.square(z).sum() / z.size))


def surface_metrics(
    surface: Surface,
    aperture_margin: float = DEFAULT_APERTURE_MARGIN,
) -> dict[str, float]:
    """Metrics of the machined surface [nm] (module docstring).

    Keys: pv_nm (max - min over all points), pv_tilt_removed_nm, rms_nm (best-fit plane
    removed), pv_aperture_nm and rms_aperture_nm (the same inside the clear aperture, the plate
    less ``aperture_margin`` [m] at every edge), form_pv_nm (PV of the 2nd-order Legendre
    part of the least-squares fit), waviness_pv_nm and waviness_rms_nm (what the fit up to 2nd
    order leaves), grid_spacing_mm. The PSD bands are :func:`ufmt.machining.psd.band_rms`'s.
    """
    if not aperture_margin >= 0:
        raise ValueError(f"aperture_margin must be >= 0 [m], got {aperture_margin!r}")
    core = surface.core_rows
    x, y, z = surface.x, surface.y[core], surface.z[core]
    plane = _plane(x, y, z)
    # the plane extended to every row (the refined edge rows too)
    xc, yc = _grid_fit(x, y).xc, surface.y - y.mean()
    slope_x = (plane[0, -1] - plane[0, 0]) / (x[-1] - x[0])
    slope_y = (plane[-1, 0] - plane[0, 0]) / (y[-1] - y[0])
    plane_all = plane.mean() + slope_x * xc[None, :] + slope_y * yc[:, None]
    flat = z - plane
    half_x = (x[-1] - x[0]) / 2 - aperture_margin
    half_y = (y[-1] - y[0]) / 2 - aperture_margin
    if half_x <= 0 or half_y <= 0:
        raise ValueError(f"aperture_margin {aperture_margin!r} m leaves no clear aperture")
    in_x = np.abs(xc) <= half_x + 1e-12
    in_y = np.abs(yc) <= half_y + 1e-12
    aperture = surface.z[np.ix_(in_y, in_x)]
    flat_aperture = flat[np.ix_(in_y[core], in_x)]
    fit, form = legendre_fit(x, y, z)
    waviness = z - fit
    out = {
        "pv_nm": _pv(surface.z) * 1e9,
        "pv_tilt_removed_nm": _pv(surface.z - plane_all) * 1e9,
        "rms_nm": _rms(flat) * 1e9,
        "pv_aperture_nm": _pv(aperture) * 1e9,
        "rms_aperture_nm": _rms(flat_aperture) * 1e9,
        "form_pv_nm": _pv(form) * 1e9,
        "waviness_pv_nm": _pv(waviness) * 1e9,
        "waviness_rms_nm": _rms(waviness) * 1e9,
    }
    out["grid_spacing_mm"] = max(surface.spacing) * 1e3
    return out
