"""Fits and spectra of a measured map with missing pixels: the Legendre polynomials up to 2nd
order, their least-squares removal over the measured pixels, and the mean 1-D PSD of the
waviness' complete line profiles (:mod:`ufmt.machining.psd`'s periodogram)."""

from __future__ import annotations

import numpy as np

from ufmt.machining.psd import DIRECTIONS, profile_psd
from ufmt.measured.read import HeightMap


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


def map_psd(height_map: HeightMap, direction: str) -> tuple[np.ndarray, np.ndarray]:
    """Mean 1-D PSD (frequency [1/m], PSD [m^2 m]) of the waviness' complete line profiles
    ``direction`` "along" (y) or "across" (x) the feed (:func:`band_rms_of`'s spectra)."""
    waviness, _ = fit_removed(legendre_basis(height_map.x, height_map.y), height_map.z)
    hx, hy = height_map.spacing
    complete = np.isfinite(waviness)
    if direction == "along":
        return profile_psd(waviness[:, complete.all(axis=0)], hy, 0)
    if direction == "across":
        return profile_psd(waviness[complete.all(axis=1), :], hx, 1)
    raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")


def plane_removed(height_map: HeightMap) -> np.ndarray:
    """The map's heights (Ny, Nx) [m] less their least-squares plane (NaN: missing)."""
    basis = legendre_basis(height_map.x, height_map.y)[:3]
    return fit_removed(basis, height_map.z)[0]
