"""Fits and spectra of a measured map with missing pixels: its clear aperture, the Legendre
polynomials up to 2nd order, their least-squares removal over the measured pixels, and the
mean 1-D PSD of the complete line profiles of the clear aperture, form removed there
(:mod:`ufmt.machining.psd`'s periodogram and band rules, as on a simulated grid)."""

from __future__ import annotations

import math

import numpy as np

from ufmt.errors import ModelError
from ufmt.machining.psd import BANDS, DIRECTIONS, profile_psd, spectra_band_rms
from ufmt.machining.surface import clear_aperture
from ufmt.measured.read import HeightMap


def aperture(height_map: HeightMap, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Column (Nx,) and row (Ny,) masks of the clear aperture: ``margin`` [m] off every edge
    (:func:`ufmt.machining.surface.clear_aperture` on each axis, as on a simulated grid), or
    one line naming the map if the margin leaves none."""
    x, y = height_map.x, height_map.y
    half_x, half_y = np.ptp(x) / 2 - margin, np.ptp(y) / 2 - margin
    if not (math.isfinite(margin) and margin >= 0 and half_x > 0 and half_y > 0):
        size = f"{np.ptp(x) * 1e3:.4g} x {np.ptp(y) * 1e3:.4g} mm"
        raise ModelError(
            f"{height_map.path}: aperture_margin {margin * 1e3:g} mm must be >= 0 and leave a "
            f"clear aperture of the {size} map"
        )
    return clear_aperture(x, margin), clear_aperture(y, margin)


def legendre_basis(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Legendre polynomials up to 2nd order on the grid (6, Ny, Nx): 1, u, v, P2(u), u v,
    P2(v), u and v the coordinates scaled to [-1, 1]."""
    u = (2 * x - x[0] - x[-1]) / (x[-1] - x[0])
    v = (2 * y - y[0] - y[-1]) / (y[-1] - y[0])
    uu, vv = np.meshgrid(u, v)
    one = np.ones_like(uu)
    return np.stack([one, uu, vv, 1.5 * uu**2 - 0.5, uu * vv, 1.5 * vv**2 - 0.5])


def fit_removed(basis: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares fit of the ``basis`` (k, Ny, Nx) to the finite heights of ``z`` (Ny, Nx):
    (residual (Ny, Nx), NaN where z is; coefficients (k,))."""
    valid = np.isfinite(z)
    design = basis[:, valid].T
    coef, *_ = np.linalg.lstsq(design, z[valid], rcond=None)
    return z - np.tensordot(coef, basis, axes=1), coef


def clear_form_removed(height_map: HeightMap, margin: float) -> HeightMap:
    """The map inside the clear aperture (:func:`aperture`, ``margin`` [m]) less its
    Legendre fit up to 2nd order over the measured pixels there (NaN: missing): the heights
    the PSD bands read, as :func:`ufmt.machining.psd.form_removed` on a simulated grid."""
    in_x, in_y = aperture(height_map, margin)
    x, y = height_map.x[in_x], height_map.y[in_y]
    z = height_map.z[np.ix_(in_y, in_x)]
    if not np.isfinite(z).any():
        raise ModelError(f"{height_map.path}: no measured pixel inside the clear aperture")
    return HeightMap(x, y, fit_removed(legendre_basis(x, y), z)[0], height_map.path)


def complete_profiles(flat: HeightMap, direction: str) -> tuple[np.ndarray, float, int]:
    """The line profiles of ``flat`` ``direction`` "along" (y: its columns) or "across" (x:
    its rows) the feed without a missing pixel: (heights, spacing [m], axis of the lines)."""
    hx, hy = flat.spacing
    complete = np.isfinite(flat.z)
    if direction == "along":
        return flat.z[:, complete.all(axis=0)], hy, 0
    if direction == "across":
        return flat.z[complete.all(axis=1), :], hx, 1
    raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")


def map_psd(
    height_map: HeightMap, direction: str, margin: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Mean 1-D PSD (frequency [1/m], PSD [m^2 m]) of the complete line profiles ``direction``
    "along" (y) or "across" (x) the feed of the clear aperture (``margin`` [m] off every
    edge), form removed there (:func:`clear_form_removed`): the spectra of
    :func:`band_rms_of`."""
    return profile_psd(*complete_profiles(clear_form_removed(height_map, margin), direction))


def band_rms_of(height_map: HeightMap, margin: float = 0.0) -> dict[str, float]:
    """Band RMS [nm] of each band of :data:`~ufmt.machining.psd.BANDS` along (y) and across
    (x) the feed over the clear aperture (``margin`` [m] off every edge), form removed there,
    complete profiles only; NaN where unresolved or no profile is complete (keys and rules as
    :func:`ufmt.machining.psd.band_rms`)."""
    flat = clear_form_removed(height_map, margin)
    profiles = {}
    for direction in DIRECTIONS:
        lines, h, axis = complete_profiles(flat, direction)
        n = lines.shape[axis] if lines.size else 0
        profiles[direction] = (n, h, lambda a=(lines, h, axis): profile_psd(*a))
    return spectra_band_rms(profiles, tuple(BANDS))


def plane_removed(height_map: HeightMap) -> np.ndarray:
    """The map's heights (Ny, Nx) [m] less their least-squares plane (NaN: missing)."""
    basis = legendre_basis(height_map.x, height_map.y)[:3]
    return fit_removed(basis, height_map.z)[0]
