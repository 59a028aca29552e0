"""Validation against Table 3 (ufmt.calibration.frequencies) and the packaged, identified model.

Oracles: the committed validation table (golden file, regenerated with ``make validate``);
the assembled mass-stiffness model as an independent solver of the same file; the validation's
targets and the documented calibration bands; hand-built mode sets whose classes, phases and
tool-tip motion are known in closed form.
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ufmt.calibration.frequencies import (
    ModeSet,
    Reference,
    ReferenceMode,
    Tag,
    check_tag,
    modeset_from_mstmm,
    pair_by_class,
    read_reference,
    tool_tip_neighbours,
    validate,
)
from ufmt.defaults import PAPER_MODES
from ufmt.errors import StudyError
from ufmt.model.load import load_model
from ufmt.plots import save_figure
from ufmt.plots.modes import equivalent_box, plot_frequencies, plot_mode

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "ufmt" / "data"
COMMITTED = ROOT / "results" / "validation" / "frequencies.csv"
COMMITTED_RESPONSE = ROOT / "results" / "validation" / "response.csv"
N_MODES = PAPER_MODES
TESTED = [1, 2, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 29]
TEXT_COLUMNS = ["symmetry_class", "shape", "table3_shape", "tag_check", "tag_detail"]
# numeric columns: (rtol, atol); values that are zero by symmetry carry solver noise only
NUMERIC = {
    "mode": (0.0, 0.0),
    "test_hz": (0.0, 0.0),
    "paper_mstmm_hz": (0.0, 0.0),
    "paper_fem_hz": (0.0, 0.0),
    "mstmm_hz": (1e-9, 0.0),
    "assembled_hz": (1e-9, 0.0),
    "mstmm_error_percent": (0.0, 1e-7),
    "paper_mstmm_error_percent": (0.0, 1e-9),
    "paper_fem_error_percent": (0.0, 1e-9),
    "assembled_vs_mstmm": (0.0, 1e-9),
    "class_purity": (0.0, 1e-9),
    "tool_tip_z": (0.0, 1e-9),  # [m/sqrt(kg)]; the largest are ~5e-2
    "tool_tip_z_participation": (0.0, 1e-7),
}


@pytest.fixture(scope="module")
def model():
    return load_model(DATA / "ufmt.toml")


@pytest.fixture(scope="module")
def reference():
    return read_reference(DATA / "paper_reference.toml")


@pytest.fixture(scope="module")
def result(model, reference):
    return validate(model, reference, N_MODES)


# ---------------------------------------------------------------------------------------------
# the packaged model against its committed table and the targets


def test_packaged_model_reproduces_its_validation_table(result):
    committed = pd.read_csv(COMMITTED, keep_default_na=False, na_values=[""])
    fresh = result.table
    assert list(fresh.columns) == list(committed.columns)
    assert set(fresh.columns) == set(NUMERIC) | set(TEXT_COLUMNS)
    for column, (rtol, atol) in NUMERIC.items():
        np.testing.assert_allclose(
            fresh[column].to_numpy(float),
            committed[column].to_numpy(float),
            rtol=rtol,
            atol=atol,
            equal_nan=True,
            err_msg=column,
        )
    for column in TEXT_COLUMNS:
        assert fresh[column].fillna("").tolist() == committed[column].fillna("").tolist(), column


def committed_response_targets() -> tuple[pd.DataFrame, list]:
    """results/validation/response.csv and the [response] targets it has one row for."""
    from ufmt.calibration.settings import read_response_settings
    from ufmt.tomlfile import read_toml

    committed = pd.read_csv(COMMITTED_RESPONSE)
    targets = read_response_settings(
        read_toml(DATA / "calibration.toml")["response"],
        read_toml(DATA / "paper_reference.toml"),
        "calibration.toml",
    ).targets
    assert committed["metric"].tolist() == [t.metric for t in targets]
    assert {"paper", "ours", "error_percent", "fitted"} <= set(committed.columns)
    return committed, targets


def test_committed_response_table_has_the_packaged_models_periodic_numbers(model, packaged_basis):
    """results/validation/response.csv (written by ``ufmt validate``): one row per paper
    quantity of the [response] targets; its fast periodic-path column is the packaged
    model's. (Small version: the exact time path of every column is the slow test below.)"""
    from ufmt.calibration.response import reference_process
    from ufmt.calibration.response_fit import response_metrics
    from ufmt.tomlfile import read_toml

    committed, targets = committed_response_targets()
    process = reference_process(read_toml(DATA / "paper_reference.toml"))
    fast = response_metrics(model, process, packaged_basis, "periodic")  # the same file
    np.testing.assert_allclose(
        [fast[t.metric] for t in targets],
        committed["ours_periodic"].to_numpy(float),
        rtol=1e-5,  # the file is written to 6 significant digits
    )


