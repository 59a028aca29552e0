"""A model's modes against the paper's Table 3: pairing, shape tags, tool-tip z, validation table.

Reference numbers come from ``ufmt/data/paper_reference.toml`` (never from code). Each Table 3
mode there carries a machine-readable ``tag`` (named bodies, motion, relative phase) read from
its "Modal shape" text; :func:`check_tag` compares a computed shape with it.

Symmetry classes. The UFMT is symmetric under x -> -x and (all parts on y = 0) y -> -y, so
every mode lies in one of four classes, named by the motions they contain: ``x/ry`` (odd in x,
even in y), ``y/rx``, ``z`` and ``rz``. A tag's motion fixes its class (rocking about y moves a
body's centre along x, so "rx" and "y" are one class). A computed mode's class is the one that
holds most of its kinetic energy (all of it for a symmetric model); the purity is that share.

Tag check of one mode (status, best first):

* ``ok``: the class is the tag's; each named body moves (its displacement amplitude, kinetic
  energy over mass, is at least PRESENCE of the largest body's); the phase, where the tag has
  one and both bodies' tagged components are significant (PHASE_SIGNIFICANT of the body's
  amplitude), is the tag's.
* ``phase``: as ``ok`` but the relative sense of the two bodies differs from the tag's.
* ``bodies``: right class, but a named body hardly moves.
* ``class``: the mode is in another symmetry class.

Tool-tip z. The tool tip is the point of ``machine.tool_body`` at radius ``tool_radius`` from
the spindle axis in the cutting plane, taken at spindle angle phi = 0 (:func:`ufmt.machining.
cutting.tool_tip`): the tip pointing along +y, the middle of the leading half of the tool circle,
where it cuts. Its z translation in a unit-modal-mass shape is ``phi_k`` [m/sqrt(kg)]; ``phi_k^2``
is the mode's residue in the tool tip's z driving-point receptance
(``H_zz = sum_k phi_k^2 / (w_k^2 - w^2)``), so the participation of mode k is
``phi_k^2 / sum_j phi_j^2`` over the modes of the table. By the machine's symmetry the tip at
phi = 0 has no z motion in the x/ry and rz classes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ufmt.assembled import AssembledModel, assembled_modes
from ufmt.defaults import PAPER_MODES
from ufmt.errors import StudyError
from ufmt.kinds import kind_of
from ufmt.machining.cutting import tool_tip
from ufmt.model.machine import machine_of
from ufmt.model.schema import Model
from ufmt.mstmm.solve import DIRECTIONS, ModalSolution, describe, energy_shares, solve_modes
from ufmt.tables import Where
from ufmt.tomlfile import read_toml

CLASSES = ("x/ry", "y/rx", "z", "rz")
CLASS_OF_MOTION = {"x": 0, "ry": 0, "y": 1, "rx": 1, "z": 2, "rz": 3}
CLASS_DIRECTIONS = ((0, 4), (1, 3), (2,), (5,))  # direction indices (x y z rx ry rz) per class
PHASES = ("same", "opposite")
FREQUENCY_COLUMNS = ("modal_test_hz", "mstmm_hz", "fem_hz")  # Table 3's columns [Hz]
STATUSES = ("ok", "phase", "bodies", "class")
PRESENCE = 0.1  # a named body moves if its amplitude is >= this share of the largest body's
PHASE_SIGNIFICANT = 0.3  # a tagged component decides the phase if >= this share of the body's
TIP_ANGLE = 0.0  # spindle angle of the tool tip [rad]: pointing along +y, mid-cut


# ---------------------------------------------------------------------------------------------
# reference data


@dataclass(frozen=True)
class Tag:
    """Machine-readable Table 3 shape: named bodies, motion (x..rz), phase ("same"/"opposite")."""

    bodies: tuple[str, ...]
    motion: str
    phase: str | None = None

    @property
    def mode_class(self) -> int:
        """Index into CLASSES of the symmetry class the motion belongs to."""
        return CLASS_OF_MOTION[self.motion]


@dataclass(frozen=True)
class ReferenceMode:
    """One row of Table 3 [Hz]; ``modal_test_hz`` is None for modes that were not measured."""

    number: int
    modal_test_hz: float | None
    mstmm_hz: float | None
    fem_hz: float | None
    description: str
    tag: Tag | None


@dataclass(frozen=True)
class Reference:
    """The paper's Table 3 and section 4.1's tool-tip z modes, as read from the data file."""

    modes: dict[int, ReferenceMode]
    tool_tip_z_modes: tuple[int, ...]
    source: str

    def tagged_prefix(self) -> int:
        """Largest K such that every mode 1..K is in the table with a tag (0 if none)."""
        k = 0
        while (k + 1) in self.modes and self.modes[k + 1].tag is not None:
            k += 1
        return k

    def column(self, name: str) -> dict[int, float]:
        """Mode number -> value of a column (``modal_test_hz``, ``mstmm_hz``, ``fem_hz``)."""
        return {n: getattr(m, name) for n, m in self.modes.items() if getattr(m, name) is not None}


def read_reference(path: str | Path) -> Reference:
    """Read ``paper_reference.toml``; errors name the file, the mode and the field
    (:class:`ufmt.tables.Where`)."""
    source = str(path)
    data = read_toml(path)
    top = Where(source, error=StudyError)
    modes: dict[int, ReferenceMode] = {}
    for i, row in enumerate(top.tables("mode", data.get("mode", []))):
        where = top.sub(f"mode[{i}]")
        where.required(row, ("number",))
        number = where.integer("number", row["number"], 1)
        if number in modes:
            where.fail("number", f"{number} appears more than once")
        values = {
            key: None
            if row.get(key) is None
            else where.number(key, row[key], sign="positive", unit="[Hz]")
            for key in FREQUENCY_COLUMNS
        }
        modes[number] = ReferenceMode(
            number, **values, description=str(row.get("description", "")), tag=_tag(where, row)
        )
    tip = data.get("tool_tip_z_modes", {}).get("modes", [])
    return Reference(dict(sorted(modes.items())), tuple(int(n) for n in tip), source)


def _tag(mode: Where, row: dict) -> Tag | None:
    """The ``tag`` of one ``[[mode]]`` table (None without one)."""
    if row.get("tag") is None:
        return None
    raw = mode.mapping("tag", row["tag"], "tag = {bodies, motion, phase}")
    where = mode.sub("tag")
    where.required(raw, ("bodies", "motion"))
    bodies = where.items("bodies", raw["bodies"], "body name", required=True)
    for j, body in enumerate(bodies):
        where.string(f"bodies[{j}]", body)
    motion = where.choice("motion", raw["motion"], DIRECTIONS, "motion")
    phase = raw.get("phase")
    if phase is not None:
        where.choice("phase", phase, PHASES, "phase")
        if len(bodies) != 2:
            where.fail("phase", f"{phase!r} needs two bodies, got {len(bodies)}")
    return Tag(tuple(bodies), motion, phase)


def tag_bodies(reference: Reference) -> set[str]:
    """The body names the reference's shape tags mention (a model must have them all for the
    tag checks)."""
    return {b for m in reference.modes.values() if m.tag is not None for b in m.tag.bodies}


# ---------------------------------------------------------------------------------------------
# modes in a form every solver can fill


@dataclass(frozen=True, eq=False)
class ModeSet:
    """What the comparison needs from an eigen-solution (n modes, B bodies).

    Attributes
    ----------
    frequencies_hz : (n,) [Hz] ascending.
    body_names : (B,) in model order; masses (B,) [kg] (0 for virtual bodies).
    shares : (n, B, 6) kinetic-energy share per body and direction (x y z rx ry rz).
    motion : (n, B, 6) signed ``[r_C; theta]`` of rigid bodies at the centre of mass per unit
        modal mass [m/sqrt(kg), rad/sqrt(kg)] (zeros for beams and virtual bodies).
    tool_tip_z : (n,) z translation of the tool tip (module docstring) [m/sqrt(kg)].
    """

    frequencies_hz: np.ndarray
    body_names: tuple[str, ...]
    masses: np.ndarray
    shares: np.ndarray
    motion: np.ndarray
    tool_tip_z: np.ndarray

    def amplitudes(self) -> np.ndarray:
        """(n, B, 6) displacement-like amplitude sqrt(share / mass) per body and direction."""
        out = np.zeros_like(self.shares)
        moving = self.masses > 0
        out[:, moving] = np.sqrt(self.shares[:, moving] / self.masses[None, moving, None])
        return out

    def classes(self) -> tuple[np.ndarray, np.ndarray]:
        """Symmetry class (index into CLASSES) and its energy share (purity), each (n,)."""
        by_class = np.stack(
            [self.shares[:, :, list(d)].sum(axis=(1, 2)) for d in CLASS_DIRECTIONS], axis=1
        )
        return np.argmax(by_class, axis=1), np.max(by_class, axis=1)


def _masses(model: Model) -> np.ndarray:
    return np.array([b.mass for b in model.bodies])


def _tool_tip_z(model: Model, motion: np.ndarray) -> np.ndarray:
    """Translation (n,) of the tool tip at spindle angle TIP_ANGLE along the spindle axis
    (z of the machine frame, :mod:`ufmt.model.orientation`), from rigid motions (n, B, 6)
    in the file's frame."""
    machine = machine_of(model)
    body = model.body(machine.tool_body)
    if not kind_of(body).ONE_FRAME:
        return np.zeros(motion.shape[0])
    v = motion[:, [b.name for b in model.bodies].index(body.name)]
    frame = machine.frame
    r, turn = v[:, :3] @ frame, v[:, 3:6] @ frame  # in the machine frame
    arm = tool_tip(TIP_ANGLE, machine) - body.center_of_mass @ frame
    return r[:, 2] + turn[:, 0] * arm[1] - turn[:, 1] * arm[0]


