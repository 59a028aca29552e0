"""Figures: geometry drawn where the model says (oracle: the model file's coordinates), every
plot returns a Figure and draws into a given axes."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from ufmt.model.load import load_model
from ufmt.mstmm.solve import solve_modes
from ufmt.plots import new_figure, save_figure
from ufmt.plots.modes import beam_polyline, plot_mode

BRIDGE = Path(__file__).resolve().parents[1] / "examples" / "bridge.toml"


@pytest.fixture(scope="module")
def bridge():
    model = load_model(BRIDGE)
    return model, solve_modes(model, count=3)


def _lines(fig: Figure, gid: str) -> np.ndarray:
    (line,) = [a for a in fig.axes[0].get_lines() if a.get_gid() == gid]
    return np.column_stack(line.get_data_3d())


def test_beam_is_drawn_start_to_end_monotone_along_its_axis(bridge):
    # the shaft runs start (top) -> end (bottom); the MSTMM stores its stations from the input
    # end, here its end, which used to come out as an "N" zigzag
    model, solution = bridge
    shaft = model.body("shaft")
    stations = solution.shapes.beams["shaft"][0]
    axis = shaft.end - shaft.start
    assert np.all(np.diff((stations - shaft.start) @ axis) < 0)  # the stored order is reversed
    line = _lines(plot_mode(model, solution.shapes, 0), "beam:shaft:undeformed")
    along = (line - shaft.start) @ axis / (axis @ axis)
    assert along[0] == 0.0 and along[-1] == 1.0
    assert np.all(np.diff(along) > 0)
    np.testing.assert_allclose(np.cross(line - shaft.start, axis), 0.0, atol=1e-12)


def test_beam_end_displacements_are_those_of_the_nearest_stations(bridge):
    model, solution = bridge
    shaft = model.body("shaft")
    positions, _, motion = solution.shapes.beams["shaft"]
    line, disp = beam_polyline(shaft, positions, motion[0])
    nearest_start = np.argmin(np.linalg.norm(positions - shaft.start, axis=1))
    nearest_end = np.argmin(np.linalg.norm(positions - shaft.end, axis=1))
    np.testing.assert_array_equal(disp[0], motion[0, nearest_start, :3])
    np.testing.assert_array_equal(disp[-1], motion[0, nearest_end, :3])


def test_mode_plot_legend_names_undeformed_and_tool_tip(bridge, tmp_path):
    model, solution = bridge
    fig = plot_mode(model, solution.shapes, 0)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "undeformed" in labels and "tool tip" in labels
    path = save_figure(fig, tmp_path / "mode.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_mode_colour_is_the_displacement_magnitude_and_bodies_are_keyed(bridge):
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    model, solution = bridge
    fig = plot_mode(model, solution.shapes, 0)
    ax = fig.axes[0]
    (deformed,) = [c for c in ax.collections if isinstance(c, Line3DCollection)]
    shares = np.asarray(deformed.get_array())
    # every edge's colour is its mean |displacement| over the largest: in [0, 1], and the
    # edge of the most moving corners near 1 (the largest is reached at a corner or station)
    assert shares.min() >= 0 and 0.9 <= shares.max() <= 1.0
    assert len(fig.axes) == 2 and "displacement" in fig.axes[1].get_ylabel()  # colour bar
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "workpiece (top centre)" in labels
    numbers = {t.get_text() for t in ax.texts}
    key = fig.texts[-1].get_text().splitlines()
    assert {line.split(":")[0] for line in key} == numbers  # each number keyed to a name


def test_mode_animation_is_a_gif_of_the_requested_frames(bridge, tmp_path):
    from PIL import Image

    from ufmt.plots.modes import animate_mode

    model, solution = bridge
    path = animate_mode(model, solution.shapes, 0, tmp_path / "mode.gif", frames=4)
    with Image.open(path) as image:
        assert image.format == "GIF" and image.n_frames == 4  # phases 1, 0, -1, 0


def test_small_grounded_body_is_in_view(bridge):
    # the bridge stands on ground but is the machine itself: it must not be cut off
    model, solution = bridge
    fig = plot_mode(model, solution.shapes, 0)
    ax = fig.axes[0]
    bridge_z = model.body("bridge").center_of_mass[2]
    assert ax.get_zlim()[0] < bridge_z < ax.get_zlim()[1]


def test_mode_plot_draws_into_a_given_axes(bridge):
    model, solution = bridge
    fig = new_figure()
    ax = fig.add_subplot(projection="3d")
    assert plot_mode(model, solution.shapes, 1, ax=ax) is fig


def test_plot_mode_of_a_user_model_stays_out_of_the_validation_folder(tmp_path, monkeypatch):
    from ufmt.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["plot-mode", "1", str(BRIDGE)]) == 0
    assert (tmp_path / "results" / "bridge" / "mode-1.png").is_file()
    assert not (tmp_path / "results" / "validation").exists()


def test_modal_solution_repr_table_plot_and_save(bridge, tmp_path):
    from ufmt.mstmm.solve import describe

    model, solution = bridge
    assert len(repr(solution)) < 1000 and "modes=3" in repr(solution)
    table = solution.to_frame(model)
    assert list(table.columns) == [
        "mode",
        "frequency_hz",
        "body",
        "direction",
        "energy_share",
    ]
    np.testing.assert_array_equal(table["frequency_hz"], solution.frequencies_hz)
    # the dominant body and direction are the first entry of `ufmt modes`' description
    lines = describe(model, solution.energy_shares(model), top=1)
    for row, line in zip(table.itertuples(), lines, strict=True):
        assert line == f"{row.body} {row.direction} {100 * row.energy_share:.0f}%"
    assert solution.to_frame().equals(table)  # the solution keeps the model it was solved for
    unbound = dataclasses.replace(solution, model=None)
    assert list(unbound.to_frame().columns) == ["mode", "frequency_hz"]
    # the energy shares stacked in the plot sum to 100 % per mode
    fig = solution.plot(model=model)
    heights = np.zeros(3)
    for bar in fig.axes[0].patches:
        heights[round(bar.get_x() + bar.get_width() / 2) - 1] += bar.get_height()
    np.testing.assert_allclose(heights, 100.0)
    written = solution.save(tmp_path, model)
    assert [p.name for p in written] == ["modes.csv", "modes.png"]
    assert all(p.is_file() for p in written)


# ---------------------------------------------------------------------------------------------
# study figures on hand-made tables


def _tick_texts(fig: Figure) -> list[str]:
    fig.canvas.draw()
    ax = fig.axes[0]
    return [t.get_text() for t in ax.get_yticklabels() + ax.get_xticklabels() if t.get_text()]


def test_pareto_log_axis_reads_plain_numbers_and_points_carry_their_recipe():
    import pandas as pd

    from ufmt.plots.studies import plot_pareto

    feed = np.array([4.0, 8.0, 16.0])
    points = pd.DataFrame(
        {"rpm": 300.0, "feed_mm_min": feed, "depth_um": 2.0, "pv_nm": [30.0, 60.0, 400.0]}
    )
    front = points.assign(cutting_time_min=1000.0 / feed)
    optima = front.iloc[[0]].assign(optimum="min-pv", travel_mm=1000.0, target_pv_nm=100.0)
    fig = plot_pareto(points, front, optima)
    texts = _tick_texts(fig)
    assert "100" in texts and "200" in texts
    assert not any("10^" in t or "times" in t or "×" in t for t in texts)
    # front points are numbered on the axes; their recipes are listed in the legend
    assert [t.get_text() for t in fig.axes[0].texts] == ["1", "2", "3"]
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any("1: 300 rpm, 16 mm/min, 2 µm" in t for t in legend)  # shortest time first
    assert not any("min-pv" in t for t in legend) and any(
        "minimum whole-plate PV" in t for t in legend
    )
    assert "Table 1" not in fig.axes[0].get_title()  # no bounds given: no claim about them
    table1 = [
        {"parameter": "rpm", "range": [200.0, 400.0]},
        {"parameter": "feed_mm_min", "range": [4.0, 16.0]},
        {"parameter": "depth_um", "range": [2.0, 8.0]},
    ]
    titled = plot_pareto(points, front, optima, bounds=table1).axes[0].get_title()
    assert "(Table 1 ranges)" in titled
    narrower = [{**table1[0], "range": [250.0, 400.0]}, *table1[1:]]
    assert "Table 1" not in plot_pareto(points, front, optima, bounds=narrower).axes[0].get_title()


def test_narrow_log_range_labels_every_digit():
    import pandas as pd

    from ufmt.plots.studies import plot_convergence

    convergence = pd.DataFrame(
        {
            "stage": "min-pv",
            "phase": "global",
            "evaluation": [1, 2, 3],
            "best_objective_nm": [150.0, 90.0, 74.0],
        }
    )
    texts = _tick_texts(plot_convergence(convergence))
    assert {"70", "80", "90", "100"} <= set(texts)  # the 74 nm optimum is read between them
    annotations = [t.get_text() for t in plot_convergence(convergence).axes[0].texts]
    assert "74" in annotations


def test_sweep_lines_show_the_interferometer_pv_and_leave_out_zero_sources():
    import pandas as pd

    from ufmt.plots.studies import plot_pv_lines

    x = np.array([1.0, 2.0, 4.0])
    points = pd.DataFrame(
        {
            "group": "k",
            "k": x,
            "pv_nm": [150.0, 140.0, 137.0],
            "pv_measured_nm": [60.0, 55.0, 52.0],
            "pv_dynamic_nm": [12.0, 9.0, 8.0],
            "pv_spindle_tilt_nm": 0.0,
            "pv_straightness_nm": 70.9,
            "status": "ok",
        }
    )
    groups = [{"name": "k", "axes": [{"parameter": "k", "log": True}]}]
    fig = plot_pv_lines(points, groups, {"k": 2.0})
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert len(fig.legends) == 1 and all(a.get_legend() is None for a in fig.axes)
    assert any(t.startswith("interferometer PV") for t in labels)
    assert any(t.startswith("whole-plate PV") for t in labels)
    assert not any("spindle tilt" in t for t in labels)  # zero: left out
    assert any("straightness alone: 70.9 nm at every point" in t for t in labels)
    vibration = next(
        a for a in fig.axes for line in a.get_lines() if line.get_label().startswith("cutting")
    )
    low, high = vibration.get_ylim()
    assert low > 0 and high < 20  # its own axis: the 12 -> 8 nm change fills it


def test_design_tradeoff_cost_is_the_optimisers_cost():
    import pandas as pd

    from ufmt.plots.studies import design_cost

    meta = {"baseline": {"k_a": 2.0, "k_b": 10.0}, "options": {"cost": {"k_a": 5.0, "k_b": 1.0}}}
    points = pd.DataFrame({"k_a": [2.0, 4.0], "k_b": [10.0, 5.0]})
    # calibrated design: every ratio 1, cost = sum of the weights
    np.testing.assert_allclose(design_cost(points, meta), [6.0, 10.5])


def test_points_outside_table1_are_shaded_on_the_sweep():
    import pandas as pd

    from ufmt.plots.studies import plot_pv_lines

    def labels(rpm):
        points = pd.DataFrame({"group": "rpm", "rpm": rpm, "pv_nm": [3.0, 2.0, 1.0]})
        groups = [{"name": "rpm", "axes": [{"parameter": "rpm", "log": False}]}]
        fig = plot_pv_lines(points, groups, {"rpm": 300.0})
        return fig.axes[0].get_legend_handles_labels()[1]

    assert "outside Table 1" in labels([150.0, 300.0, 350.0])
    assert "outside Table 1" not in labels([200.0, 300.0, 400.0])


# ---------------------------------------------------------------------------------------------
# response figures on hand-made data


def test_time_plots_shade_exactly_when_the_tool_cuts():
    from types import SimpleNamespace

    from ufmt.plots.response import plot_zre

    t = 981.0 + np.linspace(0.0, 0.4, 401)
    force = np.zeros((t.size, 3))
    cutting = (t - 981.0) % 0.2 < 0.05
    force[cutting, 2] = 1.0
    response = SimpleNamespace(t=t, force=force, z_re=np.sin(t), method="time")
    fig = plot_zre(response)
    ax = fig.axes[0]
    assert ax.get_xlim()[0] < 0.01  # time runs from the window's start
    assert "981.0 s" in ax.get_xlabel()
    (shade,) = [c for c in ax.collections if c.get_label() == "tool cutting"]
    shaded_x = np.concatenate([p.vertices[:, 0] for p in shade.get_paths()])
    assert shaded_x.min() >= 0.0 and shaded_x.max() <= 0.25 + 1e-9
    # the shade's x extents cover the cutting samples and nothing else
    inside = np.zeros(t.size, bool)
    for path in shade.get_paths():
        lo, hi = path.vertices[:, 0].min(), path.vertices[:, 0].max()
        inside |= (t - 981.0 >= lo) & (t - 981.0 <= hi)
    np.testing.assert_array_equal(inside, cutting)


def test_compared_sweep_panels_share_one_scale_and_do_not_stretch_a_small_wiggle():
    """Oracle: the data. Two parameters' metric panels get one y range; a 0.5 nm wiggle on a
    10 nm value is drawn on a range of at least MIN_SPAN_SHARE of the value (not stretched
    over the panel), and the 10 -> 20 nm trend of the other parameter fits inside it."""
    import pandas as pd

    from ufmt.plots.studies import MIN_SPAN_SHARE, plot_pv_lines

    x = np.array([1.0, 2.0, 3.0])
    wiggle = pd.DataFrame({"group": "a", "a": x, "pv_measured_nm": [10.0, 10.5, 10.0]})
    trend = pd.DataFrame({"group": "b", "b": x, "pv_measured_nm": [10.0, 15.0, 20.0]})
    groups = [{"name": n, "axes": [{"parameter": n, "log": False}]} for n in "ab"]
    fig = plot_pv_lines(pd.concat([wiggle, trend]), groups, {}, "pv_measured_nm")
    tops = [a for a in fig.axes if a.get_ylabel().startswith("interferometer PV")]
    assert len(tops) == 2 and tops[0].get_ylim() == tops[1].get_ylim()
    low, high = tops[0].get_ylim()
    assert low <= 10.0 and high >= 20.0
    alone = plot_pv_lines(wiggle, groups[:1], {}, "pv_measured_nm")
    (top,) = [a for a in alone.axes if a.get_ylabel().startswith("interferometer PV")]
    low, high = top.get_ylim()
    assert high - low >= MIN_SPAN_SHARE * 10.5 and low <= 10.0 <= 10.5 <= high


def test_uncertainty_figures_label_inputs_in_words_and_keep_indices_in_the_unit_interval():
    """Oracle: an index is a share of variance, in [0, 1]; its drawn bars, error bars and bands
    stay there even when the bootstrap's half-width does not. Labels are words with units;
    the convergence legend sits right of its axes (not over the data)."""
    import pandas as pd

    from ufmt.plots.uncertainty import input_label, plot_convergence, plot_sobol

    assert input_label("machine.tool_compliance_m_per_N") == "tool compliance [m/N]"
    assert input_label("machine.force_scale") == "force scale [-]"
    assert input_label("hinge.h31.rotational_stiffness[1]") == (
        "hinge h31 rotational stiffness y [N m/rad]"
    )
    names = ["machine.force_scale", "hinge.h25.stiffness[2]", "machine.straightness_m"]
    sobol = pd.DataFrame(
        {
            "metric": "pv_measured_nm",
            "parameter": names,
            "S1": [0.9, -0.2, 0.05],
            "S1_conf": [0.5, 0.4, 0.1],
            "ST": [1.1, 0.1, 0.05],
            "ST_conf": [0.6, 0.3, 0.1],
        }
    )
    fig = plot_sobol(sobol)
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_yticklabels()]
    assert labels == ["force scale [-]", "hinge h25 stiffness z [N/m]", "straightness [m]"]
    assert ax.get_xlim() == (0.0, 1.0)
    widths = [bar.get_width() for bar in ax.patches]
    assert len(widths) == 6 and min(widths) >= 0.0 and max(widths) <= 1.0
    errorbars = [c for c in ax.collections if c.get_segments()]
    assert errorbars
    for bars in errorbars:
        x = np.concatenate([s[:, 0] for s in bars.get_segments()])
        assert x.min() >= 0.0 and x.max() <= 1.0
    convergence = pd.DataFrame(
        {
            "metric": "pv_measured_nm",
            "statistic": "ST",
            "parameter": np.repeat(names, 3),
            "samples": np.tile([8, 16, 32], 3),
            "value": [1.3, 1.1, 0.9, -0.1, 0.05, 0.1, 0.2, 0.1, 0.05],
            "conf": [1.0, 0.6, 0.3, 0.5, 0.3, 0.1, 0.4, 0.2, 0.1],
        }
    )
    fig = plot_convergence(convergence)
    ax = fig.axes[0]
    assert ax.get_ylim() == (0.0, 1.0)
    for band in ax.collections:
        y = np.concatenate([p.vertices[:, 1] for p in band.get_paths()])
        assert y.min() >= 0.0 and y.max() <= 1.0
    fig.canvas.draw()
    legend = ax.get_legend()
    assert [t.get_text() for t in legend.get_texts()][0] == "force scale [-]"
    assert legend.get_window_extent().x0 >= ax.get_window_extent().x1


def test_time_plots_zoom_on_one_engagement_beside_the_window():
    """Oracle: a hand-made record with engagements at 0.15 + 0.2 k s lasting 0.01 s: the zoom
    shows the first whole one (from half its length before to twice after), its shade is
    exactly that engagement, and the window marks the zoomed span."""
    from types import SimpleNamespace

    from ufmt.plots.response import ZOOM_AFTER, ZOOM_BEFORE, plot_tool_tip, plot_zre

    t = 500.0 + np.arange(20001) * 1e-4
    cutting = np.round((t - 500.0) * 1e4).astype(int) % 2000 >= 1500
    cutting &= np.round((t - 500.0) * 1e4).astype(int) % 2000 < 1600
    force = np.zeros((t.size, 3))
    force[cutting, 2] = 1.0
    z = np.sin(2 * np.pi * 150 * t) * 1e-9
    response = SimpleNamespace(
        t=t, force=force, z_re=z, method="time", tip_disp=np.c_[z, z, z], tip_acc=np.c_[z, z, z]
    )
    start, end = 0.15, 0.1599
    for fig, zoom in ((plot_zre(response), 1), (plot_tool_tip(response), 1)):
        window, zoomed = fig.axes[0], fig.axes[zoom]
        low, high = zoomed.get_xlim()
        np.testing.assert_allclose(
            [low, high], [start - ZOOM_BEFORE * (end - start), end + ZOOM_AFTER * (end - start)]
        )
        (shade,) = zoomed.collections
        x = np.concatenate([p.vertices[:, 0] for p in shade.get_paths()])
        np.testing.assert_allclose([x.min(), x.max()], [start, end], atol=1e-9)
        band = [p for p in window.patches if p.get_facecolor()[:3] == (0.6, 0.6, 0.6)]
        assert len(band) == 1
