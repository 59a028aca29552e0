"""Hinge kinds and the frequency-dependent aerostatic film (ufmt.kinds.aerostatic_hinge).

Oracles: the closed-form root of w^2 m = k'(w) and the closed-form receptance
1 / (k*(W) - W^2 m + i W c_s) of a rigid puck on a film to ground; a direct solve of the
assembled model (ufmt.assembled, no MSTMM code) with the hinges at k'(w) for the natural
frequencies and at k*(W) for the FRF; the constant-stiffness limit (r = 1) against the spring
hinge, bitwise; the Zener model's own properties (storage and loss parts, bounds, the loss
peak at the corner frequency).
"""

import subprocess
import sys

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import brentq
from threadpoolctl import threadpool_limits

from ufmt.assembled import assemble
from ufmt.assembled.constraints import constraint_basis
from ufmt.errors import ModelError, UfmtError
from ufmt.kinds import HINGE_KINDS, frequency_dependent, hinge_kind_of
from ufmt.kinematics import point_motion
from ufmt.machining.frf import frf
from ufmt.machining.modal import modal_basis
from ufmt.model.load import load_model, load_model_text
from ufmt.model.write import model_to_toml
from ufmt.mstmm.dependent import bounding, frozen
from ufmt.mstmm.solve import certified_roots, solve_modes

M, K0, R, FC = 10.0, 1.0e8, 2.0, 300.0  # puck [kg], film k0 [N/m], k_inf / k0, f_c [Hz]
TAU = 1 / (2 * np.pi * FC)

PUCK = f"""
name = "puck on film"

[[body]]
name = "puck"
kind = "rigid"
mass = {M}
center_of_mass = [0.0, 0.0, 0.0]
inertia = [[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.15]]

[[hinge]]
name = "film"
kind = "aerostatic"
between = ["puck", "ground"]
at = [0.0, 0.0, 0.0]
stiffness = [inf, inf, {K0}]
rotational_stiffness = [inf, inf, inf]
stiffness_ratio = [1.0, 1.0, {R}]
corner_frequency = [{FC}, {FC}, {FC}]
"""

# two rigid bodies, a film to ground (five finite directions, ratios and corners differ) and a
# spring hinge between them, both off the centres of mass: the film couples every mode
PAIR = """
name = "carriage and head"

[[body]]
name = "carriage"
kind = "rigid"
mass = 40.0
center_of_mass = [0.0, 0.0, 0.1]
inertia = [[0.8, 0.01, 0.0], [0.01, 0.6, 0.02], [0.0, 0.02, 1.1]]

[[body]]
name = "head"
kind = "rigid"
mass = 12.0
center_of_mass = [0.05, 0.02, 0.35]
inertia = [[0.12, 0.0, 0.0], [0.0, 0.15, 0.0], [0.0, 0.0, 0.09]]

[[hinge]]
name = "film"
kind = "aerostatic"
between = ["ground", "carriage"]
at = [0.03, -0.02, 0.0]
stiffness = [2.0e8, 1.5e8, 4.0e8]
rotational_stiffness = [3.0e6, 2.0e6, 1.0e6]
damping = [1.0e3, 0.0, 0.0]
stiffness_ratio = [2.0, 1.5, 2.5]
rotational_stiffness_ratio = [1.8, 1.0, 1.2]
corner_frequency = [150.0, 400.0, 250.0]
rotational_corner_frequency = [300.0, 300.0, 80.0]

[[hinge]]
name = "spindle"
between = ["carriage", "head"]
at = [0.0, 0.0, 0.25]
stiffness = [3.0e8, 3.0e8, 6.0e8]
rotational_stiffness = [4.0e6, 4.0e6, 2.0e6]
"""


@pytest.fixture(scope="module")
def puck():
    return load_model_text(PUCK, "puck.toml")


@pytest.fixture(scope="module")
def pair():
    return load_model_text(PAIR, "pair.toml")


def _storage(w):
    """Closed-form storage stiffness k'(w) of the puck's film [N/m]."""
    x = (w * TAU) ** 2
    return K0 * (1 + (R - 1) * x / (1 + x))


# --- the kinds ------------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(HINGE_KINDS))
def test_every_hinge_kind_has_the_solver_interface(name):
    kind = HINGE_KINDS[name]
    for attr in ("NAME", "FIELDS", "REQUIRED", "parse", "written", "storage_stiffness6"):
        assert hasattr(kind, attr)
    for attr in ("complex_stiffness6", "bounds6", "count_applies", "branches6", "rotated"):
        assert callable(getattr(kind, attr))
    assert kind.NAME == name
    assert set(kind.REQUIRED) <= set(kind.FIELDS)