def modeset_from_mstmm(model: Model, shapes) -> ModeSet:
    """ModeSet of an MSTMM solution's :class:`~ufmt.mstmm.modes.ModeShapes`."""
    n = shapes.frequencies_hz.size
    motion = np.zeros((n, len(model.bodies), 6))
    for i, body in enumerate(model.bodies):
        if kind_of(body).ONE_FRAME:
            motion[:, i] = shapes.rigid[body.name]
    return ModeSet(
        np.asarray(shapes.frequencies_hz, dtype=float),
        tuple(b.name for b in model.bodies),
        _masses(model),
        energy_shares(model, shapes),
        motion,
        _tool_tip_z(model, motion),
    )


def modeset_from_dofs(
    model: Model, assembled: AssembledModel, frequencies_hz, shapes: np.ndarray
) -> ModeSet:
    """ModeSet of mass-normalised shapes (n, n_dofs) on the dofs of an assembled model.

    The kinetic energy of dof i is ``u_i (M u)_i``, summed per body and direction (a beam's
    consistent mass couples its dofs; negative cross terms are clipped and the rest renormalised).
    """
    n = shapes.shape[0]
    per_dof = shapes * (shapes @ assembled.M)
    shares = np.zeros((n, len(model.bodies), 6))
    motion = np.zeros_like(shares)
    for i, body in enumerate(model.bodies):
        dofs = assembled.body_dofs[body.name]  # (nodes, 6)
        shares[:, i] = per_dof[:, dofs].sum(axis=1)
        if kind_of(body).ONE_FRAME:
            motion[:, i] = shapes[:, dofs[0]]
    shares = np.clip(shares, 0.0, None)
    shares /= shares.sum(axis=(1, 2), keepdims=True)
    return ModeSet(
        np.asarray(frequencies_hz, dtype=float),
        tuple(b.name for b in model.bodies),
        _masses(model),
        shares,
        motion,
        _tool_tip_z(model, motion),
    )


