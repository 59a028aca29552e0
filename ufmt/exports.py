"""Exports of a simulation in the formats other tools open: the machined surface as a height
grid and the record window's time histories as a table.

Height grids (:func:`export_grid`: these formats hold an evenly spaced grid, so a
:class:`ufmt.machining.surface.Surface` with refined rows along its entry and exit edges is
written on the uniform lattice of the refined rows' step in y: the evenly spaced rows and the
refined ones exact, the rows between them a cubic spline through them in y; the features the
refined rows resolve, which set the interferometer's PV, stay in the file):

* ``.xyz``: plain text, one point per line, ``x y z`` in metres, x fastest. Surface-analysis
  and interferometer software (Gwyddion's "XYZ data", MountainsMap, MetroPro/Mx's XYZ import)
  read such point lists.
* ``.sdf``: ISO 25178-71 (the SURFSTAND / EUNA 15178 "Surface Data File") in its ASCII form
  ``aISO-1.0``: a header of ``name = value`` lines (``NumPoints`` per profile along x,
  ``NumProfiles`` along y, ``Xscale``/``Yscale``/``Zscale`` in metres, ``DataType = 7``
  double), ``*``, the heights one profile per line in units of ``Zscale`` (1 nm), ``*``, a
  trailer, ``*``.
* ``.x3p``: ISO 25178-72 XML 3D surface profile, written by SurfaceTopography (heights in
  metres, doubles).
* ``.npz``: numpy arrays ``x_m``, ``y_m``, ``z_m`` (every row, the refined ones included).

Time histories (:func:`time_frame`): one row per sample of the record window, units in the
column names.
"""

from __future__ import annotations

import datetime
from pathlib import Path

import numpy as np

from ufmt import files

SDF_MAGIC = "aISO-1.0"
SDF_ZSCALE = 1e-9  # heights written in nanometres [m per unit]
SDF_MAX_POINTS = 65535  # ISO-1.0 stores NumPoints and NumProfiles in 16 bits
_AXES = ("x", "y", "z")


def even_grid(surface) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x (Nx,), y (Ny,), z (Ny, Nx)) [m]: the evenly spaced rows of ``surface``."""
    rows = surface.core_rows
    return surface.x, surface.y[rows], surface.z[rows]


def export_grid(surface) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x (Nx,), y (Ny,), z (Ny, Nx)) [m] written by the height-grid exports (module docstring):
    :func:`even_grid` if every row is evenly spaced, else the lattice of the refined step."""
    if surface.core_rows.all():
        return even_grid(surface)
    import scipy.interpolate

    y = surface.y
    step = float(np.diff(y).min())
    n = int(round((y[-1] - y[0]) / step)) + 1
    lattice = np.linspace(y[0], y[-1], n)
    spline = scipy.interpolate.make_interp_spline(y, surface.z, k=3, axis=0)
    z = spline(lattice)
    # the computed rows exactly (the spline passes through them up to rounding)
    known = np.abs(lattice[:, None] - y[None, :]) < step * 1e-6
    rows, cols = np.nonzero(known)
    z[rows] = surface.z[cols]
    return surface.x, lattice, z


def write_xyz(surface, path) -> Path:
    """Write :func:`export_grid` as ``x y z`` lines [m] (x fastest); returns the path."""
    x, y, z = export_grid(surface)
    yy, xx = np.meshgrid(y, x, indexing="ij")
    table = np.column_stack([xx.ravel(), yy.ravel(), z.ravel()])
    return files.write_with(path, lambda b: np.savetxt(b, table, fmt="%.9e"))