def test_zener_storage_loss_bounds_and_loss_peak(pair):
    """k' = Re k* without the dashpots, between the bounds and non-decreasing; the film's loss
    Im k* - W c peaks at f_c (d/dw of k1 w tau / (1 + w^2 tau^2) vanishes at w tau = 1)."""
    hinge = pair.hinge("film")
    kind = hinge_kind_of(hinge)
    w = 2 * np.pi * np.geomspace(1.0, 1e5, 2001)
    storage, full = kind.storage_stiffness6(hinge, w), kind.complex_stiffness6(hinge, w)
    np.testing.assert_array_equal(storage, full.real)
    low, high = kind.bounds6(hinge)
    assert np.all(storage >= low) and np.all(storage <= high * (1 + 1e-15))
    assert np.all(np.diff(storage, axis=0) >= 0.0)
    loss = full.imag - w[:, None] * hinge.damping6[None, :]
    corner = np.r_[hinge.extra["corner_frequency"], hinge.extra["rotational_corner_frequency"]]
    varies = high > low
    peak_hz = w[np.argmax(loss, axis=0)] / (2 * np.pi)
    np.testing.assert_allclose(peak_hz[varies], corner[varies], rtol=0.01)  # grid spacing 0.5 %


def test_spring_hinge_is_the_default_kind(pair):
    assert pair.hinge("spindle").kind == "spring"
    assert hinge_kind_of(pair.hinge("spindle")).count_applies(pair.hinge("spindle"))
    assert frequency_dependent(pair)


def test_round_trip_writes_the_kind_and_its_fields(pair):
    text = model_to_toml(pair)
    again = load_model_text(text)
    hinge = again.hinge("film")
    assert hinge.kind == "aerostatic" and again.hinge("spindle").kind == "spring"
    for key, value in pair.hinge("film").extra.items():
        np.testing.assert_array_equal(hinge.extra[key], value)
    assert model_to_toml(again) == text
    assert 'kind = "aerostatic"' in text and text.count("kind = ") == 3  # two bodies, one hinge


@pytest.mark.parametrize(
    ("old", "new", "pattern"),
    [
        ("stiffness_ratio = [1.0, 1.0, 2.0]\n", "", r"field 'stiffness_ratio': missing"),
        ("[1.0, 1.0, 2.0]", "[1.0, 1.0, 0.5]", r"'stiffness_ratio\[2\]'.*0\.5.*1.*100"),
        ("[300.0, 300.0, 300.0]", "[300.0, nan, 300.0]", r"'corner_frequency\[1\]'"),
        ('kind = "aerostatic"', 'kind = "aerostatik"', r"field 'kind'.*aerostatic"),
        ('kind = "aerostatic"', 'kind = "spring"', r"unknown field 'stiffness_ratio'"),
        ("corner_frequency", "corner_frequncy", r"unknown field 'corner_frequncy'"),
    ],
)
def test_bad_film_fields_name_file_hinge_field(old, new, pattern):
    text = PUCK.replace(old, new)
    assert text != PUCK
    with pytest.raises(ModelError, match=r"^puck\.toml: hinge 'film': " + ".*" + pattern):
        load_model_text(text, "puck.toml")


def test_bad_film_field_exits_2_with_one_line(tmp_path):
    path = tmp_path / "puck.toml"
    path.write_text(PUCK.replace("[1.0, 1.0, 2.0]", "[1.0, 1.0, 0.5]"))
    res = subprocess.run(
        [sys.executable, "-m", "ufmt.cli", "modes", str(path)], capture_output=True, text=True
    )
    assert res.returncode == 2
    assert len(res.stderr.strip().splitlines()) == 1
    assert str(path) in res.stderr and "stiffness_ratio[2]" in res.stderr


# --- natural frequencies --------------------------------------------------------------------


def test_puck_root_is_the_closed_form(puck):
    """w^2 m = k'(w): the one root, bracketed by sqrt(k0/m) and sqrt(r k0/m)."""
    w = brentq(lambda x: x**2 * M - _storage(x), np.sqrt(K0 / M), np.sqrt(R * K0 / M), xtol=1e-12)
    solution = solve_modes(puck, fmax_hz=2000.0)
    np.testing.assert_allclose(solution.frequencies_hz, [w / (2 * np.pi)], rtol=1e-11)
    assert solution.expected == 1 and solution.rigid_body_modes == 0
    np.testing.assert_allclose(
        solution.shapes.rigid["puck"][0], [0, 0, M**-0.5, 0, 0, 0], atol=1e-14
    )


