"""Every body kind the model files accept has one entry in each per-kind table outside the
solvers (the mode plots, the mode classification), and the report reads a body's kind and
mass from the body record.

Oracles: the kind list of the model schema (``ufmt.model.rules.KINDS``); the kinds written in
the packaged model file; the rigid motion of a rigid body, which the mode
classification must pass through unchanged while other kinds carry none.
"""

from __future__ import annotations

import numpy as np

from ufmt.calibration.frequencies import MOVES_AS_ONE_FRAME, modeset_from_mstmm
from ufmt.model.load import load_model, packaged_path
from ufmt.model.rules import KINDS
from ufmt.mstmm.solve import solve_modes
from ufmt.plots.modes import BODY_DRAWINGS
from ufmt.tomlfile import read_toml


def test_each_body_kind_has_one_entry_per_table():
    assert set(BODY_DRAWINGS) == set(KINDS)
    assert set(MOVES_AS_ONE_FRAME) == set(KINDS)


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