def sdf_text(surface, created: datetime.datetime | None = None) -> str:
    """The ISO 25178-71 ASCII surface data file (module docstring) of :func:`export_grid`;
    ``created`` (default now) dates the header."""
    x, y, z = export_grid(surface)
    if x.size > SDF_MAX_POINTS or y.size > SDF_MAX_POINTS:
        raise ValueError(f"an ISO-1.0 SDF holds at most {SDF_MAX_POINTS} points per axis")
    stamp = (created or datetime.datetime.now(datetime.UTC)).strftime("%d%m%Y%H%M")
    header = {
        "ManufacID": "ufmt",
        "CreateDate": stamp,
        "ModDate": stamp,
        "NumPoints": x.size,
        "NumProfiles": y.size,
        "Xscale": repr(float(x[1] - x[0])),
        "Yscale": repr(float(y[1] - y[0])),
        "Zscale": f"{SDF_ZSCALE:.1e}",
        "Zresolution": -1,
        "Compression": 0,
        "DataType": 7,
        "CheckType": 0,
    }
    lines = [SDF_MAGIC, *(f"{k} = {v}" for k, v in header.items()), "*"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in z / SDF_ZSCALE]
    lines += ["*", f"Origin = x {float(x[0])!r} m, y {float(y[0])!r} m", "*"]
    return "\r\n".join(lines) + "\r\n"


def write_sdf(surface, path, created: datetime.datetime | None = None) -> Path:
    """Write :func:`sdf_text` to ``path``; returns the path."""
    return files.write_bytes(path, sdf_text(surface, created).encode("ascii"))


def write_x3p(surface, path) -> Path:
    """Write :func:`export_grid` as an ISO 25178-72 ``.x3p`` file (SurfaceTopography's
    writer; heights [m]); returns the path."""
    from SurfaceTopography import Topography

    x, y, z = export_grid(surface)
    sizes = (x.size * float(x[1] - x[0]), y.size * float(y[1] - y[0]))  # n h: pixel h
    topography = Topography(z.T, physical_sizes=sizes, unit="m")
    return files.write_with(path, topography.to_x3p)


def write_npz(surface, path) -> Path:
    """Write ``x_m``, ``y_m``, ``z_m`` (every row) as a compressed ``.npz``; returns the path."""
    arrays = {"x_m": surface.x, "y_m": surface.y, "z_m": surface.z}
    return files.write_with(path, lambda b: np.savez_compressed(b, **arrays))


def read_sdf(path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x (Nx,), y (Ny,), z (Ny, Nx)) [m] of an ASCII ISO 25178-71 file as :func:`write_sdf`
    writes it (origin from its trailer, else 0)."""
    text = Path(path).read_text(encoding="ascii")
    if not text.startswith(SDF_MAGIC):
        raise ValueError(f"{path}: not an ASCII ISO 25178-71 file ({SDF_MAGIC})")
    head, data, trailer = text[len(SDF_MAGIC) :].split("*")[:3]
    pairs = (line.split("=", 1) for line in head.strip().splitlines())
    fields = {k.strip(): v.strip() for k, v in pairs}
    nx, ny = int(fields["NumPoints"]), int(fields["NumProfiles"])
    z = np.array(data.split(), dtype=float).reshape(ny, nx) * float(fields["Zscale"])
    x0 = y0 = 0.0
    if "Origin" in trailer:
        parts = trailer.split()
        x0, y0 = float(parts[parts.index("x") + 1]), float(parts[parts.index("y") + 1])
    x = x0 + float(fields["Xscale"]) * np.arange(nx)
    y = y0 + float(fields["Yscale"]) * np.arange(ny)
    return x, y, z


def time_frame(response):
    """The record window's time histories as a pandas DataFrame, one row per sample:
    ``time_s`` (from the first touch), ``slide_y_m``, ``force_{x,y,z}_N``,
    ``tip_disp_{x,y,z}_nm``, ``tip_acc_{x,y,z}_mm_s2``, ``work_disp_{x,y,z}_nm``,
    ``z_re_nm``, ``cutting`` (the tool touches the workpiece)."""
    import pandas as pd

    columns = {"time_s": response.t, "slide_y_m": response.slide_y}
    for name, data, unit, scale in (
        ("force", response.force, "N", 1.0),
        ("tip_disp", response.tip_disp, "nm", 1e9),
        ("tip_acc", response.tip_acc, "mm_s2", 1e3),
        ("work_disp", response.work_disp, "nm", 1e9),
    ):
        for i, axis in enumerate(_AXES):
            columns[f"{name}_{axis}_{unit}"] = data[:, i] * scale
    columns["z_re_nm"] = response.z_re * 1e9
    columns["cutting"] = np.linalg.norm(response.force, axis=1) > 0
    return pd.DataFrame(columns)
