"""Identification of hinge stiffnesses against the modal test (paper section 2.5, "MSTMM&GA").

Sensitivity-based model updating in log-stiffness. Each parameter p scales listed components of
listed hinges by one factor, ``k = s_p k_prior``, and is identified as ``u_p = ln s_p`` within
``ln band_p``. With the paired model modes f_m(u) and the test frequencies f_t,m the cost is

    J(u) = sum_m (ln f_m(u) - ln f_t,m)^2 + rho^2 sum_p u_p^2 + penalty * (shape mismatches)

where a shape mismatch is a tested mode whose computed shape contradicts its Table 3 tag (wrong
symmetry class or a named body that does not move;
:func:`ufmt.calibration.frequencies.check_tag`), a mode that is not paired by order, or a
tool-tip z mode of section 4.1 whose tool tip moves less in z than its neighbours'
(:func:`ufmt.calibration.frequencies.tool_tip_neighbours`).

Local iteration: at u_i, with the residual r and the exact sensitivities S = d ln f / d u,
cvxpy solves the bounded, regularised least-squares step

    min_d |r + S d|^2 + rho^2 |u_i + d|^2
    s.t.  |d_p| <= t  and  ln band_p[0] <= u_i,p + d_p <= ln band_p[1]

and the step is taken if J decreases, else t is halved (a trust region). It stops when no
paired frequency changes by more than ``tolerance_percent`` in a step, t falls below
``min_trust_region``, or after ``max_iterations``. It stalls when it stops with the
acceptance levels unmet; then scipy's differential evolution searches all of ln band for the
lowest J (deterministic seed, the local result in its initial population), and the local
iteration restarts from its best point. The lower J of the two runs is kept.

Pairing inside the loop is by symmetry class and rank
(:func:`ufmt.calibration.frequencies.pair_by_class`):
for a model whose class sequence is Table 3's it is the pairing by order, and it keeps J smooth
when modes of different classes (e.g. Table 3 modes 12 and 13, 0.4 % apart) change places.
Pairing by order is enforced through the penalty and checked again on the final MSTMM solution.

Cheap model. Hinge stiffness enters the assembled model linearly, so its stiffness matrix is
``K(s) = K_fixed + sum_p s_p K_p`` exactly, and its square root ``F`` (``K = F^T F``) has one
row per spring scaled by ``sqrt(s_p)`` (:class:`ReducedModel`): the prior is assembled once,
and each evaluation is one QR (static condensation of the massless directions) and one SVD of
a dense (springs x dofs) matrix, like :func:`ufmt.assembled.assembled_modes` (a few ms for the
UFMT; it agrees with the assembled model to ~1e-13 and the result is checked by the MSTMM at
the end, ``ufmt calibrate`` reports the difference). With mass-normalised shapes phi the
sensitivity is exact (Rayleigh quotient stationarity; distinct roots):
``d ln f_m / d u_p = s_p phi_m^T K_p phi_m / (2 omega_m^2)``.
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import cvxpy as cp
import numpy as np
import pandas as pd
import scipy.linalg as sla
from scipy.optimize import differential_evolution
from threadpoolctl import threadpool_limits
from tqdm import tqdm

from ufmt.assembled import AssembledModel, assemble, structure, svd
from ufmt.calibration.frequencies import (
    ModeSet,
    Reference,
    Validation,
    check_tag,
    modeset_from_dofs,
    pair_by_class,
    read_reference,
    tool_tip_neighbours,
    validate,
)
from ufmt.calibration.tables import check_keys as _check_keys
from ufmt.calibration.tables import fail as _fail
from ufmt.calibration.tables import read_band
from ufmt.calibration.tables import suggest as _suggest
from ufmt.model.load import load_model
from ufmt.model.schema import Model
from ufmt.model.write import model_to_toml
from ufmt.tomlfile import read_toml

FIELDS = ("stiffness", "rotational_stiffness")
COLUMNS = ("modal_test_hz", "mstmm_hz", "fem_hz")
TOP_KEYS = (
    "prior",
    "reference",
    "output",
    "output_name",
    "targets",
    "settings",
    "parameter",
    "constraint",
    "response",
)
CONSTRAINT_KEYS = ("hinges", "modes", "factor", "max_change_percent", "weight", "source")
SIGNIFICANT = 6  # digits of every identified factor written to the model (deterministic files)
TARGET_KEYS = ("modes", "column", "source")
PARAMETER_KEYS = ("name", "hinges", "field", "components", "band", "reason")
UNPAIRED_RESIDUAL = 1.0  # ln-frequency residual of a Table 3 mode with no model partner


# ---------------------------------------------------------------------------------------------
# settings


@dataclass(frozen=True)
class Parameter:
    """One identified factor s: ``k = s k_prior`` on ``components`` of ``field`` of ``hinges``.

    band : (lower, upper) bounds of s [-], lower <= 1 <= upper (the prior is inside).
    """

    name: str
    hinges: tuple[str, ...]
    field: str
    components: tuple[int, ...]
    band: tuple[float, float]
    reason: str = ""


@dataclass(frozen=True)
class Settings:
    """Numerical settings of the identification (``[settings]`` of calibration.toml).

    regularisation : rho, weight of |u| [-]; trust_region : initial t, largest |d_p| per step;
    min_trust_region : stop when t falls below; max_iterations : local steps per run;
    tolerance_percent : stop when no paired frequency changes by more than this [%] in a step;
    elements_per_beam : beam mesh of the cheap assembled model; n_modes : modes solved;
    accept_max_percent, accept_mean_percent : the local run has stalled when it ends above
    these or with shape mismatches; shape_penalty : cost of one shape mismatch in J;
    seed, population, generations : differential evolution (scipy ``rng``, ``popsize``,
    ``maxiter``) of the global start; global_start : allow it at all.
    """

    regularisation: float = 0.05
    trust_region: float = 0.3
    min_trust_region: float = 1e-3
    max_iterations: int = 60
    tolerance_percent: float = 0.05
    elements_per_beam: int = 8
    n_modes: int = 30
    accept_max_percent: float = 3.0
    accept_mean_percent: float = 1.0
    shape_penalty: float = 0.01
    global_start: bool = True
    seed: int = 1
    population: int = 10
    generations: int = 60


_SETTING_RULES = {  # name -> (type, lower bound, strict)
    "regularisation": (float, 0.0, False),
    "trust_region": (float, 0.0, True),
    "min_trust_region": (float, 0.0, True),
    "max_iterations": (int, 1, False),
    "tolerance_percent": (float, 0.0, True),
    "elements_per_beam": (int, 1, False),
    "n_modes": (int, 1, False),
    "accept_max_percent": (float, 0.0, True),
    "accept_mean_percent": (float, 0.0, True),
    "shape_penalty": (float, 0.0, False),
    "global_start": (bool, None, False),
    "seed": (int, 0, False),
    "population": (int, 1, False),
    "generations": (int, 1, False),
}


_KIND_NAMES = {float: "a number", int: "an integer"}


@dataclass(frozen=True)
class Constraint:
    """A statement that the springs of ``hinges`` barely move the natural frequencies.

    Scaling all of them by ``factor`` (or 1/factor) may change no tested frequency by more than
    ``max_change_percent``, linearised: ``share_m ln(factor) / 2 <= ln(1 + max/100)`` with
    share_m the mode's strain-energy share in those springs. The violation enters J with
    ``weight`` (1: as much as the same ln-frequency error).
    """

    hinges: tuple[str, ...]
    factor: float
    max_change_percent: float
    weight: float = 1.0
    source: str = ""
    modes: tuple[int, ...] = ()  # Table 3 modes it applies to (empty: every tested mode)

    @property
    def limit(self) -> float:
        """Largest allowed strain-energy share [-]."""
        return 2.0 * math.log1p(self.max_change_percent / 100.0) / math.log(self.factor)

    def violation(self, shares: np.ndarray) -> np.ndarray:
        """ln-frequency change beyond the allowed one, per mode (>= 0)."""
        return np.maximum(0.0, 0.5 * math.log(self.factor) * (shares - self.limit))


@dataclass(frozen=True)
class Targets:
    """Table 3 modes to match: numbers (model mode N is paired with Table 3 mode N) and [Hz]."""

    modes: tuple[int, ...]
    frequencies_hz: np.ndarray
    column: str = "modal_test_hz"
    source: str = ""


@dataclass(frozen=True)
class Calibration:
    """A validated calibration file: inputs, parameters, targets and settings."""

    source: str
    prior: Path
    reference: Path
    output: Path
    output_name: str
    parameters: tuple[Parameter, ...]
    targets: Targets
    settings: Settings
    constraint: Constraint | None = None
    response: object = None  # ResponseSettings of [response] (ufmt.calibration.response_fit)


def load_calibration(
    path: str | Path, prior: str | Path | None = None, output: str | Path | None = None
) -> tuple[Calibration, Model, Reference]:
    """Read and check a calibration file, its prior model and its reference table.

    ``prior`` and ``output`` override the file's entries; the file's own paths are relative to
    its directory. Raises :class:`~ufmt.errors.StudyError` (or ModelError for the prior) with
    one line naming the file, the table and the field.
    """
    where = str(path)
    data = read_toml(path)
    _check_keys(where, data, TOP_KEYS)
    base = Path(path).parent
    for key in ("prior", "reference", "output"):
        if not isinstance(data.get(key), str):
            _fail(where, f"field {key!r}: {data.get(key)!r} must be a file path (string)")
    prior_path = Path(prior) if prior is not None else base / data["prior"]
    out_path = Path(output) if output is not None else base / data["output"]
    reference_path = base / data["reference"]
    model = load_model(prior_path)
    reference = read_reference(reference_path)
    settings = _settings(where, data.get("settings", {}))
    parameters = _parameters(where, data.get("parameter", []), model)
    targets = _targets(where, data.get("targets"), reference, settings, reference_path)
    name = data.get("output_name", "UFMT")
    if not isinstance(name, str) or not name:
        _fail(where, f"field 'output_name': {name!r} must be a non-empty string")
    constraint = _constraint(where, data.get("constraint"), model)
    response = None
    if data.get("response") is not None:  # checked now, not after the identification
        from ufmt.calibration.response_fit import read_response_settings

        response = read_response_settings(data["response"], read_toml(reference_path), where)
    calibration = Calibration(
        where,
        prior_path,
        reference_path,
        out_path,
        name,
        parameters,
        targets,
        settings,
        constraint,
        response,
    )
    return calibration, model, reference


def _settings(where: str, table) -> Settings:
    if not isinstance(table, dict):
        _fail(where, "[settings] must be a table")
    _check_keys(f"{where}: [settings]", table, _SETTING_RULES)
    values = {}
    for key, value in table.items():
        kind, low, strict = _SETTING_RULES[key]
        ok = (
            isinstance(value, bool)
            if kind is bool
            else (isinstance(value, int | float) and not isinstance(value, bool))
        )
        if ok and kind is int:
            ok = isinstance(value, int)
        if ok and low is not None:
            ok = math.isfinite(value) and (value > low if strict else value >= low)
        if not ok:
            need = (
                "true or false"
                if kind is bool
                else f"{_KIND_NAMES[kind]} {'>' if strict else '>='} {low:g}"
            )
            _fail(f"{where}: [settings]", f"field {key!r}: {value!r} must be {need}")
        values[key] = kind(value)
    return Settings(**values)


def _parameters(where: str, tables, model: Model) -> tuple[Parameter, ...]:
    if not isinstance(tables, list) or not tables:
        _fail(where, "[[parameter]]: none given; list at least one parameter to identify")
    hinge_names = [h.name for h in model.hinges]
    seen_names, seen_entries = set(), {}
    out = []
    for i, t in enumerate(tables):
        label = f"{where}: parameter[{i}]"
        if not isinstance(t, dict):
            _fail(label, "must be a table")
        name = t.get("name")
        if not isinstance(name, str) or not name:
            _fail(label, f"field 'name': {name!r} must be a non-empty string")
        label = f"{where}: parameter {name!r}"
        _check_keys(label, t, PARAMETER_KEYS)
        if name in seen_names:
            _fail(label, "field 'name': used by another parameter")
        seen_names.add(name)
        hinges = t.get("hinges")
        if not isinstance(hinges, list) or not hinges:
            _fail(label, f"field 'hinges': {hinges!r} must list hinge names")
        for h in hinges:
            if h not in hinge_names:
                _fail(
                    label,
                    f"field 'hinges': {h!r} is not a hinge of {model.source}"
                    f"{_suggest(h, hinge_names)}; hinges: {', '.join(hinge_names)}",
                )
        fld = t.get("field")
        if fld not in FIELDS:
            _fail(label, f"field 'field': {fld!r} is not one of {', '.join(FIELDS)}")
        comps = t.get("components")
        if (
            not isinstance(comps, list)
            or not comps
            or not all(
                isinstance(c, int) and not isinstance(c, bool) and 0 <= c <= 2 for c in comps
            )
            or len(set(comps)) != len(comps)
        ):
            _fail(label, f"field 'components': {comps!r} must list distinct 0, 1, 2 (x, y, z)")
        band = read_band(
            label, t.get("band"), lambda lo, hi: 0 < lo <= 1 <= hi, "0 < lower <= 1 <= upper"
        )
        for h in hinges:
            values = getattr(model.hinge(h), fld)
            for c in comps:
                if not (0 < values[c] < math.inf):
                    _fail(
                        label,
                        f"field 'components': {h} {fld}[{c}] is {values[c]!r} in {model.source}; "
                        "only finite, nonzero stiffness can be scaled",
                    )
                if (h, fld, c) in seen_entries:
                    _fail(
                        label,
                        f"field 'hinges': {h} {fld}[{c}] is also scaled by parameter "
                        f"{seen_entries[(h, fld, c)]!r}",
                    )
                seen_entries[(h, fld, c)] = name
        reason = t.get("reason", "")
        out.append(Parameter(name, tuple(hinges), fld, tuple(comps), band, reason))
    return tuple(out)


def _constraint(where: str, table, model: Model) -> Constraint | None:
    if table is None:
        return None
    label = f"{where}: [constraint]"
    if not isinstance(table, dict):
        _fail(where, "[constraint] must be a table")
    _check_keys(label, table, CONSTRAINT_KEYS)
    names = [h.name for h in model.hinges]
    hinges = table.get("hinges")
    if not isinstance(hinges, list) or not hinges or any(h not in names for h in hinges):
        _fail(label, f"field 'hinges': {hinges!r} must list hinges of {model.source}")
    values = {}
    for key, low in (("factor", 1.0), ("max_change_percent", 0.0), ("weight", 0.0)):
        v = table.get(key, 1.0 if key == "weight" else None)
        if (
            isinstance(v, bool)
            or not isinstance(v, int | float)
            or not math.isfinite(v)
            or v <= low
        ):
            _fail(label, f"field {key!r}: {v!r} must be a number > {low:g}")
        values[key] = float(v)
    modes = table.get("modes", [])
    if not isinstance(modes, list) or not all(isinstance(k, int) for k in modes):
        _fail(label, f"field 'modes': {modes!r} must list Table 3 mode numbers")
    return Constraint(
        tuple(hinges), source=str(table.get("source", "")), modes=tuple(modes), **values
    )


def _targets(where: str, table, reference: Reference, settings: Settings, ref_path) -> Targets:
    label = f"{where}: [targets]"
    if not isinstance(table, dict):
        _fail(where, "[targets]: missing; give the Table 3 modes to match")
    _check_keys(label, table, TARGET_KEYS)
    column = table.get("column", "modal_test_hz")
    if column not in COLUMNS:
        _fail(label, f"field 'column': {column!r} is not one of {', '.join(COLUMNS)}")
    modes = table.get("modes")
    if not isinstance(modes, list) or not modes:
        _fail(label, f"field 'modes': {modes!r} is empty; list at least one Table 3 mode number")
    values = reference.column(column)
    for k in modes:
        if not isinstance(k, int) or isinstance(k, bool) or k not in values:
            _fail(
                label,
                f"field 'modes': {k!r} has no {column!r} in {ref_path}; modes with one: "
                f"{', '.join(map(str, values))}",
            )
        if k > settings.n_modes:
            _fail(label, f"field 'modes': {k} exceeds [settings] n_modes = {settings.n_modes}")
    if len(set(modes)) != len(modes):
        _fail(label, f"field 'modes': {modes!r} lists a mode twice")
    modes = sorted(modes)
    hz = np.array([values[k] for k in modes])
    return Targets(tuple(modes), hz, column, str(table.get("source", "")))


# ---------------------------------------------------------------------------------------------
# parameters applied to a model


def apply_parameters(model: Model, parameters, u) -> Model:
    """A copy of ``model`` with each parameter's components scaled by ``exp(u_p)``."""
    for p, up in zip(parameters, np.asarray(u, dtype=float), strict=True):
        for h in p.hinges:
            values = np.array(getattr(model.hinge(h), p.field), dtype=float)
            values[list(p.components)] *= math.exp(up)
            model = model.with_hinge(h, **{p.field: values})
    return model