@pytest.mark.slow
def test_committed_response_table_matches_the_packaged_model(model):
    """Every column of results/validation/response.csv is the packaged model's."""
    from ufmt.calibration.response import response_table

    committed, _ = committed_response_targets()
    # as `ufmt validate` does: the response's default basis (every mode below the cutoff)
    fresh = response_table(model, DATA / "paper_reference.toml")
    assert list(fresh.columns) == list(committed.columns)
    for column in ("paper", "ours", "ours_periodic", "error_percent"):
        np.testing.assert_allclose(
            fresh[column].to_numpy(float),
            committed[column].to_numpy(float),
            rtol=1e-5,  # the file is written to 6 significant digits
            equal_nan=True,
            err_msg=column,
        )
    assert fresh["reproduced"].tolist() == committed["reproduced"].tolist()
    assert fresh["fitted"].tolist() == committed["fitted"].tolist()


def test_mstmm_and_assembled_model_agree_for_30_modes(result):
    table = result.table
    assert len(table) == N_MODES
    relative = (table["assembled_hz"] / table["mstmm_hz"] - 1.0).abs()
    assert relative.max() <= 1e-4


def test_packaged_model_meets_the_frequency_targets(result):
    tested = result.table.set_index("mode").loc[TESTED]
    err = tested["mstmm_error_percent"].abs()
    assert err.max() <= 3.0
    assert err.mean() <= 1.0
    f = result.table["mstmm_hz"].to_numpy()
    assert np.all(f[:5] < 30.0) and f[5] > 30.0
    assert abs(f[5] / 42.5 - 1.0) < 0.03


def test_tool_tip_moves_most_in_z_in_modes_11_12_18_29(result, reference):
    assert reference.tool_tip_z_modes == (11, 12, 18, 29)
    assert all(tool_tip_neighbours(result.modes, reference.tool_tip_z_modes).values())


def test_identified_stiffnesses_are_inside_their_bands(model):
    with open(DATA / "calibration.toml", "rb") as fh:
        calibration = tomllib.load(fh)
    prior = load_model(DATA / calibration["prior"])
    for p in calibration["parameter"]:
        lo, hi = p["band"]
        scales = {
            float(getattr(model.hinge(h), p["field"])[c] / getattr(prior.hinge(h), p["field"])[c])
            for h in p["hinges"]
            for c in p["components"]
        }
        assert max(scales) / min(scales) - 1.0 < 1e-12, p["name"]  # tied: one factor
        assert lo * (1 - 1e-12) <= scales.pop() <= hi * (1 + 1e-12), p["name"]
    # everything not identified is the prior's
    for h_prior, h in zip(prior.hinges, model.hinges, strict=True):
        np.testing.assert_array_equal(h.damping6, h_prior.damping6)
    assert [b.name for b in model.bodies] == [b.name for b in prior.bodies]


def test_packaged_model_file_says_it_is_generated():
    head = (DATA / "ufmt.toml").read_text().splitlines()[:3]
    assert head[0].startswith("# GENERATED")
    assert any("ufmt calibrate" in line for line in head)


def test_plots_are_written(model, result, tmp_path):
    chart = save_figure(plot_frequencies(result.table), tmp_path / "f.png")
    mode = save_figure(plot_mode(model, result.solution.shapes, 10), tmp_path / "m.png")
    for path in (chart, mode):
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ---------------------------------------------------------------------------------------------
# tags, pairing and the tool tip on hand-built modes


BODIES = ("foundation", "bed", "head")
MASSES = np.array([1000.0, 100.0, 10.0])


def _modes(motions, tip=None) -> ModeSet:
    """ModeSet of rigid-body motions (n, 3 bodies, 6) [r; theta], unit inertia per axis."""
    motion = np.asarray(motions, dtype=float)
    energy = MASSES[None, :, None] * motion**2
    shares = energy / energy.sum(axis=(1, 2), keepdims=True)
    n = motion.shape[0]
    return ModeSet(
        np.arange(1.0, n + 1.0),
        BODIES,
        MASSES,
        shares,
        motion,
        np.zeros(n) if tip is None else np.asarray(tip, dtype=float),
    )


