"""Plot functions return Figures and write PNG files that matplotlib can read back."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure

import batecho
from batecho.echoes.canonical import canonical_leaf_box
from batecho.plotting import (
    lobe_surface,
    plot_echo_image,
    plot_impulse,
    plot_impulses,
    plot_scene_3d,
    plot_spectrogram,
    plot_spectrum,
)


@pytest.fixture(scope="module")
def box():
    leaves = canonical_leaf_box(np.random.default_rng(5), density_per_m3=4.0)
    return batecho.Scene(leaves)


@pytest.fixture(scope="module")
def sonar():
    return batecho.Sonar(beamwidth_deg=30)


@pytest.fixture(scope="module")
def poses():
    # Six pulses on a circle around the box, looking at its centre; one more looking away.
    ring = batecho.circle((5.5, 0.0), radius=6.2, altitude=0.0, n_points=6, heading="center")
    away = batecho.Poses([-2.0, 0.0, 0.0], [-1.0, 0.0, 0.0])
    return batecho.Poses.concatenate([ring, away])


@pytest.fixture(scope="module")
def echoes(box, sonar, poses):
    return batecho.simulate(box, sonar, poses)


def _png_ok(fig, path) -> bool:
    fig.savefig(path, dpi=60)
    plt.close(fig)
    img = plt.imread(path)
    return path.stat().st_size > 0 and img.ndim == 3 and img.shape[0] > 10 and img.shape[1] > 10


def test_plot_impulse_writes_png(echoes, tmp_path):
    fig = plot_impulse(echoes, 0)
    assert isinstance(fig, Figure) and _png_ok(fig, tmp_path / "impulse.png")


def test_plot_impulse_names_its_unit_and_scale(echoes):
    fig = plot_impulse(echoes, 0)
    ax = fig.axes[0]
    peak = np.abs(echoes.impulse[0]).max()
    e = math.floor(math.log10(peak))
    assert ax.get_ylabel() == f"echo, relative pressure ($\\times10^{{{e}}}$)"
    drawn = np.abs(ax.lines[0].get_ydata()).max()
    assert 1.0 <= drawn < 10.0 and math.isclose(drawn * 10.0**e, peak, rel_tol=1e-12)
    fig.canvas.draw()
    assert ax.yaxis.get_offset_text().get_text() == ""  # no offset text to collide with
    plt.close(fig)


def test_plot_impulse_draws_the_envelope_over_the_impulse_in_another_colour(echoes):
    fig = plot_impulse(echoes, 0)
    imp, env = fig.axes[0].lines[:2]
    assert imp.get_label() == "impulse response" and env.get_label() == "envelope"
    assert imp.get_color() != env.get_color() and env.get_zorder() >= imp.get_zorder()
    assert np.all(env.get_ydata() >= np.abs(imp.get_ydata()) * (1 - 1e-9) - 1e-12)
    plt.close(fig)


def test_plot_impulse_keeps_its_legend_off_the_data(echoes):
    fig = plot_impulse(echoes, 0)
    fig.canvas.draw()
    ax = fig.axes[0]
    leg = ax.get_legend().get_window_extent()
    assert leg.x0 >= ax.get_window_extent().x1  # right of the axes, not over them
    plt.close(fig)


def test_plot_impulse_says_an_empty_lobe_is_exactly_zero(echoes):
    silent = int(np.flatnonzero(echoes.n_leaves == 0)[0])
    fig = plot_impulse(echoes, silent)
    assert "exactly zero" in fig.axes[0].get_title()
    plt.close(fig)


def test_plot_impulse_max_range_cuts_the_time_axis(echoes):
    fig = plot_impulse(echoes, 0, max_range_m=5.0)
    x = fig.axes[0].lines[0].get_xdata()
    assert x.max() <= 2 * 5.0 / echoes.sonar.sound_speed * 1e3 + 1e-9
    plt.close(fig)


def test_plot_impulses_one_visible_panel_per_index(echoes, tmp_path):
    fig = plot_impulses(echoes, [0, 1, 2], ncols=2, titles=["a", "b", "c"])
    visible = [ax for ax in fig.axes if ax.get_visible() and ax.get_title()]
    assert [ax.get_title() for ax in visible] == ["a", "b", "c"]
    assert _png_ok(fig, tmp_path / "impulses.png")


def test_plot_impulses_labels_time_below_and_range_above_once_per_column(echoes):
    fig = plot_impulses(echoes, [0, 1, 2, 3], ncols=2)
    fig.canvas.draw()
    panels = [ax for ax in fig.axes if ax.get_ylabel()]
    assert len(panels) == 4
    for k, ax in enumerate(panels):
        shown = [t.get_text() for t in ax.get_xticklabels() if t.get_visible() and t.get_text()]
        bottom = k >= 2
        assert (ax.get_xlabel() == "time (ms)") == bottom and bool(shown) == bottom
        ranges = [c for c in ax.child_axes if c.get_xlabel() == "range (m)"]
        assert len(ranges) == (0 if bottom else 1)
    assert len(fig.legends) == 1 and not any(ax.get_legend() for ax in panels)
    plt.close(fig)


def test_plot_spectrum_writes_png(echoes, tmp_path):
    assert _png_ok(plot_spectrum(echoes, 1), tmp_path / "spectrum.png")


def test_plot_spectrum_of_a_single_bin_marks_its_one_point(box, poses):
    # (a line through one point draws nothing)
    one_bin = batecho.simulate(
        box, batecho.Sonar(beamwidth_deg=30, band_hz=(70e3, 70e3 + 1), window="rect"), poses
    )
    assert one_bin.spectrum.shape[1] == 1
    fig = plot_spectrum(one_bin, 1)
    (line,) = fig.axes[0].get_lines()
    assert line.get_marker() not in (None, "None", "", " ")
    plt.close(fig)


def test_plot_spectrogram_writes_png(echoes, tmp_path):
    assert _png_ok(plot_spectrogram(echoes, 1), tmp_path / "spectrogram.png")


def test_plot_spectrogram_spans_the_band_and_a_quarter_of_it_either_side(echoes):
    fig = plot_spectrogram(echoes, 1)
    assert fig.axes[0].get_ylim() == pytest.approx((55.0, 85.0))
    assert "kHz" in fig.axes[0].get_ylabel() and "dB" in fig.axes[1].get_ylabel()
    plt.close(fig)


def test_plot_spectrogram_has_no_power_at_0_hz(echoes):
    """Each segment's mean removed before the window (SciPy's default) left a line at 0 Hz."""
    fig = plot_spectrogram(echoes, 1, nperseg=256)
    mesh = fig.axes[0].collections[0]
    db = np.asarray(mesh.get_array()).reshape(129, -1)  # nperseg // 2 + 1 frequencies
    assert db[0].max() < -60.0 and db.max() == 0.0
    plt.close(fig)


@pytest.mark.parametrize("scale", [1e290, 1e-290])
def test_plot_spectrogram_does_not_depend_on_the_echoes_scale(echoes, scale):
    """The power overflowed to inf or underflowed to zero: the figure was blank."""
    import dataclasses

    scaled = dataclasses.replace(echoes, impulse=echoes.impulse * scale)
    want, got = (
        np.asarray(plot_spectrogram(e, 1).axes[0].collections[0].get_array())
        for e in (echoes, scaled)
    )
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)  # dB
    plt.close("all")


def test_plot_spectrogram_says_an_empty_lobe_is_exactly_zero(echoes):
    """A silent pose's spectrogram was a black panel with nothing to say why."""
    silent = int(np.flatnonzero(echoes.n_leaves == 0)[0])
    fig = plot_spectrogram(echoes, silent)
    assert "exactly zero" in fig.axes[0].get_title()
    plt.close(fig)