def _spring_labels(model: Model) -> list[tuple[str, int]]:
    """(hinge name, component) of each finite spring direction, in
    :func:`ufmt.assembled.assemble`'s order (hinge by hinge, x, y, z, rx, ry, rz; 0 < k < inf)."""
    return [
        (h.name, j) for h in model.hinges for j, k in enumerate(h.stiffness6) if 0.0 < k < math.inf
    ]


def _spring_owners(labels, parameters) -> np.ndarray:
    """Index of the parameter that scales each spring direction (-1: none)."""
    owner = {}
    for i, p in enumerate(parameters):
        offset = 0 if p.field == "stiffness" else 3
        for h in p.hinges:
            for c in p.components:
                owner[(h, offset + c)] = i
    return np.array([owner.get(label, -1) for label in labels], dtype=int)


@dataclass(frozen=True, eq=False)
class ReducedModel:
    """Assembled model of ``model`` whose stiffness is affine in the parameters' factors.

    The assembled stiffness is ``K = F^T F`` with one row of F per spring direction,
    ``sqrt(k) d_j`` (:class:`~ufmt.assembled.AssembledModel`), so a factor s_p on parameter p's
    springs scales their rows by ``sqrt(s_p)``: ``F(s) = W(s) F_prior`` with W diagonal, and
    ``K(s) = K_fixed + sum_p s_p K_p`` exactly. Each evaluation repeats the assembled model's
    well-conditioned solution (:func:`ufmt.assembled._solve`) with the prior's constraint basis
    and mass factor fixed: static condensation of the massless directions by a QR of their
    rows of F, then the singular values of ``F_red S L^-T`` (S: Jacobi scaling of the mass,
    ``S M_a S = L L^T``), which are the angular frequencies. Working on the square root keeps
    the relative accuracy of the lowest roots near machine precision although cond(K) ~ 1e11:
    the eigenvalues of K itself carry an absolute error eps * ||K||, i.e. ~1e-5 of ln f for the
    lowest modes, which made finite differences of ln f noisy.
    """

    model: Model
    parameters: tuple[Parameter, ...]
    assembled: AssembledModel  # the prior's assembly: dof layout, M, F
    owner: np.ndarray  # (rows of F,) index of the parameter scaling each row, -1: none
    row_hinges: np.ndarray  # (rows of F,) hinge name of each row, "" for beam elements
    f_a: np.ndarray  # F_prior T_a S L^-T: motions with mass, mass-normalised coordinates
    f_b: np.ndarray  # F_prior T_b: massless motions
    t_a: np.ndarray  # T_a S L^-T: mass-normalised coordinates -> all dofs
    t_b: np.ndarray
    zero_modes: int

    @classmethod
    def build(cls, model: Model, parameters, elements_per_beam: int = 8) -> ReducedModel:
        """Assemble the prior once and note which rows of F each parameter scales."""
        parameters = tuple(parameters)
        am = assemble(model, elements_per_beam=elements_per_beam)
        labels = _spring_labels(model)
        beams = am.deformation.shape[0] - len(labels)
        owner = np.concatenate([np.full(beams, -1), _spring_owners(labels, parameters)])
        row_hinges = np.array([""] * beams + [h for h, _ in labels])
        shared = structure(am)  # bases, mass scaling and factor, zero-mode count
        t_a, t_b, scale, chol = shared.t_a, shared.t_b, shared.scale, shared.chol
        normalise = scale[:, None] * sla.solve_triangular(chol.T, np.eye(len(scale)), lower=False)
        return cls(
            model=model,
            parameters=parameters,
            assembled=am,
            owner=owner,
            row_hinges=row_hinges,
            f_a=am.deformation @ t_a @ normalise,
            f_b=am.deformation @ t_b,
            t_a=t_a @ normalise,
            t_b=t_b,
            zero_modes=shared.zero_modes,
        )

    def row_weights(self, u) -> np.ndarray:
        """sqrt(s) of each row of F: 1 for rows no parameter scales."""
        root = np.exp(0.5 * np.asarray(u, dtype=float))
        return np.where(self.owner >= 0, root[self.owner], 1.0)

    def solve(self, u, n_modes: int) -> tuple[np.ndarray, np.ndarray]:
        """Lowest ``n_modes`` nonzero frequencies [Hz] and mass-normalised shapes (n, dofs)."""
        w = self.row_weights(u)[:, None]
        f_a, f_b = w * self.f_a, w * self.f_b
        if f_b.shape[1]:
            scale_b = np.linalg.norm(f_b, axis=0)
            q_b, r_b = np.linalg.qr(f_b / scale_b)
            f_red = f_a - q_b @ (q_b.T @ f_a)
        else:
            f_red = f_a
        sigma, vh = svd(f_red)
        n_total = f_red.shape[1] - self.zero_modes
        keep = np.arange(n_total - 1, n_total - 1 - n_modes, -1)  # ascending from the lowest
        coords = vh[keep].T
        shapes = self.t_a @ coords
        if f_b.shape[1]:
            shapes -= self.t_b @ (
                sla.solve_triangular(r_b, q_b.T @ (f_a @ coords)) / scale_b[:, None]
            )
        return sigma[keep] / (2.0 * math.pi), shapes.T

    def sensitivities(self, u, frequencies_hz, shapes) -> np.ndarray:
        """d ln f_m / d u_p (n, P) = s_p phi_m^T K_p phi_m / (2 omega_m^2).

        ``phi^T s_p K_p phi`` is the strain energy (times 2) in parameter p's rows of F(s).
        """
        strain = (self.row_weights(u)[:, None] * (self.assembled.deformation @ shapes.T)) ** 2
        energy = np.zeros((len(self.parameters), strain.shape[1]))
        mine = self.owner >= 0
        np.add.at(energy, self.owner[mine], strain[mine])
        omega2 = (2.0 * math.pi * np.asarray(frequencies_hz)) ** 2
        return energy.T / (2.0 * omega2[:, None])

    def energy_shares(self, u, frequencies_hz, shapes, hinges) -> np.ndarray:
        """Share of each mode's strain energy in the springs of ``hinges`` [-] (n,).

        Scaling all of those springs by a factor c changes ln f_m by about
        ``share_m ln(c) / 2`` (the sum of their parameters' sensitivities).
        """
        rows = np.isin(self.row_hinges, list(hinges))
        strain = (
            self.row_weights(u)[rows, None] * (self.assembled.deformation[rows] @ shapes.T)
        ) ** 2
        return strain.sum(axis=0) / (2.0 * math.pi * np.asarray(frequencies_hz)) ** 2

    def modeset(self, frequencies_hz, shapes) -> ModeSet:
        """The modes as a :class:`~ufmt.calibration.frequencies.ModeSet` (pairing, tag checks)."""
        return modeset_from_dofs(self.model, self.assembled, frequencies_hz, shapes)


