"""ISO 25178-2 areal height parameters and the ISO 16610-21 Gaussian filter of a map with
missing pixels.

Parameters (:func:`areal_parameters`) over the measured pixels, heights z about their mean:
Sa = mean |z|, Sq = sqrt(mean z^2), Sp = max z, Sv = -min z, Sz = Sp + Sv,
Ssk = mean z^3 / Sq^3, Sku = mean z^4 / Sq^4 (ISO 25178-2, 4.1.1-4.1.7).

Gaussian filter (:func:`gaussian_mean`): the weighting function
s(x) = exp(-pi (x / (alpha lambda_c))^2) / (alpha lambda_c), alpha = sqrt(ln 2 / pi)
(ISO 16610-21 eq. 1), applied along x and y in turn (separable, as ISO 16610-61's areal
Gaussian), truncated at +-lambda_c. Its transmission exp(-pi (alpha lambda_c / lambda)^2) is
50 % at the cutoff wavelength lambda_c. Missing pixels and the map's ends are handled by
normalised convolution: the filtered heights are divided by the filtered mask of measured
pixels (the zero-order end-effect correction of ISO 16610-28). The mean surface is the
L-filter's output; the map less it is the S-L (roughness) surface.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.ndimage

#: alpha of the Gaussian weighting function (ISO 16610-21).
ALPHA = math.sqrt(math.log(2.0) / math.pi)


def areal_parameters(z: np.ndarray) -> dict[str, float]:
    """Sa, Sq, Sp, Sv, Sz [nm], Ssk, Sku [-] of the finite heights of ``z`` [m] about their
    mean (module docstring): keys ``sa_nm``, ``sq_nm``, ``sp_nm``, ``sv_nm``, ``sz_nm``,
    ``ssk``, ``sku``."""
    h = np.asarray(z, dtype=float)
    h = h[np.isfinite(h)]
    h = h - h.mean()
    sq = float(np.sqrt(np.mean(h**2)))
    sp, sv = float(h.max()), float(-h.min())
    moments = (float(np.mean(h**3)) / sq**3, float(np.mean(h**4)) / sq**4) if sq > 0 else (0, 0)
    return {
        "sa_nm": float(np.mean(np.abs(h))) * 1e9,
        "sq_nm": sq * 1e9,
        "sp_nm": sp * 1e9,
        "sv_nm": sv * 1e9,
        "sz_nm": (sp + sv) * 1e9,
        "ssk": moments[0],
        "sku": moments[1],
    }


def gaussian_mean(z: np.ndarray, spacing: tuple[float, float], cutoff: float) -> np.ndarray:
    """The Gaussian mean surface (Ny, Nx) [m] of ``z`` (Ny, Nx) [m] (NaN: missing), pixel
    ``spacing`` (hx, hy) [m], cutoff wavelength ``cutoff`` lambda_c [m] (module docstring).
    NaN where no measured pixel lies within the kernel."""
    if not (math.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f"cutoff must be a finite wavelength > 0 [m], got {cutoff!r}")
    valid = np.isfinite(z)
    hx, hy = spacing
    # s(x) = exp(-x^2 / (2 sigma^2)): sigma = alpha lambda_c / sqrt(2 pi)
    sigma = ALPHA * cutoff / math.sqrt(2.0 * math.pi)
    width = (sigma / hy, sigma / hx)
    kwargs = {"sigma": width, "mode": "constant", "cval": 0.0, "truncate": cutoff / sigma}
    numerator = scipy.ndimage.gaussian_filter(np.where(valid, z, 0.0), **kwargs)
    weight = scipy.ndimage.gaussian_filter(valid.astype(float), **kwargs)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(weight > 1e-12, numerator / weight, np.nan)