def _assembled_parts(model):
    """(reduced M, the constant part of K without the film, film spring rows (reduced), their
    (hinge, direction) pairs) of ``model``'s assembled model, the film at k0."""
    static = bounding(model, upper=False)
    am = assemble(static)
    basis, _ = constraint_basis(am.constraints, am.massless)
    stiffness = np.array([h.stiffness6 for h in static.hinges]).reshape(-1)
    finite = np.isfinite(stiffness) & (stiffness > 0)
    rows = am.deformation[-np.count_nonzero(finite) :] / np.sqrt(stiffness[finite])[:, None]
    pairs = [divmod(int(i), 6) for i in np.flatnonzero(finite)]
    return basis.T @ am.M @ basis, basis.T @ am.K @ basis, rows @ basis, pairs, stiffness[finite]


def _stiffness(model, parts, w, complex_part=False):
    """Reduced K at w [rad/s] from the hinge kinds' k'(w) (or k*(w) with the dashpots)."""
    _, k_static, rows, pairs, k0 = parts
    values = []
    for hinge in model.hinges:
        kind = hinge_kind_of(hinge)
        get = kind.complex_stiffness6 if complex_part else kind.storage_stiffness6
        values.append(get(hinge, np.array([w]))[0])
    k = np.array([values[h][j] for h, j in pairs])
    return k_static + (rows.T * (k - k0)) @ rows


def test_pair_roots_match_a_direct_assembled_solve(pair):
    """Each branch of det(K(k'(w)) - w^2 M) = 0 from the assembled model's generalised
    eigenvalues (scipy eigh, brentq) against the MSTMM path."""
    parts = _assembled_parts(pair)
    mass = parts[0]

    def branch(x, j):
        return x - np.sqrt(eigh(_stiffness(pair, parts, x), mass, eigvals_only=True)[j])

    lo = np.sqrt(eigh(parts[1], mass, eigvals_only=True))
    hi = np.sqrt(eigh(_stiffness(pair, parts, 1e12), mass, eigvals_only=True))
    expected = [brentq(branch, lo[j], hi[j], args=(j,), xtol=1e-10) for j in range(lo.size)]
    solution = solve_modes(pair, count=lo.size, shapes=False)
    np.testing.assert_allclose(solution.frequencies_hz, np.array(expected) / (2 * np.pi), rtol=1e-9)
    # they lie strictly inside the bounding models' frequencies (the film stiffens each mode)
    assert np.all(solution.frequencies_hz > lo / (2 * np.pi))


def test_assembled_method_finds_the_same_roots(pair):
    """`solve_modes(method="assembled")` takes the same branch search with the assembled model
    as the constant-stiffness solver: rigid bodies only, so both are exact."""
    from ufmt.solvers import solve_modes as either

    mstmm = either(pair, fmax_hz=2000.0, shapes=False)
    assembled = either(pair, fmax_hz=2000.0, method="assembled")
    np.testing.assert_allclose(assembled.frequencies_hz, mstmm.frequencies_hz, rtol=1e-9)
    assert mstmm.frequencies_hz.size >= 6


def test_transfer_matrix_is_singular_at_the_roots(pair):
    """det U_all = 0 with the hinge transfer matrices at k'(w): U_all of the model at a root
    is the frozen model's there (bitwise), and its determinant changes sign across each root
    (1e-7 either side) but not between two neighbouring roots' midpoints."""
    from ufmt.mstmm.overall import TransferSystem

    f = solve_modes(pair, count=4, shapes=False).frequencies_hz
    system = TransferSystem(pair)

    def sign(hz):
        return np.linalg.slogdet(system.evaluate(2 * np.pi * np.asarray(hz)))[0].real

    for x in f:
        w = np.array([2 * np.pi * x])
        np.testing.assert_array_equal(
            system.evaluate(w), TransferSystem(frozen(pair, x)).evaluate(w)
        )
    assert np.all(sign(f * (1 - 1e-7)) == -sign(f * (1 + 1e-7)))
    mid = np.sqrt(f[:-1] * f[1:])
    assert np.all(sign(mid[:-1]) == -sign(mid[1:]))  # one root between neighbouring midpoints


