"""A long `simulate` answers Ctrl-C: a signal handler's exception stops the call between poses
and propagates, and the next call runs as before."""

from __future__ import annotations

import signal
import time

import numpy as np
import pytest

import batecho

pytestmark = pytest.mark.skipif(
    not hasattr(signal, "setitimer"), reason="needs POSIX interval timers"
)


class Alarm(Exception):
    """Raised by the test's SIGALRM handler, as Ctrl-C's handler raises KeyboardInterrupt."""


def many_poses(n: int) -> batecho.Poses:
    return batecho.Poses(np.zeros((n, 3)), np.tile([1.0, 0.0, 0.0], (n, 1)))


def leaf_box(n: int) -> batecho.Leaves:
    rng = np.random.default_rng(2)
    centers = np.column_stack([rng.uniform(1, 9, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)])
    return batecho.Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.03, n))


@pytest.fixture
def alarm_in():
    """Arm SIGALRM to raise `Alarm` after the given seconds; disarmed and restored after."""

    def handler(signum, frame):
        raise Alarm

    previous = signal.signal(signal.SIGALRM, handler)
    yield lambda seconds: signal.setitimer(signal.ITIMER_REAL, seconds)
    signal.setitimer(signal.ITIMER_REAL, 0)
    signal.signal(signal.SIGALRM, previous)


SCENE = batecho.Scene(leaf_box(20_000))
SONAR = batecho.Sonar(lobe="cone", cone_half_angle_deg=75.0)


def test_a_signal_stops_a_long_simulate_between_poses_and_its_exception_propagates(alarm_in):
    poses = many_poses(8)
    t0 = time.perf_counter()
    batecho.simulate(SCENE, SONAR, poses, method="exact")
    per_pose = (time.perf_counter() - t0) / len(poses)
    long = many_poses(max(64, int(20.0 / per_pose)))  # about 20 s of poses, uninterrupted
    alarm_in(0.2)
    t0 = time.perf_counter()
    with pytest.raises(Alarm):
        batecho.simulate(SCENE, SONAR, long, method="exact")
    # (stopped within a few poses of the signal, not after the whole call)
    assert time.perf_counter() - t0 < 0.2 + 5.0, "the call ran on after the signal"


def test_after_an_interrupted_call_the_next_call_gives_the_same_bits(alarm_in):
    few = many_poses(3)
    before = batecho.simulate(SCENE, SONAR, few, method="exact")
    alarm_in(0.1)
    with pytest.raises(Alarm):
        batecho.simulate(SCENE, SONAR, many_poses(5_000), method="exact")
    after = batecho.simulate(SCENE, SONAR, few, method="exact")
    assert after.spectrum.tobytes() == before.spectrum.tobytes()
    assert after.impulse.tobytes() == before.impulse.tobytes()


def test_a_call_that_ends_before_the_signal_returns_its_echoes(alarm_in):
    few = many_poses(2)
    want = batecho.simulate(SCENE, SONAR, few, method="exact")
    alarm_in(30.0)
    got = batecho.simulate(SCENE, SONAR, few, method="exact")
    assert got.spectrum.tobytes() == want.spectrum.tobytes()
