"""The optimise-tolerances study kind: the cheapest allocation of a separable error budget
against its closed-form optimum (linear and root-sum-square stacking), the specification out
of reach, a metric the plate does not resolve, study-file mistakes, and identical tables with
1 or 2 workers and on dask.

The study functions are exact separable budgets with the study function's signature: three
[machine] amplitudes t_j and the head's axial compliance 1 / k, each contributing c_j t_j /
t_max,j [nm] (c_j at the loosest tolerance).
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pytest

from ufmt.errors import StudyError
from ufmt.studies.load import parse_study
from ufmt.studies.outputs import read_meta, read_table
from ufmt.studies.parallel import Execution
from ufmt.studies.runner import run_study

HERE = Path(__file__).resolve()
R = 10.0  # [nm] the part no variable reaches
#: parameter -> (tight, loose, c at the loosest [nm], cost b); cost a = 1 for each
VARIABLES = {
    "machine.straightness_m": (2e-9, 2e-7, 200.0, 1.0),
    "machine.error_motion_m": (1e-9, 1e-7, 50.0, 2.0),
    "machine.spindle_tilt_rad": (1e-7, 2e-5, 40.0, 1.0),
    "hinge.h31.stiffness[2]": (1e9, 2.5e8, 20.0, 1.0),  # stiffness: compliance 1 / k
}


def _tau(design) -> np.ndarray:
    """Normalised tolerances t / t_max of a design (compliance for the stiffness)."""
    out = []
    for name, (_, loose, _, _) in VARIABLES.items():
        value = design[name]
        out.append(loose / value if name.startswith("hinge") else value / loose)
    return np.array(out)


C = np.array([v[2] for v in VARIABLES.values()])
B = np.array([v[3] for v in VARIABLES.values()])
TAU_MIN = np.array([min(t / lo, lo / t) for t, lo, _, _ in VARIABLES.values()])


def linear_budget(design, process, model=None):
    return {"pv_measured_nm": R + float(C @ _tau(design)), "psd1_rms_nm": math.nan}


def rss_budget(design, process, model=None):
    return {"pv_measured_nm": math.sqrt(R**2 + float(np.sum((C * _tau(design)) ** 2)))}


def linear_optimum(limit):
    """Lagrange: b_j / tau_j^2 = lambda c_j, sum c_j tau_j = limit - R."""
    root = np.sqrt(B * C).sum() / (limit - R)  # sqrt(lambda)
    tau = np.sqrt(B / C) / root
    return tau, len(B) + float(np.sum(B / tau))


def rss_optimum(limit):
    """Lagrange: b_j / tau_j^2 = 2 lambda c_j^2 tau_j, sum (c_j tau_j)^2 = limit^2 - R^2."""
    d = math.sqrt(limit**2 - R**2)
    tau = np.cbrt(B / C**2) * d / math.sqrt(np.sum((C * B) ** (2 / 3)))
    return tau, len(B) + float(np.sum(B / tau))


def study_text(function: str, limit: float, extra: str = "") -> str:
    text = f'kind = "optimise-tolerances"\nfunction = "{HERE}:{function}"\n'
    text += f'metric = "pv_measured_nm"\nlimit = {limit}\nlevels = 3\n{extra}'
    for name, (tight, loose, _, b) in VARIABLES.items():
        kind = "stiffness" if name.startswith("hinge") else "tolerance"
        text += f'[[variable]]\nparameter = "{name}"\nkind = "{kind}"\n'
        text += f'range = [{tight!r}, {loose!r}]\ncost = [1.0, {b!r}]\nreason = "test"\n'
    return text


def run(tmp_path: Path, name: str, text: str, jobs=1, **kwargs) -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    execution = Execution(jobs=jobs, **kwargs)
    return run_study(
        path, execution, results=tmp_path / f"r-{jobs}-{kwargs.get('backend', '')}", progress=False
    )


@pytest.mark.parametrize(
    ("function", "limit", "optimum", "form"),
    [("linear_budget", 60.0, linear_optimum, "linear"), ("rss_budget", 60.0, rss_optimum, "rss")],
)
def test_cheapest_allocation_of_a_separable_budget_is_the_closed_form(
    tmp_path, function, limit, optimum, form
):
    """Oracle: the Lagrange optimum of sum b_j / tau_j under the budget (interior here)."""
    tau, cost = optimum(limit)
    assert np.all((tau > TAU_MIN) & (tau < 1))  # the closed form holds: no bound active
    out = run(tmp_path, function, study_text(function, limit))
    final = read_table(out / "allocation.csv").iloc[-1]
    assert final["meets"] and final["evaluated"] <= limit * (1 + 1e-9)
    assert final["cost"] == pytest.approx(cost, rel=1e-5)
    designed = _tau({name: final[name] for name in VARIABLES})
    np.testing.assert_allclose(designed, tau, rtol=1e-3)
    budget = read_table(out / "budget.csv")
    used = budget[budget["parameter"] == f"fit:{form} (used)"]
    assert len(used) == 1 and used["max_rel_residual"].iloc[0] < 1e-9  # exact fit
    np.testing.assert_allclose(budget["contribution_loose"][: len(C)], C, rtol=1e-9)
    tradeoff = read_table(out / "tradeoff.csv")
    assert tradeoff["meets"].all() and np.all(np.diff(tradeoff["cost"]) < 0)  # looser: cheaper
    assert "tolerance-tradeoff.png" in read_meta(out)["plots"]


def test_specification_out_of_reach_is_reported_not_forced(tmp_path):
    tight = R + float(C @ TAU_MIN)
    out = run(tmp_path, "reach", study_text("linear_budget", 0.9 * tight))
    assert not read_table(out / "allocation.csv")["feasible"].any()
    assert "not reachable" in read_meta(out)["headline"]


def test_unresolved_metric_stops_with_one_line(tmp_path):
    text = study_text("linear_budget", 50.0).replace('"pv_measured_nm"', '"psd1_rms_nm"')
    with pytest.raises(StudyError, match="psd1_rms_nm is not resolved.*three periods"):
        run(tmp_path, "psd1", text)


@pytest.mark.parametrize(
    ("old", "new", "where", "phrase"),
    [
        ('reason = "test"', 'reason = ""', "field 'reason'", "empty"),
        ('reason = "test"\n', "", "field 'reason'", "missing"),
        ("cost = [1.0, 2.0]", "cost = [1.0, 0.0]", "field 'cost'", "must be > 0"),
        ("limit = 50.0", "", "field 'limit'", "missing"),
        ('kind = "stiffness"', 'kind = "stifness"', "field 'kind'", "did you mean 'stiffness'"),
        ("range = [1e-09, 1e-07]", "range = [0.0, 1e-07]", "field 'range[0]'", "not positive"),
        (
            'parameter = "machine.error_motion_m"',
            'parameter = "rpm"',
            "field 'parameter'",
            "process",
        ),
        ('metric = "pv_measured_nm"', 'metric = "pv_nn"', "field 'metric'", "unknown metric"),
    ],
)
def test_study_file_mistakes_are_one_line(tmp_path, old, new, where, phrase):
    text = study_text("linear_budget", 50.0)
    assert old in text
    path = tmp_path / "bad.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(StudyError, match=phrase) as info:
        parse_study(path.read_text(), path)
    assert where in str(info.value) and "\n" not in str(info.value)


TOLERANCE_TABLES = ("points.csv", "budget.csv", "allocation.csv", "tradeoff.csv")


def test_one_and_two_workers_give_identical_tables(tmp_path):
    text = study_text("rss_budget", 60.0)
    one = run(tmp_path, "same", text, jobs=1)
    two = run(tmp_path, "same", text, jobs=2)
    for table in TOLERANCE_TABLES:
        assert (one / table).read_bytes() == (two / table).read_bytes(), table


@pytest.mark.slow
def test_dask_gives_identical_tables(tmp_path):
    from dask.distributed import LocalCluster

    text = study_text("rss_budget", 60.0)
    one = run(tmp_path, "same", text, jobs=1)
    with LocalCluster(
        n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None
    ) as cluster:
        dask = run(tmp_path, "same", text, backend="dask", scheduler=cluster.scheduler_address)
    for table in TOLERANCE_TABLES:
        assert (one / table).read_bytes() == (dask / table).read_bytes(), table


def forced_budget(design, process, model=None):
    """linear_budget with its fixed part proportional to the force factor (r = R fs / 3)."""
    force = design.get("machine.force_scale", 3.0)
    return {"pv_measured_nm": R * force / 3.0 + float(C @ _tau(design))}


def test_interval_at_the_optimum_samples_the_uncertain_bands(tmp_path):
    """Oracle: y = R fs / 3 + (allocated part), so at the optimum the interval is the force
    factor's sample interval mapped by that line, and P(meet) = P(fs <= 3) = 1."""
    extra = 'uncertain = ["machine.force_scale"]\nuncertain_samples = 16\n'
    out = run(tmp_path, "interval", study_text("forced_budget", 60.0, extra))
    final = read_table(out / "allocation.csv").iloc[-1]
    interval = read_table(out / "interval.csv").iloc[0]
    points = read_table(out / "points.csv")
    fs = points[points["group"] == "interval"]["machine.force_scale"].to_numpy()
    allocated = final["evaluated"] - R  # the calibrated force factor is 3
    expected = allocated + R * np.quantile(fs, [0.05, 0.95]) / 3.0
    np.testing.assert_allclose([interval["q05"], interval["q95"]], expected, rtol=1e-12)
    assert interval["samples"] == 16 and interval["p_meet"] == 1.0
    assert "P(meet) 1" in read_meta(out)["headline"]