def test_constant_limit_is_the_spring_hinge_bitwise(pair):
    """r = 1 in every direction: the film is the spring hinge; frequencies and FRF bitwise."""
    text = PAIR.replace("[2.0, 1.5, 2.5]", "[1.0, 1.0, 1.0]").replace(
        "[1.8, 1.0, 1.2]", "[1.0, 1.0, 1.0]"
    )
    film = load_model_text(text, "film.toml")
    spring_text = "\n".join(
        line
        for line in text.splitlines()
        if not line.startswith(
            (
                'kind = "aerostatic"',
                "stiffness_ratio",
                "rotational_stiffness_ratio",
                "corner_frequency",
                "rotational_corner_frequency",
            )
        )
    )
    spring = load_model_text(spring_text, "spring.toml")
    assert not frequency_dependent(film)
    a, b = solve_modes(film, fmax_hz=3000.0), solve_modes(spring, fmax_hz=3000.0)
    np.testing.assert_array_equal(a.frequencies_hz, b.frequencies_hz)
    np.testing.assert_array_equal(a.shapes.rigid["head"], b.shapes.rigid["head"])
    point = ("head", (0.05, 0.02, 0.4))
    ha = frf(film, direction="x", output=point, fmax_hz=2000.0, points=40)
    hb = frf(spring, direction="x", output=point, fmax_hz=2000.0, points=40)
    np.testing.assert_array_equal(ha.values, hb.values)


def test_certified_roots_refuses_a_frequency_dependent_model(puck):
    with pytest.raises(UfmtError, match="depends on frequency"):
        certified_roots(puck, 1000.0)


# --- the response ---------------------------------------------------------------------------


def test_puck_frf_is_the_closed_form(puck):
    """1 / (k*(W) - W^2 m + 2 i zeta w0 W m): the static model's mode (w0 = sqrt(k0/m)) with
    its structural damping, the film's k*(W) from its Maxwell state."""
    zeta = 0.01
    result = frf(
        puck,
        direction="z",
        output=("puck", (0.0, 0.0, 0.0)),
        zeta=zeta,
        fmin_hz=10.0,
        fmax_hz=5000.0,
        points=60,
    )
    w = 2 * np.pi * result.frequencies_hz
    s = 1j * w * TAU
    expected = 1 / (K0 * (1 + R * s) / (1 + s) - w**2 * M + 2j * zeta * np.sqrt(K0 / M) * w * M)
    np.testing.assert_allclose(result.values, expected, rtol=1e-12)


def test_pair_frf_matches_a_direct_assembled_solve(pair):
    """Point receptance on the head, every mode in the basis, structural damping 1e-9: the
    direct solve of (K*(W) - W^2 M) u = f (hinges at k*(W), dashpots included) at each W."""
    parts = _assembled_parts(pair)
    am = assemble(bounding(pair, upper=False))
    basis, _ = constraint_basis(am.constraints, am.massless)
    point = np.array([0.05, 0.02, 0.4])
    load = np.zeros(am.K.shape[0])
    load[am.body_dofs["head"][0]] = point_motion(point - am.node_positions["head"][0])[0]
    f = basis.T @ load
    result = frf(
        pair,
        direction="x",
        output=("head", tuple(point)),
        zeta=1e-9,
        fmin_hz=5.0,
        fmax_hz=3000.0,
        points=80,
        basis_cutoff_hz=1e5,
    )
    assert result.natural_hz.size == f.size  # every mode: no truncation, no residual
    w = 2 * np.pi * result.frequencies_hz
    expected = [
        f @ np.linalg.solve(_stiffness(pair, parts, x, True) - x**2 * parts[0], f) for x in w
    ]
    np.testing.assert_allclose(result.values, expected, rtol=1e-6)


def test_film_basis_spans_the_static_and_high_frequency_modes(pair):
    """The Ritz basis of the static and the high-frequency model's modes: for the rigid pair
    (12 dofs, 12 + 12 shapes) it spans everything, so it is the static model's eigenbasis
    (frequencies to rounding) with the duplicated directions dropped, and the film's motion."""
    basis = modal_basis(pair)
    static = solve_modes(bounding(pair, upper=False), fmax_hz=5000.0)
    assert static.frequencies_hz.size == 12
    np.testing.assert_allclose(basis.omega / (2 * np.pi), static.frequencies_hz, rtol=1e-12)
    assert [h.name for h, _ in basis.varying] == ["film"]


def test_film_states_close_the_acceleration(pair):
    """q'' - f from the complex modes' weights (-Omega^2 q - D q' - G s, the film's branch
    forces G s included) equals d/dt q' = 2 Re(P Lambda^2 z): the eigen-relation A V = V Lambda
    of the augmented first-order form, row by row."""
    from ufmt.machining.damping import damped_modes

    basis = modal_basis(pair)
    modes = damped_modes(basis, 0.01)
    n = basis.n_modes
    assert modes.film_outputs.shape[0] == 5  # the directions whose ratio is not 1: 3 + 2
    on = np.eye(n)
    accel = modes.state_weights(on[:, :0], on[:, :0], on)
    expected = (modes.outputs * modes.poles**2).T
    np.testing.assert_allclose(accel, expected, atol=1e-9 * np.abs(expected).max())