def test_plot_echo_image_uses_the_given_x(echoes, tmp_path):
    x = np.linspace(10.0, 70.0, len(echoes))
    fig = plot_echo_image(echoes, x=x, xlabel="angle (deg)", max_range_m=8.0)
    ax = fig.axes[0]
    lo, hi = ax.get_xlim()
    assert lo < 10.0 and hi > 70.0 and ax.get_xlabel() == "angle (deg)"
    assert ax.get_ylim()[1] <= 8.0 + 1e-9
    assert _png_ok(fig, tmp_path / "echo_image.png")


def test_plot_echo_image_colours_are_relative_to_a_percentile_not_the_loudest(box, sonar):
    """One pulse 5 cm from a leaf (1/r^2 makes it some 70 dB louder) leaves the colours of
    the other 60 within 3 dB of where they were."""
    ring = batecho.circle((5.5, 0.0), radius=6.2, altitude=0.0, n_points=60, heading="center")
    leaf, n = box.leaves.centers[0], box.leaves.normals[0]
    near = batecho.Poses(leaf - 0.05 * n, n)  # 5 cm from a leaf, facing it
    quiet = batecho.simulate(box, sonar, ring)
    loud = batecho.simulate(box, sonar, batecho.Poses.concatenate([ring, near]), min_clearance_m=0)
    assert loud.envelope()[-1].max() > 1000 * quiet.envelope().max()

    def image(e):
        fig = plot_echo_image(e)
        mesh = fig.axes[0].collections[0]
        assert mesh.norm.vmax == 0.0 and mesh.norm.vmin == -60.0
        assert "99.9th percentile" in fig.axes[1].get_ylabel()
        img = np.ma.filled(mesh.get_array(), np.nan).reshape(-1, len(e))
        plt.close(fig)
        return img

    a, b = image(quiet), image(loud)[:, : len(quiet)]
    shown = a > -50.0  # well above the floor in both
    assert shown.sum() > 1000
    assert np.abs(a[shown] - b[shown]).max() < 3.0  # dB


