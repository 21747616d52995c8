"""Every on/off option takes True or False (NumPy's included) and refuses anything else by name:
``bool("no")`` is True, so text taken as a flag would silently turn the option on."""

from __future__ import annotations

import dataclasses
from functools import cache

import numpy as np
import pytest

import batecho
from batecho import dataset, plotting, treeplots
from batecho.flight.sim import QuadrotorSim
from batecho.scenefile import run_scenefile
from batecho.trajectories import Circle, Hover, Line, Waypoints


@cache
def tree() -> batecho.Tree:
    return batecho.grow_tree()


@cache
def forest() -> batecho.Forest:
    return batecho.Forest.from_positions([[0.0, 0.0]], 0, tree=tree())


@cache
def flight() -> batecho.Flight:
    path = Line((-2.0, 1.0, 2.0), (2.0, 1.0, 2.0), speed=2.0)
    return batecho.Quadrotor.crazyflie().fly(path, duration=0.1, dt=1e-2)


WAYPOINTS = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0]]

# (the option's name, a call passing it `v`, with a folder `tmp` to write in)
OPTIONS = {
    "scale_leaves (Tree.transformed)": (
        "scale_leaves",
        lambda v, tmp: tree().transformed(scale=2.0, scale_leaves=v),
    ),
    "scale_leaves (Forest)": (
        "scale_leaves",
        lambda v, tmp: batecho.Forest.from_positions([[0.0, 0.0]], 0, tree=tree(), scale_leaves=v),
    ),
    "branches (Forest.scene)": ("branches", lambda v, tmp: forest().scene(branches=v)),
    "bark (Forest.clearance)": ("bark", lambda v, tmp: forest().clearance([0.0, 0.0, 1.0], bark=v)),
    "bark (Flight.clearance)": ("bark", lambda v, tmp: flight().clearance(forest(), bark=v)),
    "return_index (Scene.clearance)": (
        "return_index",
        lambda v, tmp: forest().scene().clearance([0.0, 0.0, 1.0], return_index=v),
    ),
    "clockwise (Circle)": ("clockwise", lambda v, tmp: Circle([0.0, 0.0], clockwise=v)),
    "closed (Waypoints)": ("closed", lambda v, tmp: Waypoints(WAYPOINTS, closed=v)),
    "drag_feedforward (Quadrotor)": (
        "drag_feedforward",
        lambda v, tmp: dataclasses.replace(batecho.Quadrotor.crazyflie(), drag_feedforward=v),
    ),
    "spreading (Sonar)": ("spreading", lambda v, tmp: batecho.Sonar(spreading=v)),
    "branches_block (Shading)": (
        "branches_block",
        lambda v, tmp: batecho.Shading(branches_block=v),
    ),
    "mtl (Tree.to_obj)": ("mtl", lambda v, tmp: tree().to_obj(tmp / "t.obj", mtl=v)),
}


def _closed(fig):
    import matplotlib.pyplot as plt

    plt.close(fig)


@cache
def echoes() -> batecho.Echoes:
    leaves = batecho.Leaves([[2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    pose = batecho.Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    return batecho.simulate(batecho.Scene(leaves), batecho.Sonar(), pose)


# Pictures: the same rule.
OPTIONS |= {
    "envelope (plot_impulse)": (
        "envelope",
        lambda v, tmp: _closed(plotting.plot_impulse(echoes(), envelope=v)),
    ),
    "wood (plot_echo_image)": (
        "wood",
        lambda v, tmp: _closed(plotting.plot_echo_image(echoes(), wood=v)),
    ),
    "bark (plot_tree)": ("bark", lambda v, tmp: _closed(treeplots.plot_tree(tree(), bark=v))),
}

# Options checked before the work that a stand-in argument would fail.
REFUSED_FIRST = {
    "deep (dataset.verify)": ("deep", lambda v, tmp: dataset.verify(tmp / "none.zarr", deep=v)),
    "plots (run_scenefile)": (
        "plots",
        lambda v, tmp: run_scenefile(tmp / "none.toml", tmp / "out", plots=v),
    ),
}


@pytest.mark.parametrize("option", OPTIONS | REFUSED_FIRST)
@pytest.mark.parametrize("value", ["no", "False", 1, None])
def test_an_option_given_anything_but_true_or_false_is_refused_by_name(option, value, tmp_path):
    name, call = (OPTIONS | REFUSED_FIRST)[option]
    with pytest.raises(TypeError, match=f"{name} must be True or False, got {value!r}"):
        call(value, tmp_path)


@pytest.mark.parametrize("option", OPTIONS)
def test_an_option_takes_numpys_true_and_false(option, tmp_path):
    _, call = OPTIONS[option]
    call(np.True_, tmp_path)
    call(np.False_, tmp_path)


def test_a_number_of_rk4_steps_given_as_text_is_refused_by_name():
    quad = batecho.Quadrotor.crazyflie()
    sim = QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))))
    with pytest.raises(TypeError, match="n_steps must be an integer >= 1, got '3'"):
        sim.step([0.0, 0.0, 0.0], n_steps="3")


def test_a_number_of_rk4_steps_beyond_any_memory_is_named_in_a_few_digits():
    quad = batecho.Quadrotor.crazyflie()
    sim = QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))))
    with pytest.raises(MemoryError, match=r"n_steps = 1e\+300 RK4 steps") as e:
        sim.step([0.0, 0.0, 0.0], n_steps=1e300)
    assert len(str(e.value)) < 300


# A number given a flag: True would be taken as 1 (a 1 m band, a 1 m/s path, a 1 m circle).
NUMBERS = {
    "band (Forest.reaches)": ("band", lambda v: forest().reaches(altitude=2.0, band=v)),
    "altitude (Forest.reaches)": ("altitude", lambda v: forest().reaches(altitude=v)),
    "speed (Line)": ("speed", lambda v: Line((0.0, 0.0, 1.0), (1.0, 0.0, 1.0), speed=v)),
    "radius (Circle)": ("radius", lambda v: Circle([0.0, 0.0], radius=v)),
    "radius_m (Flight.collision)": ("radius_m", lambda v: flight().collision(forest(), v)),
}


@pytest.mark.parametrize("number", NUMBERS)
@pytest.mark.parametrize("value", [True, np.False_])
def test_a_number_given_true_or_false_is_refused_by_name(number, value):
    name, call = NUMBERS[number]
    with pytest.raises(TypeError, match=f"{name} must be a real number, got {value!r}"):
        call(value)


@pytest.mark.parametrize(
    "kept",
    [
        lambda v: batecho.Sonar(spreading=v).spreading,
        lambda v: batecho.Shading(branches_block=v).branches_block,
        lambda v: (
            dataclasses.replace(batecho.Quadrotor.crazyflie(), drag_feedforward=v).drag_feedforward
        ),
        lambda v: Waypoints(WAYPOINTS, closed=v).closed,
    ],
    ids=["spreading", "branches_block", "drag_feedforward", "closed"],
)
def test_an_option_given_numpys_true_keeps_pythons_true(kept):
    assert type(kept(np.True_)) is bool
