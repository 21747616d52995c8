//! Tests of the flight folder: the airframe's checks and mixer, hover, velocity commands,
//! and drones that fly the same alone as in a swarm.

use super::airframe::{Airframe, AirframeParams, Configuration, Gains};
use super::control::Reference;
use super::dynamics::{rotation, StateVec, POSITION, ROTATION, ROTOR_SPEEDS, VELOCITY};
use super::integrate::{fly, heading, Swarm, VelocityCommand};
use super::rigid::{tmul, IDENTITY};

/// A Crazyflie 2.x as `Quadrotor.crazyflie()` describes it (gains at 4 and 25 rad/s).
fn crazyflie_params() -> AirframeParams {
    let (m, j) = (0.027, [1.4e-5, 1.4e-5, 2.17e-5]);
    let rpm2 = (60.0 / (2.0 * std::f64::consts::PI)).powi(2);
    let (wp, wa, zp, za) = (4.0, 25.0, 1.0, 0.9);
    AirframeParams {
        mass: m,
        inertia: j,
        arm_length: 0.046,
        k_f: 3.16e-10 * rpm2,
        k_m: 7.94e-12 * rpm2,
        motor_time_constant: 0.015,
        omega_min: 0.0,
        omega_max: 2280.0,
        drag: [9.1785e-7 * 6064.0, 9.1785e-7 * 6064.0, 10.311e-7 * 6064.0],
        configuration: Configuration::X,
        gravity: 9.81,
        gains: Gains {
            k_x: [m * wp * wp; 3],
            k_v: [2.0 * zp * m * wp; 3],
            k_r: [j[0] * wa * wa, j[1] * wa * wa, j[2] * wa * wa],
            k_omega: [
                2.0 * za * j[0] * wa,
                2.0 * za * j[1] * wa,
                2.0 * za * j[2] * wa,
            ],
        },
        drag_feedforward: true,
    }
}

fn crazyflie() -> Airframe {
    Airframe::new(crazyflie_params()).unwrap()
}

/// Level, at rest at `p`, rotors at hover speed.
fn hovering(a: &Airframe, p: [f64; 3]) -> StateVec {
    let mut y = [0.0; 22];
    y[POSITION..POSITION + 3].copy_from_slice(&p);
    for i in 0..3 {
        y[ROTATION + 4 * i] = 1.0;
    }
    for i in 0..4 {
        y[ROTOR_SPEEDS + i] = a.hover_rotor_speed();
    }
    y
}