# ---------------------------------------------------------------------------------------------
# the objective


@dataclass(frozen=True, eq=False)
class Evaluation:
    """The model at one point u: frequencies, pairing, residuals, mismatches and J."""

    u: np.ndarray
    frequencies_hz: np.ndarray
    shapes: np.ndarray
    modes: ModeSet
    paired: np.ndarray  # model mode index per target (-1: none)
    residual: np.ndarray  # ln f_model - ln f_target per target
    mismatches: dict[int, str]  # target mode -> reason
    shares: np.ndarray  # strain-energy share of the constrained hinges per target (0: none)
    constraint: np.ndarray  # its violation per target [ln f] (>= 0)
    cost: float

    @property
    def errors_percent(self) -> np.ndarray:
        """Frequency error of each paired target [%]."""
        return 100.0 * np.expm1(self.residual)


@dataclass(frozen=True, eq=False)
class Problem:
    """Targets, reference tags and the cheap model: evaluates J (module docstring)."""

    reduced: ReducedModel
    targets: Targets
    reference: Reference | None
    settings: Settings
    constraint: Constraint | None = None
    lower: np.ndarray = field(init=False)
    upper: np.ndarray = field(init=False)

    def __post_init__(self):
        bands = np.log(np.array([p.band for p in self.reduced.parameters]))
        object.__setattr__(self, "lower", bands[:, 0])
        object.__setattr__(self, "upper", bands[:, 1])

    def evaluate(self, u) -> Evaluation:
        u = np.asarray(u, dtype=float)
        f, shapes = self.reduced.solve(u, self.settings.n_modes)
        modes = self.reduced.modeset(f, shapes)
        numbers = self.targets.modes
        if self.reference is None:
            paired = np.array([k - 1 for k in numbers])
        else:
            paired = pair_by_class(self.reference, numbers, modes)
        ok = paired >= 0
        residual = np.full(len(numbers), UNPAIRED_RESIDUAL)
        residual[ok] = np.log(f[paired[ok]] / self.targets.frequencies_hz[ok])
        mismatches = self._mismatches(modes, paired)
        shares = self.shares(u, f, shapes, paired)
        violation = self.constraint.violation(shares) if self.constraint else np.zeros(0)
        weight = self.constraint.weight if self.constraint else 0.0
        cost = (
            float(residual @ residual)
            + self.settings.regularisation**2 * float(u @ u)
            + self.settings.shape_penalty * len(mismatches)
            + weight**2 * float(violation @ violation)
        )
        return Evaluation(
            u, f, shapes, modes, paired, residual, mismatches, shares, violation, cost
        )

    def shares(self, u, frequencies_hz, shapes, paired) -> np.ndarray:
        """Strain-energy share of the constrained hinges in each paired target mode."""
        if self.constraint is None:
            return np.zeros(0)
        ok = paired >= 0
        if self.constraint.modes:
            ok &= np.isin(self.targets.modes, self.constraint.modes)
        out = np.zeros(len(paired))
        out[ok] = self.reduced.energy_shares(
            u, frequencies_hz[paired[ok]], shapes[paired[ok]], self.constraint.hinges
        )
        return out

    def constraint_jacobian(self, e: Evaluation, step: float = 1e-5) -> np.ndarray:
        """d share / d u (targets, P) by forward differences (same pairing as ``e``)."""
        cols = []
        for p in range(e.u.size):
            u = e.u.copy()
            u[p] += step
            f, shapes = self.reduced.solve(u, self.settings.n_modes)
            cols.append((self.shares(u, f, shapes, e.paired) - e.shares) / step)
        return np.array(cols).T

    def _mismatches(self, modes: ModeSet, paired: np.ndarray) -> dict[int, str]:
        out = {}
        for k, j in zip(self.targets.modes, paired, strict=True):
            if j < 0:
                out[k] = "no model mode of its class"
            elif j != k - 1:
                out[k] = f"paired with model mode {j + 1}, not by order"
            elif self.reference is not None and self.reference.modes[k].tag is not None:
                status, detail = check_tag(modes, j, self.reference.modes[k].tag)
                if status in ("class", "bodies"):
                    out[k] = f"{status}: {detail}"
        if self.reference is not None and self.reference.tool_tip_z_modes:
            tip = [k for k in self.reference.tool_tip_z_modes if k <= modes.frequencies_hz.size]
            for k, above in tool_tip_neighbours(modes, tip).items():
                if not above and k not in out:
                    out[k] = "tool tip moves less in z than in a neighbouring mode"
        return out

    def cost(self, u) -> float:
        """J(u) (for the global search)."""
        return self.evaluate(u).cost