def test_uncertain_input_may_not_be_a_designed_variable(tmp_path):
    path = tmp_path / "bad.toml"
    text = study_text("linear_budget", 50.0, 'uncertain = ["machine.straightness_m"]\n')
    path.write_text(text, encoding="utf-8")
    with pytest.raises(StudyError, match="'uncertain\\[0\\]'.*designed variable"):
        parse_study(text, path)


def test_rerun_that_computes_nothing_rewrites_nothing(tmp_path):
    """Oracle: the first run's own bytes (every table, meta.json, figure, the index)."""
    text = study_text("rss_budget", 60.0)
    first_dir = run(tmp_path, "clean", text)
    root = first_dir.parent
    first = {p: p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}
    run(tmp_path, "clean", text)
    assert {p: p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()} == first


def scaled_budget(design, process, model=None):
    """linear_budget times fs / 3: an uncertain factor (the force factor) on the whole
    budget, so P(y <= L) is the probability that fs <= 3 L / (R + C tau)."""
    force = design.get("machine.force_scale", 3.0)
    return {"pv_measured_nm": force / 3.0 * (R + float(C @ _tau(design)))}


def test_probability_constraint_is_the_closed_form_at_the_samples_quantile(tmp_path):
    """Oracle: with y = (fs / 3)(R + C tau), P(y <= L) >= p over the M common samples holds
    iff C tau <= 3 L / F - R, F the ceil(p M)-th smallest sampled fs: the cheapest allocation
    is the Lagrange optimum at the level 3 L / F. F lies in the ceil(p M)-th stratum of the
    Latin hypercube of fs's log-uniform band (an analytic interval of the p quantile), and the
    model meets the limit in exactly ceil(p M) samples."""
    from ufmt.studies.bands import documented_bands

    m, p, limit = 40, 0.9, 60.0
    need = math.ceil(p * m)
    extra = f'uncertain = ["machine.force_scale"]\nuncertain_samples = {m}\nprobability = {p}\n'
    out = run(tmp_path, "chance", study_text("scaled_budget", limit, extra))
    points = read_table(out / "points.csv")
    fs = np.unique(points[points["group"] == "interval"]["machine.force_scale"])  # sorted
    band = documented_bands()["machine.force_scale"]
    stratum = band.low * (band.high / band.low) ** (np.array([need - 1, need]) / m)
    assert len(fs) == m and stratum[0] <= fs[need - 1] <= stratum[1]
    tau, cost = linear_optimum(3.0 * limit / fs[need - 1])
    assert np.all((tau > TAU_MIN) & (tau < 1))  # interior: the closed form holds
    final = read_table(out / "allocation.csv").iloc[-1]
    assert final["meets"] and final["step"] == 0 and final["p_meet"] == need / m
    assert final["cost"] == pytest.approx(cost, rel=1e-6)
    designed = _tau({name: final[name] for name in VARIABLES})
    np.testing.assert_allclose(designed, tau, rtol=1e-5)
    assert final["evaluated"] == pytest.approx(limit, rel=1e-6)  # the need-th value binds
    nominal = read_table(out / "allocation.csv").query("specification == 'nominal'").iloc[-1]
    assert nominal["cost"] > final["cost"]  # the nominal (fs = 3) design is the dearer
    interval = read_table(out / "interval.csv").set_index("specification")
    assert interval.loc["P >= 0.9", "p_meet"] == need / m
    assert interval.loc["nominal", "p_meet"] == 1.0  # fs <= 3 in every sample
    assert f"P(pv_measured_nm <= 60) >= 0.9 over {m} samples" in read_meta(out)["headline"]