SHAFT = """
name = "shaft on a film"

[[body]]
name = "shaft"
kind = "beam"
start = [0.0, 0.0, 0.5]
end = [0.0, 0.0, 0.1]
density = 7850.0
youngs_modulus = 2.1e11
shear_modulus = 8.1e10
diameter = 0.06

[[body]]
name = "head"
kind = "rigid"
mass = 8.0
center_of_mass = [0.02, 0.0, 0.07]
inertia = [[0.03, 0.0, 0.0], [0.0, 0.03, 0.0], [0.0, 0.0, 0.05]]

[[hinge]]
name = "film"
kind = "aerostatic"
between = ["ground", "shaft"]
at = [0.0, 0.0, 0.5]
stiffness = [1.0e8, 1.0e8, 2.0e8]
rotational_stiffness = [2.0e6, 2.0e6, 1.0e6]
stiffness_ratio = [2.0, 2.0, 1.5]
rotational_stiffness_ratio = [2.5, 2.5, 1.0]
corner_frequency = [200.0, 200.0, 300.0]

[[hinge]]
name = "mount"
between = ["shaft", "head"]
at = [0.0, 0.0, 0.1]
stiffness = [inf, inf, inf]
rotational_stiffness = [inf, inf, inf]
"""


def test_beam_on_a_film_frf_matches_a_fine_assembled_solve():
    """A steel shaft on a film to ground, a head on its end: the receptance at the head (the
    film's motion read on a beam end through the static model's MSTMM field) against the
    direct solve on 48 frame elements, within 1e-4 from 5 Hz to 2 kHz (measured 1.0e-5; the
    static model's modes alone, without the high-frequency model's, were 27 % off at the first
    resonance)."""
    model = load_model_text(SHAFT, "shaft.toml")
    am = assemble(bounding(model, upper=False), elements_per_beam=48)
    basis, _ = constraint_basis(am.constraints, am.massless)
    k0 = np.array([h.stiffness6 for h in bounding(model, upper=False).hinges]).reshape(-1)
    finite = np.isfinite(k0) & (k0 > 0)
    rows = am.deformation[-np.count_nonzero(finite) :] / np.sqrt(k0[finite])[:, None]
    point = np.array([0.02, 0.0, 0.03])
    load = np.zeros(am.K.shape[0])
    load[am.body_dofs["head"][0]] = point_motion(point - am.node_positions["head"][0])[0]
    result = frf(
        model,
        direction="x",
        output=("head", tuple(point)),
        zeta=1e-9,
        fmin_hz=5.0,
        fmax_hz=2000.0,
        points=60,
    )
    film = model.hinge("film")
    k_star = hinge_kind_of(film).complex_stiffness6(film, 2 * np.pi * result.frequencies_hz)
    f, m, k = basis.T @ load, basis.T @ am.M @ basis, basis.T @ am.K @ basis
    d = rows[:6] @ basis  # the film's six directions (its rows come first)
    with threadpool_limits(1):  # small dense solves: threads only add contention
        expected = [
            f @ np.linalg.solve(k + (d.T * (ks - film.stiffness6)) @ d - w**2 * m, f)
            for w, ks in zip(2 * np.pi * result.frequencies_hz, k_star, strict=True)
        ]
    np.testing.assert_allclose(result.values, expected, rtol=1e-4)


@pytest.mark.slow
def test_example_periodic_and_time_paths_agree_with_the_film():
    """examples/bridge-aerostatic.toml: the periodic steady state and the whole-cut time
    response (two recurrences over the same film states) give the same peak z_re (measured
    6e-7 apart; the spring bridge's paths agree as closely), on the film's Ritz basis (more
    modes than the static model's, sampled to the static model's highest mode)."""
    from pathlib import Path

    from ufmt import Process, simulate

    path = Path(__file__).resolve().parents[1] / "examples" / "bridge-aerostatic.toml"
    model = load_model(path)
    process = Process(rpm=300.0, feed_mm_min=15.0, depth_um=4.0)
    periodic = simulate(model, process, method="periodic").to_dict()
    time = simulate(model, process, method="time").to_dict()
    static = solve_modes(bounding(model, upper=False), fmax_hz=5000.0, shapes=False)
    assert periodic["n_modes"] > static.frequencies_hz.size
    assert periodic["basis_highest_hz"] < 5000.0
    np.testing.assert_allclose(time["zre_peak_nm"], periodic["zre_peak_nm"], rtol=1e-5)
