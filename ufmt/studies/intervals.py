"""Intervals on the headline numbers of one cut: the cut simulated at a Latin hypercube of the
model's documented bands (:func:`ufmt.studies.bands.model_bands`: the model file's own
``[[uncertain]]`` inputs, or the packaged machine's bands on the packaged machine), each
metric's quantiles beside its point value (``ufmt simulate --uncertainty N``).

Each input is sampled on its band's natural scale (log-uniform for the bands documented on a
log scale: stiffnesses, the force factor, the straightness wavelength; uniform otherwise),
independently. The samples are whole simulations with the caller's options; a design whose
stiffnesses are the model's shares the model's modal basis (no stiffness input: one basis for
every sample).

Damping (assumed bands, :mod:`ufmt.studies.bands`): ``machine.modal_damping_ratio`` is the
sample's structural ratio (it replaces the caller's ``zeta``), and ``damping.hinge_factor``
multiplies every hinge damper of the model; with a shared basis its
projected hinge damping Phi_rel^T C Phi_rel, linear in C, is multiplied instead (the same
matrix, without solving the modes again).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
from tqdm import tqdm

from ufmt import limits
from ufmt.design import MACHINE_PREFIX, apply_design, machine_target
from ufmt.errors import StudyError
from ufmt.machining.modal import modal_basis
from ufmt.studies.bands import DAMPING_PREFIX, matching, model_bands, no_bands
from ufmt.studies.uncertainty import quantile_column, summarise, unit_sample

#: the packaged machine's: [machine] bands, both bearings, the assumed damping bands (a
#: model's own [[uncertain]] inputs: all of them)
DEFAULT_INPUTS = ("machine.*", "hinge.h31.*", "hinge.h25.*", "damping.*")
INTERVAL = (0.05, 0.95)


@dataclass
class Intervals:
    """Quantiles of each metric over the sampled bands.

    ``samples``: one row per sample (its input values, then its metrics); ``inputs``: the
    sampled parameters; ``quantiles``: the interval's ends.
    """

    samples: pd.DataFrame
    inputs: tuple[str, ...]
    quantiles: tuple[float, float] = INTERVAL

    def __repr__(self) -> str:
        return f"Intervals({len(self.samples)} samples of {len(self.inputs)} inputs)"

    def to_frame(self) -> pd.DataFrame:
        """Per metric: resolved samples, mean, std and the interval's quantiles."""
        metrics = [c for c in self.samples.columns if c not in self.inputs]
        rows = [
            {"metric": m, **summarise(self.samples[m].to_numpy(float), self.quantiles)}
            for m in metrics
        ]
        return pd.DataFrame(rows).drop(columns=["limit", "p_meet", "p_meet_low", "p_meet_high"])

    def to_dict(self) -> dict:
        """{"samples", "inputs", "quantiles", "metrics": {metric: {"q05": .., "q95": ..}}}."""
        table = self.to_frame().set_index("metric")
        columns = [quantile_column(q) for q in self.quantiles]
        metrics = {m: {c: float(table.loc[m, c]) for c in columns} for m in table.index}
        return {
            "samples": len(self.samples),
            "inputs": list(self.inputs),
            "quantiles": list(self.quantiles),
            "metrics": metrics,
        }


def input_bands(patterns: Sequence[str] | None = None, model=None) -> dict:
    """The bands of ``model`` (default: the packaged machine; :func:`model_bands`, the damping
    bands included) matching the shell ``patterns``, in the bands' order (None: every input
    the model declares, or :data:`DEFAULT_INPUTS` on the packaged machine)."""
    bands = model_bands(model)
    if not bands:
        raise no_bands(model)
    if patterns is None:
        patterns = ["*"] if model is not None and model.uncertain else list(DEFAULT_INPUTS)
    if not patterns:
        raise StudyError(
            f"--uncertainty-inputs: names no band (at least one pattern of: {', '.join(bands)})"
        )
    names = [n for pattern in patterns for n in matching(pattern, bands)]
    unknown = [p for p in patterns if not matching(p, bands)]
    if unknown:
        raise StudyError(
            f"--uncertainty-inputs: {', '.join(map(repr, unknown))} matches no documented band"
            f" of {'the packaged machine' if model is None else model.source}"
            f" (bands: {', '.join(bands)})"
        )
    return {n: bands[n] for n in dict.fromkeys(names)}