# ---------------------------------------------------------------------------------------------
# local iteration and global start


class _StepProblem:
    """The cvxpy bounded, regularised least-squares step (built once, re-solved per step).

    With a constraint, its linearised violation ``w pos(a + G d)`` (a: share - limit times
    ln(factor)/2, G its gradient) joins the squared residuals.
    """

    def __init__(self, n_targets: int, n_params: int, rho: float, constraint=None):
        self.d = cp.Variable(n_params)
        self.sens = cp.Parameter((n_targets, n_params))
        self.res = cp.Parameter(n_targets)
        self.u = cp.Parameter(n_params)
        self.low = cp.Parameter(n_params)
        self.high = cp.Parameter(n_params)
        self.trust = cp.Parameter(nonneg=True)
        objective = cp.sum_squares(self.res + self.sens @ self.d) + rho**2 * cp.sum_squares(
            self.u + self.d
        )
        self.constraint = constraint
        if constraint is not None:
            self.excess = cp.Parameter(n_targets)
            self.gradient = cp.Parameter((n_targets, n_params))
            objective += constraint.weight**2 * cp.sum_squares(
                cp.pos(self.excess + self.gradient @ self.d)
            )
        constraints = [
            cp.abs(self.d) <= self.trust,
            self.u + self.d >= self.low,
            self.u + self.d <= self.high,
        ]
        self.problem = cp.Problem(cp.Minimize(objective), constraints)

    def step(self, sens, res, u, low, high, trust, shares=None, gradient=None) -> np.ndarray:
        self.sens.value, self.res.value, self.u.value = sens, res, u
        self.low.value, self.high.value, self.trust.value = low, high, trust
        if self.constraint is not None:
            half = 0.5 * math.log(self.constraint.factor)
            self.excess.value = half * (shares - self.constraint.limit)
            self.gradient.value = half * gradient
        self.problem.solve(solver=cp.CLARABEL)
        if self.d.value is None:
            raise RuntimeError(f"least-squares step failed: {self.problem.status}")
        return np.clip(u + self.d.value, low, high) - u


