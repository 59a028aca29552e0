"""A measured straightness profile of the slide's guideway: the ``straightness_profile`` CSV.

The file (columns ``position_m,height_m``, a header line, one sample a row) gives the
guideway's height z_g(s) [m] at y positions s [m] of the bed, in the machine frame (the model's
global frame for an upright spindle, :mod:`ufmt.model.orientation`).
Positions must increase strictly, every value must be finite, and the profile must cover the
guideway under the carriage's pads over the whole cut (checked by
:func:`ufmt.model.machine.read_machine`). Between samples the profile is linear; the
carriage's pads average it over their contact length (:mod:`ufmt.machining.carriage`), through
the integrals of z_g and s z_g, exact for the piecewise-linear profile.
"""

from __future__ import annotations

import csv
import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ufmt.tables import Where

COLUMNS = ("position_m", "height_m")


@dataclass(frozen=True, eq=False)
class GuidewayProfile:
    """Guideway heights ``height`` [m] at global y ``position`` [m] (strictly increasing),
    read from ``path``; ``moment0``, ``moment1`` the integrals of z_g [m^2] and of s z_g
    [m^3] from the first sample to each sample."""

    path: str
    position: np.ndarray
    height: np.ndarray
    moment0: np.ndarray = field(repr=False)
    moment1: np.ndarray = field(repr=False)
    digest: str = field(repr=False)

    def __eq__(self, other) -> bool:
        return isinstance(other, GuidewayProfile) and self.digest == other.digest

    def __hash__(self) -> int:
        return hash(self.digest)

    def at(self, s) -> np.ndarray:
        """z_g [m] at positions ``s`` [m] (linear between samples)."""
        return np.interp(s, self.position, self.height)

    def integrals(self, s) -> tuple[np.ndarray, np.ndarray]:
        """(int z_g ds, int s z_g ds) [m^2, m^3] of the linear profile from the first sample to
        ``s`` [m] (inside the samples' range), exactly."""
        s = np.asarray(s, dtype=float)
        i = np.clip(np.searchsorted(self.position, s, side="right") - 1, 0, self.position.size - 2)
        s0, z0 = self.position[i], self.height[i]
        g = (self.height[i + 1] - z0) / (self.position[i + 1] - s0)
        t = s - s0
        zero = z0 * t + g * t * t / 2
        first = s0 * zero + z0 * t * t / 2 + g * t**3 / 3
        return self.moment0[i] + zero, self.moment1[i] + first


def read_guideway_profile(value, where: Where, field_name: str, base: Path) -> GuidewayProfile:
    """The profile of the CSV at ``value`` (a path, relative to ``base``); any problem is a
    one-line error of ``where`` naming the field and the file."""
    text = where.string(field_name, value)
    path = Path(text) if Path(text).is_absolute() else base / text
    try:
        with open(path, newline="", encoding="utf-8-sig") as handle:
            rows = list(csv.reader(handle))
    except OSError as exc:
        where.fail(field_name, f"{path}: cannot be read ({exc.strerror or exc})")
    header = [c.strip() for c in rows[0]] if rows else []
    if tuple(header[:2]) != COLUMNS:
        where.fail(field_name, f"{path}: the first line must be {','.join(COLUMNS)}")
    try:
        data = np.array([[float(c) for c in row[:2]] for row in rows[1:] if row], dtype=float)
    except ValueError as exc:
        where.fail(field_name, f"{path}: {exc} (allowed: numbers [m])")
    if data.ndim != 2 or data.shape[0] < 2 or data.shape[1] != 2:
        where.fail(field_name, f"{path}: needs at least 2 rows of {','.join(COLUMNS)}")
    if not np.all(np.isfinite(data)):
        row = int(np.flatnonzero(~np.isfinite(data).all(axis=1))[0]) + 2
        where.fail(field_name, f"{path}: line {row} is not finite (allowed: finite numbers [m])")
    s, z = data[:, 0], data[:, 1]
    if not np.all(np.diff(s) > 0):
        row = int(np.flatnonzero(np.diff(s) <= 0)[0]) + 3
        where.fail(field_name, f"{path}: position_m must increase strictly (line {row} does not)")
    ds = np.diff(s)
    moment0 = np.concatenate([[0.0], np.cumsum(ds * (z[1:] + z[:-1]) / 2)])
    # int s z over one step of the linear z: ds / 6 ((2 s_i + s_j) z_i + (s_i + 2 s_j) z_j)
    pieces = ds / 6 * ((2 * s[:-1] + s[1:]) * z[:-1] + (s[:-1] + 2 * s[1:]) * z[1:])
    moment1 = np.concatenate([[0.0], np.cumsum(pieces)])
    digest = hashlib.sha256(data.tobytes()).hexdigest()
    for a in (s, z, moment0, moment1):
        a.setflags(write=False)
    return GuidewayProfile(str(path), s, z, moment0, moment1, digest)
