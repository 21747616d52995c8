"""Interaural cues and the two-ear figures: a single leaf's interaural time difference is its
path difference over the speed of sound, the level difference favours the ear it lies toward,
and the figures draw one panel per ear."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _helpers import frame_points

import batecho
from batecho import Leaves, Poses, Sonar
from batecho.echoes.binaural import interaural_level_difference, interaural_time_difference


@pytest.fixture(scope="module")
def sweep():
    """A clump of leaves 4 m ahead; the sonar's heading turns from -20 to +20 degrees."""
    rng = np.random.default_rng(0)
    c = np.array([4.0, 0.0, 0.0]) + rng.normal(scale=0.3, size=(200, 3))
    leaves = Leaves(c, rng.normal(size=(200, 3)), np.full(200, 0.02))
    yaw = np.radians(np.linspace(-20.0, 20.0, 5))
    poses = Poses(np.zeros((5, 3)), np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros(5)]))
    sonar = Sonar.binaural(0.02, 30.0, beamwidth_deg=40.0)
    return batecho.simulate(leaves, sonar, poses), np.degrees(yaw)


@pytest.mark.parametrize("az_deg", [-25.0, 15.0])
def test_a_single_leafs_interaural_time_difference_is_its_path_difference(az_deg):
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    sonar = Sonar.binaural(0.3, 20.0, window="rect", lobe="cone", cone_half_angle_deg=60.0)
    c = frame_points(pose, [3.0], [math.radians(az_deg)], [0.0])
    e = batecho.simulate(Leaves(c, [-c[0] / 3.0], [0.02]), sonar, pose)
    r = [np.linalg.norm(c[0] - np.array(rx.offset_m)) for rx in sonar.receivers]
    itd = interaural_time_difference(e)[0]
    assert abs(itd - (r[1] - r[0]) / sonar.sound_speed) <= 1.0 / sonar.fs
    assert np.sign(interaural_level_difference(e)[0]) == np.sign(az_deg)


def test_the_level_difference_follows_the_heading(sweep):
    e, _ = sweep
    ild = interaural_level_difference(e)
    # turned right (negative heading), the clump lies to the left: the left ear is louder
    assert np.all(np.diff(ild) < 0) and ild[0] > 3.0 and ild[-1] < -3.0


