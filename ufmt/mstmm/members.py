"""Exact dynamic stiffness of the members (beams) and their clamped-clamped count.

The two ingredients a member brings to the Wittrick-Williams count (:mod:`ufmt.mstmm.wittrick`):
its exact dynamic stiffness matrix (12x12 on the six small motions of each end, no mesh), and
J₀, the number of its natural frequencies with both ends clamped that lie below ω. Both are
its parts' (:func:`ufmt.kinds.beam.parts`: axial and torsion rods, two bending planes of its
theory), each a formulation of :mod:`ufmt.kinds` whose ``STACK`` computes many of them at
once; this module puts them in place.

Local axes as the MSTMM's (:func:`ufmt.mstmm.elements.beam_frame` from start to end); end
dofs ``[u v w θx θy θz]`` of the start then the end, with ``θz = dv/dx`` (x-y plane, I_z) and
``θy = -dw/dx`` (x-z plane, I_y).
"""

from __future__ import annotations

import numpy as np

from ufmt.kinds import kind_of
from ufmt.model.schema import Body
from ufmt.mstmm.elements import beam_frame


class Members:
    """The parts of a set of members stacked by formulation (each a formulation's ``STACK``),
    so that the exact dynamic stiffness and J₀ of all of them at all frequencies are a few
    array operations: the stiffness is Σ_t term_t(ω) E_t with fixed 12x12 patterns E_t
    (:attr:`patterns`, of member :attr:`owner`) and scalar terms (:meth:`terms`), the
    stacks' in the order they first appear.
    """

    def __init__(self, beams):
        groups: dict = {}  # stack class -> ([(formulation, length)], [(pattern, owner)])
        for j, beam in enumerate(beams):
            for part in kind_of(beam).parts(beam):
                stack = type(part.formulation).STACK
                members, patterns = groups.setdefault(stack, ([], []))
                members.append((part.formulation, beam.length))
                sign = part.end_signs
                for entries in stack.ENTRIES:
                    e = np.zeros((12, 12))
                    for a, b, s in entries:
                        e[part.ends[a], part.ends[b]] = s * sign[a] * sign[b]
                    patterns.append((e, j))
        self.stacks = [stack(members) for stack, (members, _) in groups.items()]
        placed = [p for _, patterns in groups.values() for p in patterns]
        self.patterns = np.array([e for e, _ in placed]).reshape(-1, 12, 12)
        self.owner = np.array([j for _, j in placed], dtype=int)

    def terms(self, omega) -> np.ndarray:
        """The scalar terms (len(ω), len(patterns)) at ω [rad/s]."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        return np.concatenate(
            [stack.terms(omega) for stack in self.stacks] or [np.zeros((omega.size, 0))], axis=1
        )

    def clamped(self, omega) -> np.ndarray:
        """J₀: the number (len(ω),) of clamped-clamped member frequencies below ω [rad/s], all
        members together."""
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        count = np.zeros(omega.size, dtype=int)
        for stack in self.stacks:
            count += stack.clamped(omega)
        return count


def member_stiffness(omega: np.ndarray, beam: Body) -> np.ndarray:
    """Exact dynamic stiffness (n, 12, 12) of the member in its local axes (module docstring)
    at ω (n,) [rad/s]; symmetric, real, infinite only at its clamped-clamped frequencies;
    at ω = 0 the static one (bending: ``EI/L³ [[12, 6L, -12, 6L], [6L, 4L², -6L, 2L²],
    ...]``)."""
    members = Members([beam])
    return np.einsum("nt,tij->nij", members.terms(omega), members.patterns)


def local_to_global(beam: Body) -> np.ndarray:
    """(12, 12) map from the global end motions (start, end) to the local ones."""
    return np.kron(np.eye(4), beam_frame(beam, beam.start, beam.end).T)
