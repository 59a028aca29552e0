"""Figures of a measured-FRF modal test: the stabilisation chart of the pole extraction
(:class:`ufmt.calibration.frf_modes.FrfModes`) and the measured FRFs overlaid with a model's
(:class:`ufmt.calibration.frf_overlay.FrfOverlay`). Data in, Figure out; never solves."""

from __future__ import annotations

import numpy as np

from ufmt.plots import new_axes, new_figure

MAX_PANELS = 6  # FRFs drawn in the overlay figure (the table holds them all)
VISIBLE = 1e-6  # an FRF whose peak is below this fraction of the largest is not drawn


def plot_stabilisation(result, ax=None):
    """Pole frequency against model order: every physical pole (grey), stable ones (black),
    the selected modes (red lines); the sum of |H| over the FRFs on a second axis."""
    fig, ax = new_axes(ax, figsize=(8.0, 4.8))
    chart = result.chart
    stable = chart["run"] >= 1
    ax.plot(
        chart.loc[~stable, "frequency_hz"],
        chart.loc[~stable, "order"],
        ".",
        color="0.7",
        ms=3,
        label="pole",
    )
    ax.plot(
        chart.loc[stable, "frequency_hz"],
        chart.loc[stable, "order"],
        "+",
        color="k",
        ms=5,
        label="stable (f, ζ)",
    )
    for k, f in enumerate(result.test.frequencies_hz):
        ax.axvline(f, color="tab:red", lw=0.8, label="selected" if k == 0 else None)
    lo, hi = result.band_hz
    freq = result.measured.frequencies_hz
    band = (freq >= lo) & (freq <= hi)
    twin = ax.twinx()
    twin.semilogy(
        freq[band], np.abs(result.measured.values[:, band]).sum(axis=0), color="tab:blue", lw=0.8
    )
    twin.set_ylabel("Σ |H| (SI)", color="tab:blue")
    ax.set_xlim(lo, hi)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("model order")
    ax.set_title(f"stabilisation chart: {result.test.frequencies_hz.size} modes", fontsize="medium")
    ax.legend(fontsize="small", loc="upper left")
    return fig


def plot_overlay(result, ax=None):
    """|H| of the measured FRFs (black) and the model's (red), one panel per FRF: the
    MAX_PANELS of largest peak, those above VISIBLE times the largest (below: round-off);
    ``ax`` a sequence of axes, one per panel drawn."""
    measured = result.measured
    peaks = np.abs(measured.values).max(axis=1)
    largest = np.argsort(-peaks, kind="stable")[:MAX_PANELS]
    drawn = sorted(int(p) for p in largest if peaks[p] > VISIBLE * peaks.max()) or [0]
    count = len(drawn)
    if ax is None:
        cols = min(3, count)
        rows = -(-count // cols)
        fig = new_figure((4.0 * cols, 2.6 * rows))
        axes = [fig.add_subplot(rows, cols, k + 1) for k in range(count)]
    else:
        axes = list(np.ravel(ax))[:count]
        fig = axes[0].figure
    labels = measured.labels
    for k, a in zip(drawn, axes, strict=False):  # a caller may pass fewer axes
        a.semilogy(
            measured.frequencies_hz, np.abs(measured.values[k]), "k", lw=0.8, label="measured"
        )
        a.semilogy(
            measured.frequencies_hz,
            np.abs(result.model[k]),
            "tab:red",
            lw=0.8,
            label=result.model_name,
        )
        a.set_title(labels[k], fontsize="small")
        a.set_xlabel("frequency [Hz]", fontsize="small")
        a.tick_params(labelsize="small")
    axes[0].set_ylabel(f"|H| ({measured.kind}, SI)", fontsize="small")
    axes[0].legend(fontsize="x-small")
    return fig
