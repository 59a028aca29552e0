"""The one table checker (ufmt.tables.Where). Oracle: the wording table in its module
docstring; every message is one line naming file, table and field, raised as the caller's
exception."""

import math

import numpy as np
import pytest

from ufmt.errors import ModelError, StudyError
from ufmt.tables import Where

MACHINE = Where("ufmt.toml", "machine", error=ModelError)


def message(call) -> str:
    with pytest.raises(ModelError) as info:
        call()
    text = str(info.value)
    assert "\n" not in text
    return text


def test_prefix_names_file_table_and_field():
    assert MACHINE.message("bad") == "ufmt.toml: machine: bad"
    assert MACHINE.message("bad", "tool_radius") == "ufmt.toml: machine: field 'tool_radius': bad"
    study = Where("study.toml", error=StudyError)
    assert study.message("bad", "n") == "study.toml: field 'n': bad"
    axis = study.sub("axis[2]")
    assert axis.sub("range").message("bad") == "study.toml: axis[2].range: bad"
    with pytest.raises(StudyError, match=r"^study\.toml: axis\[2\]: field 'n': bad$"):
        axis.fail("n", "bad")


def test_unknown_and_missing_keys():
    valid = ("tool_radius", "rotation")
    assert message(lambda: MACHINE.keys({"tool_radios": 1}, valid)).endswith(
        "machine: unknown field 'tool_radios' (did you mean 'tool_radius'?)"
    )
    assert message(lambda: MACHINE.keys({"zzz": 1}, valid)).endswith(
        "machine: unknown field 'zzz' (valid fields: tool_radius, rotation)"
    )
    assert message(lambda: MACHINE.keys({}, valid, required=valid)).endswith(
        "field 'tool_radius': missing (required)"
    )


@pytest.mark.parametrize(
    ("value", "rules", "problem"),
    [
        ("big", {"unit": "[m]"}, "expected a number, got string 'big' (allowed: finite [m])"),
        (True, {}, "expected a number, got boolean True (allowed: finite)"),
        (math.nan, {"sign": "positive"}, "nan is not a number (allowed: > 0)"),
        (0.0, {"sign": "positive", "unit": "[kg]"}, "0 is not positive (allowed: > 0 [kg])"),
        (-5, {"sign": "nonnegative"}, "-5 is negative (allowed: >= 0, finite)"),
        (math.inf, {"unit": "[m]"}, "inf is not finite (allowed: finite [m])"),
    ],
)
def test_number_rules(value, rules, problem):
    text = message(lambda: MACHINE.number("x", value, **rules))
    assert text == f"ufmt.toml: machine: field 'x': {problem}"


def test_numbers_ranges_and_choices():
    assert MACHINE.number("x", np.int64(3)) == 3.0 and MACHINE.number("x", math.inf, infinite=True)
    assert MACHINE.within("x", 0.3, 0.3, 3.0) == 0.3
    assert message(lambda: MACHINE.within("force_scale", 36.3, 0.3, 3.0)).endswith(
        "field 'force_scale': 36.3 is outside the allowed range [0.3, 3]"
    )
    assert message(lambda: MACHINE.within("nose_radius", 0.5, 1e-4, 5e-2, "[m]")).endswith(
        "0.5 is outside the allowed range [0.0001, 0.05] [m]"
    )
    assert MACHINE.numbers("xy", (1, 2.5), 2, unit="[m]") == [1.0, 2.5]
    assert message(lambda: MACHINE.numbers("xy", [1.0], 2, unit="[m]")).endswith(
        "field 'xy': expected 2 numbers [m], got an array of 1"
    )
    assert message(lambda: MACHINE.numbers("xy", [1.0, -1], 2, sign="positive")).endswith(
        "field 'xy[1]': -1 is not positive (allowed: > 0)"
    )
    assert MACHINE.choice("rotation", "cw", ("cw", "ccw"), "rotation") == "cw"
    assert message(lambda: MACHINE.choice("kind", "rigd", ("rigid", "beam"), "kind")).endswith(
        "field 'kind': unknown kind 'rigd' (did you mean 'rigid'?)"
    )
    assert message(lambda: MACHINE.choice("b", "x", ("hub", "arm"), "body", "bodies")).endswith(
        "field 'b': unknown body 'x' (valid bodies: hub, arm)"
    )


def test_counts_minimums_intervals_and_duplicates():
    assert MACHINE.integer("n", 3, 1, 5) == 3 and MACHINE.integer("seed", 0, 0) == 0
    assert message(lambda: MACHINE.integer("n", 9, 1, 5)).endswith(
        "field 'n': 9 is outside the allowed range [1, 5]"
    )
    assert message(lambda: MACHINE.integer("n", 36339061537, 1, 100_000)).endswith(
        "field 'n': 36339061537 is outside the allowed range [1, 100000]"  # digits, not 3.6e10
    )
    assert message(lambda: MACHINE.integer("starts", 0, 1)).endswith(
        "field 'starts': 0 is too small (allowed: >= 1)"
    )
    assert message(lambda: MACHINE.integer("n", 2.5, 1)).endswith(
        "field 'n': expected an integer, got float 2.5 (allowed: >= 1)"
    )
    assert message(lambda: MACHINE.minimum("factor", 1.0, 1.0, strict=True)).endswith(
        "field 'factor': 1 is too small (allowed: > 1)"
    )
    assert MACHINE.interval("range", [1, 2.5]) == (1.0, 2.5)
    assert MACHINE.interval("band", [1, 1], allow_equal=True) == (1.0, 1.0)
    assert message(lambda: MACHINE.interval("range", [400, 200])).endswith(
        "field 'range': reversed bounds [400, 200] (allowed: lower < upper)"
    )
    assert message(lambda: MACHINE.interval("range", [300, 300])).endswith(
        "field 'range': empty range [300, 300] (allowed: lower < upper)"
    )
    assert MACHINE.unique("axis", ["rpm", "feed"]) == ["rpm", "feed"]
    assert message(lambda: MACHINE.unique("axis", ["rpm", "rpm"])).endswith(
        "field 'axis': 'rpm' appears more than once"
    )
    assert MACHINE.items("hinges", ("h1",), "hinge name") == ["h1"]
    assert message(lambda: MACHINE.items("hinges", [], "hinge name", required=True)).endswith(
        "field 'hinges': empty (at least one hinge name is required)"
    )
    assert MACHINE.boolean("fit", False) is False
    assert message(lambda: MACHINE.boolean("fit", "no")).endswith(
        "field 'fit': expected true or false, got string 'no'"
    )


def test_unreadable_files_read_alike_in_every_loader(tmp_path):
    """Oracle: the wording of ufmt.tomlfile's docstring, the same from the model, study and
    settings loaders (only the exception class differs)."""
    from ufmt.model.load import load_model
    from ufmt.studies.load import load_study
    from ufmt.tomlfile import read_toml

    latin = tmp_path / "latin.toml"
    latin.write_bytes(b'name = "caf\xe9"\n')
    malformed = tmp_path / "bad.toml"
    malformed.write_text("name = \n", encoding="utf-8")
    cases = {
        tmp_path / "none.toml": "file not found",
        tmp_path: "is a directory, not a file",
        latin: "not UTF-8 text (byte 11)",
    }
    loaders = ((load_model, ModelError), (load_study, StudyError), (read_toml, StudyError))
    for load, error in loaders:
        for path, problem in cases.items():
            with pytest.raises(error) as info:
                load(path)
            assert str(info.value) == f"{path}: {problem}"
        with pytest.raises(error) as info:
            load(malformed)
        assert str(info.value).startswith(f"{malformed}: malformed TOML: ")
