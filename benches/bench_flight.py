"""Flight integration: 5 s of a Crazyflie at 1 kHz on a horizontal circle (radius 1 m, 0.2 Hz,
1.26 m/s), flown by batecho's NumPy RK4 (``method="python"``), its Rust RK4 (the default,
reference samples included), its step-by-step API, and RotorPy's Crazyflie, timed side by
side in one run (the machine is shared and noisy; the ratios are what counts).

RotorPy (https://github.com/spencerfolk/rotorpy, 3.0.0 on PyPI) is never a dependency of
batecho. Time it from a throwaway environment:

    python3 -m venv /tmp/rotorpy-venv && /tmp/rotorpy-venv/bin/pip install rotorpy==3.0.0
    python benches/bench_flight.py --rotorpy-python /tmp/rotorpy-venv/bin/python

RotorPy is timed two ways in a child process (its import excluded): its simulation loop with
the sensors and estimator off (``Multirotor.step`` + ``SE3Control.update`` +
``ThreeDCircularTraj.update`` per step, the least RotorPy can do per step) and its
``Environment.run`` at ``sim_rate=1000`` (what its examples run). The ratio the issue asks
for is against the first, the smaller.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import textwrap
import time

import numpy as np

from batecho.flight import Circle, Hover, Quadrotor, QuadrotorSim

ROTORPY = textwrap.dedent(
    """
    import json, sys, time
    import numpy as np
    from rotorpy.controllers.quadrotor_control import SE3Control
    from rotorpy.environments import Environment
    from rotorpy.trajectories.circular_traj import ThreeDCircularTraj
    from rotorpy.vehicles.crazyflie_params import quad_params
    from rotorpy.vehicles.multirotor import Multirotor
    duration, dt = float(sys.argv[1]), float(sys.argv[2])
    traj = ThreeDCircularTraj(center=np.array([0.0, 0.0, 1.0]), radius=np.array([1.0, 1.0, 0.0]),
                              freq=np.array([0.2, 0.2, 0.0]))
    f0 = traj.update(0.0)
    hover = np.sqrt(quad_params["mass"] * 9.81 / (4 * quad_params["k_eta"]))
    start = {"x": f0["x"], "v": f0["x_dot"], "q": np.array([0.0, 0.0, 0.0, 1.0]),
             "w": np.zeros(3), "wind": np.zeros(3), "rotor_speeds": np.full(4, hover)}
    n = round(duration / dt)
    vehicle, ctrl = Multirotor(quad_params, initial_state=start), SE3Control(quad_params)
    s, t = {k: np.array(v) for k, v in start.items()}, 0.0
    t0 = time.perf_counter()
    for _ in range(n):
        s = vehicle.step(s, ctrl.update(t, s, traj.update(t)), dt)
        t += dt
    loop = time.perf_counter() - t0
    err = float(np.linalg.norm(s["x"] - traj.update(t)["x"]))
    env = Environment(vehicle=Multirotor(quad_params, initial_state=start),
                      controller=SE3Control(quad_params), trajectory=traj, sim_rate=round(1 / dt))
    t0 = time.perf_counter()
    env.run(t_final=duration, use_mocap=False, plot=False, animate_bool=False, verbose=False)
    full = time.perf_counter() - t0
    print(json.dumps({"loop": loop, "environment": full, "final_error_m": err}))
    """
)


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def fly_in_calls(sim, velocity, n, dt):
    """``n`` steps of ``dt`` as calls of 50 steps (an environment's 20 Hz at 1 kHz)."""
    for _ in range(n // 50):
        sim.step(velocity, 0.5, dt=dt, n_steps=50)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=5.0, help="seconds of flight")
    ap.add_argument("--dt", type=float, default=1e-3, help="step, s")
    ap.add_argument("--repeat", type=int, default=3, help="rounds, each timing every method")
    ap.add_argument("--rotorpy-python", help="a Python with rotorpy installed (see above)")
    args = ap.parse_args()
    T, dt = args.duration, args.dt
    n = round(T / dt)
    quad = Quadrotor.crazyflie()
    traj = Circle((0.0, 0.0), radius=1.0, altitude=1.0, speed=2 * np.pi * 0.2 * 1.0)
    start = quad.initial_state(Hover((1.0, 0.0, 1.0)))
    v = [0.0, 1.0, 0.0]
    rows: dict[str, list[float]] = {}

    def add(name, seconds):
        rows.setdefault(name, []).append(seconds)

    rotorpy_error = None
    quad.fly(traj, 0.1, dt=dt)  # warm-up: the extension's first call and rayon's pool
    QuadrotorSim(quad, start, n_drones=8).step(v, dt=dt)
    for _ in range(args.repeat):
        (py, t) = timed(lambda: quad.fly(traj, T, dt=dt, method="python"))
        add("batecho, NumPy RK4 (method='python')", t)
        (rs, t) = timed(lambda: quad.fly(traj, T, dt=dt))
        add("batecho, Rust RK4 (Quadrotor.fly)", t)
        _, t = timed(lambda: QuadrotorSim(quad, start).step(v, 0.5, dt=dt, n_steps=n))
        add("batecho, QuadrotorSim.step, one call", t)
        _, t = timed(lambda: fly_in_calls(QuadrotorSim(quad, start), v, n, dt))
        add("batecho, QuadrotorSim.step, 50 steps a call (20 Hz)", t)
        _, t = timed(lambda: fly_in_calls(QuadrotorSim(quad, start, n_drones=8), v, n, dt))
        add("batecho, QuadrotorSim.step, 8 drones, per drone", t / 8)
        if args.rotorpy_python:
            out = subprocess.run(
                [args.rotorpy_python, "-c", ROTORPY, str(T), str(dt)],
                check=True,
                capture_output=True,
                text=True,
            )
            res = json.loads(out.stdout.strip().splitlines()[-1])
            add("RotorPy 3.0.0, simulation loop (no sensors)", res["loop"])
            add("RotorPy 3.0.0, Environment.run", res["environment"])
            rotorpy_error = res["final_error_m"]
    gap = np.abs(rs.positions - py.positions).max()
    print(
        f"{T:g} s at {1 / dt:g} Hz, Crazyflie, circle r = 1 m at 1.26 m/s; medians of {args.repeat}"
    )
    print(
        f"Rust vs NumPy RK4: max position difference {gap:.2e} m; tracking error "
        f"{rs.position_error.max():.2e} m"
        + (f"; RotorPy's final error {rotorpy_error:.2e} m" if rotorpy_error is not None else "")
    )
    base = (
        statistics.median(rows["RotorPy 3.0.0, simulation loop (no sensors)"])
        if args.rotorpy_python
        else None
    )
    print(f"| {'integrator':<52} | {'time (s)':>9} | {'x faster than RotorPy loop':>27} |")
    print(f"|{'-' * 54}|{'-' * 11}|{'-' * 29}|")
    for name, ts in rows.items():
        m = statistics.median(ts)
        ratio = f"{base / m:.0f}" if base else "-"
        print(f"| {name:<52} | {m:>9.4f} | {ratio:>27} |")
    if not args.rotorpy_python:
        print("(RotorPy not timed: pass --rotorpy-python, see the module docstring)")


if __name__ == "__main__":
    sys.exit(main())
