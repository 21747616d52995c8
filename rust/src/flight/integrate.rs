//! Flying: a whole reference flown from a state ([`fly`]), and drones stepped under velocity
//! commands ([`Swarm`]), drones in parallel. RK4 with the controller sampled once per step
//! (zero-order hold) as docs/model.md §8 states; each drone's arithmetic is independent of
//! the others and of the thread count.

use rayon::prelude::*;

use super::airframe::Airframe;
use super::control::{rotor_commands, Reference};
use super::dynamics::{rk4_step, rotation, v3, StateVec, POSITION};
use super::rigid::polar_factor;
use crate::error::{invalid, Result};
use crate::math::vec3::{is_finite3, V3};

/// Checks a state: finite, rotation orthonormal with det +1 to 1e-6, rotor speeds >= 0.
pub fn check_state(y: &StateVec, name: &str) -> Result<()> {
    if !y.iter().all(|x| x.is_finite()) {
        return invalid(format!("{name} must be finite"));
    }
    let r = rotation(y);
    match polar_factor(&r) {
        Some(p)
            if r.iter()
                .flatten()
                .zip(p.iter().flatten())
                .all(|(a, b)| (a - b).abs() < 1e-6) => {}
        _ => {
            return invalid(format!(
                "{name}: rotation must be a rotation matrix (orthonormal, det +1)"
            ))
        }
    }
    Ok(())
}

fn check_dt(a: &Airframe, dt: f64) -> Result<()> {
    if !(dt > 0.0) || !dt.is_finite() {
        return invalid(format!("dt must be finite and > 0, got {dt}"));
    }
    if dt > a.motor_time_constant {
        return invalid(format!(
            "dt={dt} s exceeds the motor time constant {} s; RK4 would be inaccurate",
            a.motor_time_constant
        ));
    }
    Ok(())
}

/// Flies the reference samples `refs` from `y0`: step k runs from `times[k]` to
/// `times[k + 1]` with the controller at `refs[k]` and the wind `wind[k]`. Returns the
/// states at every time (`times.len()` of them, the first `y0`).
pub fn fly(
    a: &Airframe,
    y0: &StateVec,
    refs: &[Reference],
    wind: &[V3],
    times: &[f64],
) -> Result<Vec<StateVec>> {
    check_state(y0, "initial_state")?;
    let n = times.len();
    if n < 2 || refs.len() < n - 1 || wind.len() < n - 1 {
        return invalid(format!(
            "fly needs at least 2 times and a reference sample and wind per step, got {} times, {} samples, {} winds",
            n,
            refs.len(),
            wind.len()
        ));
    }
    for k in 0..n - 1 {
        let h = times[k + 1] - times[k];
        // (times k dt rounded to f64 differ from dt by up to an ulp of the times: a grid at
        // dt = the motor time constant flies)
        let rounding = 2.0 * f64::EPSILON * times[k + 1].abs();
        if !(h > 0.0) || !h.is_finite() || h > a.motor_time_constant + rounding {
            return invalid(format!(
                "times must increase by steps in (0, {}] s (the motor time constant); step {k} is {h} s",
                a.motor_time_constant
            ));
        }
        let r = &refs[k];
        let finite = is_finite3(r.position)
            && is_finite3(r.velocity)
            && is_finite3(r.acceleration)
            && r.yaw.is_finite()
            && is_finite3(r.omega)
            && is_finite3(r.domega)
            && is_finite3(wind[k]);
        if !finite {
            return invalid(format!("reference sample or wind {k} is not finite"));
        }
    }
    let mut out = Vec::with_capacity(n);
    out.push(*y0);
    let mut y = *y0;
    for k in 0..n - 1 {
        let h = times[k + 1] - times[k];
        let cmd = rotor_commands(a, &y, &refs[k]);
        y = match rk4_step(a, &y, h, &cmd, wind[k]) {
            Some(next) => next,
            None => return invalid(format!("the flight diverged at t = {} s", times[k + 1])),
        };
        out.push(y);
    }
    Ok(out)
}

/// A velocity-and-yaw-rate command: the reference moves from the drone's position and
/// heading at the command's start at `velocity` (world, m/s) and turns at `yaw_rate`
/// (rad/s), level (zero acceleration), so its flat attitude turns at `(0, 0, yaw_rate)` in
/// the body frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VelocityCommand {
    pub velocity: V3,
    pub yaw_rate: f64,
}