def local_iteration(problem: Problem, u0, stage: str, log: _Log) -> Evaluation:
    """Trust-region iteration of bounded least-squares steps from u0 (module docstring)."""
    s = problem.settings
    current = problem.evaluate(u0)
    stepper = _StepProblem(
        len(problem.targets.modes), len(u0), s.regularisation, problem.constraint
    )
    trust = s.trust_region
    log.add(stage, 0, current, 0.0, trust)
    for it in range(1, s.max_iterations + 1):
        ok = current.paired >= 0
        sens = np.zeros((len(ok), len(u0)))
        sens[ok] = problem.reduced.sensitivities(current.u, current.frequencies_hz, current.shapes)[
            current.paired[ok]
        ]
        gradient = problem.constraint_jacobian(current) if problem.constraint else None
        while True:
            d = stepper.step(
                sens,
                current.residual,
                current.u,
                problem.lower,
                problem.upper,
                trust,
                current.shares,
                gradient,
            )
            trial = problem.evaluate(current.u + d)
            if trial.cost < current.cost or trust < s.min_trust_region:
                break
            trust /= 2.0
        if trial.cost >= current.cost:
            log.add(stage, it, current, 0.0, trust)
            break
        change = 100.0 * np.max(np.abs(trial.residual - current.residual))
        current = trial
        log.add(stage, it, current, change, trust)
        trust = min(2.0 * trust, s.trust_region) if np.max(np.abs(d)) >= 0.99 * trust else trust
        if change < s.tolerance_percent:
            break
    return current


