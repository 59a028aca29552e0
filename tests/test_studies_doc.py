"""docs/studies.md: every example parses as the study it claims, and every key the study
reader knows is documented in a table there."""

import re
import tomllib
from pathlib import Path

import pytest

from ufmt.model.design import DESIGN_ENTRY_FIELDS
from ufmt.studies.fields import AXIS_FIELDS, BOUND_FIELDS, COMMON_FIELDS, GRID_FIELDS
from ufmt.studies.kinds import KINDS
from ufmt.studies.load import load_study
from ufmt.studies.optimise import OPTIMISER_DEFAULTS

DOC = Path(__file__).resolve().parents[1] / "docs" / "studies.md"
TEXT = DOC.read_text()
EXAMPLES = re.findall(r"```toml\n(.*?)```", TEXT, flags=re.S)
DOCUMENTED = set(re.findall(r"^\| `([a-z_]+)` \|", TEXT, flags=re.M))


def test_the_page_shows_an_example_of_every_kind():
    kinds = {tomllib.loads(e)["kind"] for e in EXAMPLES}
    assert kinds == set(KINDS)


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: tomllib.loads(e)["name"])
def test_every_example_parses(tmp_path, example):
    path = tmp_path / "study.toml"
    path.write_text(example)
    study = load_study(path)
    data = tomllib.loads(example)
    assert study.kind == data["kind"] and study.name == data["name"]


def test_every_key_the_reader_knows_is_documented():
    tables = (AXIS_FIELDS, BOUND_FIELDS, GRID_FIELDS, OPTIMISER_DEFAULTS, DESIGN_ENTRY_FIELDS)
    known = set(COMMON_FIELDS).union(*tables)
    for kind in KINDS.values():
        known |= set(kind.fields)
    assert known - DOCUMENTED == set()