# ---------------------------------------------------------------------------------------------
# pairing and tag checks


def check_tag(modes: ModeSet, index: int, tag: Tag) -> tuple[str, str]:
    """(status, detail) of model mode ``index`` (0-based) against a Table 3 tag (see module)."""
    absent = [b for b in tag.bodies if b not in modes.body_names]
    if absent:
        return "bodies", f"{', '.join(absent)} not in the model"
    cls, _ = modes.classes()
    if cls[index] != tag.mode_class:
        return "class", f"{CLASSES[cls[index]]} mode, tag is {CLASSES[tag.mode_class]}"
    amp = modes.amplitudes()[index]
    size = np.linalg.norm(amp, axis=1)
    idx = [modes.body_names.index(b) for b in tag.bodies]
    still = [b for b, i in zip(tag.bodies, idx, strict=True) if size[i] < PRESENCE * size.max()]
    if still:
        return "bodies", f"{', '.join(still)} hardly move(s)"
    if tag.phase is None:
        return "ok", ""
    c = DIRECTIONS.index(tag.motion)
    comps = [modes.motion[index, i, c] for i in idx]
    if any(abs(amp[i, c]) < PHASE_SIGNIFICANT * size[i] for i in idx):
        return "ok", f"phase undetermined ({tag.motion} small)"
    phase = "same" if comps[0] * comps[1] > 0 else "opposite"
    if phase != tag.phase:
        return "phase", f"{tag.bodies[0]} and {tag.bodies[1]} {tag.motion} in {phase} sense"
    return "ok", ""