def global_start(problem: Problem, x0, log: _Log) -> np.ndarray:
    """Differential evolution over ln band for the lowest J; its best point (deterministic)."""
    s = problem.settings
    generation = [0]

    def record(intermediate_result):
        generation[0] += 1
        log.add(
            "global",
            generation[0],
            problem.evaluate(intermediate_result.x),
            math.nan,
            math.nan,
        )

    result = differential_evolution(
        problem.cost,
        list(zip(problem.lower, problem.upper, strict=True)),
        maxiter=s.generations,
        popsize=s.population,
        rng=s.seed,
        x0=np.clip(x0, problem.lower, problem.upper),
        polish=False,
        callback=record,
    )
    return result.x


def _meets(e: Evaluation, s: Settings) -> bool:
    err = np.abs(e.errors_percent)
    return (
        not e.mismatches
        and not np.any(e.constraint > 0.0)
        and err.max() <= s.accept_max_percent
        and err.mean() <= s.accept_mean_percent
    )


class _Log:
    """The iteration log (one row per step) and, optionally, a tqdm bar per stage on stderr
    showing the current max and mean |frequency error|."""

    def __init__(self, settings: Settings, progress: bool):
        self.rows: list = []
        self.settings = settings
        self.progress = progress
        self.bar = None
        self.stage = None

    def add(self, stage: str, it: int, e: Evaluation, change: float, trust: float) -> None:
        err = np.abs(e.errors_percent)
        row = {
            "stage": stage,
            "iteration": it,
            "cost": e.cost,
            "max_abs_error_percent": err.max(),
            "mean_abs_error_percent": err.mean(),
            "max_change_percent": change,
            "trust_region": trust,
            "shape_mismatches": len(e.mismatches),
            "mismatched_modes": " ".join(str(k) for k in sorted(e.mismatches)),
            "constraint_violation": float(np.max(e.constraint, initial=0.0)),
        }
        self.rows.append((row, e.u.copy()))
        if self.progress:
            if stage != self.stage:
                self.close()
                total = (
                    self.settings.generations if stage == "global" else self.settings.max_iterations
                )
                self.bar = tqdm(total=total, desc=stage, unit="step", dynamic_ncols=True)
                self.stage = stage
            self.bar.n = it
            self.bar.set_postfix_str(
                f"max {err.max():.3f} %, mean {err.mean():.3f} %, mismatches {len(e.mismatches)}"
            )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def frame(self, parameters) -> pd.DataFrame:
        """One row per iteration, then the factor s of each parameter."""
        rows = []
        for row, u in self.rows:
            rows.append(
                row | {f"s[{p.name}]": math.exp(v) for p, v in zip(parameters, u, strict=True)}
            )
        return pd.DataFrame(rows)


