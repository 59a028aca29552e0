"""Damped natural frequencies and damping ratios of a model's modes: the poles of its modal
equations with the structural damping ratio ζ and the hinge dampers (:mod:`.damping`).

A pole λ = -ζ_j ω_j + i ω_j √(1 - ζ_j²) of the first-order modal equations gives the mode's
natural frequency |λ| / 2π [Hz], its damped natural frequency Im λ / 2π [Hz] (ω_d = ω_n √(1 -
ζ²)) and its damping ratio -Re λ / |λ| [-]. Without hinge dampers the modes stay classically
damped: λ_j from ω_j and ζ alone. With them the modes couple and the poles are those of the
complex modes of the basis (:func:`ufmt.machining.damping.damped_modes`), ascending by |λ|; an
overdamped mode (a real pole pair) has no damped frequency and is left out. The basis is
solved with the model as loaded (the slide where the file puts it) and without the tool
carrier: the structure's own modes, as ``ufmt modes`` lists them, and those above them up to
the response's basis cutoff (the dampers couple a mode to the modes above it; the modes
above the basis stay undamped, as in the response).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.defaults import DEFAULT_BASIS_CUTOFF_HZ
from ufmt.machining.damping import damped_modes
from ufmt.machining.modal import modal_basis
from ufmt.machining.recurrence import DEFAULT_ZETA, modal_damping
from ufmt.model.load import as_model


@dataclass(frozen=True, eq=False, repr=False)
class DampedFrequencies:
    """The damped modes of a model: ``undamped_hz`` (n,) the undamped natural frequencies of
    the basis [Hz]; per oscillatory pole (m ≤ n, ascending by |λ|) ``natural_hz`` |λ|/2π [Hz],
    ``damped_hz`` Im λ/2π [Hz], ``damping_ratio`` -Re λ/|λ| [-]; ``zeta`` the structural
    ratio [-]; ``hinge_dampers`` whether any hinge damps (the modes are then complex)."""

    model_name: str
    undamped_hz: np.ndarray
    natural_hz: np.ndarray
    damped_hz: np.ndarray
    damping_ratio: np.ndarray
    zeta: float
    hinge_dampers: bool

    def __repr__(self) -> str:
        z = self.damping_ratio
        span = f"ζ {z.min():.3g}-{z.max():.3g}" if z.size else "none oscillatory"
        kind = "complex modes" if self.hinge_dampers else "classical damping"
        return (
            f"DampedFrequencies({self.model_name!r}: {self.damped_hz.size} damped modes, {span}, "
            f"{kind}, structural ζ {self.zeta:g})"
        )

    def to_frame(self) -> pd.DataFrame:
        """One row per damped mode: mode, natural_hz, damped_hz, damping_ratio."""
        return pd.DataFrame(
            {
                "mode": np.arange(1, self.damped_hz.size + 1),
                "natural_hz": self.natural_hz,
                "damped_hz": self.damped_hz,
                "damping_ratio": self.damping_ratio,
            }
        )

    def plot(self, ax=None):
        """Damping ratio against damped frequency, one marker per mode."""
        from ufmt.plots import new_axes

        _, ax = new_axes(ax, figsize=(6.0, 3.5))
        ax.plot(self.damped_hz, 100 * self.damping_ratio, "o")
        ax.set_xlabel("damped natural frequency [Hz]")
        ax.set_ylabel("damping ratio [%]")
        ax.set_title(f"{self.model_name}: damped modes")
        ax.grid(True, alpha=0.3)
        return ax.figure

    def save(self, directory) -> list[Path]:
        """Write ``damped-modes.csv`` and ``damped-modes.png`` (both or neither)."""
        from ufmt import files
        from ufmt.plots import DPI

        table = self.to_frame()
        with files.FileSet(directory) as written:
            table.to_csv(written.staged("damped-modes.csv"), index=False, float_format="%.10g")
            written.add("damped-modes.png", files.figure_png(self.plot(), DPI))
        return [written.directory / n for n in ("damped-modes.csv", "damped-modes.png")]


def pole_frequencies(poles) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(natural [Hz], damped [Hz], damping ratio [-]) of poles λ [1/s] (see module docstring);
    real poles (overdamped) are left out."""
    lam = np.asarray(poles, dtype=complex)
    lam = lam[lam.imag > 0.0]
    size = np.abs(lam)
    return size / (2 * np.pi), lam.imag / (2 * np.pi), -lam.real / size


def damped_frequencies(model=None, count=None, zeta=None, basis_hz=DEFAULT_BASIS_CUTOFF_HZ):
    """:class:`DampedFrequencies` of ``model`` (a path, a loaded model or None for the packaged
    UFMT): its first ``count`` damped modes (default: every mode of the basis) with the
    structural damping ratio ``zeta`` (default the model's ``machine.modal_damping_ratio``,
    :data:`~ufmt.machining.recurrence.DEFAULT_ZETA` without ``[machine]``). The basis holds
    every mode below ``basis_hz`` [Hz] (the response's default basis) and at least ``count``:
    the dampers couple the modes, and a basis cut at the listed modes misses their coupling
    to the modes above."""
    model = as_model(model)
    if zeta is None:
        machine = model.machine
        zeta = DEFAULT_ZETA if machine is None else machine.modal_damping_ratio
    basis = modal_basis(model, None, basis_hz, slide_y=0.0)
    if count is not None and basis.n_modes < count:
        basis = modal_basis(model, count, slide_y=0.0)
    ratios = modal_damping(zeta, basis.n_modes)
    modes = damped_modes(basis, ratios)
    if modes is None:
        poles = basis.omega * (-ratios + 1j * np.sqrt(1.0 - ratios**2))
    else:
        poles = modes.poles
    natural, damped, ratio = (x[:count] for x in pole_frequencies(poles))
    return DampedFrequencies(
        model.name,
        basis.omega[:count] / (2 * np.pi),
        natural,
        damped,
        ratio,
        float(zeta),
        modes is not None,
    )