#[test]
fn the_mixer_inverse_inverts_the_mixer() {
    let a = crazyflie();
    for i in 0..4 {
        for j in 0..4 {
            let s: f64 = (0..4).map(|k| a.mixer[i][k] * a.mixer_inv[k][j]).sum();
            assert!((s - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
        }
    }
}

#[test]
fn hover_rotor_speeds_give_the_weight_and_no_moment() {
    let a = crazyflie();
    let u = a.thrust_and_moments(&[a.hover_rotor_speed(); 4]);
    assert!((u[0] - a.mass * a.gravity).abs() < 1e-15);
    assert!(u[1..].iter().all(|m| m.abs() < 1e-18));
}

#[test]
fn bad_airframes_are_refused_with_the_parameter_named() {
    type Edit = fn(&mut AirframeParams);
    let cases: [(Edit, &str); 6] = [
        (|p| p.mass = -1.0, "mass"),
        (|p| p.inertia[1] = 0.0, "inertia"),
        (|p| p.k_f = f64::NAN, "k_f"),
        (|p| p.drag[2] = -0.1, "drag"),
        (|p| p.omega_max = 100.0, "hover"),
        (|p| p.gains.k_v[0] = 0.0, "k_v"),
    ];
    for (edit, name) in cases {
        let mut p = crazyflie_params();
        edit(&mut p);
        let err = Airframe::new(p).unwrap_err().to_string();
        assert!(err.contains(name), "{err} should name {name}");
    }
}

#[test]
fn a_hovering_drone_holding_its_place_stays_within_a_micrometre() {
    let a = crazyflie();
    let y0 = hovering(&a, [1.0, 2.0, 3.0]);
    let n = 2001;
    let times: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
    let refs = vec![
        Reference {
            position: [1.0, 2.0, 3.0],
            ..Default::default()
        };
        n
    ];
    let path = fly(&a, &y0, &refs, &vec![[0.0; 3]; n], &times).unwrap();
    for y in &path {
        for i in 0..3 {
            assert!((y[POSITION + i] - y0[POSITION + i]).abs() < 1e-6);
        }
    }
}

#[test]
fn a_grid_of_steps_at_the_motor_time_constant_flies_despite_rounding() {
    let a = crazyflie();
    let y0 = hovering(&a, [0.0, 0.0, 1.0]);
    // k * 0.015 in f64: some steps come out an ulp of the time longer than 0.015
    let n = 20_001;
    let times: Vec<f64> = (0..n).map(|k| k as f64 * a.motor_time_constant).collect();
    assert!(times
        .windows(2)
        .any(|w| w[1] - w[0] > a.motor_time_constant));
    let refs = vec![
        Reference {
            position: [0.0, 0.0, 1.0],
            ..Default::default()
        };
        n
    ];
    assert!(fly(&a, &y0, &refs, &vec![[0.0; 3]; n], &times).is_ok());
    // a step truly longer than the constant is still refused
    let long = [0.0, a.motor_time_constant * (1.0 + 1e-9)];
    assert!(fly(&a, &y0, &refs[..2], &[[0.0; 3]; 2], &long).is_err());
}

#[test]
fn a_velocity_command_is_reached_and_the_rotation_stays_orthonormal() {
    let a = crazyflie();
    let mut swarm = Swarm::new(a.clone(), vec![hovering(&a, [0.0; 3])]).unwrap();
    let cmd = VelocityCommand {
        velocity: [1.0, -0.5, 0.2],
        yaw_rate: 0.3,
    };
    for _ in 0..40 {
        swarm.step(&[cmd], &[[0.0; 3]], 1e-3, 50).unwrap();
    }
    let y = swarm.states()[0];
    for i in 0..3 {
        assert!((y[VELOCITY + i] - cmd.velocity[i]).abs() < 1e-3, "{y:?}");
    }
    let r = rotation(&y);
    let rtr = tmul(&r, &r);
    for i in 0..3 {
        for j in 0..3 {
            assert!((rtr[i][j] - IDENTITY[i][j]).abs() < 1e-14);
        }
    }
    // 2 s at 0.3 rad/s from yaw 0, within the transients of the tilt the drag asks for
    assert!((heading(&y) - 0.6).abs() < 0.05, "{}", heading(&y));
}

#[test]
fn a_drone_flies_the_same_alone_as_in_a_swarm() {
    let a = crazyflie();
    let cmds: Vec<VelocityCommand> = (0..5)
        .map(|i| VelocityCommand {
            velocity: [0.3 * i as f64, 0.5, -0.1],
            yaw_rate: 0.1 * i as f64,
        })
        .collect();
    let starts: Vec<StateVec> = (0..5).map(|i| hovering(&a, [i as f64, 0.0, 1.0])).collect();
    let mut swarm = Swarm::new(a.clone(), starts.clone()).unwrap();
    let path = swarm.step(&cmds, &[[0.1, 0.0, 0.0]; 5], 1e-3, 30).unwrap();
    for i in 0..5 {
        let mut alone = Swarm::new(a.clone(), vec![starts[i]]).unwrap();
        let p = alone
            .step(&cmds[i..i + 1], &[[0.1, 0.0, 0.0]], 1e-3, 30)
            .unwrap();
        assert_eq!(alone.states()[0], swarm.states()[i]);
        assert_eq!(&p[..], &path[30 * i..30 * (i + 1)]);
    }
}

#[test]
fn a_failed_step_leaves_every_drone_where_it_was() {
    let a = crazyflie();
    let mut swarm = Swarm::new(a.clone(), vec![hovering(&a, [0.0; 3]); 2]).unwrap();
    let before = swarm.states().to_vec();
    let bad = VelocityCommand {
        velocity: [f64::NAN, 0.0, 0.0],
        yaw_rate: 0.0,
    };
    let err = swarm.step(&[VelocityCommand::default(), bad], &[[0.0; 3]; 2], 1e-3, 10);
    assert!(err.unwrap_err().to_string().contains("command 1"));
    assert_eq!(swarm.states(), &before[..]);
    let err = swarm.step(&[VelocityCommand::default(); 2], &[[0.0; 3]; 2], 0.1, 10);
    assert!(err.unwrap_err().to_string().contains("motor time constant"));
}
