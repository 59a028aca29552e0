"""Body kinds as plug-ins: one module per kind, one registry line each.

A kind module owns everything the kind has: its model-file fields and reader, the fields
written back, its points (extent and hinge checks), its nodes and their point motion, its
mass block or exact member, how it moves with the carriage, and which solver formulation it
takes (transfer matrix, exact member stiffness with its clamped count, finite-element blocks).
The solvers, the machining and the calibration ask a body's kind (:func:`kind_of`), never its
type; the solvers' and the mode plots' adapters are keyed by the kind's form (:data:`FORMS`).
Adding a kind is one module and one line in :data:`BODY_KINDS`; adding a beam theory one
module and one line in :data:`ufmt.kinds.beam.THEORIES`.

Hinge kinds likewise (:data:`HINGE_KINDS`, :func:`hinge_kind_of`): a hinge kind owns its own
model-file fields beyond every hinge's (reader and writer), its complex stiffness k*(ω) and
real storage stiffness k'(ω), the constant stiffnesses bounding k'(ω), and whether it depends
on frequency (then the Wittrick-Williams count alone does not apply:
:mod:`ufmt.mstmm.dependent`).
"""

from __future__ import annotations

from types import ModuleType

from ufmt.kinds import aerostatic_hinge, beam, rigid, spring_hinge, virtual

#: kind name (the model file's ``kind``) -> its module
BODY_KINDS: dict[str, ModuleType] = {"rigid": rigid, "virtual": virtual, "beam": beam}
KINDS = tuple(BODY_KINDS)
#: how the solvers and the mode plots take a body (its module's ``FORM``): "mass", one node
#: carrying a mass block (fields ``mass``, ``center_of_mass``, ``inertia``; module functions
#: ``first_input_transfer``, ``mass_products``); "point", one massless node at its hinges'
#: point; "member", two end nodes (fields ``start``, ``end``, ``length``) and its ``parts``
#: between them (``local_frame``, ``mass_products``). A new kind of an existing form needs
#: no change in the solvers.
FORMS = ("mass", "point", "member")
#: hinge kind name (the ``[[hinge]]`` table's ``kind``, default "spring") -> its module
HINGE_KINDS: dict[str, ModuleType] = {"spring": spring_hinge, "aerostatic": aerostatic_hinge}


def kind_of(body) -> ModuleType:
    """The module of ``body``'s kind."""
    return BODY_KINDS[body.kind]


def hinge_kind_of(hinge) -> ModuleType:
    """The module of ``hinge``'s kind."""
    return HINGE_KINDS[hinge.kind]


def frequency_dependent(model) -> bool:
    """Whether a hinge of ``model`` has a stiffness that depends on frequency (its kind says
    the Wittrick-Williams count does not apply to it)."""
    return not all(hinge_kind_of(h).count_applies(h) for h in model.hinges)