def pair_by_class(reference: Reference, numbers, modes: ModeSet) -> np.ndarray:
    """Model mode index (0-based, -1 if none) for each Table 3 mode number.

    Within the run of consecutive tagged modes 1..K of the table, Table 3 mode k is paired with
    the model mode of its symmetry class and of the same rank within that class; beyond K (and
    without tags) by order. For a model whose class sequence matches the table's this is the
    pairing by order, but it stays continuous when modes of different classes swap places
    during an identification.
    """
    prefix = reference.tagged_prefix()
    cls, _ = modes.classes()
    out = np.full(len(numbers), -1)
    for j, k in enumerate(numbers):
        if k > prefix:
            out[j] = k - 1 if k <= cls.size else -1
            continue
        c = reference.modes[k].tag.mode_class
        rank = sum(reference.modes[i].tag.mode_class == c for i in range(1, k + 1))
        members = np.flatnonzero(cls == c)
        out[j] = members[rank - 1] if rank <= members.size else -1
    return out


def tool_tip_neighbours(modes: ModeSet, numbers) -> dict[int, bool]:
    """For each mode number: does its tool-tip z exceed that of its nearest other modes?

    The neighbours of mode k are the nearest modes below and above it that are not in
    ``numbers`` themselves (so adjacent tool-tip modes such as 11 and 12 share neighbours).
    """
    tip = np.abs(modes.tool_tip_z)
    chosen = set(numbers)
    out = {}
    for k in numbers:
        below = next((j for j in range(k - 1, 0, -1) if j not in chosen), None)
        above = next((j for j in range(k + 1, tip.size + 1) if j not in chosen), None)
        others = [tip[j - 1] for j in (below, above) if j is not None]
        out[k] = k <= tip.size and all(tip[k - 1] > t for t in others)
    return out


# ---------------------------------------------------------------------------------------------
# the validation table