@dataclass(frozen=True, eq=False)
class Identification:
    """Result: the factors, the final evaluation, the iteration log and the run time."""

    parameters: tuple[Parameter, ...]
    u: np.ndarray
    evaluation: Evaluation
    log: pd.DataFrame
    used_global_start: bool
    seconds: float

    @property
    def scales(self) -> np.ndarray:
        """Identified factors s = exp(u) [-]."""
        return np.exp(self.u)


def identify(
    prior: Model,
    parameters,
    targets: Targets,
    settings: Settings,
    reference: Reference | None = None,
    u0=None,
    constraint: Constraint | None = None,
    progress: bool = False,
) -> Identification:
    """Identify the parameters' factors so the model's modes match ``targets``.

    Runs the local iteration from ``u0`` (default the prior, u = 0); if it stalls and
    ``settings.global_start``, differential evolution and a second local iteration (module
    docstring). ``reference`` supplies the tags and tool-tip modes (None: order pairing only,
    no shape checks); ``constraint`` adds its violation to J; ``progress`` shows a tqdm bar per
    stage on stderr. The factors are rounded to SIGNIFICANT digits (the written model does not
    depend on the last bits of the arithmetic).
    """
    with threadpool_limits(limits=1):  # small dense matrices: one BLAS thread is fastest
        return _identify(
            prior, tuple(parameters), targets, settings, reference, u0, constraint, progress
        )


def rounded(values) -> np.ndarray:
    """``values`` rounded to SIGNIFICANT significant digits."""
    return np.array([float(f"{v:.{SIGNIFICANT}g}") for v in np.atleast_1d(values)])


def _identify(
    prior, parameters, targets, settings, reference, u0, constraint, progress
) -> Identification:
    t0 = time.perf_counter()
    problem = Problem(
        ReducedModel.build(prior, parameters, settings.elements_per_beam),
        targets,
        reference,
        settings,
        constraint,
    )
    log = _Log(settings, progress)
    start = np.zeros(len(parameters)) if u0 is None else np.asarray(u0, dtype=float)
    try:
        best = local_iteration(problem, start, "local", log)
        used = False
        if settings.global_start and not _meets(best, settings):
            used = True
            x = global_start(problem, best.u, log)
            second = local_iteration(problem, x, "local after global start", log)
            if second.cost < best.cost:
                best = second
    finally:
        log.close()
    best = problem.evaluate(np.log(rounded(np.exp(best.u))))
    return Identification(
        parameters, best.u, best, log.frame(parameters), used, time.perf_counter() - t0
    )


# ---------------------------------------------------------------------------------------------
# the command


