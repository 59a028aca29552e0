"""Model-file loading, validation and writing (ufmt.model.load).

Oracles: the values written in the file; closed-form circular-section properties
(A = pi (D^2 - d^2) / 4, I = pi (D^4 - d^4) / 64, J = 2 I); exact physical limits (a thin
disc has I_z = I_x + I_y); the round trip file -> model -> text -> model being the identity.
Every bad input must give one ModelError line naming the file, the element and the field.
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ufmt.errors import ModelError
from ufmt.model.load import load_model, load_model_text, model_from_dict
from ufmt.model.schema import Beam, RigidBody, VirtualBody
from ufmt.model.write import model_to_toml

MODELS = Path(__file__).parent / "models"

# ground - base (rigid) - shaft (beam, diameter) - hub (virtual) - arm (rigid)
BASE = """\
name = "test"

[[body]]
name = "base"
kind = "rigid"
mass = 250.0
center_of_mass = [0.0, 0.0, -0.1]
inertia = [[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0.0, 0.0, 30.0]]

[[body]]
name = "shaft"
kind = "beam"
start = [0.0, 0.0, 0.0]
end = [0.0, 0.0, 0.5]
density = 7850.0
youngs_modulus = 2.1e11
shear_modulus = 8.1e10
diameter = 0.05

[[body]]
name = "hub"
kind = "virtual"

[[body]]
name = "arm"
kind = "rigid"
mass = 3.0
center_of_mass = [0.1, 0.0, 0.5]
inertia = [[0.01, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.02]]

[[hinge]]
name = "h_ground"
between = ["ground", "base"]
at = [0.0, 0.0, -0.2]
stiffness = [1e9, 1e9, 2e9]
rotational_stiffness = [1e8, 1e8, 1e8]

[[hinge]]
name = "h_shaft"
between = ["base", "shaft"]
at = [0.0, 0.0, 0.0]
stiffness = [inf, inf, inf]
rotational_stiffness = [inf, inf, 0.0]

[[hinge]]
name = "h_hub"
between = ["shaft", "hub"]
at = [0.0, 0.0, 0.5]
stiffness = [5e8, 5e8, 5e8]
rotational_stiffness = [1e7, 1e7, 1e7]