def test_plot_echo_image_rejects_x_of_the_wrong_length(echoes):
    with pytest.raises(ValueError, match="one value per pulse"):
        plot_echo_image(echoes, x=[1.0, 2.0])


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_plot_echo_image_refuses_x_that_is_not_finite_naming_x(echoes, bad):
    x = np.arange(len(echoes), dtype=np.float64)
    x[1] = bad
    with pytest.raises(ValueError, match="x must be finite"):
        plot_echo_image(echoes, x=x)
    plt.close("all")


def test_plot_echo_image_of_silent_pulses_only(box, sonar, tmp_path):
    away = batecho.Poses([[-2.0, 0.0, 0.0], [-3.0, 0.0, 0.0]], [-1.0, 0.0, 0.0])
    e = batecho.simulate(box, sonar, away)
    assert not np.any(e.impulse)
    assert _png_ok(plot_echo_image(e), tmp_path / "silent.png")


def test_plot_scene_3d_writes_png(box, sonar, poses, tmp_path):
    members = [batecho.lobe_members(box, sonar, poses[i]) for i in (0, 3)]
    bark = (np.array([[0, 0, -2], [0.2, 0, -2], [0, 0.2, 2.0]]), np.array([[0, 1, 2]]))
    fig = plot_scene_3d(
        box,
        poses,
        sonar,
        members=members,
        trajectory=batecho.trajectories.Circle((5.5, 0.0), 6.2, 0.0),
        bark=bark,
        lobe_poses=[0, 3],
        title="scene",
    )
    assert isinstance(fig, Figure) and _png_ok(fig, tmp_path / "scene.png")


@pytest.mark.parametrize("junk", ["yes", 1, np.zeros((2, 3))])
def test_plot_scene_3d_refuses_branches_that_are_no_switch_and_no_branches(box, junk):
    with pytest.raises(TypeError, match="branches must be None, True, False or a"):
        plot_scene_3d(box, branches=junk)


def test_plot_scene_3d_keys_each_lobe_and_says_what_it_thinned(box, sonar, poses):
    members = [batecho.lobe_members(box, sonar, poses[i]) for i in (0, 3)]
    fig = plot_scene_3d(box, poses, sonar, members=members, lobe_poses=[0, 3], max_points=100)
    texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    n = box.n_leaves
    assert f"leaves ({n:,}; 100 drawn)" in texts
    assert "lobe of pulse 0" in texts and "lobe of pulse 3" in texts
    plt.close(fig)


