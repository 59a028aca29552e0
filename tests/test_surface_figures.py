"""The one surface figure (as machined, as measured) and the exports of a simulation.

Oracles: the interferometer model's own PV (an independent code path), the drawn data's own
extremes, the parabolic scallop h = f^2 / (8 r_n) of eq. 4.1, and round trips through the
written files."""

from __future__ import annotations

import datetime

import numpy as np
import pytest
from synthetic import MACHINE, synthetic_basis

import ufmt
from ufmt.exports import export_grid, read_sdf, sdf_text, write_xyz
from ufmt.machining.process import Process
from ufmt.model.machine import read_machine
from ufmt.model.schema import Model
from ufmt.plots.surface import measured_map, plot_surface_map, scallop_profile


@pytest.fixture(scope="module")
def result():
    model = Model("syn", (), (), machine=read_machine(MACHINE), source="syn.toml")
    return ufmt.simulate(
        model, Process(300, 15, 4), basis=synthetic_basis(n=6), static_correction=False
    )


def test_measured_map_is_what_the_interferometer_reports(result):
    x, y, z = measured_map(result)
    assert (z.max() - z.min()) * 1e9 == pytest.approx(result.metrics["pv_measured_nm"], rel=1e-12)
    assert x.size < result.smooth_surface.x.size and y.size < result.smooth_surface.y.size


@pytest.mark.parametrize("stage", ["machined", "measured"])
def test_map_is_diverging_about_zero_and_marks_the_drawn_extremes(result, stage):
    fig = plot_surface_map(result, stage)
    ax = fig.axes[0]
    mesh = ax.collections[0]
    z = np.asarray(mesh.get_array()).reshape(mesh._coordinates.shape[0] - 1, -1)
    norm = mesh.norm
    assert norm.vcenter == 0 and norm.vmin == -norm.vmax == -np.abs(z).max()
    marks = {line.get_label().split(":")[0]: line for line in ax.get_lines()}
    i, j = np.unravel_index(np.argmax(z), z.shape)
    assert marks["highest"].get_label().startswith(f"highest: {z[i, j]:+.1f} nm")
    i, j = np.unravel_index(np.argmin(z), z.shape)
    assert marks["lowest"].get_label().startswith(f"lowest: {z[i, j]:+.1f} nm")
    assert any("clear aperture" in p.get_label() for p in ax.patches)


def test_feed_marks_are_drawn_at_their_own_scale_only(result):
    y_um, z_nm, _ = scallop_profile(result)
    feed = result.process.feed_per_rev_m
    h = feed**2 / (8 * result.machine.nose_radius)  # at phi = 0 (the spindle axis is inside)
    assert z_nm.max() == pytest.approx(h * 1e9, rel=1e-9)
    assert z_nm.max() == pytest.approx(result.metrics["roughness_pv_nm"], rel=1e-9)
    assert y_um[-1] == pytest.approx(4 * feed * 1e6, rel=1e-9)  # four periods of f
    off = ufmt.simulate(
        Model("syn", (), (), machine=read_machine(MACHINE), source="syn.toml"),
        Process(300, 15, 4),
        basis=synthetic_basis(n=6),
        static_correction=False,
        sources=("dynamic",),
    )
    assert scallop_profile(off) is None
    texts = [t.get_text() for a in off.plot().axes for t in a.texts]
    assert "feed marks switched off" in texts


def test_export_lattice_holds_every_computed_row(result):
    # the exports' uniform lattice passes through the evenly spaced and the refined rows
    s = result.smooth_surface
    assert not s.core_rows.all()
    x, y, z = export_grid(s)
    np.testing.assert_allclose(np.diff(y), np.diff(y).mean(), rtol=1e-9)
    rows = np.abs(y[:, None] - s.y[None, :]).argmin(axis=0)
    np.testing.assert_allclose(y[rows], s.y, atol=1e-12)
    np.testing.assert_array_equal(z[rows], s.z)


