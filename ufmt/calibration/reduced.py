"""The model as a function of the identified factors: written into a model, or reduced.

:func:`apply_parameters` writes factors into a copy of a model (``k = s k_prior`` on each
parameter's springs); :class:`ReducedModel` is the cheap model the identification
(:mod:`ufmt.calibration.identify`) evaluates at every step. Hinge stiffness enters the
assembled model linearly, so its stiffness matrix is ``K(s) = K_fixed + sum_p s_p K_p``
exactly, and its square root ``F`` (``K = F^T F``) has one row per spring scaled by
``sqrt(s_p)``: the prior is assembled once, and each evaluation is one QR (static condensation
of the massless directions) and one SVD of a dense (springs x dofs) matrix, like
:func:`ufmt.assembled.assembled_modes` (a few ms for the UFMT; it agrees with the assembled
model to ~1e-13). With mass-normalised shapes phi the sensitivity is exact (Rayleigh quotient
stationarity; distinct roots): ``d ln f_m / d u_p = s_p phi_m^T K_p phi_m / (2 omega_m^2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ufmt.assembled import AssembledModel, assemble, structure, svd
from ufmt.calibration.frequencies import ModeSet, modeset_from_dofs
from ufmt.calibration.settings import Parameter
from ufmt.model.schema import Model


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
        parts = structure(am)  # bases, mass scaling and factor, zero-mode count
        t_a, t_b, scale, chol = parts.t_a, parts.t_b, parts.scale, parts.chol
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
            zero_modes=parts.zero_modes,
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