def test_plot_scene_3d_takes_lobe_labels(box, sonar, poses):
    fig = plot_scene_3d(box, poses, sonar, lobe_poses=[1], lobe_labels=["point A"])
    assert "point A" in [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    plt.close(fig)
    with pytest.raises(ValueError, match="lobe_labels"):
        plot_scene_3d(box, poses, sonar, lobe_poses=[1, 2], lobe_labels=["only one"])


def test_plot_scene_3d_keeps_its_legend_below_the_axes(box, sonar, poses):
    fig = plot_scene_3d(box, poses, sonar, lobe_poses=[0])
    fig.canvas.draw()
    ax = fig.axes[0]
    assert ax.get_legend().get_window_extent().y1 <= ax.get_window_extent().y0 + 1.0
    plt.close(fig)


def test_plot_scene_3d_gives_a_short_axis_fewer_ticks(box):
    line = batecho.line_to([-14.0, 0.0, 0.0], [0.0, 0.0, 0.0], n_points=5)
    fig = plot_scene_3d(box, line)
    ax = fig.axes[0]
    spans = np.array([np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())])

    def n_ticks(axis, lim):
        t = axis.get_ticklocs()
        return int(((t >= lim[0]) & (t <= lim[1])).sum())

    counts = [
        n_ticks(ax.xaxis, ax.get_xlim()),
        n_ticks(ax.yaxis, ax.get_ylim()),
        n_ticks(ax.zaxis, ax.get_zlim()),
    ]
    longest = int(np.argmax(spans))
    for k in range(3):
        assert counts[k] <= max(3, 9 * spans[k] / spans[longest])
    plt.close(fig)


def test_plot_scene_3d_has_equal_scale_on_every_axis(box, poses):
    fig = plot_scene_3d(box.leaves, poses, trajectory=poses.positions)
    ax = fig.axes[0]
    spans = np.array([np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())])
    aspect = np.asarray(ax.get_box_aspect(), dtype=float)
    np.testing.assert_allclose(aspect / aspect.max(), spans / spans.max(), rtol=1e-6)
    plt.close(fig)


def test_plot_scene_3d_takes_anything_with_leaves(box, tmp_path):
    class Thing:
        leaves = box.leaves
        bark_vertices = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
        bark_faces = np.array([[0, 1, 2]])

    assert _png_ok(plot_scene_3d(Thing(), max_points=50), tmp_path / "thing.png")


def test_plot_scene_3d_rejects_other_objects():
    with pytest.raises(TypeError, match="Leaves"):
        plot_scene_3d(object())


def test_lobe_surface_reaches_10_m_on_the_axis(sonar, poses):
    X, Y, Z = lobe_surface(sonar, poses[0])
    tip = np.array([X[0, 0], Y[0, 0], Z[0, 0]])
    assert abs(np.linalg.norm(tip - poses.positions[0]) - 10.0) < 1e-9


def test_lobe_surface_closes_at_the_pulse_position(sonar, poses):
    X, Y, Z = lobe_surface(sonar, poses[2])
    last = np.stack([X[-1], Y[-1], Z[-1]], axis=-1)
    np.testing.assert_allclose(last, np.broadcast_to(poses.positions[2], last.shape))


def test_lobe_surface_of_a_cone_stays_in_the_cone(poses):
    cone = batecho.Sonar(lobe="cone", cone_half_angle_deg=12.0)
    X, Y, Z = lobe_surface(cone, poses[1])
    v = np.stack([X, Y, Z], axis=-1).reshape(-1, 3) - poses.positions[1]
    r = np.linalg.norm(v, axis=1)
    ok = r > 1e-12
    ang = np.degrees(np.arccos(np.clip(v[ok] @ poses.forward[1] / r[ok], -1, 1)))
    assert r.max() <= cone.range_limit_m + 1e-9 and ang.max() <= 12.0 + 1e-6


def test_lobe_surface_bounds_the_counting_leaves(box, sonar, poses):
    # Every counting leaf lies within the drawn boundary along its own direction.
    i = 0
    X, Y, Z = lobe_surface(sonar, poses[i], n_alpha=200, n_phi=8)
    d = poses.forward[i]
    members = batecho.lobe_members(box, sonar, poses[i])
    v = box.leaves.centers[members] - poses.positions[i]
    r = np.linalg.norm(v, axis=1)
    ang = np.arccos(np.clip(v @ d / r, -1, 1))
    # The beam is circular: the boundary's range as a function of the angle off the axis.
    s = np.stack([X[:-1, 0], Y[:-1, 0], Z[:-1, 0]], axis=-1) - poses.positions[i]
    sr = np.linalg.norm(s, axis=1)
    sa = np.arccos(np.clip(s @ d / sr, -1, 1))
    assert np.all(r <= np.interp(ang, sa, sr) * (1 + 1e-6) + 1e-9)
    assert math.isclose(sr[0], 10.0)


