"""Modal parameters from measured FRFs (:mod:`.frf_file`) with sdypy-EMA: LSCF poles over a
range of model orders, a stabilisation chart, automatic pole selection, LSFD residues, and the
modes as a :class:`~ufmt.calibration.modal_test.ModalTest` (frequencies, damping ratios,
shapes at the response sensors), which validation and calibration take as any modal test.

Poles. The least-squares complex-frequency estimator (LSCF, ``sdypy.EMA.Model.get_poles``)
fits one common-denominator model to every FRF inside the band [f_min, f_max] for model
orders 2, 4, ..., 2 ``order``. A pole λ gives the natural frequency |λ| / 2π and damping ratio
-Re λ / |λ|; physical poles have 0 < ζ < MAX_DAMPING and lie in the band.

Stabilisation. A physical pole at one order is *stable* when the order below has a physical
pole within FREQUENCY_TOLERANCE (relative) in frequency and DAMPING_TOLERANCE (relative) in
damping ratio; its *run* is the number of consecutive orders below over which that holds.

Selection (automatic). Every pole whose run reaches STABLE_ORDERS is a mode candidate. Those
of the highest order holding any are modes; going down the orders, a candidate is a mode
unless a mode already chosen lies within FREQUENCY_TOLERANCE of it (each mode keeps its
estimate of the highest order: a mode that noise hides at the top orders is still found below).
Spurious poles of noise and of the residual terms wander with the order and are left out; two
modes closer than the tolerance are separated only where the top order resolves them.
Given approximate frequencies (``approx_hz``) instead, each is the stable pole (run >= 1)
nearest to it, from the highest order that has one within APPROX_WINDOW.

Residues and shapes. LSFD (``get_constants``, lower and upper residuals) gives the residue
A_pr of every FRF p in every mode r. For each mode the reference whose FRFs carry the largest
residues gives the shape: the residues of its FRFs at their response sensors, rotated to the
largest one and the real part taken (a complex residue of a lightly damped mode is real up to
one phase). A sensor that reference did not measure is NaN in that mode.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.calibration.frf_file import MeasuredFrf, read_measured_frf
from ufmt.calibration.modal_test import ModalTest, modal_test
from ufmt.errors import StudyError
from ufmt.tables import Where

DEFAULT_ORDER = 30  # highest LSCF order / 2 (sdypy's pol_order_high)
MAX_ORDER = 100
FREQUENCY_TOLERANCE = 0.005  # [-] relative: a stable pole's frequency between two orders
DAMPING_TOLERANCE = 0.05  # [-] relative: a stable pole's damping ratio between two orders
STABLE_ORDERS = 5  # consecutive stable orders that make a pole a mode
MAX_DAMPING = 0.2  # [-] a physical pole's damping ratio is below
APPROX_WINDOW = 0.05  # [-] relative: how far a given approximate frequency may be from its pole


@dataclass(frozen=True, eq=False, repr=False)
class FrfModes:
    """The modes extracted from measured FRFs: ``test`` the :class:`ModalTest` (modes 1..m);
    ``chart`` one row per physical pole of every order (order, frequency_hz, damping_ratio,
    run, selected); ``residues`` (P, m) complex LSFD residues; ``synthesised`` (P, F) the
    FRFs the modes and residuals rebuild over the band; ``band_hz`` (f_min, f_max)."""

    measured: MeasuredFrf
    test: ModalTest
    chart: pd.DataFrame
    residues: np.ndarray
    synthesised: np.ndarray
    band_hz: tuple[float, float]

    def __repr__(self) -> str:
        f = self.test.frequencies_hz
        span = f"{f.min():.4g}-{f.max():.4g} Hz" if f.size else "none"
        return (
            f"FrfModes({self.measured.source!r}: {f.size} modes ({span}) in "
            f"{self.band_hz[0]:.4g}-{self.band_hz[1]:.4g} Hz from "
            f"{len(self.measured.outputs)} FRFs)"
        )

    def to_frame(self) -> pd.DataFrame:
        """One row per mode: mode, frequency_hz, damping_ratio."""
        t = self.test
        return pd.DataFrame(
            {"mode": t.modes, "frequency_hz": t.frequencies_hz, "damping_ratio": t.damping_ratio}
        )

    def plot(self, ax=None):
        """The stabilisation chart (:func:`ufmt.plots.frf_test.plot_stabilisation`)."""
        from ufmt.plots.frf_test import plot_stabilisation

        return plot_stabilisation(self, ax=ax)

    def save(self, directory) -> list[Path]:
        """Write ``frf-modes.csv`` (the modes as a modal-test file), ``stabilisation.csv`` (the
        chart) and ``stabilisation.png``, as one set."""
        from ufmt import files
        from ufmt.plots import DPI

        names = ("frf-modes.csv", "stabilisation.csv", "stabilisation.png")
        test, chart = self.test.to_frame(), self.chart
        with files.FileSet(directory) as written:
            test.to_csv(written.staged(names[0]), index=False, float_format="%.10g")
            chart.to_csv(written.staged(names[1]), index=False, float_format="%.8g")
            written.add(names[2], files.figure_png(self.plot(), DPI))
        return [written.directory / n for n in names]


def extract_modes(
    measured,
    fmin_hz: float | None = None,
    fmax_hz: float | None = None,
    order: int = DEFAULT_ORDER,
    approx_hz=None,
    unit: str | None = None,
) -> FrfModes:
    """The modes of ``measured`` (a :class:`MeasuredFrf` or a path, read with ``unit``)
    between ``fmin_hz`` and ``fmax_hz`` [Hz] (default: the file's first and last lines), LSCF
    orders up to 2 ``order``, selected automatically or nearest ``approx_hz`` (module
    docstring)."""
    import sdypy.EMA as EMA

    if not isinstance(measured, MeasuredFrf):
        measured = read_measured_frf(measured, unit)
    where = Where(measured.source, error=StudyError)
    freq = measured.frequencies_hz
    lo = freq[0] if fmin_hz is None else where.number("fmin_hz", fmin_hz, sign="positive")
    hi = freq[-1] if fmax_hz is None else where.number("fmax_hz", fmax_hz, sign="positive")
    if not freq[0] <= lo < hi <= freq[-1]:
        where.fail(
            "band", f"[{lo:g}, {hi:g}] Hz is not inside the file's {freq[0]:g}-{freq[-1]:g} Hz"
        )
    order = where.integer("order", order, low=STABLE_ORDERS + 1, high=MAX_ORDER)
    model = EMA.Model(
        measured.values, freq, lower=lo, upper=hi, pol_order_high=order, frf_form=measured.kind
    )
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        model.get_poles(method="lscf", show_progress=False)
    chart = stabilisation(model.all_poles, lo, hi)
    rows = _selected(where, chart, approx_hz)
    chart["selected"] = False
    chart.loc[rows, "selected"] = True
    picked = chart.loc[rows].sort_values("frequency_hz")
    model.pole_ind = picked[["order_index", "pole_index"]].to_numpy(int)
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        synthesised, residues = model.get_constants(method="lsfd", f_lower=lo, f_upper=hi)
    test = _as_test(measured, picked, residues)
    return FrfModes(measured, test, chart, residues, synthesised, (float(lo), float(hi)))


def stabilisation(all_poles, lo: float, hi: float) -> pd.DataFrame:
    """The stabilisation chart (module docstring): one row per physical pole of every order
    with its run of stable orders below it."""
    rows, below = [], None
    for k, poles in enumerate(all_poles):
        lam = np.asarray(poles, dtype=complex)
        index = np.flatnonzero(lam.imag > 0)
        f = np.abs(lam[index]) / (2 * np.pi)
        z = -lam[index].real / np.abs(lam[index])
        ok = (f >= lo) & (f <= hi) & (z > 0) & (z < MAX_DAMPING)
        index, f, z = index[ok], f[ok], z[ok]
        run = np.zeros(f.size, dtype=int)
        if below is not None and below[0].size and f.size:
            near = np.argmin(np.abs(f[:, None] - below[0][None, :]), axis=1)
            df = np.abs(f - below[0][near]) / f
            dz = np.abs(z - below[1][near]) / below[1][near]
            stable = (df < FREQUENCY_TOLERANCE) & (dz < DAMPING_TOLERANCE)
            run = np.where(stable, below[2][near] + 1, 0)
        below = (f, z, run)
        for j, fj, zj, rj in zip(index, f, z, run, strict=True):
            rows.append((k, int(j), 2 * (k + 1), fj, zj, int(rj)))
    columns = ["order_index", "pole_index", "order", "frequency_hz", "damping_ratio", "run"]
    return pd.DataFrame(rows, columns=columns)


def _selected(where: Where, chart: pd.DataFrame, approx_hz) -> list[int]:
    """Row labels of ``chart`` chosen as modes: automatic or nearest ``approx_hz``."""
    by_order = chart.sort_values("order", ascending=False, kind="stable")
    if approx_hz is None:
        ready = by_order[by_order["run"] >= STABLE_ORDERS]
        top = ready["order"].max() if len(ready) else 0
        chosen: list[int] = list(ready.index[ready["order"] == top])
        for label, row in ready[ready["order"] < top].iterrows():
            f = chart.loc[chosen, "frequency_hz"].to_numpy()
            if not np.any(np.abs(f - row.frequency_hz) < FREQUENCY_TOLERANCE * row.frequency_hz):
                chosen.append(label)
        if not chosen:
            where.fail_table(
                f"no pole is stable over {STABLE_ORDERS} orders in the band: widen the band, "
                "raise the order or give approximate frequencies"
            )
        return chosen
    stable = by_order[by_order["run"] >= 1]
    chosen = []
    for f in where.numbers("approx_hz", list(approx_hz), len(list(approx_hz)), sign="positive"):
        near = stable[np.abs(stable["frequency_hz"] - f) < APPROX_WINDOW * f]
        if near.empty:
            where.fail("approx_hz", f"no stable pole within {100 * APPROX_WINDOW:g} % of {f:g} Hz")
        best = near[near["order"] == near["order"].max()]
        chosen.append(int((best["frequency_hz"] - f).abs().idxmin()))
    where.unique("approx_hz", chosen)
    return chosen


def _as_test(measured: MeasuredFrf, picked: pd.DataFrame, residues: np.ndarray) -> ModalTest:
    """The modal test of the selected poles: shapes from the residues (module docstring)."""
    sensors = list(dict.fromkeys(measured.outputs))
    column = {s: j for j, s in enumerate(sensors)}
    references = list(dict.fromkeys(measured.inputs))
    shapes = np.full((len(picked), len(sensors)), np.nan)
    for r in range(len(picked)):
        a = residues[:, r]
        weight = [np.linalg.norm(a[[i == ref for i in measured.inputs]]) for ref in references]
        ref = references[int(np.argmax(weight))]
        rows = [p for p, i in enumerate(measured.inputs) if i == ref]
        big = a[rows][np.argmax(np.abs(a[rows]))]
        for p in rows:
            shapes[r, column[measured.outputs[p]]] = (a[p] * np.conj(big) / abs(big)).real
    modes = np.arange(1, len(picked) + 1)
    f, z = picked["frequency_hz"].to_numpy(), picked["damping_ratio"].to_numpy()
    return modal_test(modes, f, z, sensors, shapes, measured.source)