def _sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def provenance_header(
    calibration: Calibration,
    result: Identification,
    mstmm_errors: np.ndarray,
    response=None,
) -> str:
    """Comment block on top of the generated model file: how it was made and how to remake it."""
    err = np.abs(mstmm_errors)
    lines = [
        "# GENERATED FILE - do not edit by hand.",
        "# Written by `ufmt calibrate` (make calibrate); regenerate with:",
        "#     python -m ufmt.cli calibrate [--prior PATH] [--settings PATH] [--output PATH]",
        f"# Prior: {calibration.prior.name} (sha256 {_sha256(calibration.prior)}); settings: "
        f"{Path(calibration.source).name} (sha256 {_sha256(Path(calibration.source))}).",
        f"# Targets: Table 3 modes {', '.join(map(str, calibration.targets.modes))}, column "
        f"{calibration.targets.column!r} of {calibration.reference.name}.",
        f"# MSTMM result: max |error| {err.max():.3f} %, mean |error| {err.mean():.3f} %; "
        f"global start used: {'yes' if result.used_global_start else 'no'}.",
    ]
    c = calibration.constraint
    if c is not None:
        shares = result.evaluation.shares
        modes = ", ".join(map(str, c.modes or calibration.targets.modes))
        lines.append(
            f"# Constraint: {', '.join(c.hinges)} x{c.factor:g} moves none of modes {modes} by "
            f"more than {c.max_change_percent:g} % (strain-energy share <= {c.limit:.3f}); "
            f"largest share {shares.max():.3f} "
            f"(mode {calibration.targets.modes[int(shares.argmax())]})."
        )
    lines.append("# Identified factors (k = s * k_prior; band in brackets):")
    width = max(len(p.name) for p in result.parameters)
    for p, s in zip(result.parameters, result.scales, strict=True):
        lines.append(f"#   {p.name:<{width}}  s = {s:.6g}  [{p.band[0]:g}, {p.band[1]:g}]")
    if response is not None:
        lines.append(
            f"# Response fit ({response.settings.method} path, reference process; "
            "[machine] values, band in brackets):"
        )
        for p in response.settings.parameters:
            flag = "  AT BOUND" if p.key in response.at_bound else ""
            flag = flag if p.fit else "  held"
            lines.append(
                f"#   {p.key} = {response.values[p.key]:.6g} {p.unit}  "
                f"[{p.band[0]:g}, {p.band[1]:g}]{flag}"
            )
        for key in response.settings.skipped:
            lines.append(f"#   {key}: not a [machine] field of this version, skipped")
        for t, r in zip(response.settings.targets, response.residuals, strict=True):
            paper = "> 0" if t.kind == "positive" else f"{t.paper:.6g}"
            lines.append(
                f"#   {t.metric}: ours {response.metrics[t.metric]:.4g}, paper {paper} {t.unit}, "
                f"residual {r:+.3f}"
            )
    return "\n".join(lines) + "\n"


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """What ``ufmt calibrate`` did: the identification, the model, its MSTMM check, the
    response fit (None without a ``[response]`` table) and the file written."""

    identification: Identification
    model: Model
    validation: Validation
    output: Path
    response: object = None


def calibrate(
    settings_path: str | Path,
    prior: str | Path | None = None,
    output: str | Path | None = None,
    log_path: str | Path | None = None,
    progress: bool = False,
) -> CalibrationRun:
    """Identify the stiffnesses of a calibration file, check them by the MSTMM, fit the
    ``[response]`` parameters, write the model and the log."""
    calibration, model, reference = load_calibration(settings_path, prior, output)
    result = identify(
        model,
        calibration.parameters,
        calibration.targets,
        calibration.settings,
        reference,
        constraint=calibration.constraint,
        progress=progress,
    )
    identified = replace(
        apply_parameters(model, calibration.parameters, result.u), name=calibration.output_name
    )
    check = validate(identified, reference, calibration.settings.n_modes)
    fit = None
    if calibration.response is not None:
        from ufmt.calibration.response import reference_process
        from ufmt.calibration.response_fit import fit_response, with_values
        from ufmt.machining.modal import basis_from_shapes

        fit = fit_response(
            identified,
            calibration.response,
            reference_process(read_toml(calibration.reference)),
            basis_from_shapes(check.solution.shapes),
            progress=progress,
        )
        identified = with_values(identified, fit.values)
    tested = check.table.set_index("mode").loc[list(calibration.targets.modes)]
    errors = 100.0 * (tested["mstmm_hz"].to_numpy() / calibration.targets.frequencies_hz - 1.0)
    tip = check.summary["tool_tip_z_modes_above_neighbours"]
    final = {
        "stage": "mstmm check",
        "iteration": 0,
        "max_abs_error_percent": float(np.abs(errors).max()),
        "mean_abs_error_percent": float(np.abs(errors).mean()),
        "shape_mismatches": int(tested["tag_check"].isin(["class", "bodies"]).sum())
        + sum(not above for above in tip.values()),
        "mismatched_modes": " ".join(
            str(k)
            for k in sorted(
                set(check.summary["tag_mismatches"]) | {k for k, a in tip.items() if not a}
            )
        ),
    }
    final.update(
        {f"s[{p.name}]": s for p, s in zip(calibration.parameters, result.scales, strict=True)}
    )
    log = pd.concat([result.log, pd.DataFrame([final])], ignore_index=True)
    calibration.output.parent.mkdir(parents=True, exist_ok=True)
    calibration.output.write_text(
        provenance_header(calibration, result, errors, fit) + model_to_toml(identified)
    )
    if log_path is not None:
        Path(log_path).parent.mkdir(parents=True, exist_ok=True)
        log.to_csv(log_path, index=False, float_format="%.8g")
    return CalibrationRun(replace(result, log=log), identified, check, calibration.output, fit)
