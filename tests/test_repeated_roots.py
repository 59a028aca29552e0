"""No root is ever lost: repeated (symmetric) roots, an isotropic rotor whose double roots
were once dropped, and the loud failure when a counted root cannot be found."""

import functools
import json

import numpy as np
import pytest
from synthetic import axisymmetric_chain

from ufmt.assembled import assembled_modes
from ufmt.cli import main
from ufmt.model.load import load_model, model_from_dict, packaged_path
from ufmt.mstmm import wittrick
from ufmt.mstmm.modes import modal_mass, mode_shapes, shape_state_keys
from ufmt.mstmm.overall import TransferSystem
from ufmt.mstmm.roots import RootsLostError
from ufmt.mstmm.solve import certified_roots, solve_modes
from ufmt.mstmm.wittrick import RootCounter

INF = float("inf")
RIGID = {"stiffness": [INF] * 3, "rotational_stiffness": [INF] * 3}
STEEL = {"density": 7850.0, "youngs_modulus": 2.1e11, "shear_modulus": 8.1e10}


def rotor_dict() -> dict:
    """An isotropic rotor: a 0.8 m shaft of 0.05 m diameter on two bearings of 1e7 N/m
    (every translation, tilting free), a 10 kg disk (0.2 m diameter) in the middle. The
    structure is axisymmetric, so every bending mode is a double root."""
    m, r = 10.0, 0.1
    polar, diametral = m * r**2 / 2, m * r**2 / 4
    bearing = {"stiffness": [1e7] * 3, "rotational_stiffness": [0.0] * 3}
    half = [0.4, 0.0, 0.0]
    return {
        "name": "rotor",
        "body": [
            {"name": "left", "kind": "beam", "start": [0, 0, 0], "end": half, "diameter": 0.05}
            | STEEL,
            {"name": "right", "kind": "beam", "start": half, "end": [0.8, 0, 0], "diameter": 0.05}
            | STEEL,
            {
                "name": "disk",
                "kind": "rigid",
                "mass": m,
                "center_of_mass": half,
                "inertia": np.diag([polar, diametral, diametral]).tolist(),
            },
        ],
        "hinge": [
            {"name": "bearing_a", "between": ["ground", "left"], "at": [0, 0, 0]} | bearing,
            {"name": "bearing_b", "between": ["right", "ground"], "at": [0.8, 0, 0]} | bearing,
            {"name": "hub_a", "between": ["left", "disk"], "at": half} | RIGID,
            {"name": "hub_b", "between": ["disk", "right"], "at": half} | RIGID,
        ],
    }


def to_toml(model: dict) -> str:
    """The model dict as a TOML file (numbers, strings and nested lists only)."""

    def value(v):
        return json.dumps(np.asarray(v).tolist() if isinstance(v, list) else v).replace(
            "Infinity", "inf"
        )

    lines = [f"name = {value(model['name'])}"]
    for table in ("body", "hinge"):
        for entry in model[table]:
            lines.append(f"[[{table}]]")
            lines += [f"{k} = {value(v)}" for k, v in entry.items()]
    return "\n".join(lines) + "\n"


def _pairs(f: np.ndarray) -> int:
    """Number of repeated roots (equal to 1e-9) among sorted frequencies."""
    return int(np.sum(np.diff(f) <= 1e-9 * f[1:]))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_repeated_roots_of_axisymmetric_chains_all_found(seed):
    """Every root the exact assembled model (rigid bodies: no mesh) counts, to 1e-9, with
    each double root twice and mass-orthonormal shapes for each pair."""
    model = model_from_dict(axisymmetric_chain(seed))
    exact = assembled_modes(model).frequencies_hz
    assert _pairs(exact) >= 3  # the oracle itself has the double roots
    fmax = float(exact[-1]) * 1.01
    system, roots = certified_roots(model, fmax)
    assert roots.missing_hz.size == 0
    np.testing.assert_allclose(roots.frequencies_hz, exact, rtol=1e-9)
    shapes = mode_shapes(system, roots.frequencies_hz)
    np.testing.assert_allclose(modal_mass(model, shapes.rigid, shapes.beams), 1.0, rtol=1e-8)
    z = shapes.z_all
    for i in np.flatnonzero(np.diff(exact) <= 1e-9 * exact[1:]):
        pair = z[[i, i + 1]]
        assert np.linalg.matrix_rank(pair, tol=1e-6 * np.abs(pair).max()) == 2


@functools.cache
def rotor_reference() -> np.ndarray:
    """The rotor's frequencies below 5.1 kHz from assembled meshes of 32 and 64 elements per
    beam, Richardson-extrapolated for the linear axial elements' h² error (bending converges
    as h⁴ and is already below 1e-9 there)."""
    model = model_from_dict(rotor_dict())
    f32, f64 = (
        assembled_modes(model, fmax_hz=5100.0, elements_per_beam=n).frequencies_hz for n in (32, 64)
    )
    return (4 * f64 - f32[: f64.size]) / 3


@pytest.mark.parametrize("fmax", [2500.0, 3000.0, 5000.0])
def test_isotropic_rotor_keeps_every_double_root(fmax):
    """Every double root below --fmax (a sign scan once returned 10 of 15 modes at 3000 Hz and
    11 of 21 at 5000 Hz). Oracle: the assembled model (converges from above to the MSTMM's
    exact beams), Richardson-extrapolated."""
    model = model_from_dict(rotor_dict())
    fine = rotor_reference()
    sol = solve_modes(model, fmax_hz=fmax)
    assert sol.frequencies_hz.size == sol.expected == np.sum(fine <= fmax)
    np.testing.assert_allclose(sol.frequencies_hz, fine[fine <= fmax], rtol=1e-6)
    assert _pairs(sol.frequencies_hz) >= 5