def test_sdf_and_xyz_round_trip_the_even_grid(result, tmp_path):
    x, y, z = export_grid(result.smooth_surface)
    text = sdf_text(result.smooth_surface, datetime.datetime(2026, 1, 2, 3, 4))
    lines = text.split("\r\n")
    assert lines[0] == "aISO-1.0" and "CreateDate = 020120260304" in lines
    assert f"NumPoints = {x.size}" in lines and f"NumProfiles = {y.size}" in lines
    (tmp_path / "s.sdf").write_text(text, encoding="ascii", newline="")
    rx, ry, rz = read_sdf(tmp_path / "s.sdf")
    np.testing.assert_allclose(rx, x, atol=1e-12)
    np.testing.assert_allclose(ry, y, atol=1e-12)
    np.testing.assert_allclose(rz, z, atol=1e-15)  # 1e-6 nm written
    points = np.loadtxt(write_xyz(result.smooth_surface, tmp_path / "s.xyz"))
    assert points.shape == (z.size, 3)
    np.testing.assert_allclose(points[:, 2].reshape(z.shape), z, rtol=1e-8, atol=1e-20)
    np.testing.assert_allclose(points[: x.size, 0], x, rtol=1e-8)


def test_time_frame_is_the_record_window(result, tmp_path):
    frame = result.to_frame(kind="time")
    r = result.response
    assert len(frame) == r.t.size
    np.testing.assert_array_equal(frame["z_re_nm"], r.z_re * 1e9)
    np.testing.assert_array_equal(frame["tip_acc_z_mm_s2"], r.tip_acc[:, 2] * 1e3)
    assert frame["cutting"].any() and not frame["cutting"].all()
    with pytest.raises(ValueError, match="kind"):
        result.to_frame(kind="modes")
    names = {p.name for p in result.save(tmp_path)}
    assert {"surface.sdf", "surface.xyz", "time.csv", "surface_measured.png"} <= names


def test_psd_figure_draws_the_psd_the_band_rms_integrates(result):
    from ufmt.machining.psd import BANDS, band_power
    from ufmt.plots.psd import KDP_SPEC_RMS_NM, band_verdict, plot_psd

    fig = plot_psd(result)
    ax = fig.axes[0]
    along = next(line for line in ax.get_lines() if line.get_label().startswith("along"))
    f_mm, psd_nm2mm = along.get_data()
    # the drawn curve is in 1/mm and nm^2 mm: back to SI, its PSD1 power is the metric's
    power = band_power(np.r_[0.0, f_mm * 1e3], np.r_[0.0, psd_nm2mm * 1e-21], BANDS["psd1"])
    assert np.sqrt(power) * 1e9 == pytest.approx(result.metrics["psd1_rms_along_nm"], rel=1e-9)
    text = fig.texts[-1].get_text()
    value = result.metrics["psd1_rms_along_nm"]
    verdict = "passes" if value <= KDP_SPEC_RMS_NM["psd1"] else "fails"
    assert f"PSD1 RMS along : {value:.2f} nm (limit 1.8 nm: {verdict})" in text
    assert "grid" in band_verdict(float("nan"), 1.1, 100, 1e-3, BANDS["psd2"])
    assert "profile 52 mm < 3 x 33 mm" in band_verdict(float("nan"), 1.8, 53, 1e-3, BANDS["psd1"])


def test_pv_by_source_draws_acting_sources_and_names_the_rest(result):
    from ufmt.plots.surface import plot_pv_by_source

    fig = plot_pv_by_source([result], ["reference cut"])
    ax = fig.axes[0]
    acting = [n for n, v in result.pv_by_source_nm.items() if v]
    idle = [n for n, v in result.pv_by_source_nm.items() if not v]
    bars = [b for c in ax.containers for b in c]
    assert len(bars) == len(acting) + 2  # each acting source, the whole-plate and measured totals
    heights = [b.get_height() for b in bars]
    expected = [result.pv_by_source_nm[n] for n in acting]
    expected += [result.metrics["pv_nm"], result.metrics["pv_measured_nm"]]
    np.testing.assert_allclose(heights, expected)
    for name in idle:
        assert name.replace("_", " ") in ax.get_xlabel()
