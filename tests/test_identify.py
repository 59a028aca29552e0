"""Identification of hinge stiffnesses (ufmt.calibration: settings, reduced, identify, pipeline).

Oracles: an independent eigen-solution (``ufmt.assembled.assembled_modes`` on the model with the
stiffnesses written in) for the cheap affine model and for the "measured" frequencies of a
perturbed model whose stiffnesses are therefore known; central finite differences for the exact
sensitivities (the sum of a hinge's sensitivities is half its strain-energy share); a feasible
constraint that must move a known amount of load; the packaged files for the error messages
(file and field named).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from ufmt.assembled import assembled_modes
from ufmt.calibration.frequencies import Reference, ReferenceMode, Tag, modeset_from_dofs
from ufmt.calibration.identify import identify
from ufmt.calibration.pipeline import calibrate
from ufmt.calibration.reduced import ReducedModel, apply_parameters
from ufmt.calibration.settings import (
    Constraint,
    Parameter,
    Settings,
    Targets,
    load_calibration,
)
from ufmt.cli import main
from ufmt.defaults import PAPER_MODES
from ufmt.errors import StudyError
from ufmt.model.load import load_model

DATA = Path(__file__).resolve().parents[1] / "ufmt" / "data"
CALIBRATION = DATA / "calibration.toml"
PRIOR = DATA / "ufmt-prior.toml"
N_MODES = PAPER_MODES
ELEMENTS = 8

# a few well-separated parameters, each driving some of the first 30 modes
PARAMETERS = (
    Parameter("h14.z", ("h14",), "stiffness", (2,), (0.2, 5.0)),
    Parameter("h14.rz", ("h14",), "rotational_stiffness", (2,), (0.2, 5.0)),
    Parameter("h15.z", ("h15",), "stiffness", (2,), (0.2, 5.0)),
    Parameter("gantry_joints.z", ("h17", "h18", "h29", "h30"), "stiffness", (2,), (0.2, 5.0)),
    Parameter("h16.x", ("h16",), "stiffness", (0,), (1 / 3, 3.0)),
    Parameter("h31.z", ("h31",), "stiffness", (2,), (0.5, 2.0)),
)
TRUE_SCALES = np.array([1.3, 0.7, 1.3, 0.7, 1.25, 0.75])  # +-25..30 % from the prior


@pytest.fixture(scope="module")
def prior():
    return load_model(PRIOR)


@pytest.fixture(scope="module")
def reduced(prior):
    return ReducedModel.build(prior, PARAMETERS, ELEMENTS)


def test_affine_model_matches_the_assembled_model(prior, reduced):
    u = np.log(TRUE_SCALES)
    f, _ = reduced.solve(u, N_MODES)
    truth = assembled_modes(
        apply_parameters(prior, PARAMETERS, u), count=N_MODES, elements_per_beam=ELEMENTS
    ).frequencies_hz
    # both solve the square-root form K = F^T F by an SVD: relative accuracy near eps even for
    # the lowest roots of a K with condition ~1e11
    np.testing.assert_allclose(f, truth, rtol=1e-9)


def test_sensitivities_are_the_derivatives_of_ln_f(reduced):
    u = np.log(TRUE_SCALES)
    f, shapes = reduced.solve(u, N_MODES)
    exact = reduced.sensitivities(u, f, shapes)
    step = 1e-2
    for p in range(len(PARAMETERS)):
        du = np.zeros(len(PARAMETERS))
        du[p] = step
        up, _ = reduced.solve(u + du, N_MODES)
        down, _ = reduced.solve(u - du, N_MODES)
        central = (np.log(up) - np.log(down)) / (2 * step)
        # central difference: step^2 * d3(ln f)/du3 / 6 <~ 2e-5, plus the solver's rounding
        # (~1e-13 of ln f, see above) / step
        np.testing.assert_allclose(exact[:, p], central, atol=1e-4, err_msg=PARAMETERS[p].name)
    # each frequency's sensitivities to all stiffness sum to 1/2 at most (f ~ sqrt(k))
    assert np.all(exact >= -1e-12) and np.all(exact.sum(axis=1) <= 0.5 + 1e-9)


def _class_reference(model, modes) -> Reference:
    """A Table-3-like reference whose tags are the symmetry classes of ``modes`` (ModeSet)."""
    classes, _ = modes.classes()
    motion = {0: "x", 1: "y", 2: "z", 3: "rz"}
    return Reference(
        {
            k + 1: ReferenceMode(k + 1, f, None, None, "", Tag((model.bodies[0].name,), motion[c]))
            for k, (f, c) in enumerate(zip(modes.frequencies_hz, classes, strict=True))
        },
        (),
        "<truth>",
    )


def _exact_settings(n_modes: int, elements: int) -> Settings:
    """Identification settings that fit to the targets exactly: no regularisation, no shape
    penalty, no global start."""
    return Settings(
        regularisation=0.0,
        tolerance_percent=1e-6,
        max_iterations=40,
        shape_penalty=0.0,
        global_start=False,
        n_modes=n_modes,
        elements_per_beam=elements,
    )


def test_recovers_known_stiffnesses_from_perturbed_model_frequencies(prior):
    """+-25..30 % on six factors; modes 2/3 and others change order, so pair by class."""
    truth_model = apply_parameters(prior, PARAMETERS, np.log(TRUE_SCALES))
    truth = assembled_modes(truth_model, count=N_MODES, elements_per_beam=ELEMENTS)
    modes = modeset_from_dofs(truth_model, truth.assembled, truth.frequencies_hz, truth.shapes)
    numbers = tuple(range(1, N_MODES + 1))
    targets = Targets(numbers, np.asarray(truth.frequencies_hz))
    settings = _exact_settings(N_MODES, ELEMENTS)
    result = identify(prior, PARAMETERS, targets, settings, _class_reference(prior, modes))
    np.testing.assert_allclose(result.scales, TRUE_SCALES, rtol=5e-3)
    assert np.max(np.abs(result.evaluation.errors_percent)) < 1e-3
    assert result.log["cost"].is_monotonic_decreasing


def test_pairing_by_order_alone_fails_when_modes_change_places(prior):
    """Without classes, modes 2 (bounce) and 3 (bed torsion) swap and the fit goes astray."""
    truth_model = apply_parameters(prior, PARAMETERS, np.log(TRUE_SCALES))
    truth = assembled_modes(truth_model, count=N_MODES, elements_per_beam=ELEMENTS)
    targets = Targets(tuple(range(1, N_MODES + 1)), np.asarray(truth.frequencies_hz))
    settings = Settings(
        regularisation=0.0, global_start=False, n_modes=N_MODES, elements_per_beam=ELEMENTS
    )
    result = identify(prior, PARAMETERS, targets, settings)
    assert abs(result.scales[0] / TRUE_SCALES[0] - 1.0) > 0.1


def test_global_start_takes_over_where_the_local_iteration_stalls(prior):
    """From a corner of the bands, one local step is not enough (a stall): DE then finds it."""
    params = PARAMETERS[:3]
    true_scales = TRUE_SCALES[:3]
    truth = assembled_modes(
        apply_parameters(prior, params, np.log(true_scales)), count=10, elements_per_beam=4
    ).frequencies_hz
    targets = Targets(tuple(range(1, 11)), np.asarray(truth))
    settings = Settings(
        regularisation=0.0,
        tolerance_percent=1e-6,
        max_iterations=1,
        accept_max_percent=1e-3,
        accept_mean_percent=1e-3,
        n_modes=10,
        elements_per_beam=4,
        population=8,
        generations=15,
    )
    start = np.log([5.0, 0.2, 5.0])
    result = identify(prior, params, targets, settings, u0=start)
    assert result.used_global_start
    assert list(dict.fromkeys(result.log["stage"])) == [
        "local",
        "global",
        "local after global start",
    ]
    np.testing.assert_allclose(result.scales, true_scales, rtol=5e-3)
    again = identify(prior, params, targets, settings, u0=start)
    np.testing.assert_array_equal(result.u, again.u)  # deterministic (seeded)


# ---------------------------------------------------------------------------------------------
# the spindle-bearing constraint (section 4.2)


def test_bearing_energy_share_is_twice_the_sum_of_its_sensitivities():
    prior = load_model(PRIOR)
    params = (
        Parameter("h25.t", ("h25",), "stiffness", (0, 1, 2), (0.5, 2.0)),
        Parameter("h25.r", ("h25",), "rotational_stiffness", (0, 1), (0.5, 2.0)),
        Parameter("h31.z", ("h31",), "stiffness", (2,), (0.5, 2.0)),
    )
    reduced = ReducedModel.build(prior, params, 4)
    u = np.log([1.3, 0.8, 1.1])
    f, shapes = reduced.solve(u, 20)
    sens = reduced.sensitivities(u, f, shapes)
    share = reduced.energy_shares(u, f, shapes, ["h25"])
    np.testing.assert_allclose(share, 2.0 * sens[:, :2].sum(axis=1), rtol=1e-9, atol=1e-15)
    assert np.all((share >= 0.0) & (share <= 1.0))


def test_bearing_constraint_moves_the_axial_load_to_the_head_bearing():
    """Mode 18 (spindle + head axial) is matched at the prior with 43 % of its strain energy in
    h25; with the constraint (x2 on h25 moves it by <= 5 %, i.e. share <= 0.141) the
    identification must trade h25.z for h31.z, keeping the frequency."""
    prior = load_model(PRIOR)
    params = (
        Parameter("h25.z", ("h25",), "stiffness", (2,), (0.1, 10.0)),
        Parameter("h31.z", ("h31",), "stiffness", (2,), (0.1, 10.0)),
    )
    f, shapes = ReducedModel.build(prior, params, 4).solve(np.zeros(2), 20)
    targets = Targets((18,), f[17:18])
    settings = _exact_settings(20, 4)
    free = identify(prior, params, targets, settings)
    assert free.scales == pytest.approx([1.0, 1.0])  # the prior already matches
    constraint = Constraint(("h25",), factor=2.0, max_change_percent=5.0, modes=(18,))
    tied = identify(prior, params, targets, settings, constraint=constraint)
    assert constraint.limit == pytest.approx(2 * np.log(1.05) / np.log(2.0))
    assert tied.evaluation.shares[0] <= constraint.limit + 1e-3
    assert tied.scales[0] < 1.0 < tied.scales[1]
    assert abs(tied.evaluation.errors_percent[0]) < 0.05


# ---------------------------------------------------------------------------------------------
# the calibration file


def _write(tmp_path: Path, text: str) -> Path:
    text = text.replace('prior = "ufmt-prior.toml"', f'prior = "{PRIOR}"')
    text = text.replace(
        'reference = "paper_reference.toml"', f'reference = "{DATA / "paper_reference.toml"}"'
    )
    text = text.replace('output = "ufmt.toml"', f'output = "{tmp_path / "out.toml"}"')
    path = tmp_path / "calibration.toml"
    path.write_text(text)
    return path


def _edited(tmp_path: Path, old: str, new: str) -> Path:
    text = CALIBRATION.read_text()
    assert old in text
    return _write(tmp_path, text.replace(old, new, 1))


def test_packaged_calibration_loads(prior):
    calibration, model, reference = load_calibration(CALIBRATION)
    assert calibration.targets.modes == (1, 2, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 29)
    assert [m.modal_test_hz for m in map(reference.modes.get, calibration.targets.modes)] == list(
        calibration.targets.frequencies_hz
    )
    assert all(p.band[0] <= 1.0 <= p.band[1] for p in calibration.parameters)
    assert model.name == prior.name


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (
            "modes = [1, 2, 6,",
            "modes = [1, 2, 4, 6,",
            r"calibration\.toml: targets: field 'modes\[2\]': 4 has no 'modal_test_hz'",
        ),
        (
            "modes = [1, 2, 6,",
            "modes = [99, 1, 2, 6,",
            r"calibration\.toml: targets: field 'modes\[0\]': 99 has no 'modal_test_hz'",
        ),
        (
            "modes = [1, 2, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 29]",
            "modes = []",
            r"calibration\.toml: targets: field 'modes': empty \(at least one Table 3 mode",
        ),
        (
            'hinges = ["h16"]',
            'hinges = ["h99"]',
            r"calibration\.toml: parameter 'h16\.x': field 'hinges\[0\]': unknown hinge 'h99'",
        ),
        (
            'column = "modal_test_hz"',
            'column = "modal_hz"',
            r"calibration\.toml: targets: field 'column': unknown column 'modal_hz' \(did you mean",
        ),
        (
            "band = [0.333, 3.0]",
            "band = [1.5, 3.0]",
            r"calibration\.toml: parameter 'h16\.x': field 'band': \[1\.5, 3\] does not contain 1.*"
            r"\(allowed: 0 < lower <= 1 <= upper\)",
        ),
        (
            "trust_region = 0.3",
            "trust_region = -0.3",
            r"calibration\.toml: settings: field 'trust_region': -0\.3 is not positive "
            r"\(allowed: > 0\)",
        ),
        (
            "regularisation = 0.05",
            "regularization = 0.05",
            r"calibration\.toml: settings: unknown field 'regularization' \(did you mean "
            r"'regularisation'\?\)",
        ),
        (  # [response] is checked when the file is loaded, before any identification
            "starts = 3",
            "starts = 0",
            r"calibration\.toml: response: field 'starts': 0 is too small \(allowed: >= 1\)",
        ),
        (
            'key = "force_scale"',
            'key = "force_scale"\nfit = "no"',
            r"calibration\.toml: response\.parameter 'force_scale': field 'fit': "
            r"expected true or false, got string 'no'",
        ),
    ],
)
def test_bad_calibration_input_names_file_and_field(tmp_path, old, new, message):
    path = _edited(tmp_path, old, new)
    with pytest.raises(StudyError, match=message):
        load_calibration(path)


def test_parameter_on_a_released_direction_is_refused(tmp_path):
    path = _edited(
        tmp_path,
        'name = "h16.x"\nhinges = ["h16"]\nfield = "stiffness"\ncomponents = [0]',
        'name = "h25.rz"\nhinges = ["h25"]\nfield = "rotational_stiffness"\ncomponents = [2]',
    )
    with pytest.raises(StudyError, match=r"parameter 'h25\.rz': .*h25 rotational_stiffness\[2\]"):
        load_calibration(path)


def test_cli_reports_bad_calibration_in_one_line(tmp_path, capsys):
    path = _edited(tmp_path, 'hinges = ["h16"]', 'hinges = ["h99"]')
    assert main(["calibrate", "--settings", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "calibration.toml" in err and "'hinges[0]'" in err and "h99" in err


@pytest.mark.slow
def test_calibrate_regenerates_the_packaged_model(tmp_path):
    """`make calibrate` on a fresh clone writes the committed ufmt.toml: the same provenance
    header and stiffnesses, and the same force scale to 1e-9 (it comes from a time-domain
    simulation whose last digits follow the root finder's). Run as the CLI runs every command,
    with one BLAS thread: the response fit ends at a kink of the PV (docs/ufmt-model.md,
    'Response fit'), and where it lands follows the last digits of the linear algebra."""
    with threadpool_limits(limits=1, user_api="blas"):
        run = calibrate(CALIBRATION, output=tmp_path / "ufmt.toml", log_path=tmp_path / "log.csv")
    new, committed = run.output.read_text(), (DATA / "ufmt.toml").read_text()
    strip = [line for line in new.splitlines() if not line.startswith("force_scale")]
    assert strip == [line for line in committed.splitlines() if not line.startswith("force_scale")]
    scales = [load_model(str(p)).machine.force_scale for p in (run.output, DATA / "ufmt.toml")]
    assert scales[0] == pytest.approx(scales[1], rel=1e-9)
    err = np.abs(run.validation.table.dropna(subset=["test_hz"])["mstmm_error_percent"])
    assert err.max() <= 3.0 and err.mean() <= 1.0
    assert math.isfinite(run.identification.seconds)


def test_cli_calibrate_is_deterministic_and_reports_the_response_fit(tmp_path, capsys):
    """Rerunning `ufmt calibrate` on an unchanged prior rewrites the same bytes; the
    command prints every response residual and the implied forces (small settings)."""
    text = CALIBRATION.read_text()
    for old, new in (
        ("max_iterations = 60", "max_iterations = 2"),
        ("global_start = true", "global_start = false"),
        ("max_evaluations = 40", "max_evaluations = 1"),  # one Jacobian, no step
        ("starts = 3", "starts = 1"),  # restarts: tests/test_response_fit.py
    ):
        assert old in text
        text = text.replace(old, new)
    path = _write(tmp_path, text)
    outputs = []
    for run in (1, 2):
        log = tmp_path / f"log{run}.csv"
        assert main(["calibrate", "--settings", str(path), "--log", str(log)]) == 0
        outputs.append(((tmp_path / "out.toml").read_bytes(), log.read_bytes()))
    assert outputs[0] == outputs[1]
    out = capsys.readouterr().out
    for needle in (
        "pv_measured_nm",
        "zre_peak_nm",
        "tip_acc_measured_mm_s2",
        "centre_rise_nm",
        "GPa",
    ):
        assert needle in out
    model = load_model(tmp_path / "out.toml")
    assert 0.3 <= model.machine.force_scale <= 3.0