def validation_table(
    model: Model, reference: Reference, mstmm: ModeSet, assembled_hz: np.ndarray
) -> pd.DataFrame:
    """One row per mode of ``mstmm`` (model mode N beside Table 3 mode N).

    Columns: mode, test_hz, paper_mstmm_hz, paper_fem_hz, mstmm_hz, assembled_hz,
    mstmm_error_percent (this project's MSTMM against the test), paper_mstmm_error_percent,
    paper_fem_error_percent (recomputed from the printed frequencies), assembled_vs_mstmm
    (relative difference), symmetry_class, class_purity, shape (dominant bodies and directions
    by kinetic energy), table3_shape, tag_check, tag_detail, tool_tip_z (|z| of the tool tip in
    the unit-modal-mass shape [m/sqrt(kg)]), tool_tip_z_participation (share of the tool-tip z
    residues of these modes).
    """
    n = mstmm.frequencies_hz.size
    numbers = np.arange(1, n + 1)
    test = reference.column("modal_test_hz")
    paper = reference.column("mstmm_hz")
    fem = reference.column("fem_hz")
    cls, purity = mstmm.classes()
    rows = []
    tip2 = mstmm.tool_tip_z**2
    shape = describe(model, mstmm.shares, top=3)
    for k in numbers:
        ref = reference.modes.get(int(k))
        status, detail = (
            ("", "") if ref is None or ref.tag is None else check_tag(mstmm, k - 1, ref.tag)
        )
        f = mstmm.frequencies_hz[k - 1]
        f_test = test.get(int(k), np.nan)
        rows.append(
            {
                "mode": int(k),
                "test_hz": f_test,
                "paper_mstmm_hz": paper.get(int(k), np.nan),
                "paper_fem_hz": fem.get(int(k), np.nan),
                "mstmm_hz": f,
                "assembled_hz": assembled_hz[k - 1] if k <= assembled_hz.size else np.nan,
                "mstmm_error_percent": 100.0 * (f / f_test - 1.0),
                "paper_mstmm_error_percent": 100.0 * (paper.get(int(k), np.nan) / f_test - 1.0),
                "paper_fem_error_percent": 100.0 * (fem.get(int(k), np.nan) / f_test - 1.0),
                "assembled_vs_mstmm": (assembled_hz[k - 1] / f - 1.0)
                if k <= assembled_hz.size
                else np.nan,
                "symmetry_class": CLASSES[cls[k - 1]],
                "class_purity": purity[k - 1],
                "shape": shape[k - 1],
                "table3_shape": "" if ref is None else ref.description,
                "tag_check": status,
                "tag_detail": detail,
                "tool_tip_z": abs(mstmm.tool_tip_z[k - 1]),
                "tool_tip_z_participation": tip2[k - 1] / tip2.sum(),
            }
        )
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame, reference: Reference, modes: ModeSet) -> dict:
    """Max and mean |error| [%] over the tested modes, tag statuses and the tool-tip check."""
    tested = table.dropna(subset=["test_hz"])
    err = tested["mstmm_error_percent"].abs()
    tip = tool_tip_neighbours(modes, reference.tool_tip_z_modes)
    below = int(np.sum(table["mstmm_hz"] < 30.0))
    return {
        "tested_modes": [int(k) for k in tested["mode"]],
        "max_abs_error_percent": float(err.max()),
        "mean_abs_error_percent": float(err.mean()),
        "tag_mismatches": {
            int(r.mode): r.tag_check for r in tested.itertuples() if r.tag_check != "ok"
        },
        "tool_tip_z_modes_above_neighbours": tip,
        "modes_below_30_hz": below,
        "mode_6_hz": float(table["mstmm_hz"].iloc[5]) if len(table) >= 6 else math.nan,
    }


# ---------------------------------------------------------------------------------------------
# running it


@dataclass(frozen=True, eq=False)
class Validation:
    """The validation of one model: the table, its summary and the MSTMM solution it used."""

    table: pd.DataFrame
    summary: dict
    modes: ModeSet
    solution: ModalSolution  # with shapes, for the mode plots


def validate(model: Model, reference: Reference, n_modes: int = PAPER_MODES) -> Validation:
    """MSTMM and assembled-model modes of ``model`` against Table 3 (:func:`validation_table`).

    The assembled model uses its automatic mesh (relative error target 1e-8 below the highest
    mode), so its column checks the MSTMM independently.
    """
    solution = solve_modes(model, count=n_modes, method="mstmm", shapes=True)
    modes = modeset_from_mstmm(model, solution.shapes)
    assembled = assembled_modes(model, count=n_modes).frequencies_hz
    table = validation_table(model, reference, modes, np.asarray(assembled))
    return Validation(table, summary(table, reference, modes), modes, solution)
