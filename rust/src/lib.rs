//! batecho: foliage echoes for bat-inspired sonar (the pure-Rust core).
//!
//! The numeric kernels here use no pyo3; the Python extension lives in [`bindings`] behind the
//! `python` feature, so `cargo test` and `cargo bench` run without Python.
//! Units: metres, seconds, hertz, radians.

pub mod absorption;
pub mod beam;
pub mod error;
pub mod impulse;
pub mod kernel;
pub mod leaf_model;
pub mod lobe;
pub mod obj;
pub mod phase;
pub mod pose;
pub mod scene;
pub mod simulate;
pub mod sonar;
pub mod spectrum;

#[cfg(feature = "python")]
mod bindings;

pub use error::{Error, Result};
