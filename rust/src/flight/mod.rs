//! The quadrotor (docs/model.md §8): its airframe and rotor mixer, the rigid-body dynamics
//! with rotor lag, the SE(3) controller, and RK4 flights of a reference or of velocity
//! commands, drones in parallel. Needs only `math`.

pub mod airframe;
pub mod control;
pub mod dynamics;
pub mod integrate;
pub mod rigid;

#[cfg(test)]
mod tests;

pub use airframe::{Airframe, AirframeParams, Configuration, Gains};
pub use control::Reference;
pub use dynamics::StateVec;
pub use integrate::{fly, Swarm, VelocityCommand};
