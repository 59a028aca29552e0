"""Every body kind the model files accept has a form that each per-form table (the MSTMM's,
the assembled model's, the mode plots') has, and the report reads a body's kind and mass from
the body record.

Oracles: the form list of the registry (``ufmt.kinds.FORMS``); the kinds written in the
packaged model file; the rigid motion of a rigid body, which the mode classification must pass
through unchanged while other kinds carry none.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from ufmt.assembled.bodies import BODY_KINDS as ASSEMBLED_KINDS
from ufmt.calibration.frequencies import modeset_from_mstmm
from ufmt.kinds import BODY_KINDS, FORMS, KINDS
from ufmt.kinds.beam import THEORIES
from ufmt.model.load import load_model, packaged_path
from ufmt.mstmm.bodies import BODY_RULES
from ufmt.mstmm.solve import solve_modes
from ufmt.plots.modes import BODY_DRAWINGS
from ufmt.tomlfile import read_toml


def test_each_body_form_has_one_entry_per_table_and_each_kind_a_form():
    assert set(BODY_DRAWINGS) == set(FORMS)
    assert set(BODY_RULES) == set(FORMS)
    assert set(ASSEMBLED_KINDS) == set(FORMS)
    assert {BODY_KINDS[name].FORM for name in KINDS} <= set(FORMS)


#: what every kind module defines (the plug-in's interface, docs/architecture.md)
KIND_INTERFACE = (
    "NAME CLASS FORM FIELDS REQUIRED WRITTEN ONE_FRAME MASSLESS MEMBER MESHED HINGES_AT_ENDS "
    "parse written points section_width check_hinge_point node_points point_map node_mass rigidity "
    "moved hinge_motion sensor_motion"
).split()


@pytest.mark.parametrize("name", KINDS)
def test_each_kind_module_has_the_whole_interface(name):
    module = BODY_KINDS[name]
    missing = [a for a in KIND_INTERFACE if not hasattr(module, a)]
    assert not missing and module.NAME == name
    assert set(module.REQUIRED) <= set(module.FIELDS)
    assert module.CLASS.__dataclass_fields__["kind"].default == name


def _body_type_checks(source: str) -> list[int]:
    """Lines of ``isinstance(x, <a body class>)`` in a module's source."""
    classes = {"RigidBody", "VirtualBody", "Beam", "Body"}
    return [
        node.lineno
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.Call)
        and getattr(node.func, "id", None) == "isinstance"
        and {getattr(n, "id", getattr(n, "attr", None)) for n in ast.walk(node.args[1])} & classes
    ]


def test_no_module_outside_the_kinds_asks_a_body_its_type():
    package = Path(__file__).resolve().parents[1] / "ufmt"
    hits = [
        f"{path.relative_to(package)}:{line}"
        for path in package.rglob("*.py")
        if "kinds" not in path.relative_to(package).parts
        for line in _body_type_checks(path.read_text(encoding="utf-8"))
    ]
    assert not hits, hits


def test_the_type_check_finder_can_fail():
    assert _body_type_checks("if isinstance(b, Beam):\n    pass\n") == [1]
    assert _body_type_checks("isinstance(b, (RigidBody, float))\n") == [1]
    assert _body_type_checks("isinstance(b, float)\n") == []


def test_each_body_record_carries_its_file_kind_and_a_mass():
    """The report reads ``kind`` and ``mass`` of every body: the kind written in the model
    file, and its mass (a virtual body: none)."""
    model = load_model()
    written = [b["kind"] for b in read_toml(packaged_path())["body"]]
    assert [b.kind for b in model.bodies] == written
    for body in model.bodies:
        assert body.mass == 0.0 if body.kind == "virtual" else body.mass > 0.0


def test_rigid_motion_passes_through_and_other_kinds_carry_none():
    model = load_model()
    shapes = solve_modes(model, count=8).shapes
    modes = modeset_from_mstmm(model, shapes)
    for i, body in enumerate(model.bodies):
        if body.kind == "rigid":
            np.testing.assert_array_equal(modes.motion[:, i], shapes.rigid[body.name])
        else:
            assert not modes.motion[:, i].any()


#: what a kind module of each form defines besides the common interface
FORM_INTERFACE = {
    "mass": ("first_input_transfer", "mass_products", "node_mass"),
    "point": (),
    "member": ("parts", "local_frame", "mass_products"),
}


@pytest.mark.parametrize("name", KINDS)
def test_each_kind_module_has_its_forms_interface(name):
    module = BODY_KINDS[name]
    assert [a for a in FORM_INTERFACE[module.FORM] if not hasattr(module, a)] == []


def _named_kinds(source: str, names: set) -> list[int]:
    """Lines of string constants (not docstrings: a whole name only) equal to one of
    ``names``, and of attributes ``.theory`` or ``.timoshenko``, in a module's source."""
    return [
        node.lineno
        for node in ast.walk(ast.parse(source))
        if (isinstance(node, ast.Constant) and node.value in names)
        or (isinstance(node, ast.Attribute) and node.attr in ("theory", "timoshenko"))
    ]


def test_the_solvers_never_name_a_body_kind_or_a_beam_theory():
    """The MSTMM, the assembled model, the machining, the calibration and the plots call the
    kinds' interfaces (forms, formulations): no kind or theory name, no theory flag."""
    names = set(KINDS) | set(THEORIES)
    package = Path(__file__).resolve().parents[1] / "ufmt"
    hits = [
        f"{path.relative_to(package)}:{line}"
        for folder in ("mstmm", "assembled", "machining", "calibration", "plots")
        for path in (package / folder).rglob("*.py")
        for line in _named_kinds(path.read_text(encoding="utf-8"), names)
    ]
    assert not hits, hits


def test_the_kind_name_finder_can_fail():
    names = set(KINDS) | set(THEORIES)
    assert _named_kinds('if body.kind == "beam":\n    pass\n', names) == [1]
    assert _named_kinds("x = beam.timoshenko\n", names) == [1]
    assert _named_kinds('"""A beam and a rigid body."""\n', names) == []