impl VelocityCommand {
    /// The reference `s` seconds after the command's start at `start` with yaw `yaw0`.
    #[inline(always)]
    pub fn reference(&self, start: V3, yaw0: f64, s: f64) -> Reference {
        let v = self.velocity;
        Reference {
            position: [
                start[0] + v[0] * s,
                start[1] + v[1] * s,
                start[2] + v[2] * s,
            ],
            velocity: v,
            acceleration: [0.0; 3],
            yaw: yaw0 + self.yaw_rate * s,
            omega: [0.0, 0.0, self.yaw_rate],
            domega: [0.0; 3],
        }
    }
}

/// The yaw of a state as the controller's desired attitude defines it: the heading of the
/// horizontal direction in the plane of body x and body z, so that
/// [`super::control::desired_attitude`] of the body's thrust axis and this yaw is the body's
/// attitude. A tilted body's x axis alone would point elsewhere.
#[inline(always)]
pub fn heading(y: &StateVec) -> f64 {
    let r = rotation(y);
    let (b1, b3) = ([r[0][0], r[1][0], r[2][0]], [r[0][2], r[1][2], r[2][2]]);
    let hx = b3[2] * b1[0] - b1[2] * b3[0];
    let hy = b3[2] * b1[1] - b1[2] * b3[1];
    hy.atan2(hx)
}

/// Flies one drone `n_steps` steps of `dt` under `cmd` and `wind`; its position after each
/// step goes to `path`.
fn step_one(
    a: &Airframe,
    y: &mut StateVec,
    cmd: &VelocityCommand,
    wind: V3,
    dt: f64,
    path: &mut [V3],
) -> bool {
    let start = v3(y, POSITION);
    let yaw0 = heading(y);
    for (k, out) in path.iter_mut().enumerate() {
        let r = cmd.reference(start, yaw0, k as f64 * dt);
        let w = rotor_commands(a, y, &r);
        match rk4_step(a, y, dt, &w, wind) {
            Some(next) => *y = next,
            None => return false,
        }
        *out = v3(y, POSITION);
    }
    true
}

/// N drones of one airframe, stepped together under velocity commands.
#[derive(Clone, Debug)]
pub struct Swarm {
    pub airframe: Airframe,
    states: Vec<StateVec>,
}

impl Swarm {
    /// Drones at `states` (each checked by [`check_state`]).
    pub fn new(airframe: Airframe, states: Vec<StateVec>) -> Result<Swarm> {
        let mut s = Swarm {
            airframe,
            states: Vec::new(),
        };
        s.reset(states)?;
        Ok(s)
    }

    /// Puts the drones at `states` (their number may change).
    pub fn reset(&mut self, states: Vec<StateVec>) -> Result<()> {
        if states.is_empty() {
            return invalid("a swarm needs at least one drone");
        }
        for (i, y) in states.iter().enumerate() {
            check_state(y, &format!("state of drone {i}"))?;
        }
        self.states = states;
        Ok(())
    }

    pub fn states(&self) -> &[StateVec] {
        &self.states
    }

    pub fn len(&self) -> usize {
        self.states.len()
    }

    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Flies every drone `n_steps` RK4 steps of `dt` s, drone i under `commands[i]` and
    /// `wind[i]` (world, m/s), in parallel. Returns the positions after each step, drone by
    /// drone (`n_drones * n_steps` of them). On an error no drone moves.
    pub fn step(
        &mut self,
        commands: &[VelocityCommand],
        wind: &[V3],
        dt: f64,
        n_steps: usize,
    ) -> Result<Vec<V3>> {
        let n = self.states.len();
        if commands.len() != n || wind.len() != n {
            return invalid(format!(
                "need one command and one wind per drone ({n}), got {} and {}",
                commands.len(),
                wind.len()
            ));
        }
        check_dt(&self.airframe, dt)?;
        if n_steps == 0 {
            return invalid("n_steps must be >= 1");
        }
        for (i, (c, w)) in commands.iter().zip(wind).enumerate() {
            if !is_finite3(c.velocity) || !c.yaw_rate.is_finite() {
                return invalid(format!("command {i} is not finite"));
            }
            if !is_finite3(*w) {
                return invalid(format!("wind {i} is not finite"));
            }
        }
        let mut next = self.states.clone();
        let mut path = vec![[0.0; 3]; n * n_steps];
        let a = &self.airframe;
        let failed = next
            .par_iter_mut()
            .zip(path.par_chunks_mut(n_steps))
            .zip(commands.par_iter().zip(wind.par_iter()))
            .enumerate()
            .filter_map(|(i, ((y, p), (c, w)))| (!step_one(a, y, c, *w, dt, p)).then_some(i))
            .min();
        if let Some(i) = failed {
            return invalid(format!(
                "drone {i} diverged (its state left the finite numbers)"
            ));
        }
        self.states = next;
        Ok(path)
    }
}
