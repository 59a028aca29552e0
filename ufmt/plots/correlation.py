"""The MAC matrix of a test-analysis correlation (:class:`ufmt.calibration.correlation.
Correlation`): test modes down, model modes across, the pairs framed, the frequency error of
each pair beside its row. Data in, Figure out; never solves."""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Rectangle

from ufmt.plots import new_axes


def plot_mac(correlation, ax=None):
    """Heat map of the MAC (0 white to 1 dark); a frame on each paired cell; rows without a
    measured shape are grey with their order pairing framed dashed."""
    mac = correlation.mac
    n_test, n_model = mac.shape
    fig, ax = new_axes(ax, figsize=(max(5.0, 0.32 * n_model + 3.0), max(3.5, 0.32 * n_test + 2.0)))
    shown = np.ma.masked_invalid(mac)
    image = ax.imshow(shown, vmin=0.0, vmax=1.0, cmap="Blues", aspect="auto")
    ax.set_facecolor("0.85")
    fig.colorbar(image, ax=ax, label="MAC")
    for i, row in enumerate(correlation.table.itertuples()):
        if row.paired_by:
            ax.add_patch(
                Rectangle(
                    (row.model_mode - 1.5, i - 0.5),
                    1,
                    1,
                    fill=False,
                    edgecolor="tab:red",
                    linewidth=1.6,
                    linestyle="-" if row.paired_by == "mac" else "--",
                )
            )
    labels = [
        f"{k}: {f:.4g} Hz" + ("" if np.isnan(e) else f" ({e:+.2f} %)")
        for k, f, e in zip(
            correlation.table["test_mode"],
            correlation.table["test_hz"],
            correlation.table["error_percent"],
            strict=True,
        )
    ]
    ax.set_yticks(range(n_test), labels)
    ax.set_xticks(range(n_model), [str(j + 1) for j in range(n_model)])
    ax.set_xlabel("model mode")
    ax.set_ylabel("test mode: frequency (model error)")
    ax.set_title(f"{correlation.model_name}: MAC against {_name(correlation.test.source)}")
    return fig


def _name(source: str) -> str:
    """The test file's name without its folders."""
    return source.replace("\\", "/").rsplit("/", 1)[-1] or "the test"
