"""Reading a measured height map: any format SurfaceTopography reads (Zygo MetroPro ``.dat``
and ``.datx``, ISO 25178-72 ``.x3p``, ISO 25178-71 ``.sdf``, plain-text ``.xyz``, ~40 more)
and ufmt's own ``.npz`` export.

SurfaceTopography is used because it reads the vendors' phase-to-height scaling correctly
(a public Zygo NewView MetroPro map reads the same Sq in it and in prysm; surfalize's
phase-resolution table is off by one). Its grids are (Nx, Ny) with the physical size
n h (pixel h); here they become x (Nx,), y (Ny,), z (Ny, Nx) [m], x = h_x (0 .. Nx-1), the
file's lateral and height units converted to metres. Missing pixels (masked or NaN in the
file) are NaN. A file without units (plain-text xyz) is in metres, as ufmt writes it, unless
``unit`` says otherwise.

ufmt's ``.npz`` (``x_m``, ``y_m``, ``z_m``, ``z_smooth_m``, ``z_measured_m``; every row of the
simulated grid, the refined edge rows included) is read on the lattice
:func:`ufmt.exports.export_grid` writes, from ``z_measured_m`` (the surface as the
interferometer sees it, as in the other exports), else ``z_smooth_m``, else ``z_m``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ufmt.errors import ModelError

#: Length units a unitless file may be declared in, and their size [m].
UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "nm": 1e-9}


@dataclass(frozen=True, eq=False)
class HeightMap:
    """A measured map: x (Nx,), y (Ny,) [m] evenly spaced, z (Ny, Nx) [m] (NaN: missing);
    ``path`` the file it was read from."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    path: str = ""

    @property
    def spacing(self) -> tuple[float, float]:
        """Pixel (hx, hy) [m]."""
        return float(self.x[1] - self.x[0]), float(self.y[1] - self.y[0])

    @property
    def valid(self) -> np.ndarray:
        """Mask (Ny, Nx) of the measured pixels."""
        return np.isfinite(self.z)

    def transposed(self) -> HeightMap:
        """The map with x and y exchanged (a map whose feed runs along x, turned to y)."""
        return HeightMap(self.y, self.x, self.z.T.copy(), self.path)


def read_map(path, unit: str | None = None) -> HeightMap:
    """The :class:`HeightMap` of the file ``path`` (module docstring); ``unit`` (one of
    :data:`UNITS`) for a file that carries none. Raises ModelError naming the file and what is
    wrong if it cannot be read or is not an evenly spaced areal map."""
    path = Path(path)
    if unit is not None and unit not in UNITS:
        raise ModelError(f"{path}: unit {unit!r} is not one of {', '.join(UNITS)}")
    if not path.is_file():
        raise ModelError(f"{path}: no such file")
    if path.suffix.lower() == ".npz":
        with np.load(path) as data:
            if {"x_m", "y_m", "z_m"} <= set(data.files):
                return _check(_ufmt_npz(data, path), path)
    return _check(_read_topography(path, unit), path)


def _read_topography(path: Path, unit: str | None) -> HeightMap:
    """The map of a file SurfaceTopography reads."""
    import warnings

    from SurfaceTopography.IO import open_topography

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = open_topography(str(path))
            channel = reader.channels[0]
            declared = channel.unit
            if isinstance(declared, tuple):
                declared = declared[0]
            given = None if declared else (unit or "m").replace("um", "µm")
            topography = reader.topography(unit=given)
    except Exception as exc:  # the readers raise many kinds; report one line
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ModelError(f"{path}: not a readable height map ({reason})") from None
    if topography.dim != 2:
        raise ModelError(f"{path}: a line scan, not an areal map (dim {topography.dim})")
    if not topography.is_uniform:
        raise ModelError(f"{path}: points not on an evenly spaced grid")
    topography = topography.to_unit("m")
    heights = topography.heights()
    z = np.ma.filled(np.ma.masked_invalid(heights).astype(float), np.nan).T
    hx, hy = (float(h) for h in topography.pixel_size)
    nx, ny = topography.nb_grid_pts
    return HeightMap(hx * np.arange(nx), hy * np.arange(ny), z, str(path))


def _ufmt_npz(data, path: Path) -> HeightMap:
    """The map of ufmt's ``.npz`` export on the lattice of :func:`ufmt.exports.export_grid`."""
    from ufmt.exports import export_grid
    from ufmt.machining.surface import Surface

    x, y = np.asarray(data["x_m"], float), np.asarray(data["y_m"], float)
    key = next(k for k in ("z_measured_m", "z_smooth_m", "z_m") if k in data.files)
    z = np.asarray(data[key], float)
    if x.ndim != 1 or y.ndim != 1 or z.shape != (y.size, x.size) or min(x.size, y.size) < 2:
        raise ModelError(f"{path}: z_m must be (len(y_m), len(x_m)), got {z.shape}")
    step = float(np.diff(y).max())
    index = (y - y[0]) / step
    core = np.abs(index - np.round(index)) < 1e-6
    x, y, z = export_grid(Surface(x, y, z, core))
    return HeightMap(x, y, z, str(path))


def _check(height_map: HeightMap, path: Path) -> HeightMap:
    """The map, if it has at least 2 x 2 pixels, positive finite steps and measured pixels."""
    x, y, z = height_map.x, height_map.y, height_map.z
    if min(x.size, y.size) < 2:
        raise ModelError(f"{path}: {x.size} x {y.size} pixels; a map needs at least 2 x 2")
    hx, hy = height_map.spacing
    if not all(math.isfinite(h) and h > 0 for h in (hx, hy)):
        raise ModelError(f"{path}: pixel size ({hx}, {hy}) m must be finite and > 0")
    if np.isinf(z).any():
        raise ModelError(f"{path}: heights must be finite (NaN marks a missing pixel)")
    if not np.isfinite(z).any():
        raise ModelError(f"{path}: no measured pixel")
    return height_map