def _unit(body: int, direction: int, value: float = 1.0) -> np.ndarray:
    m = np.zeros((3, 6))
    m[body, direction] = value
    return m


def test_check_tag_reads_class_bodies_and_phase():
    same = _unit(0, 5) + _unit(1, 5, 3.0)  # foundation and bed turn about z together
    opposite = _unit(0, 5) + _unit(1, 5, -3.0)
    bounce = _unit(0, 2) + _unit(1, 2)
    bed_only = _unit(0, 5, 1e-3) + _unit(1, 5)  # foundation amplitude 1e-3 of the bed's
    modes = _modes([same, opposite, bounce, bed_only])
    tag = Tag(("bed", "foundation"), "rz", "same")
    assert check_tag(modes, 0, tag)[0] == "ok"
    assert check_tag(modes, 1, tag)[0] == "phase"
    assert check_tag(modes, 2, tag)[0] == "class"
    assert check_tag(modes, 3, tag)[0] == "bodies"
    # rocking about x belongs with translation along y (one symmetry class)
    rock = _modes([_unit(1, 3) + _unit(1, 1, 0.5)])
    assert rock.classes()[0][0] == 1
    assert check_tag(rock, 0, Tag(("bed",), "y"))[0] == "ok"


def test_pair_by_class_keeps_rank_within_class():
    tags = {1: "rz", 2: "z", 3: "rz", 4: "z"}
    reference = Reference(
        {k: ReferenceMode(k, 1.0, None, None, "", Tag(("bed",), m)) for k, m in tags.items()},
        (),
        "<test>",
    )
    # model: z, rz, rz, z  (first two swapped with respect to the table)
    modes = _modes([_unit(1, 2), _unit(1, 5), _unit(1, 5, 2.0), _unit(1, 2, 2.0)])
    assert pair_by_class(reference, [1, 2, 3, 4], modes).tolist() == [1, 0, 2, 3]
    # beyond the tagged run 1..4: by order
    assert pair_by_class(reference, [4], modes).tolist() == [3]


def test_tool_tip_neighbours_compares_with_the_nearest_other_modes():
    modes = _modes([_unit(1, 2)] * 6, tip=[0.1, 0.5, 0.2, 0.3, 0.0, 0.4])
    assert tool_tip_neighbours(modes, [2, 4]) == {2: True, 4: True}  # 2 vs 1, 3; 4 vs 3, 5
    assert tool_tip_neighbours(modes, [3]) == {3: False}  # 0.2 < 0.5 of mode 2
    assert tool_tip_neighbours(modes, [6]) == {6: True}  # last mode: one neighbour


def test_tool_tip_z_is_head_z_plus_tilt_times_radius(model, result):
    """z of the tip at (x0, y0 + R, z_c): u_z + theta_x R - theta_y * 0 (closed form)."""
    machine = model.machine
    head = model.body(machine.tool_body)
    v = result.solution.shapes.rigid[head.name]
    arm_y = machine.spindle_axis_xy[1] + machine.tool_radius - head.center_of_mass[1]
    arm_x = machine.spindle_axis_xy[0] - head.center_of_mass[0]
    expected = v[:, 2] + v[:, 3] * arm_y - v[:, 4] * arm_x
    np.testing.assert_allclose(result.modes.tool_tip_z, expected, rtol=0, atol=1e-15)
    fresh = modeset_from_mstmm(model, result.solution.shapes)
    np.testing.assert_array_equal(fresh.tool_tip_z, result.modes.tool_tip_z)


def test_equivalent_box_of_a_box_is_the_box():
    from ufmt.model.schema import RigidBody

    m, a, b, c = 12.0, 0.3, 0.5, 0.7
    inertia = np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12
    body = RigidBody("box", m, np.zeros(3), inertia)
    np.testing.assert_allclose(equivalent_box(body), [a, b, c], rtol=1e-12)


def test_bad_reference_tag_names_file_and_field(tmp_path):
    text = (DATA / "paper_reference.toml").read_text()
    bad = tmp_path / "reference.toml"
    bad.write_text(
        text.replace('motion = "rz", phase = "same"', 'motion = "rot", phase = "same"', 1)
    )
    with pytest.raises(StudyError) as info:
        read_reference(bad)
    assert str(info.value) == (
        f"{bad}: mode[0].tag: field 'motion': unknown motion 'rot'"
        " (valid motions: x, y, z, rx, ry, rz)"
    )
