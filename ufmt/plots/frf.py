"""The figure of an FRF (:class:`ufmt.machining.frf.FrfResult`): the magnitude/phase figure
of :func:`ufmt.plots.response.plot_frf` (natural frequencies and spindle harmonics marked),
labelled with the model, the quantity, its ends and directions. Data in, Figure out."""

from __future__ import annotations

from ufmt.plots.response import plot_frf

SYMBOL = {"receptance": "H", "mobility": "Y", "accelerance": "A"}
UNIT = {"receptance": "m/N", "mobility": "m/(s N)", "accelerance": "m/(s² N)"}


def plot_frf_result(result, ax=None):
    """Log-log magnitude over semi-log phase; ``ax``: two axes (magnitude, phase)."""
    fig = plot_frf(result.frequencies_hz, result.values, natural_hz=result.natural_hz, ax=ax)
    mag = fig.axes[0] if ax is None else ax[0]
    symbol = f"${SYMBOL[result.kind]}_{{{''.join(result.direction)}}}$"
    mag.lines[0].set_label(f"|{symbol}|")
    mag.legend(fontsize="small")
    mag.set_ylabel(f"|{symbol}| [{UNIT[result.kind]}]")
    ends = result.output if result.output == result.input else f"{result.output} / {result.input}"
    mag.set_title(
        f"{result.model_name}: {result.kind}, {ends}\n"
        f"({result.direction[0]} response to a {result.direction[1]} force)",
        fontsize="medium",
    )
    return fig