def test_rotor_count_returns_the_asked_modes():
    """--count 16 returned 10 modes on main."""
    model = model_from_dict(rotor_dict())
    sol = solve_modes(model, count=16)
    fine = rotor_reference()[:16]
    np.testing.assert_allclose(sol.frequencies_hz, fine, rtol=1e-6)


@pytest.fixture
def lossy_rotor(tmp_path, monkeypatch):
    """The rotor file with the count given one extra (fake) mode at 1234.5 Hz, which neither
    Newton nor the fallback (here failing: NaN) can find."""
    path = tmp_path / "rotor.toml"
    path.write_text(to_toml(rotor_dict()))
    real_below = RootCounter.below

    def with_fake_mode(self, hz, design=None):
        return real_below(self, hz, design) + (np.atleast_1d(hz) > 1234.5)

    monkeypatch.setattr(RootCounter, "below", with_fake_mode)
    monkeypatch.setattr(RootCounter, "refine", lambda self, lo, hi, **_: np.full(len(lo), np.nan))
    return path


@pytest.mark.parametrize("json_flag", [[], ["--json"]])
def test_cli_fails_loudly_naming_the_missing_frequency(lossy_rotor, capsys, json_flag):
    code = main(["modes", str(lossy_rotor), "--fmax", "3000", *json_flag])
    out, err = capsys.readouterr()
    assert code != 0
    assert out == ""
    assert err.count("\n") == 1 and "1234.5 Hz" in err and "missing" in err


def test_solve_modes_raises_when_a_root_is_lost(lossy_rotor):
    from ufmt.model.load import load_model

    with pytest.raises(RootsLostError, match="1234.5"):
        solve_modes(load_model(lossy_rotor), fmax_hz=3000.0)


def test_cli_rotor_json_count_matches(tmp_path, capsys):
    path = tmp_path / "rotor.toml"
    path.write_text(to_toml(rotor_dict()))
    assert main(["modes", str(path), "--fmax", "5000", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["count"] == out["expected_count"] >= 21


@pytest.mark.parametrize("seed", [1, 2])
def test_newton_null_space_matches_inverse_iteration(seed):
    """The null bases that come with the Newton steps span the same space as the batched
    inverse iteration at the converged roots (principal angles below 1e-8)."""
    model = model_from_dict(axisymmetric_chain(seed))
    exact = assembled_modes(model).frequencies_hz
    system, roots = certified_roots(model, exact[-1] * 1.01)
    f = roots.frequencies_hz
    from_newton = mode_shapes(system, f, roots.null_vectors).z_all
    from_inverse = mode_shapes(system, f).z_all
    first = np.flatnonzero(np.r_[True, np.diff(f) > 1e-9 * f[1:]])
    for a, b in zip(first, np.r_[first[1:], f.size], strict=True):
        qa = np.linalg.qr(from_newton[a:b].T)[0]
        qb = np.linalg.qr(from_inverse[a:b].T)[0]
        cosines = np.linalg.svd(qa.T @ qb, compute_uv=False)
        np.testing.assert_allclose(cosines, 1.0, atol=1e-8)


@pytest.mark.parametrize("start_rtol", [3e-2, 1e-8])
def test_rotor_roots_found_from_coarse_or_fine_brackets(monkeypatch, start_rtol):
    """Brackets of 3 % (Newton may leave some to the fallback bisection on the count) or
    1e-8: every root of the rotor below 5 kHz either way (oracle: the extrapolated assembled
    reference)."""
    monkeypatch.setattr(wittrick, "START_RTOL", start_rtol)
    sol = solve_modes(model_from_dict(rotor_dict()), fmax_hz=5000.0)
    fine = rotor_reference()
    np.testing.assert_allclose(sol.frequencies_hz, fine[fine <= 5000.0], rtol=1e-6)


@pytest.mark.parametrize(
    "model, fmax",
    [
        (model_from_dict(rotor_dict()), 5000.0),
        (model_from_dict(axisymmetric_chain(2)), None),
        (load_model(packaged_path("ufmt-prior.toml")), 1500.0),
    ],
    ids=["rotor", "chain", "packaged"],
)
def test_state_maps_from_the_newton_walks_match_a_walk_at_the_roots(model, fmax):
    """The state maps that come with the Newton walks, interpolated to each root from ω and
    ω + dω, are those a walk at the roots gives (oracle: :meth:`TransferSystem.states` at
    the roots): within 1e-13 of each root's largest map entry (measured ≤ 8e-15; an error of
    order the last step, ≤ 1e-8 relative, would show as ~1e-8), repeated roots included."""
    exact = assembled_modes(model, fmax_hz=None if fmax is None else 1.05 * fmax).frequencies_hz
    fmax = float(exact[-1]) * 1.01 if fmax is None else fmax
    keys = shape_state_keys(TransferSystem(model))
    system, roots = certified_roots(model, fmax, state_keys=keys)
    assert roots.states is not None and roots.frequencies_hz.size >= 10
    assert set(roots.states) == set(shape_state_keys(system))
    walked = system.states(2 * np.pi * roots.frequencies_hz)
    for key, interpolated in roots.states.items():
        assert np.array_equal(interpolated.cols, walked[key].cols)
        exact_map = walked[key].arr
        scale = np.abs(exact_map).max(axis=(1, 2), keepdims=True)
        assert np.all(np.abs(interpolated.arr - exact_map) <= 1e-13 * scale)