def test_plot_scene_3d_draws_a_forests_bark():
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from batecho.paper import make_forest

    forest = make_forest([[0.0, 0.0], [5.0, 0.0]], np.random.default_rng(1), "lsystem")
    fig = plot_scene_3d(forest, max_points=500, max_bark_faces=300)
    fig.canvas.draw()
    polys = [c for c in fig.axes[0].collections if isinstance(c, Poly3DCollection)]
    assert len(polys) == 1 and len(polys[0].get_paths()) == 300
    plt.close(fig)


@pytest.fixture(scope="module")
def two_ear_echoes(box, poses):
    return batecho.simulate(box, batecho.Sonar.binaural(0.02, 30.0), poses)


@pytest.mark.parametrize(
    "plot",
    [
        plot_impulse,
        plot_spectrum,
        plot_spectrogram,
        plot_echo_image,
    ],
    ids=lambda f: f.__name__,
)
def test_a_one_receiver_figure_of_two_ears_echoes_names_for_receiver(two_ear_echoes, plot):
    with pytest.raises(ValueError, match=r"for_receiver"):
        plot(two_ear_echoes)
    plt.close("all")


@pytest.mark.parametrize("plot", [plot_impulse, plot_spectrum, plot_spectrogram])
def test_a_pose_index_out_of_range_is_refused_by_name(echoes, plot):
    with pytest.raises(
        ValueError, match=f"pose index 99 out of range: the echoes have {len(echoes)}"
    ):
        plot(echoes, 99)


def test_the_echo_image_refuses_a_dynamic_range_that_is_not_positive(echoes):
    with pytest.raises(ValueError, match="dynamic_range_db"):
        plot_echo_image(echoes, dynamic_range_db=-10.0)


@pytest.mark.parametrize("max_range_m", [-1.0, 0.0, math.nan])
@pytest.mark.parametrize(
    "plot",
    [
        plot_impulse,
        plot_echo_image,
        lambda e, max_range_m: plot_impulses(e, [0, 1], max_range_m=max_range_m),
    ],
    ids=["plot_impulse", "plot_echo_image", "plot_impulses"],
)
def test_a_max_range_that_is_not_positive_is_refused_naming_it(echoes, plot, max_range_m):
    # (it drew a record cut to nothing, titled "no echo", or failed with an IndexError)
    with pytest.raises(ValueError, match="max_range_m"):
        plot(echoes, max_range_m=max_range_m)
    plt.close("all")


@pytest.mark.parametrize("db", [np.float32(40.0), np.int64(40)])
def test_the_echo_image_takes_a_dynamic_range_given_as_a_numpy_number(echoes, db):
    fig = plot_echo_image(echoes, dynamic_range_db=db)
    assert fig.axes[0].collections[0].get_clim() == (-40.0, 0.0)
    plt.close(fig)


@pytest.mark.parametrize("indices", [[0.7, 1], np.array([0.5, 1.5]), "01"])
def test_plot_impulses_refuses_pose_indices_that_are_not_ints(echoes, indices):
    # (int() truncated them: [0.7, 1] drew pose 0)
    with pytest.raises(TypeError, match="index"):
        plot_impulses(echoes, indices)
    plt.close("all")


def test_plot_impulses_refuses_titles_that_do_not_name_each_panel(echoes):
    with pytest.raises(ValueError, match="titles"):
        plot_impulses(echoes, [0, 1, 2], titles=["a"])
    plt.close("all")


@pytest.mark.parametrize("margin_hz", [-1e6, math.nan])
def test_the_spectrogram_refuses_a_margin_that_is_negative_or_nan(echoes, margin_hz):
    # (a negative margin turned the frequency axis upside down, past the band)
    with pytest.raises(ValueError, match="margin_hz"):
        plot_spectrogram(echoes, margin_hz=margin_hz)
    plt.close("all")


def test_the_spectrogram_refuses_segments_longer_than_the_record_or_empty(echoes):
    for nperseg in (0, 10**9):
        with pytest.raises(ValueError, match="nperseg"):
            plot_spectrogram(echoes, nperseg=nperseg)
