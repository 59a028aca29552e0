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

from ufmt import files, limits
from ufmt.errors import ModelError
from ufmt.limits import MAX_MAP_BYTES
from ufmt.tables import Where
from ufmt.tomlfile import read_text

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
    writes it (origin from its trailer, else 0).

    Raises ModelError naming the file and the field: a file that is not ASCII ISO-1.0 or is
    larger than :data:`ufmt.limits.MAX_MAP_BYTES`, ``NumPoints`` or ``NumProfiles`` outside
    1-65535, a scale that is not a finite number > 0, heights that are not finite numbers
    or not ``NumPoints`` x ``NumProfiles`` of them, an origin that is not finite.
    """
    where = Where(str(path), error=ModelError)
    try:
        text = read_text(path, ModelError, MAX_MAP_BYTES).encode("ascii").decode("ascii")
    except UnicodeEncodeError as exc:
        where.fail_table(f"not ASCII text (character {exc.start}); an ASCII {SDF_MAGIC} file")
    if not text.startswith(SDF_MAGIC) or text.count("*") < 2:
        where.fail_table(f"not an ASCII ISO 25178-71 file (starts with {SDF_MAGIC}, then *)")
    head, data, trailer = (text[len(SDF_MAGIC) :].split("*") + [""])[:3]
    fields = {}
    for line in head.strip().splitlines():
        name, equals, value = line.partition("=")
        if not equals:
            where.fail_table(f"header line {limits.shown(line)} is not 'name = value'")
        fields[name.strip()] = value.strip()
    for name in ("NumPoints", "NumProfiles", "Xscale", "Yscale", "Zscale"):
        if name not in fields:
            where.missing(name, "a header field of ISO 25178-71")
    nx, ny = (
        where.integer(name, _header_number(where, name, fields[name], int), 1, SDF_MAX_POINTS)
        for name in ("NumPoints", "NumProfiles")
    )
    scales = [
        where.number(
            name, _header_number(where, name, fields[name], float), sign="positive", unit="[m]"
        )
        for name in ("Xscale", "Yscale", "Zscale")
    ]
    try:
        heights = np.array(data.split(), dtype=float)
    except ValueError:
        where.fail("data", "a height is not a number")
    if heights.size != nx * ny:
        where.fail("data", f"{heights.size} heights; NumPoints x NumProfiles = {nx * ny}")
    if not np.all(np.isfinite(heights)):
        where.fail("data", "a height is NaN or infinite (allowed: finite numbers)")
    z = heights.reshape(ny, nx) * scales[2]
    x0 = y0 = 0.0
    if "Origin" in trailer:
        parts = trailer.split()
        try:
            x0, y0 = float(parts[parts.index("x") + 1]), float(parts[parts.index("y") + 1])
        except (ValueError, IndexError):
            where.fail("Origin", "expected 'Origin = x X m, y Y m'")
        if not (np.isfinite(x0) and np.isfinite(y0)):
            where.fail("Origin", f"x {x0!r}, y {y0!r} (allowed: finite numbers [m])")
    x = x0 + scales[0] * np.arange(nx)
    y = y0 + scales[1] * np.arange(ny)
    return x, y, z


def _header_number(where: Where, name: str, text: str, kind):
    """A header value as ``kind`` (int or float), else ModelError naming the field."""
    try:
        return kind(text)
    except ValueError:
        where.fail(
            name, f"{limits.shown(text)} is not {'an integer' if kind is int else 'a number'}"
        )


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
