"""Mode shapes from the MSTMM: null vectors of U_all, states everywhere, body motions, modal
masses and mass-normalised augmented eigenvectors (paper section 2.5, eqs. 3.8-3.11).

For each natural frequency ω_k the boundary unknowns Z_all are the null vector of U_all(ω_k)
(several for a repeated root); transferring them through the elements gives the state at every
end of every element. A rigid body's motion is its centre-of-mass translation and rotation
``[r_C; θ]``; a beam's is its displacement field, sampled at Gauss points for the modal mass.
Repeated roots are made mass-orthogonal; all shapes are normalised to unit modal mass.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ufmt.mstmm.bodies import ShapeParts, beam_field, rules_of
from ufmt.mstmm.newton_step import orthonormal
from ufmt.mstmm.overall import TransferSystem, equilibrate
from ufmt.mstmm.roots import OFF_ROOT, batched_solve


@dataclass(frozen=True, eq=False)
class ModeShapes:
    """Mass-normalised modes of a model.

    frequencies_hz (n,); z_all (n, size) boundary (and segment) unknowns; rigid: body ->
    (n, 6) motion [r_C (m); θ (rad)] per unit modal mass; virtual: body -> (n, 6) motion at
    its point; beams: beam -> (positions (g, 3) [m],
    weights (g,) [m], motion (n, g, 6)). Shapes have unit modal mass, signed so that each
    mode's largest translation is positive; ``modal_mass`` (n,) [kg] is the modal mass of
    each shape scaled to a largest translation of +1 (eq. 3.11). Points
    of rigid bodies: ``ufmt.machining.modal.basis_from_shapes(shapes).point_shapes``; points
    along beams: :func:`beam_shape`.
    """

    frequencies_hz: np.ndarray
    z_all: np.ndarray
    rigid: dict[str, np.ndarray]
    virtual: dict[str, np.ndarray]
    beams: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    modal_mass: np.ndarray
    centers: dict[str, np.ndarray]

    @property
    def omega(self) -> np.ndarray:
        """Natural angular frequencies [rad/s]."""
        return 2 * np.pi * self.frequencies_hz


def null_vectors(u: np.ndarray, u_near: np.ndarray, multiplicity: int) -> np.ndarray:
    """Orthonormal right null vectors (n_roots, size, multiplicity) of U_all at roots.

    Batched inverse iteration on the equilibrated U_all: two solves with the LU of each
    matrix turn any start block into its null space (the error shrinks by σ_min/σ_m+1 per
    solve, ~1e-6 or less at a root found to 1e-12), a QR after each solve keeps the block
    orthonormal, so a repeated root gets an orthonormal basis of its null space. The scaling
    comes from ``u_near``, U_all slightly off the root: equilibrating at the root itself would
    blow up the rows that vanish there and hide the null space.
    """
    r, c = equilibrate(u_near)
    a = u * r * c
    start = np.random.default_rng(0).standard_normal((a.shape[-1], multiplicity))
    x = np.broadcast_to(start, (a.shape[0], *start.shape))
    for _ in range(2):
        x = orthonormal(batched_solve(a, x))
    return c[:, 0, :, None] * x


def shape_state_keys(system: TransferSystem) -> tuple:
    """The state maps (:meth:`TransferSystem.states` keys) :func:`mode_shapes` reads, one per
    body (its :attr:`~ufmt.mstmm.bodies.BodyRules.state_key`: a rigid body's first input, a
    beam's input end, a virtual body's output)."""
    topo = system.topology
    return tuple(rules_of(body).state_key(topo, body) for body in system.model.bodies)


def mode_shapes(system: TransferSystem, frequencies_hz, null_space=None, states=None) -> ModeShapes:
    """Mass-normalised mode shapes at the given natural frequencies [Hz] (ascending).

    ``null_space`` (n, size): null vectors of U_all already known per root (from the Newton
    iteration, :attr:`ufmt.mstmm.roots.Roots.null_vectors`); rows of NaN, or None, are
    computed here by :func:`null_vectors`. ``states``: the state maps of
    :func:`shape_state_keys` at the roots if already known (:attr:`Roots.states`), else one
    walk makes them.
    """
    f = np.asarray(frequencies_hz, dtype=float)
    model = system.model
    omega = 2 * np.pi * f
    if states is None:
        states = system.states(omega)
    z = np.full((f.size, system.size), np.nan) if null_space is None else np.array(null_space)
    # groups of repeated roots share a null space; one batched solve per multiplicity
    first = np.flatnonzero(np.r_[True, np.abs(np.diff(f)) > 1e-9 * f[1:]])
    size = np.diff(np.r_[first, f.size])
    unknown = np.isnan(z[first]).any(axis=1)
    for m in np.unique(size[unknown]):
        starts = first[unknown & (size == m)]
        u_near = system.evaluate(omega[starts] * OFF_ROOT)
        vecs = null_vectors(system.evaluate(omega[starts]), u_near, int(m))
        for k in range(m):
            z[starts + k] = np.real(vecs[:, :, k])
    parts = ShapeParts()
    for body in model.bodies:
        rules_of(body).shape(system, body, states, z, omega, parts)
    ones = np.ones(f.size)
    shapes = ModeShapes(f, z, parts.rigid, parts.virtual, parts.beams, ones, parts.centers)
    _orthonormalise_repeated(model, shapes)
    shapes = _scaled(shapes, 1.0 / _signed_peak(shapes))
    mass = modal_mass(model, shapes.rigid, shapes.beams)
    return replace(_scaled(shapes, 1.0 / np.sqrt(mass)), modal_mass=mass)


def _signed_peak(shapes: ModeShapes) -> np.ndarray:
    """Per mode, the largest translation of any body [m], with its sign: dividing by it makes
    the mode's largest translation +1 (the first in body order among those within 1e-6 of the
    largest, so that rounding is unlikely to flip a mode's sign); 1 for a mode without
    translation."""
    n = shapes.frequencies_hz.size
    translations = np.concatenate(
        [v[:, :3] for v in shapes.rigid.values()]
        + [m[:, :, :3].reshape(n, -1) for _, _, m in shapes.beams.values()]
        + [np.zeros((n, 1))],
        axis=1,
    )
    size = np.abs(translations)
    first = np.argmax(size >= (1.0 - 1e-6) * size.max(axis=1, keepdims=True), axis=1)
    peak = translations[np.arange(n), first]
    return np.where(peak == 0.0, 1.0, peak)


def beam_shape(system: TransferSystem, shapes: ModeShapes, beam_name: str, fractions):
    """Motion (n, P, 6) [m, rad] of beam points at ``fractions`` of its length from its start,
    for the modes of ``shapes`` (same normalisation), with their positions (P, 3) [m]."""
    beam = system.model.body(beam_name)
    states = system.states(shapes.omega)
    positions, _, motion = beam_field(system, beam, states, shapes.z_all, shapes.omega, fractions)
    return positions, motion


def kinetic_terms(model, rigid_a, beams_a, rigid_b=None, beams_b=None) -> np.ndarray:
    """Mass products ⟨V_a, M V_b⟩ split per body and direction: (n, bodies, 6) [kg].

    Rigid bodies (eq. 3.1): m r_a·r_b per axis and θ_a,i (J θ_b)_i per axis; beams:
    ∫ρA u_a·u_b ds per axis and ∫ρJp τ_a τ_b ds (τ the twist about the beam axis) split over
    the global axes by the squared axis components. Summed over bodies and directions this is
    the modal mass (b = a) or the mass inner product of two modes; with b = a, per body and
    direction, the kinetic-energy distribution of a mode.
    """
    rigid_b = rigid_a if rigid_b is None else rigid_b
    beams_b = beams_a if beams_b is None else beams_b
    n = next(iter(rigid_a.values() or [m for _, _, m in beams_a.values()])).shape[0]
    out = np.zeros((n, len(model.bodies), 6))
    for k, body in enumerate(model.bodies):
        rules_of(body).kinetic(body, rigid_a, beams_a, rigid_b, beams_b, out[:, k])
    return out


def modal_mass(model, rigid, beams) -> np.ndarray:
    """⟨V, M V⟩ per mode [kg] (eq. 3.11), from :func:`kinetic_terms`."""
    return kinetic_terms(model, rigid, beams).sum(axis=(1, 2))


def _mass_inner(model, shapes: ModeShapes, i: int, j: int) -> float:
    """⟨V_i, M V_j⟩ of two modes of ``shapes`` [kg]."""

    def one(m):
        rigid = {k: v[[m]] for k, v in shapes.rigid.items()}
        beams = {k: (p, w, v[[m]]) for k, (p, w, v) in shapes.beams.items()}
        return rigid, beams

    return float(kinetic_terms(model, *one(i), *one(j)).sum())


def _orthonormalise_repeated(model, shapes: ModeShapes) -> ModeShapes:
    """Gram-Schmidt in the mass inner product within each group of repeated roots."""
    f = shapes.frequencies_hz
    close = np.abs(f[:, None] - f[None, :]) <= 1e-9 * f[:, None]
    for i, j in zip(*np.nonzero(np.tril(close, -1)), strict=True):  # i, then j ascending
        c = _mass_inner(model, shapes, i, j) / _mass_inner(model, shapes, j, j)
        _combine(shapes, i, j, -c)
    return shapes


def _combine(shapes: ModeShapes, i: int, j: int, c: float) -> None:
    """Mode i += c * mode j in place (all stored fields)."""
    shapes.z_all[i] += c * shapes.z_all[j]
    for d in (shapes.rigid, shapes.virtual):
        for v in d.values():
            v[i] += c * v[j]
    for _, _, mot in shapes.beams.values():
        mot[i] += c * mot[j]


def _scaled(shapes: ModeShapes, scale: np.ndarray) -> ModeShapes:
    """Every field multiplied by ``scale`` per mode (unit modal mass)."""
    s2 = scale[:, None]
    return ModeShapes(
        shapes.frequencies_hz,
        shapes.z_all * s2,
        {k: v * s2 for k, v in shapes.rigid.items()},
        {k: v * s2 for k, v in shapes.virtual.items()},
        {k: (p, w, m * scale[:, None, None]) for k, (p, w, m) in shapes.beams.items()},
        shapes.modal_mass,
        shapes.centers,
    )
