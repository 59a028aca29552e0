"""PSD figure of a simulation: the 1-D PSDs along and across the feed, on log-log axes, with
the PSD1 and PSD2 bands shaded and each band's RMS printed against the specification it is
judged by.

The PSDs are the ones the band RMS values are computed from: the simulation's line profiles'
(``psd_spectra``, :mod:`ufmt.machining.lines`; else :func:`ufmt.machining.psd.surface_psd` of
its grid: form removed, Hann window, the mean over the line profiles) of the surface without
the feed marks over the clear aperture (the plate less ``aperture_margin`` at every edge, as
``pv_measured_nm``; the form fitted there); the band RMS values are the simulation's own
metrics (``psd1_rms_along_nm``, ...), "not resolved" where the plate is
too short for the band (:func:`ufmt.machining.psd.band_resolved`).

Specification (:data:`KDP_SPEC_RMS_NM`): the mid-spatial-frequency limits quoted for the
frequency-conversion KDP crystals of large laser facilities in the fly-cutting literature,
PSD1 (2.5-33 mm) RMS <= 1.8 nm and PSD2 (0.12-2.5 mm) RMS <= 1.1 nm, following the NIF
practice of specifying optics by band RMS of 1-D PSDs (J. K. Lawson et al., "Specification of
optical components using the power spectral density function", Proc. SPIE 2536, 38 (1995)).
They are a reading aid, not an input of any computation; a user judging against another
specification passes ``spec``.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from ufmt.machining.psd import BANDS, DIRECTIONS, N_MIN_PERIODS, surface_psd
from ufmt.machining.surface import DEFAULT_APERTURE_MARGIN, clear_aperture
from ufmt.plots import new_axes, new_figure

#: Band RMS limits [nm] a KDP surface is judged by (module docstring).
KDP_SPEC_RMS_NM = {"psd1": 1.8, "psd2": 1.1}
BAND_COLOURS = {"psd1": "tab:blue", "psd2": "tab:orange"}
DIRECTION_STYLE = {
    "along": {"color": "k", "ls": "-", "label": "along the feed (y)"},
    "across": {"color": "tab:red", "ls": "--", "label": "across the feed (x)"},
}


def band_verdict(value_nm: float, spec_nm: float, n: int, spacing: float, band) -> str:
    """One reading of a band RMS against its limit, "1.23 nm (limit 1.8 nm: passes)", or why
    the profile of ``n`` points ``spacing`` [m] apart does not resolve ``band`` [m]."""
    if value_nm is None or not math.isfinite(value_nm):
        lam_min, lam_max = band
        if 2 * spacing > lam_min * (1 + 1e-9):
            return (
                f"not resolved (a {spacing * 1e3:.2g} mm grid resolves wavelengths"
                f" >= {2 * spacing * 1e3:.2g} mm, not {lam_min * 1e3:g} mm)"
            )
        length = (n - 1) * spacing * 1e3
        return f"not resolved (profile {length:.0f} mm < {N_MIN_PERIODS} x {lam_max * 1e3:g} mm)"
    verdict = "passes" if value_nm <= spec_nm else "fails"
    return f"{value_nm:.2f} nm (limit {spec_nm:g} nm: {verdict})"


def plot_psd(
    result,
    ax=None,
    spec: dict[str, float] | None = None,
    aperture_margin: float = DEFAULT_APERTURE_MARGIN,
) -> Figure:
    """The 1-D PSDs [nm^2 mm] of a :class:`ufmt.simulate.SimulationResult`'s surface along
    and across the feed against spatial frequency [1/mm], PSD1/PSD2 shaded, band RMS against
    ``spec`` (default :data:`KDP_SPEC_RMS_NM`) printed below; ``aperture_margin`` [m] the one
    the result was simulated with (:func:`spectra`). Draws into ``ax`` if given."""
    spec = spec or KDP_SPEC_RMS_NM
    fig, ax = new_axes(ax, (7.2, 5.6))
    drawn = spectra(result, aperture_margin)
    for direction in DIRECTIONS:
        _, _, f, psd = drawn[direction]
        keep = (f > 0) & (psd > 0)
        ax.loglog(f[keep] * 1e-3, psd[keep] * 1e18 * 1e3, lw=1.2, **DIRECTION_STYLE[direction])
    _bands_and_axes(ax)
    lines = _verdicts(result, spec, drawn)
    lines.append(_limits(spec))
    words = aperture_words(aperture_margin)
    fig.suptitle(f"Surface PSD without the feed marks\n{words}", fontsize=10)
    fig.text(0.01, 0.0, "\n".join(lines), fontsize=8, va="bottom", family="monospace")
    fig.get_layout_engine().set(rect=(0, 0.16, 1, 0.84))
    return fig


def plot_psd_extremes(
    results: dict[str, object],
    metric: str = "pv_measured_nm",
    spec: dict[str, float] | None = None,
    aperture_margin: float = DEFAULT_APERTURE_MARGIN,
) -> Figure:
    """The 1-D PSDs [nm^2 mm] of several simulations in one figure: a panel along and one
    across the feed, one line style per result (``results``: label -> SimulationResult, e.g.
    a sweep's best and worst design, simulated with one ``aperture_margin`` [m]), PSD1/PSD2
    shaded, each result's ``metric`` [nm] in the legend and its band RMS against ``spec``
    (default :data:`KDP_SPEC_RMS_NM`) below."""
    spec = spec or KDP_SPEC_RMS_NM
    drawn = {label: spectra(result, aperture_margin) for label, result in results.items()}
    fig = new_figure((11.0, 6.4))
    axes = fig.subplots(1, 2, sharey=True)
    styles = ("-", "--", ":", "-.")
    for ax, direction in zip(axes, DIRECTIONS, strict=True):
        for (label, result), ls in zip(results.items(), styles, strict=False):
            _, _, f, psd = drawn[label][direction]
            keep = (f > 0) & (psd > 0)
            value = result.metrics.get(metric, math.nan)
            ax.loglog(
                f[keep] * 1e-3, psd[keep] * 1e18 * 1e3, lw=1.2, ls=ls,
                color=DIRECTION_STYLE[direction]["color"], label=f"{label} ({value:.1f} nm)",
            )  # fmt: skip
        _bands_and_axes(ax)
        ax.set_title(DIRECTION_STYLE[direction]["label"], fontsize=9)
    axes[1].set_ylabel("")
    lines = [
        f"{label:<6} " + line
        for label, r in results.items()
        for line in _verdicts(r, spec, drawn[label])
    ]
    lines.append(_limits(spec) + f"; legend: {metric} [nm]")
    words = aperture_words(aperture_margin)
    fig.suptitle(f"Surface PSD without the feed marks\n{words}", fontsize=10)
    fig.text(0.01, 0.0, "\n".join(lines), fontsize=8, va="bottom", family="monospace")
    share = 0.02 + 0.024 * len(lines)  # of the height, for the verdict lines below
    fig.get_layout_engine().set(rect=(0, share, 1, 1 - share))
    return fig


def _bands_and_axes(ax) -> None:
    """PSD1/PSD2 shading, axis labels (a wavelength axis on top), grid and legend."""
    for name, (lam_min, lam_max) in BANDS.items():
        ax.axvspan(
            1e-3 / lam_max,
            1e-3 / lam_min,
            color=BAND_COLOURS[name],
            alpha=0.12,
            lw=0,
            label=f"{name.upper()}: {lam_min * 1e3:g}-{lam_max * 1e3:g} mm",
        )
    ax.set_xlabel("spatial frequency [1/mm]")
    ax.set_ylabel("PSD [nm$^2$ mm]")
    top = ax.secondary_xaxis("top", functions=(_inverse, _inverse))
    top.set_xlabel("wavelength [mm]")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="lower left")


def _verdicts(result, spec: dict[str, float], profile: dict) -> list[str]:
    """One line per band and direction: the band RMS of ``result`` against its limit;
    ``profile`` its :func:`spectra`."""
    m = result.metrics
    return [
        f"{name.upper()} RMS {direction:<6}: "
        + band_verdict(
            m.get(f"{name}_rms_{direction}_nm"), limit, *profile[direction][:2], BANDS[name]
        )
        for name, limit in spec.items()
        for direction in DIRECTIONS
    ]


def spectra(
    result, aperture_margin: float = DEFAULT_APERTURE_MARGIN
) -> dict[str, tuple[int, float, np.ndarray, np.ndarray]]:
    """Per direction (points per profile, step [m], frequency [1/m], mean PSD [m^2 m]) of the
    profiles ``result``'s bands read, over the clear aperture: its line profiles (over the
    aperture it was simulated with), else its smooth surface's grid over the plate less
    ``aperture_margin`` [m] at every edge, which must be the one it was simulated with
    (:func:`ufmt.simulate`'s default, as every study's)."""
    if result.psd_spectra is not None:
        return result.psd_spectra
    surface, margin = result.smooth_surface, aperture_margin
    hx, hy = surface.spacing
    n_y = int(clear_aperture(surface.y[surface.core_rows], margin).sum())
    n_x = int(clear_aperture(surface.x, margin).sum())
    size = {"along": (n_y, hy), "across": (n_x, hx)}
    return {d: (*size[d], *surface_psd(surface, d, aperture_margin=margin)) for d in DIRECTIONS}


def aperture_words(margin: float) -> str:
    """Where the drawn spectra come from, for a title: the clear aperture, ``margin`` [m]."""
    return (
        f"clear aperture ({margin * 1e3:g} mm margin), form removed there, Hann window: "
        "the bands' spectra"
    )


def _limits(spec: dict[str, float]) -> str:
    limits = ", ".join(f"{name.upper()} RMS <= {limit:g} nm" for name, limit in spec.items())
    return f"limits: {limits} (KDP specification, ufmt.plots.psd)"


def _inverse(value):
    with np.errstate(divide="ignore"):
        return 1.0 / np.asarray(value, dtype=float)
