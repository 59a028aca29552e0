"""The assembled model's eigen-solution: exact condensation of the massless dofs and natural
frequencies as singular values (see the package docstring), with the stiffness-free parts
(:class:`Structure`) built once per structure and shared by the designs of a study."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ufmt.assembled.bodies import body_kind
from ufmt.assembled.constraints import (
    check_no_massless_mechanism,
    constraint_basis,
    split_massless,
    zero_mode_count,
)
from ufmt.assembled.matrices import AssembledModel, assemble
from ufmt.assembled.mesh import DEFAULT_ELEMENTS_PER_BEAM, DEFAULT_RTOL, MAX_ELEMENTS_PER_BEAM
from ufmt.model.schema import Model
from ufmt.recent import Recent


def svd(a: np.ndarray, vectors: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Singular values (descending) and right singular vectors (rows; None without
    ``vectors``) of a."""

    def run(driver):
        if not vectors:
            return sla.svd(a, compute_uv=False, lapack_driver=driver), None
        _, s, vh = sla.svd(a, full_matrices=False, lapack_driver=driver)
        return s, vh

    try:
        return run("gesdd")
    except np.linalg.LinAlgError:
        return run("gesvd")


def _unit_columns(basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row of each column's first nonzero and the columns that are not unit vectors (a single
    1) of a motion basis (whose columns are mostly unit vectors)."""
    nonzero = basis != 0.0
    first = np.argmax(nonzero, axis=0)
    single = np.count_nonzero(nonzero, axis=0) == 1
    return first, np.flatnonzero(~single | (basis[first, np.arange(basis.shape[1])] != 1.0))


def _times_basis(a: np.ndarray, basis: np.ndarray, unit=None) -> np.ndarray:
    """``a @ basis`` [units of a]: unit columns of the basis copy a column of a, only the others
    are multiplied; unit: :func:`_unit_columns` of basis if already known."""
    first, mixed = _unit_columns(basis) if unit is None else unit
    out = a[:, first]
    out[:, mixed] = a @ basis[:, mixed]
    return out


@dataclass(frozen=True, eq=False)
class Structure:
    """The parts of the eigen-solution that do not depend on the stiffness values: bases T_a,
    T_b (:func:`_split_massless`), T_a's unit columns, the zero-mode count, the Jacobi
    scaling S and the Cholesky factor of ``S M_a S`` (see :func:`_solve`)."""

    t_a: np.ndarray
    t_b: np.ndarray
    unit_a: tuple[np.ndarray, np.ndarray]
    zero_modes: int
    scale: np.ndarray
    chol: np.ndarray


STRUCTURES_KEPT = 8
_STRUCTURES = Recent(STRUCTURES_KEPT)  # AssembledModel.structure_key -> Structure


def structure(am: AssembledModel) -> Structure:
    """:class:`Structure` of ``am``, built once per :attr:`AssembledModel.structure_key`
    (mesh, constraints, spring directions and masses: the designs of a stiffness study
    share it)."""
    return _STRUCTURES.get(am.structure_key, lambda: _build_structure(am))


def _build_structure(am: AssembledModel) -> Structure:
    """:class:`Structure` of ``am`` (see :func:`structure`)."""
    basis, independent = constraint_basis(am.constraints, am.massless)
    t_a, t_b = split_massless(am, basis, independent)
    check_no_massless_mechanism(am, t_b)
    unit_a = _unit_columns(t_a)
    m_a = _reduced_mass(am, t_a, unit_a)
    scale = 1.0 / np.sqrt(np.diag(m_a))
    chol = np.linalg.cholesky(scale[:, None] * m_a * scale[None, :])
    for a in (t_a, t_b, scale, chol, *unit_a):
        a.flags.writeable = False
    return Structure(t_a, t_b, unit_a, zero_mode_count(am), scale, chol)


def _condensed(am: AssembledModel, shared: Structure):
    """Massive and massless bases, ``F_a``, ``F_red = (I - P_b) F_a`` and the QR of F_b
    (see :func:`_solve`); ``shared``: :func:`structure` of ``am``."""
    t_a, t_b = shared.t_a, shared.t_b
    f_a = _times_basis(am.deformation, t_a, shared.unit_a)
    f_b = _times_basis(am.deformation, t_b)
    scale_b = np.linalg.norm(f_b, axis=0)
    q_b, r_b = np.linalg.qr(f_b / scale_b)
    f_red = f_a - q_b @ (q_b.T @ f_a) if t_b.shape[1] else f_a  # nothing massless: F_a
    return t_a, t_b, f_a, f_red, (q_b, r_b, scale_b)


def reduced_matrices(am: AssembledModel) -> tuple[np.ndarray, np.ndarray, int]:
    """Stiffness [N/m...] and mass [kg...] on the independent massive dofs, and the number
    of zero-frequency modes: ``K_red = F_red^T F_red`` (exact static condensation of the
    massless dofs, see :func:`_solve`), ``M_red = T_a^T M T_a``. For eigen-solvers that
    take (K, M), e.g. ``scipy.linalg.eigh(K, M, subset_by_index=...)`` (benchmarks)."""
    shared = structure(am)
    t_a, _, _, f_red, _ = _condensed(am, shared)
    return f_red.T @ f_red, _reduced_mass(am, t_a, shared.unit_a), shared.zero_modes


def _reduced_mass(am: AssembledModel, t_a: np.ndarray, unit) -> np.ndarray:
    """``M_a = T_a^T M T_a`` [kg, kg m, kg m^2] on the massive coordinates (``unit``:
    :func:`_unit_columns` of T_a)."""
    first, mixed = unit
    m_t = _times_basis(am.M, t_a, unit)
    m_a = m_t[first]
    m_a[mixed] = t_a[:, mixed].T @ m_t
    return m_a


def _solve(am: AssembledModel, with_shapes: bool = True):
    """Nonzero angular frequencies [rad/s] ascending, mass-normalised shapes (None without
    ``with_shapes``: singular values only, about half the time), zero-mode count.

    With ``u = T_a a + T_b b`` (b massless), ``F_a = F T_a``, ``F_b = F T_b`` and P_b the
    projector on the range of F_b, the exact static condensation is
    ``K_aa - K_ab K_bb^-1 K_ba = F_red^T F_red``, ``F_red = (I - P_b) F_a``, and
    ``b = -F_b^+ F_a a``. With S the Jacobi scaling of ``M_a = T_a^T M T_a`` and
    ``S M_a S = L L^T``, omega are the singular values of ``F_red S L^-T`` and the right
    singular vectors v give ``a = S L^-T v`` (``a^T M_a a = 1``).
    """
    shared = structure(am)
    t_a, t_b, f_a, f_red, (q_b, r_b, scale_b) = _condensed(am, shared)
    zero_modes, scale, chol = shared.zero_modes, shared.scale, shared.chol
    n_modes = t_a.shape[1] - zero_modes
    sigma, vh = svd(sla.solve_triangular(chol, (f_red * scale).T, lower=True).T, with_shapes)
    omega = sigma[:n_modes][::-1]
    if not with_shapes:
        return omega, None, zero_modes
    coords = scale[:, None] * sla.solve_triangular(chol.T, vh[:n_modes][::-1].T, lower=False)
    condensed = sla.solve_triangular(r_b, q_b.T @ (f_a @ coords)) / scale_b[:, None]
    shapes = (t_a @ coords - t_b @ condensed).T
    sign = np.sign(shapes[np.arange(n_modes), np.argmax(np.abs(shapes), axis=1)])
    return omega, shapes * sign[:, None], zero_modes


@dataclass(frozen=True, eq=False)
class AssembledModes:
    """Natural frequencies and mode shapes of the assembled model.

    Attributes
    ----------
    frequencies_hz : (n_modes,) nonzero natural frequencies [Hz], ascending.
    rigid_body_modes : number of zero-frequency (rigid-body and mechanism) modes (not listed).
    shapes : (n_modes, n_dofs) mass-normalised shapes on all dofs of ``assembled``,
        ``shapes @ M @ shapes.T = I`` [m/sqrt(kg), rad/sqrt(kg)]; largest entry positive;
        None when computed without shapes.
    assembled : the model they belong to (dofs, mesh, K, M).
    """

    frequencies_hz: np.ndarray
    rigid_body_modes: int
    shapes: np.ndarray | None
    assembled: AssembledModel

    @property
    def dof_labels(self) -> tuple[tuple[str, int, str], ...]:
        """(body name, node, component) of each column of ``shapes``."""
        return self.assembled.dof_labels

    def body_motion(self, body_name: str) -> np.ndarray:
        """Motion ``[r; theta]`` of a body in each mode.

        (n_modes, 6) at the centre of mass of a rigid body or the point of a virtual body;
        (n_modes, n_nodes, 6) at the mesh nodes of a beam (``assembled.node_positions``).
        """
        dofs = self.assembled.body_dofs[body_name]
        motion = self.shapes[:, dofs]
        return motion if len(dofs) > 1 else motion[:, 0]


def assembled_modes(
    model: Model,
    fmax_hz: float | None = None,
    count: int | None = None,
    elements_per_beam: int | None = None,
    rtol: float = DEFAULT_RTOL,
    max_elements_per_beam: int = MAX_ELEMENTS_PER_BEAM,
    shapes: bool = True,
) -> AssembledModes:
    """Natural frequencies and mode shapes by the assembled model ("ordinary method").

    Parameters
    ----------
    fmax_hz : keep the modes at or below this frequency [Hz]; also sets the automatic mesh.
    count : keep at most this many (the lowest). Without ``fmax_hz`` and ``elements_per_beam``
        the mesh is set by the ``count``-th frequency of a first solution on the default mesh.
    elements_per_beam : a fixed mesh instead of the automatic one (:func:`elements_for`).
    rtol, max_elements_per_beam : target error and cap of the automatic mesh.
    shapes : False skips the mode shapes (``shapes`` is None; singular values only: the
        estimates that count and bracket the MSTMM roots).

    Every frequency converges from above as the mesh is refined (consistent mass,
    Rayleigh-Ritz), so the number of modes found below ``fmax_hz`` never exceeds the exact one.
    """
    mesh_hz = fmax_hz
    meshed = any(body_kind(b).meshed for b in model.bodies)
    if mesh_hz is None and count is not None and elements_per_beam is None and meshed:
        first = assembled_modes(
            model, count=count, elements_per_beam=DEFAULT_ELEMENTS_PER_BEAM, shapes=False
        )
        if len(first.frequencies_hz):
            mesh_hz = float(first.frequencies_hz[-1])
    am = assemble(model, elements_per_beam, mesh_hz, rtol, max_elements_per_beam)
    omega, vectors, zero_modes = _solve(am, shapes)
    freq = omega / (2.0 * math.pi)
    keep = np.ones(len(freq), dtype=bool) if fmax_hz is None else freq <= fmax_hz
    if count is not None:
        keep &= np.arange(len(freq)) < count
    return AssembledModes(
        frequencies_hz=freq[keep],
        rigid_body_modes=zero_modes,
        shapes=None if vectors is None else vectors[keep],
        assembled=am,
    )