[[hinge]]
name = "h_arm"
between = ["hub", "arm"]
at = [0.0, 0.0, 0.5]
stiffness = [1e8, 1e8, 1e8]
rotational_stiffness = [1e6, 1e6, 1e6]
"""

ARM_BEAM = """\
[[body]]
name = "arm"
kind = "beam"
start = [0.0, 0.0, 0.5]
end = [0.3, 0.0, 0.5]
density = 2700.0
youngs_modulus = 7.0e10
shear_modulus = 2.6e10
area = 1.2e-3
second_moment_y = 4.0e-7
second_moment_z = 9.0e-7
polar_moment = 1.3e-6
"""

# a valid [machine] table for BASE, as the inner part of an inline table
MACHINE = (
    'tool_body = "arm", workpiece_body = "base", spindle_axis_xy = [0.0, 0.0], '
    "cutting_plane_z = 0.5, tool_radius = 0.2, workpiece_size = [0.1, 0.1], "
    'workpiece_center_xy = [0.0, 0.0], rotation = "cw"'
)

ARM_RIGID = BASE[BASE.index('[[body]]\nname = "arm"') : BASE.index("[[hinge]]")]


def edit(text: str, old: str, new: str) -> str:
    """``text`` with the one occurrence of ``old`` replaced by ``new``."""
    assert text.count(old) == 1, old
    return text.replace(old, new)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_base_model_is_valid(tmp_path):
    model = load_model(write(tmp_path, BASE))
    assert [b.name for b in model.bodies] == ["base", "shaft", "hub", "arm"]


# (id, old text, new text, regex the one-line message must match: file, element, field, problem)
BAD = [
    (
        "unknown_kind",
        'name = "base"\nkind = "rigid"',
        'name = "base"\nkind = "rigd"',
        r"body 'base': field 'kind': unknown kind 'rigd' \(did you mean 'rigid'\?\)",
    ),
    ("missing_kind", 'kind = "virtual"\n', "", r"body 'hub': field 'kind': missing \(valid kinds"),
    ("missing_mass", "mass = 250.0\n", "", r"body 'base': field 'mass': missing"),
    (
        "missing_body_name",
        'name = "hub"\n',
        "",
        r"body #3: field 'name': missing",
    ),
    (
        "missing_hinge_field",
        "rotational_stiffness = [1e8, 1e8, 1e8]\n",
        "",
        r"hinge 'h_ground': field 'rotational_stiffness': missing",
    ),
    (
        "misspelled_hinge_field",
        "stiffness = [1e9, 1e9, 2e9]",
        "stifness = [1e9, 1e9, 2e9]",
        r"hinge 'h_ground': unknown field 'stifness' \(did you mean 'stiffness'\?\)",
    ),
    (
        "misspelled_body_field",
        "center_of_mass = [0.0, 0.0, -0.1]",
        "centre_of_mass = [0.0, 0.0, -0.1]",
        r"body 'base': unknown field 'centre_of_mass' \(did you mean 'center_of_mass'\?\)",
    ),
    (
        "misspelled_kind_key",
        'kind = "virtual"',
        'knd = "virtual"',
        r"body 'hub': unknown field 'knd' \(did you mean 'kind'\?\)",
    ),
    (
        "field_of_other_kind",
        'kind = "virtual"',
        'kind = "virtual"\nmass = 1.0',
        r"body 'hub': unknown field 'mass' \(valid fields for kind 'virtual': name, kind, number\)",
    ),
    (
        "misspelled_top_field",
        'name = "test"',
        'nmae = "test"',
        r"top level: unknown field 'nmae' \(did you mean 'name'\?\)",
    ),
    ("missing_model_name", 'name = "test"\n', "", r"top level: field 'name': missing"),
    (
        "wrong_type",
        "mass = 250.0",
        'mass = "heavy"',
        r"body 'base': field 'mass': expected a number, got string 'heavy'",
    ),
    (
        "wrong_length",
        "at = [0.0, 0.0, -0.2]",
        "at = [0.0, -0.2]",
        r"hinge 'h_ground': field 'at': expected 3 numbers \[m\], got an array of 2",
    ),
    (
        "wrong_type_in_vector",
        "at = [0.0, 0.0, -0.2]",
        'at = [0.0, 0.0, "low"]',
        r"hinge 'h_ground': field 'at\[2\]': expected a number, got string 'low'",
    ),
    (
        "number_not_integer",
        'name = "hub"',
        'name = "hub"\nnumber = 1.5',
        r"body 'hub': field 'number': expected an integer, got float 1.5",
    ),
    (
        "zero_mass",
        "mass = 250.0",
        "mass = 0.0",
        r"body 'base': field 'mass': 0 is not positive \(allowed: > 0 \[kg\]\)",
    ),
    (
        "negative_mass",
        "mass = 250.0",
        "mass = -5.0",
        r"body 'base': field 'mass': -5 is not positive",
    ),
    (
        "infinite_mass",
        "mass = 250.0",
        "mass = inf",
        r"body 'base': field 'mass': inf is not finite",
    ),
    (
        "zero_length_beam",
        "end = [0.0, 0.0, 0.5]",
        "end = [0.0, 0.0, 0.0]",
        r"body 'shaft': field 'end': beam length is 0",
    ),
    (
        "nonpositive_density",
        "density = 7850.0",
        "density = 0.0",
        r"body 'shaft': field 'density': 0 is not positive \(allowed: > 0 \[kg/m\^3\]\)",
    ),
    (
        "inertia_not_symmetric",
        "[[20.0, 0.5, 0.0], [0.5, 22.0",
        "[[20.0, 0.5, 0.0], [0.4, 22.0",
        r"body 'base': field 'inertia': not symmetric: inertia\[0\]\[1\] = 0.5 but "
        r"inertia\[1\]\[0\] = 0.4",
    ),
    (
        "inertia_not_positive_definite",
        "[[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0.0, 0.0, 30.0]]",
        "[[20.0, 0.0, 0.0], [0.0, -22.0, 0.0], [0.0, 0.0, 30.0]]",
        r"body 'base': field 'inertia': not positive definite: principal moments \[-22, 20, 30\]",
    ),
    (
        "inertia_singular",
        "[[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0.0, 0.0, 30.0]]",
        "[[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 2.0]]",
        r"body 'base': field 'inertia': not positive definite",
    ),
    (
        "inertia_not_physical",
        "[[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0.0, 0.0, 30.0]]",
        "[[10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 30.0]]",
        r"body 'base': field 'inertia': principal moments \[10, 10, 30\] \[kg m\^2\] are not "
        r"physical",
    ),
    (
        "inertia_wrong_shape",
        "[[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0.0, 0.0, 30.0]]",
        "[[20.0, 0.5, 0.0], [0.5, 22.0], [0.0, 0.0, 30.0]]",
        r"body 'base': field 'inertia\[1\]': expected 3 numbers \[kg m\^2\], got an array of 2",
    ),
    (
        "hinge_unknown_body",
        'between = ["ground", "base"]',
        'between = ["ground", "bsae"]',
        r"hinge 'h_ground': field 'between\[1\]': unknown body 'bsae' \(did you mean 'base'\?\)",
    ),
    (
        "hinge_same_body_twice",
        'between = ["hub", "arm"]',
        'between = ["arm", "arm"]',
        r"hinge 'h_arm': field 'between': connects 'arm' to itself",
    ),
    (
        "hinge_ground_to_ground",
        'between = ["ground", "base"]',
        'between = ["ground", "ground"]',
        r"hinge 'h_ground': field 'between': connects 'ground' to itself",
    ),
    (
        "hinge_between_three",
        'between = ["ground", "base"]',
        'between = ["ground", "base", "shaft"]',
        r"hinge 'h_ground': field 'between': expected two body names .*got an array of 3",
    ),
    (
        "duplicate_body_name",
        'name = "hub"',
        'name = "base"',
        r"body 'base': field 'name': duplicate body name \(body #1 and body #3",
    ),
    (
        "duplicate_hinge_name",
        'name = "h_arm"',
        'name = "h_hub"',
        r"hinge 'h_hub': field 'name': duplicate hinge name \(hinge #3 and hinge #4",
    ),
    (
        "body_named_ground",
        'name = "hub"',
        'name = "ground"',
        r"body 'ground': field 'name': 'ground' is reserved",
    ),
    (
        "duplicate_element_number",
        'name = "h_arm"',
        'name = "h_arm"\nnumber = 7',
        r"hinge 'h_arm': field 'number': 7 is already the number of body 'hub'",
    ),
    (
        "hinge_not_at_beam_end",
        "at = [0.0, 0.0, 0.5]\nstiffness = [5e8",
        "at = [0.0, 0.0, 0.4]\nstiffness = [5e8",
        r"hinge 'h_hub': field 'at': \[0, 0, 0.4\] is not at an end of beam 'shaft'",
    ),
    (
        "hinge_just_off_beam_end",  # 1e-8 x length off the end: beyond the 1e-9 tolerance
        "at = [0.0, 0.0, 0.5]\nstiffness = [5e8",
        "at = [0.0, 0.0, 0.500000005]\nstiffness = [5e8",
        r"hinge 'h_hub': field 'at': .* is not at an end of beam 'shaft'",
    ),
    (
        "virtual_body_two_points",
        "at = [0.0, 0.0, 0.5]\nstiffness = [1e8",
        "at = [0.1, 0.0, 0.5]\nstiffness = [1e8",
        r"hinge 'h_arm': field 'at': impossible geometry: virtual body 'hub' is a point, but "
        r"hinge 'h_hub' puts it at \[0, 0, 0.5\] and this hinge at \[0.1, 0, 0.5\]",
    ),
    (
        "nan_stiffness",
        "stiffness = [1e9, 1e9, 2e9]",
        "stiffness = [nan, 1e9, 2e9]",
        r"hinge 'h_ground': field 'stiffness\[0\]': nan is not a number",
    ),
    (
        "nan_center_of_mass",
        "center_of_mass = [0.0, 0.0, -0.1]",
        "center_of_mass = [0.0, nan, -0.1]",
        r"body 'base': field 'center_of_mass\[1\]': nan is not a number",
    ),
    (
        "nan_in_machine",
        'name = "test"',
        'name = "test"\nmachine = { '
        + MACHINE.replace("tool_radius = 0.2", "tool_radius = nan")
        + " }",
        r"machine: field 'tool_radius': nan is not a number \(allowed: > 0 \[m\]\)",
    ),
    (
        "misspelled_machine_field",
        'name = "test"',
        'name = "test"\nmachine = { ' + MACHINE.replace("tool_radius", "tool_radios") + " }",
        r"machine: unknown field 'tool_radios' \(did you mean 'tool_radius'\?\)$",
    ),
    (
        "machine_tool_not_a_body",
        'name = "test"',
        'name = "test"\nmachine = { ' + MACHINE.replace('"arm"', '"head"') + " }",
        r"machine: field 'tool_body': 'head' is not a body of the model",
    ),
    (
        "negative_stiffness",
        "stiffness = [1e9, 1e9, 2e9]",
        "stiffness = [1e9, 1e9, -1e9]",
        r"hinge 'h_ground': field 'stiffness\[2\]': -1e\+09 is negative "
        r"\(allowed: >= 0, 0 = released, inf = rigid\)$",
    ),
    (
        "negative_infinite_stiffness",
        "rotational_stiffness = [1e8, 1e8, 1e8]",
        "rotational_stiffness = [1e8, -inf, 1e8]",
        r"hinge 'h_ground': field 'rotational_stiffness\[1\]': -inf is negative",
    ),
    (
        "negative_damping",
        "rotational_stiffness = [1e8, 1e8, 1e8]",
        "rotational_stiffness = [1e8, 1e8, 1e8]\ndamping = [0.0, -5.0, 0.0]",
        r"hinge 'h_ground': field 'damping\[1\]': -5 is negative \(allowed: >= 0, finite",
    ),
    (
        "infinite_damping",
        "rotational_stiffness = [1e8, 1e8, 1e8]",
        "rotational_stiffness = [1e8, 1e8, 1e8]\nrotational_damping = [inf, 0.0, 0.0]",
        r"hinge 'h_ground': field 'rotational_damping\[0\]': inf is not finite",
    ),
    (
        "body_without_hinge",
        '[[hinge]]\nname = "h_ground"',
        '[[body]]\nname = "loose"\nkind = "virtual"\n\n[[hinge]]\nname = "h_ground"',
        r"body 'loose': has no hinge",
    ),
    (
        "body_not_connected_to_ground",
        'between = ["shaft", "hub"]',
        'between = ["arm", "hub"]',
        r"body 'hub': not connected to 'ground': .* \(it is linked only to 'arm'\)",
    ),
    (
        "machine_not_a_table",
        'name = "test"',
        'name = "test"\nmachine = 3',
        r"top level: field 'machine': expected a table \[machine\], got integer 3",
    ),
]

BEAM_BAD = [
    (
        "diameter_and_explicit_section",
        "diameter = 0.05",
        "diameter = 0.05\narea = 1e-3",
        r"body 'shaft': field 'area': give either 'diameter' .* not both",
    ),
    (
        "inner_not_less_than_outer",
        "diameter = 0.05",
        "diameter = 0.05\ninner_diameter = 0.05",
        r"body 'shaft': field 'inner_diameter': 0.05 is not less than diameter 0.05",
    ),
    (
        "inner_without_outer",
        "diameter = 0.05",
        "inner_diameter = 0.02",
        r"body 'shaft': field 'inner_diameter': needs 'diameter'",
    ),
    (
        "no_section",
        "diameter = 0.05\n",
        "",
        r"body 'shaft': field 'diameter': missing \(a section: give 'diameter', or area",
    ),
    (
        "zero_diameter",
        "diameter = 0.05",
        "diameter = 0.0",
        r"body 'shaft': field 'diameter': 0 is not positive \(allowed: > 0 \[m\]\)",
    ),
    (
        "explicit_section_incomplete",
        "second_moment_z = 9.0e-7\n",
        "",
        r"body 'arm': field 'second_moment_z': missing \(an explicit section needs",
    ),
    (
        "explicit_section_nonpositive",
        "polar_moment = 1.3e-6",
        "polar_moment = -1.3e-6",
        r"body 'arm': field 'polar_moment': -1.3e-06 is not positive \(allowed: > 0 \[m\^4\]\)",
    ),
    (
        "orientation_parallel_to_axis",
        "polar_moment = 1.3e-6",
        "polar_moment = 1.3e-6\norientation = [-2.0, 0.0, 0.0]",
        r"body 'arm': field 'orientation': \[-2, 0, 0\] is zero or parallel to the beam axis",
    ),
]


def _bad_text(old: str, new: str, case: str) -> str:
    if case == "duplicate_element_number":  # also number the body 'hub' 7
        return edit(edit(BASE, old, new), 'name = "hub"', 'name = "hub"\nnumber = 7')
    if case.startswith("explicit_") or case == "orientation_parallel_to_axis":
        return edit(edit(BASE, ARM_RIGID, ARM_BEAM + "\n"), old, new)
    return edit(BASE, old, new)


@pytest.mark.parametrize(
    ("case", "old", "new", "pattern"), BAD + BEAM_BAD, ids=[c[0] for c in BAD + BEAM_BAD]
)
def test_bad_input_names_file_element_field(tmp_path, case, old, new, pattern):
    path = write(tmp_path, _bad_text(old, new, case))
    with pytest.raises(ModelError) as info:
        load_model(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: "), message
    assert re.search(pattern, message), message


def test_bodies_not_an_array_of_tables(tmp_path):
    path = write(tmp_path, 'name = "test"\n[body]\nname = "a"\n')
    with pytest.raises(
        ModelError,
        match=r"model\.toml: top level: field 'body': expected an array of tables "
        r"\[\[body\]\], got a table$",
    ):
        load_model(path)


def test_misspelled_machine_field_stops_ufmt_modes(tmp_path):
    """A bad [machine] table fails at load: `ufmt modes` exits 2 with one line (file, field)."""
    machine = MACHINE.replace("tool_radius", "tool_radios")
    path = write(tmp_path, edit(BASE, 'name = "test"', f'name = "test"\nmachine = {{ {machine} }}'))
    res = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", "modes", str(path)], capture_output=True, text=True
    )
    assert res.returncode == 2
    assert res.stderr.strip() == (
        f"ufmt modes: error: {path}: machine: unknown field 'tool_radios' "
        "(did you mean 'tool_radius'?)"
    )


def test_beam_end_within_tolerance_is_accepted(tmp_path):
    # 1e-10 x length off the end is inside the 1e-9 relative tolerance.
    text = edit(
        BASE,
        "at = [0.0, 0.0, 0.5]\nstiffness = [5e8",
        "at = [0.0, 0.0, 0.50000000005]\nstiffness = [5e8",
    )
    text = edit(
        text,
        "at = [0.0, 0.0, 0.5]\nstiffness = [1e8",
        "at = [0.0, 0.0, 0.50000000005]\nstiffness = [1e8",
    )
    assert load_model(write(tmp_path, text)).hinge("h_hub").at[2] == 0.50000000005


def test_file_not_found(tmp_path):
    path = tmp_path / "missing.toml"
    with pytest.raises(ModelError, match=rf"^{re.escape(str(path))}: file not found$"):
        load_model(path)
    with pytest.raises(ModelError, match=r": is a directory, not a file$"):
        load_model(tmp_path)


def test_malformed_toml_gives_line_and_column(tmp_path):
    path = write(tmp_path, edit(BASE, "mass = 250.0", "mass = = 250.0"))
    with pytest.raises(
        ModelError, match=r"model\.toml: malformed TOML: .*\(at line 6, column 8\)$"
    ):
        load_model(path)


def test_text_and_dict_sources_are_named():
    with pytest.raises(ModelError, match=r"^<string>: body 'base': field 'mass': missing"):
        load_model_text(edit(BASE, "mass = 250.0\n", ""))
    with pytest.raises(ModelError, match=r"^built\.toml: top level: field 'body': empty"):
        model_from_dict({"name": "x", "body": []}, source="built.toml")


# ---------------------------------------------------------------------------------------------
# good models


def test_good_fixture_values():
    path = MODELS / "good_mixed.toml"
    model = load_model(path)
    assert model.source == str(path)
    assert model.name == "mixed"
    assert [type(b) for b in model.bodies] == [RigidBody, Beam, VirtualBody, Beam]
    assert [b.number for b in model.bodies] == [1, 2, 3, None]

    base = model.body("base")
    assert base.mass == 250.0
    np.testing.assert_array_equal(base.center_of_mass, [0.0, 0.0, -0.1])
    np.testing.assert_array_equal(base.inertia, [[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0, 0, 30.0]])

    # hollow circle, closed form
    shaft = model.body("shaft")
    outer, inner = 0.05, 0.02
    second = math.pi * (outer**4 - inner**4) / 64
    assert shaft.area == pytest.approx(math.pi * (outer**2 - inner**2) / 4, rel=1e-15)
    assert shaft.second_moment_y == shaft.second_moment_z == pytest.approx(second, rel=1e-15)
    assert shaft.polar_moment == shaft.torsion_constant == pytest.approx(2 * second, rel=1e-15)
    assert shaft.length == 0.5
    assert shaft.orientation is None

    # explicit section: torsion constant defaults to the polar moment
    arm = model.body("arm")
    assert (arm.area, arm.second_moment_y, arm.second_moment_z) == (1.2e-3, 4.0e-7, 9.0e-7)
    assert arm.torsion_constant == arm.polar_moment == 1.3e-6
    np.testing.assert_array_equal(arm.orientation, [0.0, 1.0, 1.0])

    h_ground = model.hinge("h_ground")
    assert h_ground.between == ("ground", "base") and h_ground.number == 4
    np.testing.assert_array_equal(h_ground.damping6, [1e3, 1e3, 2e3, 10.0, 10.0, 10.0])
    h_shaft = model.hinge("h_shaft")
    np.testing.assert_array_equal(h_shaft.rigid, [True] * 5 + [False])
    np.testing.assert_array_equal(h_shaft.released, [False] * 5 + [True])
    np.testing.assert_array_equal(h_shaft.damping6, np.zeros(6))
    np.testing.assert_array_equal(model.hinge("h_hub").released, [False] * 3 + [True] * 3)

    machine = model.machine
    assert (machine.tool_body, machine.workpiece_body, machine.rotation) == ("arm", "base", "ccw")
    assert (machine.spindle_axis_xy, machine.cutting_plane_z) == ((0.1, 0.0), 0.0)
    assert (machine.tool_radius, machine.workpiece_size) == (0.2, (0.05, 0.04))
    assert (machine.nose_radius, machine.force_scale) == (2e-3, 1.0)  # given, default
    assert list(machine.table) == [
        "tool_body",
        "workpiece_body",
        "spindle_axis_xy",
        "cutting_plane_z",
        "tool_radius",
        "workpiece_size",
        "workpiece_center_xy",
        "rotation",
        "nose_radius",
    ]
    for b in (base, shaft, arm):
        for v in vars(b).values():
            if isinstance(v, np.ndarray):
                assert not v.flags.writeable
    for v in (h_ground.at, h_ground.stiffness, h_ground.damping):
        assert not v.flags.writeable


def test_str_and_path_sources_agree():
    path = MODELS / "good_mixed.toml"
    assert model_to_toml(load_model(str(path))) == model_to_toml(load_model(path))


def test_solid_circle_and_explicit_torsion_constant(tmp_path):
    model = load_model(write(tmp_path, BASE))
    shaft = model.body("shaft")
    assert shaft.area == pytest.approx(math.pi * 0.05**2 / 4, rel=1e-15)
    assert shaft.second_moment_y == pytest.approx(math.pi * 0.05**4 / 64, rel=1e-15)
    text = edit(BASE, ARM_RIGID, ARM_BEAM + "torsion_constant = 2.5e-7\n\n")
    arm = load_model(write(tmp_path, text)).body("arm")
    assert (arm.polar_moment, arm.torsion_constant) == (1.3e-6, 2.5e-7)


def test_inertia_limits_accepted(tmp_path):
    # A thin disc sits exactly on the triangle inequality: I_z = I_x + I_y.
    disc = "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]"
    old = "[[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0.0, 0.0, 30.0]]"
    model = load_model(write(tmp_path, edit(BASE, old, disc)))
    np.testing.assert_array_equal(model.body("base").inertia, np.diag([1.0, 1.0, 2.0]))
    # Asymmetry of 1e-12 relative is inside the 1e-9 tolerance; the stored tensor is symmetric.
    nearly = "[[20.0, 0.5, 0.0], [0.50000000000002, 22.0, 0.0], [0.0, 0.0, 30.0]]"
    inertia = load_model(write(tmp_path, edit(BASE, old, nearly))).body("base").inertia
    np.testing.assert_array_equal(inertia, inertia.T)


def test_model_from_dict_accepts_numpy_and_matches_toml(tmp_path):
    data = {
        "name": "test",
        "body": [
            {
                "name": "base",
                "kind": "rigid",
                "mass": np.float64(250.0),
                "center_of_mass": np.array([0.0, 0.0, -0.1]),
                "inertia": np.array([[20.0, 0.5, 0.0], [0.5, 22.0, 0.0], [0.0, 0.0, 30.0]]),
            }
        ],
        "hinge": [
            {
                "name": "h_ground",
                "between": ("ground", "base"),
                "at": (0.0, 0.0, -0.2),
                "stiffness": [np.inf, 0, np.int64(7)],
                "rotational_stiffness": np.full(3, 1e8),
            }
        ],
    }
    model = model_from_dict(data, source="built")
    assert model.source == "built"
    hinge = model.hinge("h_ground")
    np.testing.assert_array_equal(hinge.stiffness, [np.inf, 0.0, 7.0])
    assert hinge.between == ("ground", "base")
    again = load_model_text(model_to_toml(model))
    np.testing.assert_array_equal(again.body("base").inertia, data["body"][0]["inertia"])
    np.testing.assert_array_equal(again.hinge("h_ground").stiffness, [np.inf, 0.0, 7.0])


# ---------------------------------------------------------------------------------------------
# round trip


def _fields(obj) -> dict:
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in vars(obj).items()}


def assert_same_model(a, b):
    assert a.name == b.name
    assert a.machine == b.machine
    assert [_fields(x) for x in a.bodies] == [_fields(x) for x in b.bodies]
    assert [_fields(x) for x in a.hinges] == [_fields(x) for x in b.hinges]


def test_round_trip_fixture_is_exact():
    model = load_model(MODELS / "good_mixed.toml")
    text = model_to_toml(model)
    assert "inf" in text
    again = load_model_text(text)
    assert_same_model(model, again)
    assert model_to_toml(again) == text


def test_round_trip_full_precision_and_awkward_names(tmp_path):
    text = edit(BASE, 'name = "test"', 'name = "quote \\" back\\\\slash \\t tab, ünï"')
    text = edit(text, "mass = 250.0", "mass = 0.1234567890123456789")
    text = edit(text, 'name = "hub"', 'name = "hub \\"9\\""')
    text = text.replace('"hub"', '"hub \\"9\\""')
    text += (  # keys out of the documented order, integers where floats are meant
        '\n[machine]\nrotation = "cw"\ntool_body = "arm"\nworkpiece_body = "base"\n'
        "spindle_axis_xy = [0, 0]\ncutting_plane_z = 1\ntool_radius = 0.1234567890123456789\n"
        "workpiece_size = [0.1, 0.1]\nworkpiece_center_xy = [0, 0]\nforce_scale = 2\n"
    )
    model = load_model(write(tmp_path, text))
    assert model.body("base").mass == 0.1234567890123456789
    assert "cutting_plane_z = 1\ntool_radius = 0.12345678901234568\n" in model_to_toml(model)
    assert model.body('hub "9"').kind == "virtual"
    out = model_to_toml(model)
    again = load_model_text(out)
    assert_same_model(model, again)
    assert model_to_toml(again) == out