def sample_designs(bands: Mapping, n: int, seed: int = 1) -> pd.DataFrame:
    """A Latin hypercube of ``n`` designs over ``bands`` (log-uniform where the band is on a
    log scale), one column per parameter [SI]."""
    u = unit_sample("lhs", len(bands), n, seed)
    columns = {}
    for j, (name, band) in enumerate(bands.items()):
        if band.log:
            lo, hi = np.log10(band.low), np.log10(band.high)
            columns[name] = 10.0 ** (lo + u[:, j] * (hi - lo))
        else:
            columns[name] = band.low + u[:, j] * (band.high - band.low)
    return pd.DataFrame(columns)


def headline_intervals(
    model,
    process,
    n: int,
    patterns: Sequence[str] | None = None,
    seed: int = 1,
    progress: bool = False,
    **options,
) -> Intervals:
    """The cut of ``process`` on ``model`` (a loaded Model) simulated at ``n`` Latin-hypercube
    samples (1 to :data:`ufmt.limits.MAX_UNCERTAINTY_SAMPLES`) of the model's bands matching
    ``patterns`` (:func:`input_bands`; a model that declares none: one line saying how);
    ``options`` go to :func:`ufmt.simulate.simulate` (method, sources,
    basis size...). ``progress``: a progress bar on stderr (when it is a terminal)."""
    from ufmt.simulate import simulate

    n = limits.count("--uncertainty", n, 1, limits.MAX_UNCERTAINTY_SAMPLES, StudyError)
    bands = input_bands(patterns, model)
    designs = sample_designs(bands, n, seed)
    shared_basis = all(
        machine_target(name) is not None or name.startswith(DAMPING_PREFIX) for name in bands
    )
    basis = options.get("basis")  # the caller's basis: its hinge damping scaled too
    if shared_basis and basis is None:
        basis_options = {"n_modes": options.get("n_modes")}
        if "basis_cutoff_hz" in options:
            basis_options["cutoff_hz"] = options["basis_cutoff_hz"]
        basis = modal_basis(model, **basis_options)
    rows = []
    bar = tqdm(total=n, desc="uncertainty", unit="sample", disable=None if progress else True)
    for design in designs.to_dict("records"):
        sample_model, sample_options = _with_damping(model, design, basis, options)
        result = simulate(apply_design(sample_model, design), process, **sample_options)
        metrics = {k: np.nan if v is None else float(v) for k, v in result.metrics.items()}
        rows.append(metrics)
        bar.update()
    bar.close()
    samples = pd.concat([designs, pd.DataFrame(rows)], axis=1)
    return Intervals(samples, tuple(bands))


def _with_damping(model, design: dict, basis, options: Mapping) -> tuple:
    """(model, simulate options) of one sample: its ``damping.hinge_factor`` taken out of
    ``design`` and applied (on every hinge damper and on the shared ``basis``' projected hinge
    damping); a sampled ``machine.modal_damping_ratio`` replaces the caller's ``zeta``."""
    options = dict(options)
    if f"{MACHINE_PREFIX}modal_damping_ratio" in design:
        options.pop("zeta", None)  # the sample's ratio, through its [machine] value
    factor = design.pop(f"{DAMPING_PREFIX}hinge_factor", None)
    if factor is not None:
        model = scale_hinge_damping(model, factor)
        if basis is not None and basis.hinge_damping is not None:
            basis = replace(basis, hinge_damping=factor * basis.hinge_damping)
    if basis is not None:
        options["basis"] = basis
    return model, options


def scale_hinge_damping(model, factor: float):
    """A copy of ``model`` with every hinge's ``damping`` and ``rotational_damping`` times
    ``factor`` (>= 0)."""
    for hinge in model.hinges:
        model = model.with_hinge(
            hinge.name,
            damping=factor * np.asarray(hinge.damping),
            rotational_damping=factor * np.asarray(hinge.rotational_damping),
        )
    return model