def test_probability_needs_uncertain_bands_and_a_probability(tmp_path):
    path = tmp_path / "bad.toml"
    for extra, phrase in (
        ("probability = 0.9\n", "uncertain"),
        ('uncertain = ["machine.force_scale"]\nprobability = 1.0\n', "outside \\(0, 1\\)"),
    ):
        text = study_text("linear_budget", 50.0, extra)
        with pytest.raises(StudyError, match=phrase) as err:
            parse_study(text, path)
        assert "\n" not in str(err.value)


def test_uncertain_bands_are_the_study_models_own(tmp_path):
    """On a model with [[uncertain]] tables the patterns match its bands (the declared band,
    log scale as declared); on one without, one line saying how to declare them."""
    bridge = (Path(__file__).resolve().parents[1] / "examples" / "bridge.toml").read_text()
    bridge = bridge.split("\n[[uncertain]]")[0]  # without the example's own tables
    declared = (
        '\n[[uncertain]]\nname = "machine.force_scale"\nband = [0.8, 1.25]\n'
        'distribution = "loguniform"\nsource = "test"\n'
    )
    text = (
        f'kind = "optimise-tolerances"\nfunction = "{HERE}:linear_budget"\nmodel = "m.toml"\n'
        'limit = 50.0\nuncertain = ["machine.*"]\n[[variable]]\n'
        'parameter = "machine.straightness_m"\nrange = [2e-9, 2e-7]\ncost = [1.0, 1.0]\n'
        'reason = "test"\n'
    )
    path = tmp_path / "s.toml"
    (tmp_path / "m.toml").write_text(bridge + declared, encoding="utf-8")
    study = parse_study(text, path)
    uncertain = [b for b in study.bounds if b.parameter == "machine.force_scale"]
    assert [(b.low, b.high, b.log) for b in uncertain] == [(0.8, 1.25, True)]
    assert study.options["uncertain"] == ["machine.force_scale"]
    (tmp_path / "m.toml").write_text(bridge, encoding="utf-8")
    with pytest.raises(StudyError, match="declares no uncertain inputs") as err:
        parse_study(text, path)
    assert "\n" not in str(err.value)
