"""The nodal exact dynamic stiffness matrix K(ω) of a model, for the Wittrick-Williams count.

Nodes carry six small motions ``[r; θ]`` each (global frame, paper eq. 2.5): a rigid body's
at its centre of mass, a virtual body's at its point, a beam's at each end. K(ω) is

* each rigid body's ``-ω² M`` (mass and inertia tensor at the centre of mass, eqs. 2.8, 2.9);
* each hinge's springs on the relative motion ``d = u_A(P) - u_B(P)`` of its two bodies at
  the hinge point P (eqs. 2.13, 2.14), ``u(P) = [r_C + θ × (P - C); θ]`` for a rigid body,
  the node's own motion for a virtual body or a beam end, zero for ground: ``k d_j²`` per
  finite direction, nothing for a released one (stiffness 0);
* each beam's exact dynamic stiffness (:func:`ufmt.mstmm.members.member_stiffness`).

A rigid direction (stiffness inf) is the linear constraint ``d_j = 0``: the motions it allows
are ``u = N v`` with N an orthonormal basis of the constraints' null space, and K(ω) is
taken as ``Nᵀ K(ω) N``, the dynamic stiffness of the constrained structure (any other basis
is a congruence of it, so its inertia, the count, is the same: Sylvester's law).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np
import scipy.linalg as sla

from ufmt.errors import ModelError
from ufmt.kinds import kind_of
from ufmt.model.schema import GROUND, Model
from ufmt.mstmm.members import Members, local_to_global, member_stiffness
from ufmt.recent import Recent

RANK_RTOL = 1e-9  # rank of geometric (unit-row) matrices, relative to the largest value
COMPONENTS = ("x", "y", "z", "rx", "ry", "rz")
CHUNK = 32  # frequencies per block of the condensation's products (temporaries stay in cache)
T = TypeVar("T")


@dataclass(frozen=True, eq=False)
class NodalStiffness:
    """K(ω) = static - ω² mass + Σ_beams Gᵀ D_beam(ω) G on the constrained motions v.

    Attributes
    ----------
    static : (n, n) the hinge springs' stiffness [N/m, N, N m/rad].
    mass : (n, n) the rigid bodies' mass [kg, kg m, kg m²].
    beams : (beam, columns (c,), G (12, c)) per beam: G maps the c coordinates v[columns]
        its ends depend on to its local end motions.
    zero_modes : motions that strain nothing (rigid-body and mechanism modes).
    shared : what every design of its structure shares (:class:`_Structure`: the beams'
        terms and matrices, the condensation's geometry), or None (built for this one).
    """

    static: np.ndarray
    mass: np.ndarray
    beams: tuple
    zero_modes: int
    shared: _Structure | None = None

    @property
    def order(self) -> int:
        """Number of constrained nodal motions n."""
        return self.static.shape[0]

    def matrix(self, omega) -> np.ndarray:
        """K(ω) (len(ω), n, n) at ω [rad/s]."""
        return self._matrix(np.atleast_1d(np.asarray(omega, dtype=float)), kept=False)

    def _matrix(self, omega: np.ndarray, kept: bool) -> np.ndarray:
        """K(ω) at ω [rad/s]; ``kept``: the beams' part kept for every design of the
        structure (the few ω of :meth:`estimates`: the springs are no part of it)."""
        k = np.repeat(self.static[None], omega.size, axis=0)
        rows, cols = self.mass_entries
        k[:, rows, cols] -= (omega**2)[:, None] * self.mass[rows, cols]

        def beam_blocks():  # (columns, Gᵀ D_beam(ω) G (len(ω), c, c)) per beam
            return [
                (columns, g.T @ member_stiffness(omega, beam) @ g)
                for beam, columns, g in self.beams
            ]

        if kept and self.shared is not None:
            blocks = self.shared.kept(("beam blocks", omega.tobytes()), beam_blocks)
        else:
            blocks = beam_blocks()
        for columns, block in blocks:
            k[:, columns[:, None], columns] += block
        return k

    @functools.cached_property
    def mass_entries(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the nonzero entries of ``mass``."""
        return np.nonzero(self.mass)

    @functools.cached_property
    def members(self) -> Members:
        """The beams' deformations stacked (:class:`ufmt.mstmm.members.Members`)."""
        if self.shared is not None:
            return self.shared.kept("members", lambda: Members([b for b, _, _ in self.beams]))
        return Members([beam for beam, _, _ in self.beams])

    def clamped(self, omega) -> np.ndarray:
        """J₀(ω): the beams' clamped-clamped frequencies below ω [rad/s] (len(ω),)."""
        return self.members.clamped(omega)

    @functools.cached_property
    def condensation(self) -> Condensation:
        """K(ω) condensed onto its outer coordinates (:class:`Condensation`)."""
        return Condensation.of(self)

    def estimates(self, step_hz: float = 1.0) -> np.ndarray:
        """Estimates [rad/s] of the natural frequencies, ascending: the eigenvalues of the
        linearisation K(ω) ≈ K(0) - ω² M₀ (M₀ = -dK/dω² at 0 by a difference over
        ``step_hz``: the beams' consistent mass, one element each); exact for springs and
        rigid bodies, rougher for modes the beams carry. Empty where M₀ is not positive
        definite. Only where to look: the count J certifies every root."""
        omega = 2.0 * np.pi * step_hz
        k = self._matrix(np.array([0.0, omega]), kept=True)
        mass = (k[0] - k[1]) / omega**2
        try:
            mu = sla.eigh(k[0], 0.5 * (mass + mass.T), eigvals_only=True, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            return np.zeros(0)
        return np.sqrt(mu[mu > 0])


@dataclass(frozen=True, eq=False)
class Condensation:
    """K(ω) split into inner coordinates I (masses on springs: K_II = S_II - ω² M_II, linear
    in ω², no beam touches them) and outer ones O (the beams' ends and the massless
    coordinates), the inner ones eliminated exactly.

    With Φ the M_II-orthonormal modes of the inner structure (O clamped), ΦᵀS_IIΦ = Λ,
    ΦᵀM_IIΦ = I (one symmetric eigenproblem per design), K_II(ω) is congruent to
    diag(λ_i - ω²) and its Schur complement is
    ``C(ω) = K_OO(ω) - Wᵀ diag(1/(λ_i - ω²)) W``, W = Φᵀ(S_IO - ω² M_IO). By Haynsworth's
    inertia additivity s{K} = #{λ_i < ω²} + s{C}, and det K = det(Φ)⁻² Π(λ_i - ω²) det C:
    the count needs an LDLᵀ of C only (order 18 instead of 78 on the packaged model), and
    WᵀDW is one (o, r) @ (r, o) product per ω. Without inner coordinates (M_II not positive
    definite), or where that product costs more per ω than an LDLᵀ of the whole K
    (r o² > n³/3), C = K.

    Attributes
    ----------
    inner, outer : coordinates of v in I and in O.
    poles : λ_i (r,) [rad²/s²], the inner structure's squared natural frequencies.
    static, mass : S_OO, M_OO (o, o).
    coupling, mass_coupling : a = ΦᵀS_IO and b = ΦᵀM_IO (r, o): W = a - ω² b (b None
        without mass coupling between inner and outer coordinates).
    members : the beams' stiffness terms (:class:`ufmt.mstmm.members.Members`).
    scatter : K_OO's beam part terms(ω) @ P, P (terms, o²) each term's pattern GᵀE_tG on O,
        sparse: layers (term, entry of C flattened, value), each entry at most once per
        layer: ``k[:, entry] += terms[:, term] * value`` layer by layer adds the few nonzeros
        of P alone, elementwise, in an order that does not depend on the number of
        frequencies (a product would take another BLAS path at one).
    """

    inner: np.ndarray
    outer: np.ndarray
    poles: np.ndarray
    static: np.ndarray
    mass: np.ndarray
    coupling: np.ndarray
    mass_coupling: np.ndarray | None
    members: Members
    scatter: tuple

    @classmethod
    def of(cls, nodal: NodalStiffness) -> Condensation:
        """The condensation of ``nodal`` (inner: massive coordinates no beam touches)."""
        n = nodal.order
        touched = np.zeros(n, dtype=bool)
        for _, columns, _ in nodal.beams:
            touched[columns] = True
        inner = np.flatnonzero(~touched & (np.diag(nodal.mass) > 0))
        return cls._split(nodal, inner)

    @classmethod
    def of_whole(cls, nodal: NodalStiffness) -> Condensation:
        """No condensation: every coordinate outer (C = K)."""
        return cls._split(nodal, np.zeros(0, dtype=int))

    @classmethod
    def _split(cls, nodal: NodalStiffness, inner: np.ndarray) -> Condensation:
        """The condensation of the ``inner`` coordinates (a positive definite M_II)."""
        n = nodal.order
        try:
            poles, phi = sla.eigh(
                nodal.static[np.ix_(inner, inner)], nodal.mass[np.ix_(inner, inner)]
            )
        except (np.linalg.LinAlgError, ValueError):  # M_II singular: no inner coordinates
            inner, poles, phi = inner[:0], np.zeros(0), np.zeros((0, 0))
        outer = np.setdiff1d(np.arange(n), inner)
        a = phi.T @ nodal.static[np.ix_(inner, outer)]
        b = phi.T @ nodal.mass[np.ix_(inner, outer)]
        if inner.size * outer.size**2 > n**3 / 3:
            return cls.of_whole(nodal)  # costs more per ω than the LDLᵀ of the whole K
        static = nodal.static[np.ix_(outer, outer)]
        mass = nodal.mass[np.ix_(outer, outer)]
        coupled = b if b.any() else None  # mass coupling between inner and outer coordinates
        scatter = _scatter(nodal, outer)  # the same for every design of the structure
        return cls(inner, outer, poles, static, mass, a, coupled, nodal.members, scatter)


def _scatter(nodal: NodalStiffness, outer: np.ndarray) -> tuple:
    """:attr:`Condensation.scatter` of the beams of ``nodal`` on the ``outer`` coordinates
    (built once per structure)."""
    if nodal.shared is None:
        return _build_scatter(nodal, outer)
    return nodal.shared.kept(("scatter", outer.tobytes()), lambda: _build_scatter(nodal, outer))


def _build_scatter(nodal: NodalStiffness, outer: np.ndarray) -> tuple:
    """:attr:`Condensation.scatter` of the beams of ``nodal`` on the ``outer`` coordinates."""
    position = np.full(nodal.order, -1)
    position[outer] = np.arange(outer.size)
    members = nodal.members
    term, entry, value = [np.zeros(0, dtype=int)], [np.zeros(0, dtype=int)], [np.zeros(0)]
    for j, (_, columns, g) in enumerate(nodal.beams):
        at = position[columns]
        terms = np.flatnonzero(members.owner == j)
        block = g.T @ members.patterns[terms] @ g  # (terms, c, c)
        t, r, c = np.nonzero(block)
        term.append(terms[t])
        entry.append(at[r] * outer.size + at[c])
        value.append(block[t, r, c])
    term, entry, value = np.concatenate(term), np.concatenate(entry), np.concatenate(value)
    order = np.lexsort((term, entry))
    term, entry, value = term[order], entry[order], value[order]
    first = np.r_[0, np.flatnonzero(np.diff(entry)) + 1]  # each entry's first nonzero
    layer = np.arange(entry.size) - np.repeat(first, np.diff(np.r_[first, entry.size]))
    return tuple(
        (term[layer == i], entry[layer == i], value[layer == i])
        for i in range(layer.max(initial=-1) + 1)
    )


def _same_scatter(a: tuple, b: tuple) -> bool:
    """Whether two :attr:`Condensation.scatter` are the same."""
    return (
        a is b
        or len(a) == len(b)
        and all(
            np.array_equal(x, y)
            for p, q in zip(a, b, strict=True)
            for x, y in zip(p, q, strict=True)
        )
    )


class CondensationStack:
    """The :class:`Condensation` of several designs of one structure (same coordinates, beams
    and masses; their springs differ), evaluated at any (design, ω) pairs in one pass."""

    def __init__(self, condensations: list[Condensation]):
        first = condensations[0]
        for other in condensations[1:]:
            if not (
                np.array_equal(other.outer, first.outer)
                and _same_scatter(other.scatter, first.scatter)
                and np.array_equal(other.mass, first.mass)
            ):
                raise ValueError("designs of different structures cannot share a count")
        self.members, self.mass, self.scatter = first.members, first.mass, first.scatter
        self.mass_entries = np.nonzero(self.mass)
        self.order = first.outer.size
        self.static = np.array([c.static for c in condensations])
        self.poles = np.array([c.poles for c in condensations])
        self.coupling = np.array([c.coupling for c in condensations])
        self.mass_coupling = None  # b of each design, if M_IO ≠ 0 (then in all designs)
        if first.mass_coupling is not None:
            self.mass_coupling = np.array([c.mass_coupling for c in condensations])

    def complement(self, omega, design) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(C(ω) (len(ω), o, o), #{λ_i < ω²} (len(ω),), Σ log|λ_i - ω²| (len(ω),)) of each
        design ``design`` (len(ω),) at ω [rad/s]; log|det K| = Σ log|λ_i - ω²| + log|det C|
        - 2 log|det Φ| (:class:`Condensation`). Each ω's C is formed by elementwise steps and
        one (o, r) @ (r, o) product of its own: the same arithmetic however many ω and
        designs share the call, so a design's count and roots do not depend on its batch."""
        w2 = np.atleast_1d(np.asarray(omega, dtype=float)) ** 2
        terms = self.members.terms(np.sqrt(w2))
        gap = self.poles[design] - w2[:, None]
        with np.errstate(divide="ignore"):
            # ω on a pole to the last bit: a mode of the inner structure the outer coordinates
            # do not feel (w_i at rounding level), a root of K itself: log|det K| = -inf
            inverse = np.where(gap == 0.0, 0.0, 1.0 / gap)
            log_gap = np.sum(np.log(np.abs(gap)), axis=1)
        k = np.empty((w2.size, self.order, self.order))
        if len(self.poles) == 1:  # one design: its ω in slices (views, no copies)
            for start in range(0, w2.size, CHUNK):  # CHUNK ω at a time: temporaries in cache
                at = slice(start, start + CHUNK)
                k[at] = self._block(0, w2[at], terms[at], inverse[at])
        for d in np.unique(design) if len(self.poles) > 1 else ():
            at = np.flatnonzero(design == d)
            for start in range(0, at.size, CHUNK):
                block = at[start : start + CHUNK]
                k[block] = self._block(d, w2[block], terms[block], inverse[block])
        return k, np.count_nonzero(gap < 0, axis=1), log_gap

    def _block(self, design: int, w2, terms, inverse) -> np.ndarray:
        """C(ω) (len(ω), o, o) of one design at ω² [rad²/s²] (len(ω),), given the beams'
        ``terms`` (len(ω), t) and 1/(λ_i - ω²) (len(ω), r)."""
        n, o = w2.size, self.order
        k = np.repeat(self.static[design][None], n, axis=0)
        rows, cols = self.mass_entries
        k[:, rows, cols] -= w2[:, None] * self.mass[rows, cols]
        flat = k.reshape(n, o * o)
        for term, entry, value in self.scatter:
            flat[:, entry] += terms[:, term] * value
        if inverse.shape[1]:
            k -= self._coupled(design, w2, inverse)
        return k

    def _coupled(self, design: int, w2: np.ndarray, inverse: np.ndarray) -> np.ndarray:
        """Wᵀ diag(1/(λ_i - ω²)) W (len(ω), o, o) of one design at ω² [rad²/s²] (len(ω),),
        ``inverse`` 1/(λ_i - ω²) (len(ω), r): one (o, r) @ (r, o) product per ω."""
        a = self.coupling[design]
        if self.mass_coupling is None:
            return a.T @ (inverse[:, :, None] * a)
        w = a - w2[:, None, None] * self.mass_coupling[design]
        return np.swapaxes(w, 1, 2) @ (inverse[:, :, None] * w)


class _Layout:
    """Node dofs of every body: name -> (first dof, node points (k, 3) [m])."""

    def __init__(self, model: Model):
        self.model = model
        self.nodes: dict[str, tuple[int, np.ndarray]] = {}
        self.size = 0
        for body in model.bodies:
            points = _node_points(model, body)
            self.nodes[body.name] = (self.size, points)
            self.size += 6 * len(points)

    def point_map(self, name: str, point) -> tuple[np.ndarray, np.ndarray]:
        """(dofs (6,), T (6, 6)): the motion ``[r; θ]`` at ``point`` of body ``name`` is
        ``T u[dofs]`` (the body's kind places the point on one of its nodes)."""
        body = self.model.body(name)
        first, points = self.nodes[name]
        node, t = kind_of(body).point_map(body, points, point, self.model.source)
        return first + 6 * node + np.arange(6), t


def _node_points(model: Model, body) -> np.ndarray:
    """The points (k, 3) [m] of a body's nodes."""
    return kind_of(body).node_points(model, body)


def _hinge_rows(layout: _Layout, hinge) -> np.ndarray:
    """(6, size) relative motion ``d = u_A(P) - u_B(P)`` of the hinge's two bodies."""
    rows = np.zeros((6, layout.size))
    for name, sign in zip(hinge.between, (1.0, -1.0), strict=True):
        if name != GROUND:
            dofs, t = layout.point_map(name, hinge.at)
            rows[:, dofs] += sign * t
    return rows


def _null_basis(constraints: np.ndarray, size: int) -> np.ndarray:
    """Basis N (size, n) of the motions the rigid directions allow (``C N = 0``), sparse:
    the dependent dofs are picked by column-pivoted QR of the unit rows of C, and every
    independent dof is a coordinate of its own (a unit column), so a beam or a body couples
    only to the few coordinates its own dofs depend on."""
    if len(constraints) == 0:
        return np.eye(size)
    rows = constraints / np.linalg.norm(constraints, axis=1, keepdims=True)
    r, perm = sla.qr(rows, mode="r", pivoting=True)
    pivots = np.abs(np.diag(r))
    rank = int(np.count_nonzero(pivots > RANK_RTOL * pivots[0]))
    dependent, independent = perm[:rank], perm[rank:]
    basis = np.zeros((size, independent.size))
    basis[independent, np.arange(independent.size)] = 1.0
    basis[dependent] = -sla.solve_triangular(r[:rank, :rank], r[:rank, rank:])
    basis[np.abs(basis) < RANK_RTOL * np.abs(basis).max()] = 0.0  # rounding of exact zeros
    return basis


def _rank(a: np.ndarray) -> int:
    """Numerical rank of a geometric matrix (singular values above RANK_RTOL of the largest)."""
    if a.size == 0:
        return 0
    s = sla.svdvals(a)
    return int(np.count_nonzero(s > RANK_RTOL * max(s[0], 1.0)))


def _rigidity(layout: _Layout, body) -> np.ndarray:
    """(r, size) rows that vanish when the body moves rigidly (none for a body that cannot
    deform)."""
    rows = np.zeros((0, layout.size))
    local = kind_of(body).rigidity(body)
    if local is not None:
        first, _ = layout.nodes[body.name]
        rows = np.zeros((len(local), layout.size))
        rows[:, first : first + local.shape[1]] = local
    return rows


def _check_massless_mechanism(layout, basis, springs, massless) -> None:
    """ModelError if a motion of the virtual bodies alone strains no hinge."""
    if not massless.any():
        return
    alone = basis @ sla.null_space(basis[~massless], rcond=RANK_RTOL)
    if alone.shape[1] == 0 or _rank(springs @ alone) == alone.shape[1]:
        return
    z = alone @ sla.null_space(springs @ alone, rcond=RANK_RTOL)[:, 0]
    dof = int(np.argmax(np.abs(z)))
    name = next(n for n, (first, p) in layout.nodes.items() if first <= dof < first + 6 * len(p))
    raise ModelError(
        f"{layout.model.source}: body {name!r}: massless mechanism: it moves "
        f"({COMPONENTS[dof % 6]}) without straining any hinge; give the hinges on it a "
        "nonzero stiffness in that direction"
    )


_STRUCTURES = Recent(8)  # Model.structure_key() -> _Structure


@dataclass(frozen=True, eq=False)
class _Structure:
    """What every design of a stiffness study shares (built once per structure).

    Attributes
    ----------
    basis : N (dofs, n), the motions the rigid directions allow.
    zero_modes : motions that strain nothing.
    elastic : (6 hinges,) which hinge directions are springs (finite, nonzero stiffness).
    springs : (springs, n) their relative motions d_j on the constrained motions (d_j N):
        the hinges' stiffness is ``springsᵀ diag(k) springs``.
    mass : (n, n) the rigid bodies' mass on the constrained motions.
    beams : as :attr:`NodalStiffness.beams`.
    """

    basis: np.ndarray
    zero_modes: int
    elastic: np.ndarray
    springs: np.ndarray
    mass: np.ndarray
    beams: tuple
    _kept: dict = field(default_factory=dict, repr=False)

    def kept(self, key: Hashable, build: Callable[[], T]) -> T:
        """``build()``, once per ``key`` for every design of this structure (what depends
        on the beams, masses and geometry alone)."""
        if key not in self._kept:
            self._kept[key] = build()
        return self._kept[key]


def _structure(model: Model) -> _Structure:
    """The :class:`_Structure` of ``model``'s structure (cached)."""

    def build():
        layout = _Layout(model)
        rows = [_hinge_rows(layout, h) for h in model.hinges]
        k = [h.stiffness6 for h in model.hinges]
        rigid = [r[np.isinf(s)] for r, s in zip(rows, k, strict=True)]
        elastic = [r[np.isfinite(s) & (s > 0)] for r, s in zip(rows, k, strict=True)]
        basis = _null_basis(np.concatenate([np.zeros((0, layout.size)), *rigid]), layout.size)
        springs = np.concatenate([np.zeros((0, layout.size)), *elastic])
        norms = np.linalg.norm(springs, axis=1, keepdims=True)
        unit = springs / np.where(norms > 0, norms, 1.0)
        massless = np.zeros(layout.size, dtype=bool)
        for body in model.bodies:
            if kind_of(body).MASSLESS:
                first, points = layout.nodes[body.name]
                massless[first : first + 6 * len(points)] = True
        _check_massless_mechanism(layout, basis, unit, massless)
        rigidity = [_rigidity(layout, b) for b in model.bodies]
        zero_modes = basis.shape[1] - _rank(np.concatenate([unit, *rigidity]) @ basis)
        k = np.concatenate([np.zeros(0), *k])
        mass, beams = _bodies(model, layout, basis)
        return _Structure(basis, zero_modes, np.isfinite(k) & (k > 0), springs @ basis, mass, beams)

    return _STRUCTURES.get(model.structure_key(), build)


def _bodies(model: Model, layout: _Layout, basis: np.ndarray) -> tuple[np.ndarray, tuple]:
    """(the bodies' node masses (n, n) on the constrained motions, the members (beams) as
    :attr:`NodalStiffness.beams`)."""
    mass = np.zeros((layout.size, layout.size))
    beams = []
    for body in model.bodies:
        first, _ = layout.nodes[body.name]
        kind = kind_of(body)
        block = kind.node_mass(body)
        if block is not None:
            mass[first : first + len(block), first : first + len(block)] = block
        if kind.MEMBER:
            g = local_to_global(body) @ basis[first : first + 12]
            columns = np.flatnonzero(np.any(g != 0.0, axis=0))
            beams.append((body, columns, g[:, columns]))
    return basis.T @ mass @ basis, tuple(beams)


def nodal_stiffness(model: Model) -> NodalStiffness:
    """The :class:`NodalStiffness` of ``model`` (module docstring): the hinges' springs on
    the cached geometry of its structure.

    Raises
    ------
    ModelError
        A hinge stiffness that is negative or NaN: its structure (which springs exist) would
        be cached for every design of the same key (:meth:`Model.structure_key` tells only
        the rigid and released directions apart), so it is refused before.
    """
    _check_stiffness_values(model)
    structure = _structure(model)
    k = np.concatenate([np.zeros(0), *(h.stiffness6 for h in model.hinges)])[structure.elastic]
    static = structure.springs.T @ (k[:, None] * structure.springs)
    return NodalStiffness(static, structure.mass, structure.beams, structure.zero_modes, structure)


def _check_stiffness_values(model: Model) -> None:
    """ModelError unless every hinge stiffness is positive, 0 (released) or inf (rigid)."""
    for hinge in model.hinges:
        bad = ~(hinge.stiffness6 >= 0.0)  # negative or NaN
        if bad.any():
            value = hinge.stiffness6[np.flatnonzero(bad)[0]]
            raise ModelError(
                f"{model.source}: hinge {hinge.name!r}: stiffness {value:g} must be positive, "
                "0 (released) or inf (rigid)"
            )