def test_interaural_differences_need_two_receivers():
    leaves = Leaves([[2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    e = batecho.simulate(leaves, Sonar(), Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="two receivers"):
        interaural_level_difference(e)


def test_the_two_ear_figures_have_a_panel_per_ear(sweep):
    import matplotlib.pyplot as plt

    from batecho.outputs.binaural import (
        plot_binaural_echo_images,
        plot_binaural_impulses,
        plot_interaural_differences,
    )

    e, heading = sweep
    fig = plot_binaural_impulses(e, 3, max_range_m=6.0)
    assert [ax.get_title().split(" ear")[0] for ax in fig.axes[:2]] == ["left", "right"]
    fig2 = plot_binaural_echo_images(e, x=heading, xlabel="heading (deg)")
    assert len(fig2.axes) == 3  # two images and their shared colour bar
    fig3 = plot_interaural_differences(e, x=heading, xlabel="heading (deg)")
    assert fig3.axes[1].get_xlabel() == "heading (deg)"
    for f in (fig, fig2, fig3):
        plt.close(f)


@pytest.mark.parametrize("max_range_m", [-1.0, 0.0, math.nan])
@pytest.mark.parametrize(
    "cue",
    [
        interaural_level_difference,
        interaural_time_difference,
        batecho.plotting.plot_binaural_impulses,
        batecho.plotting.plot_binaural_echo_images,
        batecho.plotting.plot_interaural_differences,
    ],
)
def test_a_max_range_that_is_not_positive_is_refused_naming_it(sweep, cue, max_range_m):
    # (the cues were NaN for every pulse, as though no ear heard anything)
    import matplotlib.pyplot as plt

    with pytest.raises(ValueError, match="max_range_m"):
        cue(sweep[0], max_range_m=max_range_m)
    plt.close("all")


@pytest.mark.parametrize("db", [-10.0, 0.0, math.nan])
def test_the_two_ear_echo_images_refuse_a_dynamic_range_that_is_not_positive(sweep, db):
    with pytest.raises(ValueError, match="dynamic_range_db"):
        batecho.plotting.plot_binaural_echo_images(sweep[0], dynamic_range_db=db)


def test_one_receivers_echoes_are_the_slice_of_its_axis(sweep):
    e, _ = sweep
    right = e.for_receiver(1)
    assert right.n_receivers == 0 and right.receiver == 1
    assert np.array_equal(right.impulse, e.impulse[:, 1])
    ds = right.to_xarray()
    assert list(ds["receiver"].values) == ["right"]
    with pytest.raises(ValueError, match="out of range"):
        e.for_receiver(2)


@pytest.fixture(scope="module")
def one_ear_deaf():
    """Two pulses: the first hears a leaf beside the left ear only (outside the right ear's
    cone), the second a leaf straight ahead with both ears."""
    leaves = Leaves(
        [[1.0, 0.45, 0.0], [-3.0, 0.0, 0.0]], [[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], [0.02, 0.02]
    )
    poses = Poses(np.zeros((2, 3)), [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    sonar = Sonar.binaural(1.0, 0.0, lobe="cone", cone_half_angle_deg=30.0)
    e = batecho.simulate(leaves, sonar, poses)
    assert e.n_leaves.tolist() == [[1, 0], [1, 1]]
    return e


def test_the_interaural_figure_warns_naming_the_ear_that_hears_nothing(one_ear_deaf):
    import matplotlib.pyplot as plt

    from batecho.outputs.binaural import plot_interaural_differences

    with pytest.warns(UserWarning, match=r"1 of 2 pulses .*pulses 0; silent: the right ear at 1"):
        fig = plot_interaural_differences(one_ear_deaf)
    plt.close(fig)


def test_the_interaural_figure_draws_the_heard_pulses_and_marks_the_silent_ones(one_ear_deaf):
    import matplotlib.pyplot as plt

    from batecho.outputs.binaural import plot_interaural_differences

    with pytest.warns(UserWarning):
        fig = plot_interaural_differences(one_ear_deaf)
    for ax in fig.axes[:2]:
        points = [ln for ln in ax.lines if ln.get_marker() == "o"]
        assert [list(ln.get_xdata()) for ln in points] == [[1.0]]
        assert np.all(np.isfinite(points[0].get_ydata()))
        marks = [ln for ln in ax.lines if ln.get_label() == "right ear hears nothing"]
        assert [list(ln.get_xdata()) for ln in marks] == [[0.0]]
    assert any("hears nothing" in t.get_text() for t in fig.texts)
    plt.close(fig)


@pytest.mark.parametrize("scale", [1e290, 1e-290])
def test_the_interaural_level_difference_does_not_depend_on_the_echoes_scale(sweep, scale):
    # (the energies overflowed to inf or underflowed to zero: the level difference was NaN,
    # as though an ear heard nothing)
    import dataclasses

    e, _ = sweep
    scaled = dataclasses.replace(e, impulse=e.impulse * scale)
    want = interaural_level_difference(e)
    np.testing.assert_allclose(interaural_level_difference(scaled), want, rtol=0, atol=1e-9)


@pytest.mark.parametrize("scale", [1e290, 1e-290])
def test_the_interaural_time_difference_does_not_depend_on_the_echoes_scale(sweep, scale):
    # (the envelopes' correlation overflowed or underflowed to zero: the time difference was
    # the edge of the lag window)
    import dataclasses

    e, _ = sweep
    scaled = dataclasses.replace(e, impulse=e.impulse * scale)
    want = interaural_time_difference(e)
    np.testing.assert_allclose(interaural_time_difference(scaled), want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("max_lag_s", [-1e-4, 0.0, math.nan, math.inf])
def test_a_max_lag_that_is_not_positive_and_finite_is_refused_naming_it(sweep, max_lag_s):
    # (NaN and inf raised NumPy's "cannot convert float NaN to integer"; a negative lag was
    # taken as one sample)
    with pytest.raises(ValueError, match="max_lag_s"):
        interaural_time_difference(sweep[0], max_lag_s=max_lag_s)


@pytest.mark.parametrize("ears", [(1.5, 0), (True, 0), (0,), "01", None])
@pytest.mark.parametrize("cue", [interaural_level_difference, interaural_time_difference])
def test_ears_that_are_not_two_receiver_indices_are_refused_naming_them(sweep, cue, ears):
    # (NumPy's IndexError, or an unpacking error, named neither ears nor what they must be)
    with pytest.raises(TypeError, match="ears must be two int receiver indices"):
        cue(sweep[0], ears=ears)


def test_the_two_ear_echo_images_refuse_x_that_is_not_finite_naming_x(sweep):
    import matplotlib.pyplot as plt

    from batecho.outputs.binaural import plot_binaural_echo_images

    e, yaw = sweep
    with pytest.raises(ValueError, match="x must be finite"):
        plot_binaural_echo_images(e, x=np.where(np.arange(len(e)) == 2, np.inf, yaw))
    plt.close("all")


@pytest.mark.parametrize("index", [5, -6])
def test_the_two_ear_impulses_refuse_a_pose_index_out_of_range_naming_it(sweep, index):
    from batecho.outputs.binaural import plot_binaural_impulses

    with pytest.raises(ValueError, match=f"pose index {index} out of range"):
        plot_binaural_impulses(sweep[0], index)
